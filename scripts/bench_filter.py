#!/usr/bin/env python3
"""Benchmark the project's SMC-PHD step against Stone Soup 1.9 and time the agent's decision.

Usage: ``python scripts/bench_filter.py [--json]``

1. Filter step (predict + update + resample) at 5k and 20k particles with 15 measurements, in
   one process:
   - project: ``SatPhdFilter.predict`` + ``correct`` (gated update, uniform and measurement
     births, systematic resampling back to N);
   - Stone Soup stock: ``SMCPHDPredictor`` + ``SMCPHDUpdater`` with ``CartesianToBearingRange``
     (fixed covariance; its logpdf loops over measurements and adds a noise sample), scalar p_D,
     systematic resampling back to N, the same number of uniform birth particles;
   - Stone Soup vectorised: the same, with the updater's likelihood replaced by one vectorised
     noise-free (N, M) evaluation of the paper's range-dependent likelihood.
   Stone Soup's p_D is a scalar, so it evaluates every particle; the project evaluates only the
   particles inside the sensing square (p_D = 0 elsewhere). The speed-up therefore depends on
   where the particles are, and both placements are printed:
   - "tracking": 20 % of the particles are a tracked target's cloud inside the square, 80 % are
     the diffuse PHD spread uniformly over the 100 m x 100 m area (what an agent tracking one
     target holds: the diffuse mass of uniform births outside its view, which gating skips);
   - "all in square": every particle inside the sensing square (no gating gain).
2. Decision step: ``Agent.step`` (filter correct, extraction, mode machine, search planning or
   the 17-action Renyi tracking control, predict) timed inside the one-agent in-process loop of
   ``sat_world_sim.inprocess_swarm`` on a scenario where the agent searches, then tracks, over
   the seeds DECISION_SEEDS (whether and when the target is found depends on the seed: with the
   persistent profile the agent never tracks on seed 0); with the default parameters (particle
   budget adaptive, up to 20k) and with the persistent profile (config/persistent.yaml,
   issue 15) at a fixed 20k particles. Percentiles over all steps and per mode.
3. The tracking control's norm: the persistent decision step again, each seed run once with
   the control's own norm (sensor_model.plain_hypot) and once with the filter's (np.hypot,
   the control before session 38), in turns; the runs are the same step for step
   (tracking_control.py), so the steps pair up: their ratio is what the control's norm saves.

With ``--json`` the last line printed is a JSON object for the 20k "tracking" case with keys
particles, speedup_vs_stonesoup, speedup_vs_stonesoup_vectorized, decision_step_p95_ms,
decision_step_p95_ms_persistent_20k, decision_step_p95_ms_persistent_20k_track (its TRACK
steps only) and decision_step_p95_ms_persistent_20k_hypot (3.).
"""

import argparse
from dataclasses import replace
import datetime
import json
from pathlib import Path
import sys
import time

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(REPO / 'src' / 'sat_agent'), str(REPO / 'src' / 'sat_world_sim')]

from sat_agent import sensor_model  # noqa: E402
from sat_agent.config import load_params_file, SatParams  # noqa: E402
from sat_agent.phd_filter import ParticlePHD, SatPhdFilter  # noqa: E402

POSE = np.array([50.0, 50.0])
TARGET = np.array([52.0, 48.5])
N_MEASUREMENTS = 15
SIZES = (5000, 20000)
# Seeds of the decision-step scenario: with the persistent profile the agent tracks on 4 of them
# (seed 0 not), the default profile on all.
DECISION_SEEDS = range(5)


