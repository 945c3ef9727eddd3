"""Turn plain per-step records of a run into the ``metrics.json`` dict of SPEC.md.

The records are plain data (numpy arrays, dicts, strings), never Agent objects, so the in-process
swarm, the ROS logger and an offline bag replay can all feed this module.

Definitions (the paper leaves them open):

- Swarm estimate at step k: the union of every agent's extracted target positions, where points
  of different agents closer than ``merge_distance`` are merged (greedy, in ascending agent id
  then row order: a point joins the nearest cluster without a point of its own agent if that
  cluster's mean is within the distance; clusters are reported as their means). Two agents
  tracking one target report one target, not two; one agent's estimates are never merged with
  each other (its filter tells two close targets apart, as when it tracks both).
- OSPA (Eqn. ospa, cut-off c = 10 m, order p = 2) between the true positions and the swarm
  estimate; both empty gives 0, so steps with nothing to find and nothing claimed score 0.
- ``first_in_view``: first step the target's true position is inside some agent's sensing square.
- Estimate of a target: each agent's estimates are assigned one-to-one to the true targets
  that some sensing square has held at or before the step (``seen_masks``;
  ``ospa.gated_pairs``: ``linear_sum_assignment`` on the distances, pairs farther than
  ``detection_radius`` do not count), so an estimate of one target never also counts for a
  second target next to it. A target no square has held yet cannot have been measured (p_D = 0
  outside the square), so an estimate near it is about something else (a coasted report of
  another target, clutter): it is a false track, not a detection or a tracked step (until
  session 73 it counted as both; README, *Evaluation*, says what that moved).
- ``first_detected``: first step, at or after the target's first view, with some agent's
  estimate assigned to the target.
- ``detection_delay`` = first_detected - first_in_view (None when either is None).
- ``time_to_detection`` = first_detected - born, the search-and-track figure of merit; for a
  target never detected it is censored at the steps it was alive in the records (flagged by
  ``first_detected`` None), so policies that miss targets are not rewarded for it.
- Tracked target at step k: some agent's estimate assigned to it (``n_tracked``); tracked by
  two or more agents at once: a duplicate (``n_duplicate``).
- False track at step k: an agent's estimate assigned to no true target (``n_false``, summed
  over agents; an estimate near a target no square has held yet is one); ``false_track_steps``
  counts the steps with at least one.
- ``detectable_share``: the share of the run's targets whose true position was inside some
  agent's sensing square at some step (``first_in_view`` not None): the targets the search
  made detectable, whatever the detector made of them ("entered" in the tables and the trials'
  record; the column was ``entered_share`` until 2026-12-06).
- ``born`` / ``died``: first and last step the target is alive in the records (``died`` is None
  when it is still alive at the last recorded step).
"""

from dataclasses import dataclass, field
import json
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from sat_agent.ospa import gated_pairs, ospa
from sat_agent.sensor_model import in_sensing_square


@dataclass
class StepRecord:
    """Everything recorded about one step k of a run, as plain data.

    Poses are the positions s_k at which the step's scans were taken; estimates and modes are the
    agents' outputs of step k; radio counts are the reports each agent sent at step k (one
    report per agent and step, counted once per receiving neighbour).
    """

    step: int
    truth_ids: np.ndarray                      # (n,) ids of the targets alive at k
    truth_positions: np.ndarray                # (n, 2)
    agent_poses: Dict[int, np.ndarray]         # agent id -> (2,)
    modes: Dict[int, str]                      # agent id -> 'SEARCH' | 'TRACK'
    estimates: Dict[int, np.ndarray]           # agent id -> (m, 2) estimated positions
    plans: Dict[int, np.ndarray] = field(default_factory=dict)   # agent id -> (K, 2) walk
    searched_fraction: float = 0.0             # in [0, 1]
    radio_messages: Dict[int, int] = field(default_factory=dict)
    radio_bytes: Dict[int, int] = field(default_factory=dict)
    overlap_events: List[dict] = field(default_factory=list)
    refused_actions: Dict[int, str] = field(default_factory=dict)
    replans: Dict[int, str] = field(default_factory=dict)   # agent id -> why it replanned


@dataclass(frozen=True)
class MetricsConfig:
    """Parameters of the evaluation (see the module docstring)."""

    cutoff: float = 10.0            # OSPA c (m)
    order: int = 2                  # OSPA p
    sensor_side: float = 10.0       # a, for "in view"
    # Half a metre more than the 1 m range noise at the square's edge would allow three sigmas;
    # 3 m keeps two targets a sensing-square apart from merging.
    merge_distance: float = 3.0
    # Half the sensing square: an estimate this close can only be about this target.
    detection_radius: float = 5.0


