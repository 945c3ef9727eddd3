"""Per-step records (metrics.StepRecord) from the graph's messages, live or from a bag.

rclpy messages and rosbags' deserialized messages have the same field names, so the live
metrics node and the offline replay of a bag build their records with these same functions:
metrics computed either way are equal.
"""

from dataclasses import replace
from pathlib import Path
import pickle
from typing import List, Mapping, Optional, Sequence, Tuple

import numpy as np

from sat_agent.density_codec import decode_density, DensityDecodeError
from sat_world_sim.metrics import compute_metrics, StepRecord, write_metrics
from sat_world_sim.plots import write_plots
from sat_world_sim.topics import agent_of

MODE_NAMES = {0: 'SEARCH', 1: 'TRACK'}
# A step's record is made once the world's truth is this many steps further on and the step's
# messages are all in (RunCollector.settle_ready). DDS does not order messages across topics, so
# the truth of a later step says nothing about an agent's status of this one; only each writer's
# own order does. The live metrics node and the offline replay of a bag apply the same rule.
SETTLE_STEPS = 20
# ... or once the truth is this many steps further on, whatever is missing: a message this late
# may have left its writer's history (sat_agent.qos.DEPTH) before it could be repaired.
LATE_LIMIT_STEPS = 200


def _xy(points) -> np.ndarray:
    return np.array([[p.x, p.y] for p in points], dtype=float).reshape(-1, 2)


def traffic_by_sender(traffic) -> dict:
    """Cumulative (messages, bytes) sent per agent from a RadioTraffic message."""
    totals = {}
    for sender, messages, nbytes in zip(traffic.sender, traffic.messages, traffic.bytes):
        count, size = totals.get(int(sender), (0, 0))
        totals[int(sender)] = (count + int(messages), size + int(nbytes))
    return totals


def step_record(truth, statuses: Mapping[int, object], traffic=None,
                previous_traffic=None) -> StepRecord:
    """Build the StepRecord of one step from its GroundTruth, AgentStatus per agent and traffic.

    traffic / previous_traffic are the RadioTraffic messages of this step and the one before
    (cumulative counters): their difference is what each agent sent at this step.
    """
    alive = [t for t in truth.targets if t.alive]
    now = traffic_by_sender(traffic) if traffic is not None else {}
    before = traffic_by_sender(previous_traffic) if previous_traffic is not None else {}
    ids = sorted(statuses)
    return StepRecord(
        step=int(truth.step),
        truth_ids=np.array([t.id for t in alive], dtype=int),
        truth_positions=_xy([t.position for t in alive]),
        agent_poses={int(a.id): np.array([a.position.x, a.position.y]) for a in truth.agents},
        modes={a: MODE_NAMES.get(int(statuses[a].mode), 'UNKNOWN') for a in ids},
        estimates={a: _xy([t.position for t in statuses[a].estimate.targets]
                          + list(statuses[a].coasted)) for a in ids},
        plans={a: _xy(statuses[a].plan) for a in ids},
        searched_fraction=float(truth.searched_fraction),
        radio_messages={a: now.get(a, (0, 0))[0] - before.get(a, (0, 0))[0] for a in now},
        radio_bytes={a: now.get(a, (0, 0))[1] - before.get(a, (0, 0))[1] for a in now},
        overlap_events=[{'step': int(truth.step), 'agent': a,
                         'left_for': int(statuses[a].yielded_to)}
                        for a in ids if statuses[a].yielded_to],
    )


def density_values(msg) -> Optional[np.ndarray]:
    """(height, width) float32 values of a SearchDensity message; None if they do not decode."""
    try:
        return decode_density(msg.values_zlib, (int(msg.grid.height), int(msg.grid.width)))
    except DensityDecodeError:
        return None


def route(topic: str, agent_ids) -> Optional[Tuple[str, Optional[int]]]:
    """Return which part of a run a topic feeds, as (kind, agent id or None).

    ('step' | 'truth' | 'radio', None) for the world's topics, ('status' | 'density', agent id)
    for an agent's status and search density, None for the rest. The metrics (RunCollector)
    and the Rerun view (rerun_view.StepBuffer) read the same topics.
    """
    world = {'/world/step': 'step', '/world/truth': 'truth', '/world/radio': 'radio'}
    if topic in world:
        return world[topic], None
    owner = agent_of(topic)
    if owner is None or owner[0] not in agent_ids:
        return None
    kind = {'status': 'status', 'radio/out/search_density': 'density'}.get(owner[1])
    return (kind, owner[0]) if kind else None


class StepMessages:
    """The messages of one run that metrics and views read, grouped by kind and step.

    ``add(topic, msg)`` takes the graph's topic names (records.route), from the live graph or a
    bag alike. Subclasses decide which search densities to keep (``keep_density``) and when a
    step's messages can go.
    """

    def __init__(self, agent_ids):
        self.agent_ids = sorted(int(i) for i in agent_ids)
        self.truths, self.traffic, self.statuses, self.densities = {}, {}, {}, {}
        self.final = None   # the world's last WorldStep (finished = True)

    def add(self, topic: str, msg) -> None:
        """Take one message of the graph; topics it does not use are ignored."""
        kind, agent = route(topic, self.agent_ids) or (None, None)
        if kind == 'step' and msg.finished:
            self.final = msg
        elif kind == 'truth':
            self.truths[int(msg.step)] = msg
        elif kind == 'radio':
            self.traffic[int(msg.step)] = msg
        elif kind == 'status':
            self.statuses[(agent, int(msg.step))] = msg
        elif kind == 'density':
            self.keep_density(agent, int(msg.step), msg)

    def keep_density(self, agent: int, step: int, msg) -> None:
        """Store a search density (subclasses say which ones they need)."""
        raise NotImplementedError


