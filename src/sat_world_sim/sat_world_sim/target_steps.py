"""Where a run's target-steps go: found or not yet, and why a found target goes untracked.

A diagnostic, not a metric (docs/persistent_trials.md, sessions 25 and 45). Every step of every
live target falls in one of CATEGORIES, by the metrics' own definitions (metrics.py):

- before its first detection (``first_detected``): out of every square, or in one;
- at or after it: ``tracked`` (some agent's report within the detection radius, coasted reports
  included), else ``in view, not reported`` (some square holds it), else ``a track holds it,
  reported off it`` (an agent still keeps a track that last had this target within the radius,
  but its report, coasted or estimated, lies farther off), else ``dropped: <reason>``: the
  latest track of it that an agent dropped, with track_coasting's DROP_REASONS (its fit left
  A, its report expired, it was too short to coast, a square passed over it and saw nothing,
  a neighbour reported it), else ``no track ever held it`` (a report passed within the radius,
  but no track of any agent ever lay within it: a report of another target, or a false alarm).

The tracks are an agent's beyond_paper/track_coasting.py tracks (none without
additions.track_coasting: every found target untracked out of view is then "no track ever held
it"). scripts/ospa_breakdown.py prints the shares over seeds.
"""

from collections import Counter
from dataclasses import dataclass, field
from typing import Dict, Optional, Tuple

import numpy as np

from sat_agent.beyond_paper.track_coasting import DROP_REASONS
from sat_world_sim.metrics import MetricsConfig, SeenTargets, StepRecord, trackers
from sat_world_sim.ospa_breakdown import note_followed_targets

BEFORE = ('before detection, out of view', 'before detection, in view')
AFTER = (('tracked', 'in view, not reported', 'a track holds it, reported off it')
         + tuple(f'dropped: {reason}' for reason in DROP_REASONS)
         + ('no track ever held it',))
CATEGORIES = BEFORE + AFTER


def category(found_before: bool, tracked: bool, in_view: bool, held: bool,
             dropped: Optional[str]) -> str:
    """Return the category of one target-step (module docstring).

    found_before: detected at an earlier step; tracked and in_view: at this step; held: a track
    of it is kept; dropped: the reason its latest dropped track was dropped, or None.
    """
    if not (found_before or tracked):
        return BEFORE[1] if in_view else BEFORE[0]
    if tracked:
        return AFTER[0]
    if in_view:
        return AFTER[1]
    if held:
        return AFTER[2]
    return AFTER[-1] if dropped is None else f'dropped: {dropped}'


@dataclass
class TargetStepLedger:
    """Counts a run's target-steps by category; observe() after every step of the swarm."""

    config: MetricsConfig = MetricsConfig()
    counts: Counter = field(default_factory=Counter)
    # note_followed_targets's map, for every agent's tracks at once.
    _followed: Dict[int, Tuple[object, Optional[int]]] = field(default_factory=dict)
    _dropped: Dict[int, str] = field(default_factory=dict)
    _found: set = field(default_factory=set)
    _seen: SeenTargets = field(init=False)

    def __post_init__(self):
        self._seen = SeenTargets(self.config.sensor_side)

    def observe(self, swarm, record: StepRecord) -> None:
        """Count the step's target-steps (swarm: inprocess_swarm.InProcessSwarm after step())."""
        truth = np.asarray(record.truth_positions, dtype=float).reshape(-1, 2)
        ids = [int(i) for i in np.asarray(record.truth_ids).reshape(-1)]
        live = set()
        for agent in swarm.agents.values():
            for track, reason in agent.coasting.drops:
                target = self._followed.get(id(track), (None, None))[1]
                if target is not None:
                    self._dropped[target] = reason
            note_followed_targets(agent.coasting.tracks, record.step, truth, ids,
                                  self._followed, self.config)
            live.update(id(track) for track in agent.coasting.tracks)
        self._followed = {key: value for key, value in self._followed.items() if key in live}
        held = {target for _, target in self._followed.values()}
        in_view, seen = self._seen.step(record)
        tracked = trackers(truth, record.estimates, self.config.detection_radius, seen)[0] > 0
        for row, target in enumerate(ids):
            self.counts[category(target in self._found, bool(tracked[row]), bool(in_view[row]),
                                 target in held, self._dropped.get(target))] += 1
            if tracked[row]:
                self._found.add(target)
