"""Where a run's mean OSPA goes: what-ifs on the swarm estimate (a diagnostic, not a metric).

OSPA (Eqn. ospa; c and p of metrics.MetricsConfig) charges a missed target c^p, a false
estimate c^p when the estimates outnumber the targets, and a matched pair its distance^p. Each
what-if changes the swarm estimate of every step (metrics.swarm_estimate) and scores it again:

- ``reported``: the swarm estimate the metrics score;
- ``without false``: the estimates farther than c from every true target removed;
- ``and localised``: besides, each estimate within the detection radius of a target moved onto
  the nearest one;
- ``and kept after detection``: besides, every target detected at this or an earlier step
  (metrics' first_detected) that no estimate lies within the detection radius of added at its
  true position: a team that never loses a target once it has found it.

``false_sources`` steps an in-process swarm and sorts its false reports (farther than c from
every target) by source: an agent's own estimate (X-hat_k), or a coasted track
(additions.track_coasting) whose target has died, whose target lives farther than c away, or
that never had a target within the detection radius (born on clutter). Per source: the false
report-steps per run and the mean OSPA without them.

``ospa_regimes`` splits the mean OSPA by how the step's swarm estimate (m points) compares with
its targets (n): with m < n a report farther than c from every target costs nothing (it takes
the place of a missed target's c^p), so only the steps where the reports outnumber the targets
charge a false one; the steps with targets and no report score c (session 45).

scripts/ospa_breakdown.py prints all three over seeds (docs/persistent_trials.md, sessions 30
and 45), with sat_world_sim/target_steps.py's split of the target-steps.
"""

from dataclasses import dataclass
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np
from scipy.spatial.distance import cdist

from sat_agent.ospa import ospa
from sat_world_sim.metrics import compute_metrics, MetricsConfig, StepRecord, swarm_estimate

WHAT_IFS = ('reported', 'without false', 'and localised', 'and kept after detection')
REGIMES = ('targets, no report', 'fewer reports than targets', 'as many',
           'more reports than targets', 'reports, no target', 'neither')
SOURCES = ('estimate', 'coasted, target died', 'coasted, target alive', 'coasted, no target')


def what_if_estimates(truth: np.ndarray, estimate: np.ndarray, detected: np.ndarray,
                      config: MetricsConfig) -> Tuple[np.ndarray, ...]:
    """Return the step's swarm estimate under each of WHAT_IFS (module docstring).

    truth (n, 2), estimate (m, 2); detected (n,) bools: the target was detected at this step
    or before.
    """
    truth = np.asarray(truth, dtype=float).reshape(-1, 2)
    estimate = np.asarray(estimate, dtype=float).reshape(-1, 2)
    gaps = cdist(estimate, truth) if len(truth) and len(estimate) else None
    if gaps is None:
        kept = localised = estimate[:0]
        tracked = np.zeros(len(truth), dtype=bool)
    else:
        kept_rows = gaps.min(axis=1) <= config.cutoff
        kept = estimate[kept_rows]
        nearest = gaps[kept_rows].argmin(axis=1)
        close = gaps[kept_rows].min(axis=1) <= config.detection_radius
        localised = kept.copy()
        localised[close] = truth[nearest[close]]
        tracked = gaps.min(axis=0) <= config.detection_radius
    lost = truth[np.asarray(detected, dtype=bool) & ~tracked]
    return estimate, kept, localised, np.vstack([localised, lost])


def what_if_ospa(records: Sequence[StepRecord], config: MetricsConfig = MetricsConfig()
                 ) -> Dict[str, float]:
    """Return the mean OSPA over the records under each of WHAT_IFS."""
    first = {t['id']: t['first_detected']
             for t in compute_metrics(records, '', 0, config)['targets']}
    totals = np.zeros(len(WHAT_IFS))
    for record in records:
        truth = np.asarray(record.truth_positions, dtype=float).reshape(-1, 2)
        detected = np.array([first[int(i)] is not None and first[int(i)] <= record.step
                             for i in np.asarray(record.truth_ids).reshape(-1)], dtype=bool)
        estimates = what_if_estimates(
            truth, swarm_estimate(record.estimates, config.merge_distance), detected, config)
        totals += [ospa(truth, e, config.cutoff, config.order).distance for e in estimates]
    return dict(zip(WHAT_IFS, totals / max(len(records), 1)))


def regime(targets: int, reports: int) -> str:
    """Return the step's entry of REGIMES for n targets and m reports (module docstring)."""
    if targets == 0:
        return REGIMES[4] if reports else REGIMES[5]
    if reports == 0:
        return REGIMES[0]
    return REGIMES[1] if reports < targets else REGIMES[2] if reports == targets else REGIMES[3]


def ospa_regimes(records: Sequence[StepRecord], config: MetricsConfig = MetricsConfig()
                 ) -> Dict[str, Tuple[float, float]]:
    """Return per REGIMES entry (share of the steps, its part of the mean OSPA).

    The parts sum to the mean OSPA of the records.
    """
    shares, parts = dict.fromkeys(REGIMES, 0.0), dict.fromkeys(REGIMES, 0.0)
    for record in records:
        truth = np.asarray(record.truth_positions, dtype=float).reshape(-1, 2)
        estimate = swarm_estimate(record.estimates, config.merge_distance)
        name = regime(len(truth), len(estimate))
        shares[name] += 1.0
        parts[name] += ospa(truth, estimate, config.cutoff, config.order).distance
    steps = max(len(records), 1)
    return {name: (shares[name] / steps, parts[name] / steps) for name in REGIMES}