def particle_set(count, layout, rng):
    """Return (N, 4) states and weights: one target's cloud plus diffuse mass (module doc)."""
    states = np.zeros((count, 4))
    states[:, [1, 3]] = rng.normal(0.0, 1.0, (count, 2))
    cloud = count // 5 if layout == 'tracking' else count
    states[:cloud, [0, 2]] = TARGET + rng.normal(0.0, 1.0, (cloud, 2))
    if layout == 'tracking':
        states[cloud:, [0, 2]] = rng.uniform(0.0, 100.0, (count - cloud, 2))
    else:
        states[cloud // 2:, [0, 2]] = POSE + rng.uniform(-5.0, 5.0, (count - cloud // 2, 2))
    inside = sensor_model.in_sensing_square(states[:, [0, 2]], POSE, 10.0)
    states[:cloud][~inside[:cloud], 0] = TARGET[0]       # keep the whole cloud in view
    states[:cloud][~inside[:cloud], 2] = TARGET[1]
    weights = np.where(np.arange(count) < cloud, 1.0 / cloud, 1.0 / max(count - cloud, 1))
    return states, weights


def scan(params, rng):
    """One target detection plus clutter: N_MEASUREMENTS rows of [range, bearing]."""
    clean = replace(params.sensor, p_detect=1.0, clutter_rate=0.0)
    z, _ = sensor_model.simulate_scan(TARGET[None], POSE, clean, rng)
    clutter = np.column_stack([rng.uniform(0, params.sensor.max_range, N_MEASUREMENTS - 1),
                               rng.uniform(-np.pi, np.pi, N_MEASUREMENTS - 1)])
    return np.vstack([z, clutter])


def time_calls(run, repetitions):
    """Median wall time of run() in milliseconds (run does its own untimed setup)."""
    samples = [run() for _ in range(repetitions)]
    return float(np.median(samples)) * 1e3


def project_step_ms(params, states, weights, z, repetitions):
    count = len(weights)
    params = replace(params, phd=replace(params.phd, min_particles=count, max_particles=count))
    sat = SatPhdFilter(params, np.random.default_rng(1))

    def run():
        sat.targets = ParticlePHD(states.copy(), weights.copy())
        sat.pending_births = ParticlePHD.empty()
        start = time.perf_counter()
        sat.predict(POSE)
        sat.correct(z, POSE)
        return time.perf_counter() - start

    return time_calls(run, repetitions)


class _StoneSoup:
    """Stone Soup 1.9 SMC-PHD predictor and updater configured like the project's filter."""

    def __init__(self, params, count, vectorized):
        from stonesoup.models.measurement.nonlinear import CartesianToBearingRange
        from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                        ConstantVelocity)
        from stonesoup.predictor.particle import SMCPHDPredictor
        from stonesoup.resampler.particle import SystematicResampler
        from stonesoup.sampler.particle import ParticleSampler
        from stonesoup.types.array import StateVector
        from stonesoup.types.numeric import Probability
        from stonesoup.updater.particle import SMCPHDUpdater

        sensor = params.sensor
        rng = np.random.default_rng(2)

        def uniform_births(num_samples):
            samples = np.zeros((num_samples, 4))
            samples[:, [0, 2]] = rng.uniform(0.0, 100.0, (num_samples, 2))
            samples[:, [1, 3]] = rng.normal(0.0, params.phd.birth_velocity_std, (num_samples, 2))
            return samples

        cv = ConstantVelocity(params.motion.process_noise)
        self.predictor = SMCPHDPredictor(
            transition_model=CombinedLinearGaussianTransitionModel([cv, cv]),
            death_probability=-np.log(params.motion.p_survival),
            birth_probability=params.phd.birth_particles_uniform / count,
            birth_rate=params.phd.birth_rate,
            birth_sampler=ParticleSampler(distribution_func=uniform_births, params={},
                                          ndim_state=4))
        self.model = CartesianToBearingRange(
            ndim_state=4, mapping=(0, 2),
            noise_covar=np.diag([sensor.sigma_bearing_0 ** 2, sensor.sigma_range_0 ** 2]),
            translation_offset=StateVector(POSE))

        class VectorizedUpdater(SMCPHDUpdater):
            """Likelihood of all particles and measurements in one numpy evaluation."""

            def _get_measurement_loglikelihoods(self, prediction, detections):
                z = np.array([[float(d.state_vector[1, 0]), float(d.state_vector[0, 0])]
                              for d in detections])
                points = np.asarray(prediction.state_vector, dtype=float)[[0, 2], :].T
                return sensor_model.log_likelihood(z, points, POSE, sensor)

        updater_class = VectorizedUpdater if vectorized else SMCPHDUpdater
        self.updater = updater_class(
            measurement_model=self.model, prob_detect=Probability(sensor.p_detect),
            clutter_intensity=sensor_model.clutter_intensity(sensor),
            resampler=SystematicResampler(), num_samples=count)

    def step_ms(self, states, weights, z, repetitions):
        from stonesoup.types.angle import Bearing
        from stonesoup.types.array import StateVector, StateVectors
        from stonesoup.types.detection import Detection, MissedDetection
        from stonesoup.types.hypothesis import SingleHypothesis
        from stonesoup.types.multihypothesis import MultipleHypothesis
        from stonesoup.types.state import ParticleState

        now = datetime.datetime(2026, 1, 1)
        later = now + datetime.timedelta(seconds=1)
        detections = [Detection(StateVector([Bearing(row[1]), row[0]]), timestamp=later,
                                measurement_model=self.model) for row in z]

        def run():
            prior = ParticleState(StateVectors(states.T.copy()), log_weight=np.log(weights),
                                  timestamp=now)
            start = time.perf_counter()
            prediction = self.predictor.predict(prior, timestamp=later)
            hypotheses = MultipleHypothesis(
                [SingleHypothesis(prediction, MissedDetection(timestamp=later))]
                + [SingleHypothesis(prediction, d) for d in detections])
            self.updater.update(hypotheses)
            return time.perf_counter() - start

        return time_calls(run, repetitions)


