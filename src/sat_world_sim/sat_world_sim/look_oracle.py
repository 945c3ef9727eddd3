"""What perfect triage of the looks would give: a value-of-information diagnostic, not a policy.

A searching agent of the persistent profile looks at the tentative PHD peaks and the newborn
spots of its scans (sat_agent/beyond_paper/investigation.py): it holds its walk on a peak, or
keeps a spot in its next square, so that a second scan confirms a target or kills a false
alarm. At the random default nearly every candidate is a false alarm (session 41: 3.8 % of the
spots it may keep and 13 % of the peaks have a true target within 3 m), and each look costs
the walk ground it would have searched (docs/persistent_trials.md).

Here the agents' looks see only the candidates that a true target lies within ``radius`` of
at the scan's step, read from the world's truth; ``kinds`` says which candidates are so
triaged: 'spots', 'peaks' or both. Everything else (the filter and its births, extraction,
TRACK, coasting, revisits, the radio) is the profile's, and so are every random stream, so a
run without targets gives exactly the run without looks (tests/test_look_oracle.py). Paired
with the profile on the same seeds (scripts/look_oracle.py), the difference bounds what any
triage of the looks by the information a scan carries could give.

The wrapping replaces each agent's ``investigation.look`` on the instance, in the simulator's
package: the agents' code is unchanged and never sees the truth outside this diagnostic.
"""

from dataclasses import replace
from functools import partial
from typing import Callable, Optional, Sequence

import numpy as np
from scipy.spatial.distance import cdist

from sat_agent.config import SatParams
from sat_agent.phd_filter import BirthSpots

from sat_world_sim.inprocess_swarm import InProcessSwarm, run_swarm, SwarmRun
from sat_world_sim.scenario import Scenario

TRIAGE_KINDS = ('spots', 'peaks')
# The radius of a PHD peak's region (phd.peak_radius) and of session 40's count of real spots.
DEFAULT_RADIUS = 3.0


def truth_near(points: np.ndarray, truth: np.ndarray, radius: float) -> np.ndarray:
    """Return a (n,) mask of the points within radius of some true target position."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    truth = np.asarray(truth, dtype=float).reshape(-1, 2)
    if not len(points) or not len(truth):
        return np.zeros(len(points), dtype=bool)
    return cdist(points, truth).min(axis=1) <= radius


def triaged_look(look: Callable, truth_now: Callable[[], np.ndarray],
                 kinds: Sequence[str] = TRIAGE_KINDS,
                 radius: float = DEFAULT_RADIUS) -> Callable:
    """Wrap Investigation.look so that it sees only the candidates of kinds near a true target.

    truth_now() returns the (n, 2) true positions at the step of the scan being looked at.
    """
    unknown = sorted(set(kinds) - set(TRIAGE_KINDS))
    if unknown:
        raise ValueError(f'kinds {unknown}: each must be one of {TRIAGE_KINDS}')

    def look_at_real(mode, estimate, cooldown_left, birth_spots):
        truth = truth_now()
        if 'spots' in kinds:
            real = truth_near(birth_spots.positions, truth, radius)
            birth_spots = BirthSpots(birth_spots.measurements[real],
                                     birth_spots.positions[real], birth_spots.masses[real])
        if 'peaks' in kinds and estimate.tentative:
            real = truth_near([peak.position for peak in estimate.tentative], truth, radius)
            estimate = replace(
                estimate, tentative=tuple(p for p, r in zip(estimate.tentative, real) if r),
                tentative_streaks=tuple(s for s, r in zip(estimate.tentative_streaks, real) if r))
        return look(mode, estimate, cooldown_left, birth_spots)

    return look_at_real


def oracle_looks(swarm: InProcessSwarm, kinds: Sequence[str] = TRIAGE_KINDS,
                 radius: float = DEFAULT_RADIUS) -> None:
    """Give every agent of the swarm triaged looks (run_swarm's prepare hook).

    The agents step after the world's scans and before it moves (InProcessSwarm.step), so the
    world's truth at a look is that of the scan looked at.
    """
    for agent in swarm.agents.values():
        agent.investigation.look = triaged_look(
            agent.investigation.look, lambda: swarm.world.truth().positions, kinds, radius)


def run_with_oracle_looks(scenario: Scenario, params: SatParams,
                          kinds: Sequence[str] = TRIAGE_KINDS, radius: float = DEFAULT_RADIUS,
                          steps: Optional[int] = None) -> SwarmRun:
    """Run the scenario in-process (inprocess_swarm.run_swarm) with triaged looks."""
    return run_swarm(scenario, params, steps,
                     prepare=partial(oracle_looks, kinds=kinds, radius=radius))