class RunCollector(StepMessages):
    """Turns one run's messages into metrics.json and plots, in memory bounded over the run.

    Fed by the live metrics node and by the offline replay of a bag alike, so both compute
    metrics with the same code. A step's messages are kept until the world is SETTLE_STEPS
    further on; then the step becomes a compact StepRecord (no plans, no particles, no
    densities) and its messages go. Only each agent's last search density is kept (the final
    plot) and the last steps' plans (records()[-1].plans, the plot's last plans).
    """

    def __init__(self, agent_ids):
        super().__init__(agent_ids)
        # Settled records, pickled: about a quarter of the live objects' memory (~0.3 KB per
        # agent and step), and whatever fields metrics.StepRecord has, they come back equal.
        self.settled: List[bytes] = []
        self.settled_up_to = 0   # steps up to this one are in self.settled
        self.newest = {}         # (kind, agent) -> newest step received ('radio', None) too

    def add(self, topic: str, msg) -> None:
        """Take one message of the graph; one of a step settled already is dropped."""
        kind, agent = route(topic, self.agent_ids) or (None, None)
        # The last settled step's traffic is still needed: the next record is a difference.
        oldest = self.settled_up_to + (0 if kind == 'radio' else 1)
        if kind in ('truth', 'radio', 'status') and int(msg.step) < oldest:
            return
        super().add(topic, msg)
        if kind in ('radio', 'status'):
            self.newest[(kind, agent)] = max(self.newest.get((kind, agent), 0), int(msg.step))
        if kind == 'truth':
            self.settle(self.settle_ready(int(msg.step)))

    def _all_in(self, step: int) -> bool:
        """Whether no message of step is still to come.

        A message is in, or its writer (which delivers in order) sent a later one already, or
        (statuses) its agent did not answer the step: it is inactive in the next step's truth.
        """
        if step not in self.traffic and self.newest.get(('radio', None), 0) <= step:
            return False
        after = self.truths.get(step + 1)
        inactive = {int(a.id) for a in after.agents if not a.active} if after else set()
        return all((agent, step) in self.statuses or agent in inactive
                   or self.newest.get(('status', agent), 0) > step for agent in self.agent_ids)

    def settle_ready(self, newest: int) -> int:
        """Return the last step that can become a record once the truth of newest is in.

        Steps go in order; each when SETTLE_STEPS behind newest and all its messages are in,
        or whatever is missing once LATE_LIMIT_STEPS behind.
        """
        ready = self.settled_up_to
        for step in sorted(s for s in self.truths if s <= newest - SETTLE_STEPS):
            if step > newest - LATE_LIMIT_STEPS and not self._all_in(step):
                break
            ready = step
        return ready

    def keep_density(self, agent: int, step: int, msg) -> None:
        """Store a search density; the metrics only need each agent's last (the final plot)."""
        self.densities[agent] = msg

    def settle(self, up_to: int) -> None:
        """Turn every step up to up_to into a compact record and drop its messages."""
        for step in sorted(s for s in self.truths if s <= up_to):
            self.settled.append(pickle.dumps(replace(self.step_record(step), plans={})))
        self.settled_up_to = max(self.settled_up_to, up_to)
        for store, keep_from in ((self.truths, up_to + 1), (self.traffic, up_to)):
            for step in [s for s in store if s < keep_from]:
                del store[step]
        for key in [k for k in self.statuses if k[1] <= up_to]:
            del self.statuses[key]

    def step_record(self, step: int) -> StepRecord:
        """Build the StepRecord of a step whose truth is in from the messages kept."""
        return step_record(self.truths[step],
                           {i: self.statuses[(i, step)] for i in self.agent_ids
                            if (i, step) in self.statuses},
                           self.traffic.get(step), self.traffic.get(step - 1))

    def complete(self) -> bool:
        """Whether the run finished and its last step's truth, traffic and statuses are in."""
        if self.final is None:
            return False
        last = int(self.final.step)
        truth = self.truths.get(last)
        if truth is None or last not in self.traffic:
            return False
        return all((int(a.id), last) in self.statuses for a in truth.agents
                   if a.active and int(a.id) in self.agent_ids)

    def records(self) -> List[StepRecord]:
        """One StepRecord per step that has ground truth, in step order."""
        return [pickle.loads(record) for record in self.settled] + \
            [self.step_record(step) for step in sorted(self.truths)]

    def metrics(self, records: Sequence[StepRecord], dropped=None) -> dict:
        """Return the metrics.json dict of the run (dropped: compute_metrics)."""
        final = self.final
        return compute_metrics(records, final.scenario if final else '',
                               int(final.seed) if final else 0,
                               late_commands=int(final.late_commands) if final else 0,
                               dropped=dropped)

    def fused_density(self) -> Optional[np.ndarray]:
        """Elementwise max of the last search density each agent sent."""
        values = [v for _, m in sorted(self.densities.items())
                  if (v := density_values(m)) is not None]
        return np.maximum.reduce(values) if values else None

    def write(self, run_dir, area, dropped=None) -> dict:
        """Write <run_dir>/metrics.json and <run_dir>/plots/*.png; return the metrics."""
        run_dir = Path(run_dir)
        run_dir.mkdir(parents=True, exist_ok=True)
        records = self.records()
        metrics = self.metrics(records, dropped)
        write_metrics(metrics, run_dir / 'metrics.json')
        write_plots(metrics, records, run_dir / 'plots', area=area,
                    final_density=self.fused_density())
        return metrics