@dataclass
class FalseSources:
    """False report-steps per source, the mean OSPA without each, and the run's records."""

    mean_ospa: float
    counts: Dict[str, int]
    mean_ospa_without: Dict[str, float]
    records: List[StepRecord]


def coasted_tracks(tracks: Sequence, step: int) -> List:
    """Return the tracks behind an agent's coasted rows at step, in their order.

    TrackCoasting.update keeps the tracks matched at step first, then the coasted ones in the
    order it appends their rows, then the new ones (which have an estimate at step).
    """
    return [track for track in tracks if track.steps[-1] < step]


def report_sources(truth: np.ndarray, truth_ids: Sequence[int], own: np.ndarray,
                   coasted: np.ndarray, targets_of: Sequence[Optional[int]],
                   config: MetricsConfig) -> List[Optional[str]]:
    """Return each report's source if it is false (farther than c from every target), else None.

    own (e, 2) the agent's estimates, coasted (k, 2) its coasted rows and targets_of (k,) the id
    of the target each coasted track last had within the detection radius (None: never).
    """
    reports = np.vstack([np.reshape(own, (-1, 2)), np.reshape(coasted, (-1, 2))])
    truth = np.asarray(truth, dtype=float).reshape(-1, 2)
    false = (np.ones(len(reports), dtype=bool) if not len(truth)
             else cdist(reports, truth).min(axis=1) > config.cutoff)
    alive = {int(i) for i in truth_ids}
    sources: List[Optional[str]] = []
    for row, is_false in enumerate(false):
        if not is_false:
            sources.append(None)
        elif row < len(own):
            sources.append(SOURCES[0])
        else:
            target = targets_of[row - len(own)]
            sources.append(SOURCES[3] if target is None
                           else SOURCES[2] if target in alive else SOURCES[1])
    return sources


def false_sources(swarm, steps: int, config: MetricsConfig = MetricsConfig(),
                  ledger=None) -> FalseSources:
    """Step an in-process swarm (inprocess_swarm.InProcessSwarm); sort its false reports.

    The sources are the module docstring's; the run's records are kept for what_if_ospa and
    ospa_regimes. ledger: a target_steps.TargetStepLedger that observes every step, or None.
    """
    # note_followed_targets's map.
    followed: Dict[int, Tuple[object, Optional[int]]] = {}
    counts = dict.fromkeys(SOURCES, 0)
    ospa_sums = np.zeros(len(SOURCES) + 1)
    records = []
    for _ in range(steps):
        record = swarm.step()
        records.append(record)
        if ledger is not None:
            ledger.observe(swarm, record)
        truth = np.asarray(record.truth_positions, dtype=float).reshape(-1, 2)
        ids = [int(i) for i in np.asarray(record.truth_ids).reshape(-1)]
        reports: Dict[int, Tuple[np.ndarray, List[Optional[str]]]] = {}
        live = set()
        for agent_id, output in swarm.last_outputs.items():
            tracks = swarm.agents[agent_id].coasting.tracks
            note_followed_targets(tracks, record.step, truth, ids, followed, config)
            live.update(id(track) for track in tracks)
            coasted = coasted_tracks(tracks, record.step)
            own = output.report.target_positions()
            sources = report_sources(truth, ids, own, output.coasted,
                                     [followed.get(id(t), (None, None))[1] for t in coasted],
                                     config)
            reports[agent_id] = (output.reported_positions(), sources)
            for source in sources:
                if source is not None:
                    counts[source] += 1
        for key in [k for k in followed if k not in live]:
            del followed[key]
        ospa_sums += [ospa_without(truth, reports, drop, config)
                      for drop in (None,) + SOURCES]
    means = ospa_sums / max(steps, 1)
    return FalseSources(float(means[0]), counts,
                        dict(zip(SOURCES, (float(m) for m in means[1:]))), records)


def note_followed_targets(tracks, step: int, truth: np.ndarray, ids: Sequence[int],
                          followed: Dict[int, Tuple[object, Optional[int]]],
                          config: MetricsConfig) -> None:
    """Note, for each track continued at step, the target within the detection radius of it.

    followed: id(track) -> (track, id of the target it last had within the radius, or None);
    the track is held so that its id is not reused while it is in the map.
    """
    for track in tracks:
        if track.steps[-1] != step:
            continue
        target = followed.get(id(track), (None, None))[1]
        if len(truth):
            gaps = np.hypot(*(truth - track.predict(step)).T)
            nearest = int(np.argmin(gaps))
            if gaps[nearest] <= config.detection_radius:
                target = ids[nearest]
        followed[id(track)] = (track, target)


def ospa_without(truth: np.ndarray, reports: Mapping[int, Tuple[np.ndarray, list]],
                 drop: Optional[str], config: MetricsConfig) -> float:
    """Return the step's OSPA of the swarm estimate without the reports of source drop.

    reports: agent id -> ((r, 2) reports, their r sources from report_sources).
    """
    kept = {agent: points[[source is None or source != drop for source in sources]]
            for agent, (points, sources) in reports.items()}
    return ospa(truth, swarm_estimate(kept, config.merge_distance), config.cutoff,
                config.order).distance
