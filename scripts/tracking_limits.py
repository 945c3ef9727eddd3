#!/usr/bin/env python3
"""What limits tracking under dense clutter: the figures of README "Clutter".

Three in-process measurements (no ROS), each for the filter's Q scales given by --q-scales:

1. hover: a walking target (0.6 m/s) starts 4 m from an agent that stays put; the median, over
   seeds, of the PHD mass within 2 m of the target after each of 8 scans. Under lambda = 10 it
   settles near 1 - kappa / g-bar, so a wide predicted cloud (large Q) keeps it low.
2. single: one agent on config/scenarios/single_target.yaml; mean OSPA (c = 10, p = 2) while
   tracking, pooled over each block of 10 seeds.
3. triggers: the first 30 steps of single_target.yaml with looks at tentative peaks switched
   off; for each mass threshold, in how many seeds a peak (tentative or confirmed) within 2.5 m
   of the target reaches it, after one scan or on two scans in a row (within 2 m of the last
   scan's predicted peak), and on what share of the scans such a peak appears away from every
   target (clutter).

    scripts/with_env.sh python scripts/tracking_limits.py [--params config/dense_clutter.yaml]
        [--q-scales 1 0.02] [--blocks 0 20 30]
"""

import argparse
from pathlib import Path

import numpy as np

from sat_agent import motion_model, sensor_model
from sat_agent.config import load_params_file, SatParams
from sat_agent.phd_filter import SatPhdFilter
from sat_world_sim.inprocess_swarm import InProcessSwarm, run_swarm
from sat_world_sim.metrics import compute_metrics
from sat_world_sim.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
SINGLE = ROOT / 'config' / 'scenarios' / 'single_target.yaml'
THRESHOLDS = (0.1, 0.2, 0.3)
TRUE_PEAK_DISTANCE = 2.5   # m: a peak this close to the target is about the target
SAME_PEAK_DISTANCE = 2.0   # m: two scans' peaks this close are the same peak


def hover_masses(params: SatParams, seeds: int, scans: int = 8) -> np.ndarray:
    """Median over seeds of the PHD mass within 2 m of the target after each scan."""
    pose = np.array([50.0, 50.0])
    masses = np.zeros((seeds, scans))
    for seed in range(seeds):
        rng = np.random.default_rng(seed)
        phd = SatPhdFilter(params, np.random.default_rng(1000 + seed))
        phd.predict(pose)
        target = pose + np.array([3.2, 2.4])
        for scan in range(scans):
            measurements, _ = sensor_model.simulate_scan(target[None], pose, params.sensor, rng)
            phd.correct(measurements, pose)
            points = motion_model.positions(phd.targets.states)
            masses[seed, scan] = phd.targets.weights[np.hypot(*(points - target).T) < 2.0].sum()
            phd.predict(pose)
            target = target + np.array([-0.6, 0.0])
    return np.median(masses, axis=0)


def single_agent_ospa(params: SatParams, first_seed: int, seeds: int = 10) -> float:
    """Mean OSPA while tracking, pooled over the block's seeds."""
    tracked = []
    scenario = load_scenario(SINGLE)
    for seed in range(first_seed, first_seed + seeds):
        run = run_swarm(scenario.with_seed(seed), params)
        metrics = compute_metrics(run.records, scenario.name, seed)
        tracked += [s['ospa'] for s in metrics['steps'] if s['tracking']]
    return float(np.mean(tracked)) if tracked else float('nan')


def peaks_seen(params: SatParams, seed: int, steps: int):
    """Per step: the truth and the (position, predicted position, mass) of every peak seen."""
    scenario = load_scenario(SINGLE).with_seed(seed)
    swarm = InProcessSwarm(scenario, params)
    (agent_id,) = scenario.agent_ids
    for _ in range(steps):
        record = swarm.step()
        estimate = swarm.last_outputs[agent_id].estimate
        peaks = [(t.position, t.position + t.velocity, t.weight) for t in estimate.tentative]
        peaks += [(t.position, t.position + t.velocity, 1.0) for t in estimate.targets]
        yield record.truth_positions, peaks


def trigger_rates(params: SatParams, seeds: int, steps: int = 30) -> dict:
    """{(threshold, scans in a row): (seeds whose target is marked, % of scans with clutter)}."""
    looks_off = params.with_overrides({'additions': {'investigation': False},
                                       'phd': {'tentative_threshold': min(THRESHOLDS)}})
    marked = {(m, n): 0 for m in THRESHOLDS for n in (1, 2)}
    false_scans = dict.fromkeys(marked, 0)
    for seed in range(seeds):
        hit = set()
        previous = []
        for truth, peaks in peaks_seen(looks_off, seed, steps):
            for key in marked:
                threshold, in_a_row = key
                on_clutter = False
                for position, predicted, mass in peaks:
                    if mass < threshold or (in_a_row == 2 and not any(
                            w >= threshold and np.hypot(*(p - predicted)) < SAME_PEAK_DISTANCE
                            for p, w in previous)):
                        continue
                    near = len(truth) and np.hypot(*(truth - position).T).min() < \
                        TRUE_PEAK_DISTANCE
                    if near:
                        hit.add(key)
                    else:
                        on_clutter = True
                false_scans[key] += on_clutter
            previous = [(predicted, mass) for _, predicted, mass in peaks]
        for key in hit:
            marked[key] += 1
    return {key: (marked[key], 100.0 * false_scans[key] / (seeds * steps)) for key in marked}


def main(argv=None) -> int:
    """Command-line entry point (module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--params', type=Path, default=ROOT / 'config' / 'dense_clutter.yaml',
                        help='parameter file (default: the dense reading of the clutter)')
    parser.add_argument('--q-scales', type=float, nargs='+', default=[1.0, 0.02],
                        help='filter Q scales (motion.process_noise) to compare')
    parser.add_argument('--blocks', type=int, nargs='+', default=[0, 20, 30],
                        help='first seeds of the 10-seed blocks of the single-agent runs')
    parser.add_argument('--hover-seeds', type=int, default=20)
    parser.add_argument('--trigger-seeds', type=int, default=12)
    args = parser.parse_args(argv)
    base = load_params_file(args.params)
    for scale in args.q_scales:
        params = base.with_overrides({'motion': {'process_noise': scale}})
        print(f'Q scale {scale:g}')
        hover = ' '.join(f'{m:.2f}' for m in hover_masses(params, args.hover_seeds))
        print(f'  hover: median mass near the target after each scan: {hover}')
        for first in args.blocks:
            print(f'  single: seeds {first}-{first + 9}: mean OSPA while tracking '
                  f'{single_agent_ospa(params, first):.2f} m')
        rates = trigger_rates(params, args.trigger_seeds)
        for (threshold, in_a_row), (seeds, clutter) in sorted(rates.items()):
            print(f'  triggers: mass >= {threshold:g} on {in_a_row} scan(s) in a row: target '
                  f'marked in {seeds}/{args.trigger_seeds} seeds, clutter on {clutter:.0f} % '
                  'of scans')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