def filter_rows(params, have_stonesoup):
    """Time every (size, layout) case; return a list of result dicts."""
    rows = []
    for count in SIZES:
        for layout in ('tracking', 'all in square'):
            rng = np.random.default_rng(count)
            states, weights = particle_set(count, layout, rng)
            z = scan(params, rng)
            inside = sensor_model.in_sensing_square(states[:, [0, 2]], POSE, 10.0).mean()
            row = {'particles': count, 'layout': layout, 'in_square': float(inside),
                   'project_ms': project_step_ms(params, states, weights, z, 40)}
            if have_stonesoup:
                stock = _StoneSoup(params, count, vectorized=False)
                row['stonesoup_ms'] = stock.step_ms(states, weights, z, 3 if count > 5000 else 5)
                vectorized = _StoneSoup(params, count, vectorized=True)
                row['stonesoup_vectorized_ms'] = vectorized.step_ms(states, weights, z, 10)
            rows.append(row)
    return rows


def decision_step_ms(params, steps=150, seeds=DECISION_SEEDS, norms=(None,)):
    """Time Agent.step in a one-agent in-process loop: {norm: (all samples, per mode)}.

    norms: the tracking control's (None: its own); with several, each seed runs with each in
    turns (the order reversed on odd seeds), so a machine's drift weighs on each alike.
    """
    runs = {norm: ([], []) for norm in norms}
    for seed in seeds:
        for norm in (norms if seed % 2 == 0 else norms[::-1]):
            seed_samples, seed_modes = _timed_run(params, steps, seed, norm)
            runs[norm][0].extend(seed_samples)
            runs[norm][1].extend(seed_modes)
    timed = {}
    for norm, (samples, modes) in runs.items():
        samples, modes = np.array(samples) * 1e3, np.array(modes)
        timed[norm] = samples, {mode: samples[modes == mode] for mode in sorted(set(modes))}
    return timed


def _timed_run(params, steps, seed, norm=None):
    """Return the seconds and modes of every Agent.step of one run of the scenario."""
    from sat_world_sim.inprocess_swarm import InProcessSwarm
    from sat_world_sim.scenario import scenario_from_mapping

    # config/scenarios/single_target.yaml's agent and first target (born in its first walk,
    # found in 2-6 steps over seeds 0-9 by the default profile), slower and longer-lived, so
    # the agent searches, then tracks for most steps; a second target is born away from it at
    # k = 40.
    scenario = scenario_from_mapping({
        'name': 'bench', 'seed': seed, 'steps': steps, 'truth_process_noise': 1e-4,
        'agents': [{'id': 1, 'start': [50.0, 50.0]}],
        'targets': [{'id': 1, 'born': 3, 'died': steps, 'start': [46.0, 40.0],
                     'end': [70.0, 10.0]},
                    {'id': 2, 'born': 40, 'died': steps, 'start': [20.0, 80.0],
                     'end': [60.0, 60.0]}]})
    swarm = InProcessSwarm(scenario, params)
    agent = swarm.agents[1]
    if norm is not None:
        agent.tracking.norm = norm
    timed_step = agent.step
    samples, modes = [], []

    def step(*args, **kwargs):
        start = time.perf_counter()
        output = timed_step(*args, **kwargs)
        samples.append(time.perf_counter() - start)
        modes.append(output.mode.name)
        return output

    agent.step = step
    for _ in range(steps):
        swarm.step()
    return samples, modes


