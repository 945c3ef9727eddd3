"""What perfect triage of the false alarms would give: a value-of-information diagnostic.

At the random default the paper's clutter (lambda = 10 false alarms a scan, ~0.4 in a square)
outnumbers the targets a square holds some tenfold, and it costs the persistent profile in two
ways (docs/persistent_trials.md, sessions 41-42). A searching agent looks at the tentative PHD
peaks and the newborn spots of its scans (sat_agent/beyond_paper/investigation.py): it holds
its walk on a peak, or keeps a spot in its next square, so that a second scan confirms a target
or kills a false alarm; nearly every candidate is a false alarm (3.8 % of the spots it may
keep and 13 % of the peaks have a true target within 3 m), and each look costs the walk ground
it would have searched. And the false alarms reach the filter: they seed births, start tracks
that the probation ends, pass the gates of the tracks' fits.

Here the agents see only what the truth says is real; ``kinds`` says what is so triaged:

- 'spots', 'peaks': the looks see only the candidates of that kind that a true target lies
  within ``radius`` of at the scan's step. Everything else (the filter and its births,
  extraction, TRACK, coasting, revisits, the radio) is the profile's.
- 'scans': the false alarms are taken out of every agent's scan before its filter sees it, so
  every measurement an agent gets is a target's. The filter's model is the profile's: its
  clutter intensity kappa (Eqn. satphd_correct) still says lambda false alarms a scan, so a
  target is confirmed as slowly as with the clutter, and the difference from a run without
  clutter (``sensor.clutter_rate`` 0, which sets kappa to 0 too) is what the model's
  caution costs.

Every random stream is the profile's, so a run without targets gives exactly the run without
looks ('spots' and 'peaks') or without clutter ('scans'; with no measurement kappa never enters
the update): tests/test_triage_oracle.py. Paired with the profile on the same seeds
(scripts/triage_oracle.py), the difference bounds what any triage by the information a scan
carries could give, in the looks or in the filter.

The wrapping replaces each agent's ``investigation.look`` and the world's ``scan_all`` on the
instances, in the simulator's package: the agents' code is unchanged and never sees the truth
outside this diagnostic.
"""

from dataclasses import replace
from functools import partial
from typing import Callable, Dict, Optional, Sequence

import numpy as np
from scipy.spatial.distance import cdist

from sat_agent.config import SatParams
from sat_agent.phd_filter import BirthSpots

from sat_world_sim.inprocess_swarm import InProcessSwarm, run_swarm, SwarmRun
from sat_world_sim.scenario import Scenario
from sat_world_sim.world_model import Scan

LOOK_KINDS = ('spots', 'peaks')
TRIAGE_KINDS = LOOK_KINDS + ('scans',)
# The radius of a PHD peak's region (phd.peak_radius) and of session 40's count of real spots.
DEFAULT_RADIUS = 3.0


def check_kinds(kinds: Sequence[str], allowed: Sequence[str] = TRIAGE_KINDS) -> None:
    """Raise ValueError naming every kind that is not one of allowed."""
    unknown = sorted(set(kinds) - set(allowed))
    if unknown:
        raise ValueError(f'kinds {unknown}: each must be one of {tuple(allowed)}')


def truth_near(points: np.ndarray, truth: np.ndarray, radius: float) -> np.ndarray:
    """Return a (n,) mask of the points within radius of some true target position."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    truth = np.asarray(truth, dtype=float).reshape(-1, 2)
    if not len(points) or not len(truth):
        return np.zeros(len(points), dtype=bool)
    return cdist(points, truth).min(axis=1) <= radius


def triaged_look(look: Callable, truth_now: Callable[[], np.ndarray],
                 kinds: Sequence[str] = LOOK_KINDS,
                 radius: float = DEFAULT_RADIUS) -> Callable:
    """Wrap Investigation.look so that it sees only the candidates of kinds near a true target.

    truth_now() returns the (n, 2) true positions at the step of the scan being looked at.
    """
    check_kinds(kinds, LOOK_KINDS)

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


def real_scans(scan_all: Callable[[], Dict[int, Scan]]) -> Callable[[], Dict[int, Scan]]:
    """Wrap World.scan_all so that every scan keeps only its targets' rows (no false alarm).

    The world still draws its clutter, so its random streams, and so every target's
    measurement, are those of the run with the false alarms.
    """
    def without_clutter():
        scans = {}
        for agent_id, scan in scan_all().items():
            real = scan.source_ids >= 0
            scans[agent_id] = Scan(scan.measurements[real], scan.source_ids[real])
        return scans

    return without_clutter


def oracle_triage(swarm: InProcessSwarm, kinds: Sequence[str] = LOOK_KINDS,
                  radius: float = DEFAULT_RADIUS) -> None:
    """Triage what kinds name, by the truth, for every agent of the swarm (run_swarm's hook).

    The agents step after the world's scans and before it moves (InProcessSwarm.step), so the
    world's truth at a look is that of the scan looked at.
    """
    check_kinds(kinds)
    looks = tuple(kind for kind in kinds if kind in LOOK_KINDS)
    if looks:
        for agent in swarm.agents.values():
            agent.investigation.look = triaged_look(
                agent.investigation.look, lambda: swarm.world.truth().positions, looks, radius)
    if 'scans' in kinds:
        swarm.world.scan_all = real_scans(swarm.world.scan_all)


def run_with_oracle_triage(scenario: Scenario, params: SatParams,
                           kinds: Sequence[str] = LOOK_KINDS, radius: float = DEFAULT_RADIUS,
                           steps: Optional[int] = None) -> SwarmRun:
    """Run the scenario in-process (inprocess_swarm.run_swarm) with the kinds triaged."""
    return run_swarm(scenario, params, steps,
                     prepare=partial(oracle_triage, kinds=kinds, radius=radius))