def swarm_estimate(estimates: Mapping[int, np.ndarray], merge_distance: float) -> np.ndarray:
    """Merge the agents' estimated positions into one set (see the module docstring)."""
    sums: List[np.ndarray] = []
    members: List[set] = []
    for agent in sorted(estimates):
        for point in np.asarray(estimates[agent], dtype=float).reshape(-1, 2):
            # An agent's own estimates are distinct targets: only other agents' points merge.
            open_clusters = [i for i, ids in enumerate(members) if agent not in ids]
            if open_clusters:
                means = np.array([sums[i] / len(members[i]) for i in open_clusters])
                gaps = np.hypot(*(means - point).T)
                nearest = int(np.argmin(gaps))
                if gaps[nearest] <= merge_distance:
                    sums[open_clusters[nearest]] = sums[open_clusters[nearest]] + point
                    members[open_clusters[nearest]].add(agent)
                    continue
            sums.append(point.copy())
            members.append({agent})
    if not sums:
        return np.zeros((0, 2))
    return np.array(sums) / np.array([len(ids) for ids in members])[:, None]


def compute_metrics(records: Sequence[StepRecord], scenario: str, seed: int,
                    config: MetricsConfig = MetricsConfig(), late_commands: int = 0,
                    dropped: Optional[Mapping[str, int]] = None) -> dict:
    """Return the metrics.json dict (JSON-serialisable, deterministic) of a run's records.

    late_commands: commands that missed their step (real-time clock; 0 in lock-step and in the
    in-process swarm, where every agent answers every step). dropped: messages the metrics
    node refused, per reason (unsigned, too_large, out_of_window, ...); empty in a clean run.
    """
    records = sorted(records, key=lambda r: r.step)
    views = seen_masks(records, config)
    # Per record: (agents' estimates assigned to each true target, estimates assigned to none).
    assigned = [trackers(r.truth_positions, r.estimates, config.detection_radius, seen)
                for r, (_, seen) in zip(records, views)]
    steps = [_step_metrics(r, config, *a) for r, a in zip(records, assigned)]
    targets = _target_metrics(records, [in_view for in_view, _ in views],
                              [per_target > 0 for per_target, _ in assigned])
    radio = _radio_metrics(records)
    return {
        'scenario': scenario,
        'seed': int(seed),
        'config': {'ospa_cutoff': config.cutoff, 'ospa_order': config.order,
                   'merge_distance': config.merge_distance,
                   'detection_radius': config.detection_radius},
        'steps': steps,
        'targets': targets,
        'overlap_events': [dict(e) for r in records for e in r.overlap_events],
        'radio': radio,
        'late_commands': int(late_commands),
        'dropped': {str(k): int(n) for k, n in sorted((dropped or {}).items())},
        'summary': _summary(steps, targets, radio),
    }


def write_metrics(metrics: dict, path) -> None:
    """Write the metrics dict as indented JSON (sorted keys, so files diff cleanly)."""
    with open(path, 'w', encoding='utf-8') as stream:
        json.dump(metrics, stream, indent=1, sort_keys=True)
        stream.write('\n')


def _step_metrics(record: StepRecord, config: MetricsConfig, per_target: np.ndarray,
                  false: int) -> dict:
    truth = np.asarray(record.truth_positions, dtype=float).reshape(-1, 2)
    estimate = swarm_estimate(record.estimates, config.merge_distance)
    result = ospa(truth, estimate, config.cutoff, config.order)
    modes = {str(a): str(record.modes[a]) for a in sorted(record.modes)}
    return {
        'step': int(record.step),
        'ospa': float(result.distance),
        'ospa_loc': float(result.localisation),
        'ospa_card': float(result.cardinality),
        'n_true': int(len(truth)),
        'n_est': int(len(estimate)),
        'searched_pct': 100.0 * float(record.searched_fraction),
        'tracking': any(m == 'TRACK' for m in modes.values()),
        'modes': modes,
        'n_tracked': int(np.count_nonzero(per_target >= 1)),
        'n_duplicate': int(np.count_nonzero(per_target >= 2)),
        'n_false': false,
    }


def _target_metrics(records: Sequence[StepRecord], in_views: Sequence[np.ndarray],
                    detections: Sequence[np.ndarray]) -> List[dict]:
    """Per target: birth, death, first view and first detection (module docstring).

    in_views, detections: per record, which of its targets are in a square and have an
    estimate assigned.
    """
    targets: Dict[int, dict] = {}
    last_step = records[-1].step if records else None
    for record, in_view, detected in zip(records, in_views, detections):
        ids = np.asarray(record.truth_ids, dtype=int).reshape(-1)
        for row, target_id in enumerate(ids.tolist()):
            entry = targets.setdefault(target_id, {'id': target_id, 'born': record.step,
                                                   'died': None, 'first_in_view': None,
                                                   'first_detected': None})
            entry['last_seen_alive'] = record.step
            entry['alive_steps'] = entry.get('alive_steps', 0) + 1
            if in_view[row] and entry['first_in_view'] is None:
                entry['first_in_view'] = record.step
            if detected[row] and entry['first_detected'] is None:
                entry['first_detected'] = record.step
    result = []
    for target_id in sorted(targets):
        entry = targets[target_id]
        last = entry.pop('last_seen_alive')
        entry['died'] = None if last == last_step else last
        seen, found = entry['first_in_view'], entry['first_detected']
        entry['detection_delay'] = None if seen is None or found is None else found - seen
        alive = entry.pop('alive_steps')
        entry['time_to_detection'] = alive if found is None else found - entry['born']
        result.append(entry)
    return result