def print_decision_step(title, samples, by_mode):
    """Print the decision step's percentiles, overall and per mode."""
    print(f'decision step ({title}; Agent.step, one-agent in-process loop, seeds '
          f'{DECISION_SEEDS.start}-{DECISION_SEEDS.stop - 1}, {len(samples)} steps): '
          f'p50 {np.percentile(samples, 50):.2f} ms, '
          f'p95 {np.percentile(samples, 95):.2f} ms, max {samples.max():.2f} ms')
    for mode, values in by_mode.items():
        print(f'  {mode}: {len(values)} steps, p50 {np.percentile(values, 50):.2f} ms, '
              f'p95 {np.percentile(values, 95):.2f} ms')


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--json', action='store_true',
                        help='print a JSON summary of the 20k tracking case as the last line')
    args = parser.parse_args(argv)
    params = SatParams()
    try:
        import stonesoup
        have_stonesoup = True
        version = stonesoup.__version__
    except ImportError:
        have_stonesoup, version = False, 'not installed'
    print(f'SMC-PHD step (predict + update + resample), {N_MEASUREMENTS} measurements, '
          f'Stone Soup {version}; medians in ms')
    print('layouts: "tracking" = 20% of particles a target cloud inside the 10 m square, 80% '
          'diffuse over the 100 m area; "all in square" = every particle inside the square')
    rows = filter_rows(params, have_stonesoup)
    for row in rows:
        line = (f"N={row['particles']:>6} {row['layout']:<14} ({row['in_square']:.0%} in "
                f"square): project {row['project_ms']:7.2f}")
        if have_stonesoup:
            row['speedup'] = row['stonesoup_ms'] / row['project_ms']
            row['speedup_vectorized'] = row['stonesoup_vectorized_ms'] / row['project_ms']
            line += (f" | stonesoup {row['stonesoup_ms']:8.1f} (x{row['speedup']:.1f})"
                     f" | stonesoup vectorised {row['stonesoup_vectorized_ms']:7.2f}"
                     f" (x{row['speedup_vectorized']:.1f})")
        print(line)
    samples, by_mode = decision_step_ms(params)[None]
    print_decision_step('default parameters', samples, by_mode)
    persistent = load_params_file(REPO / 'config' / 'persistent.yaml')
    persistent = replace(persistent, phd=replace(persistent.phd, min_particles=20000,
                                                 max_particles=20000))
    timed = decision_step_ms(persistent, norms=(None, np.hypot))
    persistent_samples, persistent_modes = timed[None]
    hypot_samples, hypot_modes = timed[np.hypot]
    print_decision_step('config/persistent.yaml, 20k particles', persistent_samples,
                        persistent_modes)
    print_decision_step('the same, the tracking control with np.hypot', hypot_samples,
                        hypot_modes)
    tracking = persistent_modes.get('TRACK', np.array([np.nan]))
    # The steps pair up only while both norms choose every action alike (tracking_control.py).
    hypot_tracking = hypot_modes.get('TRACK', np.zeros(0))
    if 'TRACK' in persistent_modes and len(hypot_tracking) == len(tracking):
        print(f'  TRACK steps, paired (the same steps): median ratio np.hypot / own '
              f'x{np.median(hypot_tracking / tracking):.2f}; p95 of all steps '
              f'x{np.percentile(hypot_samples, 95) / np.percentile(persistent_samples, 95):.2f}')
    else:
        print('  no paired ratio: the two norms did not run the same TRACK steps')
    if args.json:
        main_row = next(r for r in rows if r['particles'] == 20000 and r['layout'] == 'tracking')
        print(json.dumps({
            'particles': main_row['particles'],
            'speedup_vs_stonesoup': round(main_row.get('speedup', float('nan')), 2),
            'speedup_vs_stonesoup_vectorized': round(
                main_row.get('speedup_vectorized', float('nan')), 2),
            'decision_step_p95_ms': round(float(np.percentile(samples, 95)), 3),
            'decision_step_p95_ms_persistent_20k': round(
                float(np.percentile(persistent_samples, 95)), 3),
            'decision_step_p95_ms_persistent_20k_track': round(
                float(np.percentile(tracking, 95)), 3),
            'decision_step_p95_ms_persistent_20k_hypot': round(
                float(np.percentile(hypot_samples, 95)), 3)}))
    return 0


if __name__ == '__main__':
    sys.exit(main())
