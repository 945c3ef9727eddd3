"""Which agents the lock-step world waits for: a silent agent is let go, rejoins when it speaks.

In the lock-step clock (world_sim_node) step k ends once every *active* agent has answered scan
k. An agent silent for ``agent_timeout`` seconds is let go at that step, and the world steps on
at the pace of the others (two agents: tens of steps a second). A restarted or overloaded agent
answers the newest scan it holds, and by the time its answer arrives the world may be several
steps further: its lag is its step time over the world's. Until 2026-12 only an answer to the
current scan or the one before rejoined, so an agent whose steps were slower than the world's
(a respawned one on a loaded machine: CI, tests/test_faults.py) stayed inactive for the rest of
the run. Here any answer to a scan sent since it was let go rejoins it; the world then waits for
its answer to the current scan again (the agent skips to the newest scan it holds), which puts
it back in lock-step. Anything older is what it said before it went silent and rejoins nothing.

The silence that lets an agent go is measured in the world's own running time: while
world_sim does not run (suspended, or starved of CPU on a loaded machine) the agents' answers
wait unread in its DDS queues, and on waking its timer can fire before they are read. So a tick
counts for at most WORLD_STALL_S of the world's time: one later than that after the one before
moves the step's deadline by the excess (deadline_after_stall). A world suspended early in a
step then wakes with most of agent_timeout left to read the answers, and one starved for good
still lets a silent agent go (each tick still counts WORLD_STALL_S), only later.

How far back an answer may be is REJOIN_STEPS, world_sim's step window behind (message_auth):
a rejoining agent's lag is far below it (a few steps in tests/test_faults.py's kill and
respawn), and replays are refused by their counter, not by the window.
"""

from dataclasses import dataclass, field
from typing import Dict, Iterable, Set

# world_sim's step window behind: how old an agent's answer may be and still be heard (above).
REJOIN_STEPS = 100
# The most of the world's time one tick of world_sim's 20 ms timer counts for (above).
WORLD_STALL_S = 0.25


def deadline_after_stall(deadline: float, previous_tick: float, now: float) -> float:
    """Return the step's deadline, moved by the gap since the last tick over WORLD_STALL_S."""
    return deadline + max(0.0, now - previous_tick - WORLD_STALL_S)


@dataclass
class Attendance:
    """The agents the world waits for (``active``) and the step each silent one was let go at."""

    ids: Iterable[int]
    active: Set[int] = field(init=False)
    let_go_at: Dict[int, int] = field(default_factory=dict)

    def __post_init__(self):
        self.ids = tuple(int(i) for i in self.ids)
        self.active = set(self.ids)

    def let_go(self, agents: Iterable[int], step: int):
        """Stop waiting for agents, silent at step: they hold position until they speak."""
        for agent in agents:
            self.active.discard(agent)
            self.let_go_at[agent] = step

    def heard(self, agent: int, step: int) -> bool:
        """Take an authentic answer of agent to scan step; return whether it rejoins with it.

        It rejoins when it was let go and the answer is to a scan of the step it was let go at or
        a later one (module docstring).
        """
        if agent in self.active or step < self.let_go_at.get(agent, step):
            return False
        self.active.add(agent)
        self.let_go_at.pop(agent, None)
        return True