def in_any_square(points: np.ndarray, poses: Mapping[int, np.ndarray], side: float):
    """Mask of the (n, 2) points inside some agent's sensing square (``first_in_view``)."""
    mask = np.zeros(len(points), dtype=bool)
    for pose in poses.values():
        mask |= in_sensing_square(points, pose, side)
    return mask


@dataclass
class SeenTargets:
    """The targets some sensing square has held so far; ``step`` once per record, in step order."""

    side: float
    ids: set = field(default_factory=set)

    def step(self, record: StepRecord) -> Tuple[np.ndarray, np.ndarray]:
        """Return (in some square now, in some square at or before now) of the record's targets.

        The second mask is which targets an estimate may be assigned to (module docstring).
        """
        ids = np.asarray(record.truth_ids, dtype=int).reshape(-1)
        truth = np.asarray(record.truth_positions, dtype=float).reshape(-1, 2)
        in_view = in_any_square(truth, record.agent_poses, self.side)
        self.ids.update(ids[in_view].tolist())
        return in_view, np.isin(ids, list(self.ids))


def seen_masks(records: Sequence[StepRecord], config: MetricsConfig
               ) -> List[Tuple[np.ndarray, np.ndarray]]:
    """``SeenTargets.step`` of every record, in step order."""
    seen = SeenTargets(config.sensor_side)
    return [seen.step(record) for record in records]


def trackers(points: np.ndarray, estimates: Mapping[int, np.ndarray], radius: float,
             eligible: np.ndarray):
    """Count per true point the agents with an estimate assigned to it, and the false estimates.

    eligible: mask of the points an estimate may be assigned to (``SeenTargets``).
    Returns (counts per point, estimates of all agents assigned to no point); module docstring.
    """
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    rows = np.flatnonzero(eligible)
    counts = np.zeros(len(points), dtype=int)
    false = 0
    for estimate in estimates.values():
        found = np.asarray(estimate, dtype=float).reshape(-1, 2)
        hits, _ = gated_pairs(points[rows], found, radius)
        counts[rows[hits]] += 1
        false += len(found) - len(hits)
    return counts, false


def _radio_metrics(records: Sequence[StepRecord]) -> dict:
    agents = sorted({a for r in records for a in list(r.radio_messages) + list(r.radio_bytes)})
    return {str(a): {'messages': int(sum(r.radio_messages.get(a, 0) for r in records)),
                     'bytes': int(sum(r.radio_bytes.get(a, 0) for r in records))}
            for a in agents}


def _summary(steps: List[dict], targets: List[dict], radio: dict) -> dict:
    """Per-run figures of the Monte Carlo evaluation (time averages over every step)."""
    tracked = [s['ospa'] for s in steps if s['tracking']]
    target_steps = sum(s['n_true'] for s in steps)
    agents = {a for s in steps for a in s['modes']}
    agent_steps = max(len(agents), 1) * max(len(steps), 1)
    return {
        'mean_ospa': _mean([s['ospa'] for s in steps]),
        'mean_ospa_loc': _mean([s['ospa_loc'] for s in steps]),
        'mean_ospa_card': _mean([s['ospa_card'] for s in steps]),
        'mean_ospa_tracking': _mean(tracked),
        'tracking_steps': len(tracked),
        'final_searched_pct': steps[-1]['searched_pct'] if steps else 0.0,
        'targets_to_detect': len(targets),
        'detected_share': _share(sum(t['first_detected'] is not None for t in targets),
                                 len(targets)),
        'detectable_share': _share(sum(t['first_in_view'] is not None for t in targets),
                                   len(targets)),
        'mean_time_to_detection': _mean([t['time_to_detection'] for t in targets]),
        'tracked_share': _share(sum(s['n_tracked'] for s in steps), target_steps),
        'duplicate_tracking_steps': sum(1 for s in steps if s['n_duplicate']),
        'false_track_steps': sum(1 for s in steps if s['n_false']),
        'radio_msgs_per_agent_step': sum(r['messages'] for r in radio.values()) / agent_steps,
        'bytes_per_agent_step': sum(r['bytes'] for r in radio.values()) / agent_steps,
    }


def _share(part: int, whole: int) -> Optional[float]:
    return float(part) / whole if whole else None


def _mean(values: Sequence[float]) -> Optional[float]:
    return float(np.mean(values)) if len(values) else None
