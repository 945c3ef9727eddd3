"""What a baseline of the evaluation sees at step k and what it returns.

A baseline is an object with ``choose(pose, view) -> SearchMove`` and a class attribute
``steers_tracking``:

- False (lawnmower, random walk): it replaces only how a *searching* agent moves; in TRACK the
  agent keeps the paper's tracking control (Eqn. track_control).
- True (PHD-weighted Voronoi, Thompson-sampling PHD): it is the agent's whole controller, in
  SEARCH and in TRACK, as in its paper, where one control law both searches and tracks (the
  PHD's peaks attract the agents).

``BaselineView`` is everything the agent core hands over at step k, after the SAT-PHD was
predicted to k+1 (agent_core.Agent.step): no more than the agent's own filter and what the
radio carried from the agents in range.
"""

from dataclasses import dataclass
from typing import NamedTuple, Sequence

import numpy as np

from sat_agent.phd_filter import ParticlePHD

# Last spawn_key element of a baseline's generator, keyed (agent_id, this): apart from the
# world's streams ((0,), (1,), ...) and the filter's ((agent_core.FILTER_STREAM +
# phd.filter_stream, agent_id)), and from each other.
RANDOM_WALK_STREAM = 1
THOMPSON_STREAM = 2


def baseline_rng(seed: int, agent_id: int, stream: int) -> np.random.Generator:
    """Return the generator of one agent's baseline, seeded with (seed, agent_id, stream)."""
    return np.random.default_rng(np.random.SeedSequence(
        int(seed), spawn_key=(int(agent_id), int(stream))))


class SearchMove(NamedTuple):
    """One step of a baseline: the action, the point it steers to and the path ahead (K, 2)."""

    action: int
    goal: np.ndarray
    plan: np.ndarray


@dataclass(frozen=True, eq=False)
class BaselineView:
    """The inputs of a baseline's step k.

    step: k. phd: the agent's true-target PHD predicted to k+1 (Eqn. satphd_predict, the births
    included). own_report: the agent's report of step k (agent_core.AgentReport): its pose, its
    search density after fusion with the neighbours' (posterior of k, as sent) and its estimate
    X-hat_k. reports: the neighbours' reports of step k-1 the radio delivered (agents within
    C_R), one per sender, ordered by id.
    """

    step: int
    phd: ParticlePHD
    own_report: object
    reports: Sequence[object] = ()
