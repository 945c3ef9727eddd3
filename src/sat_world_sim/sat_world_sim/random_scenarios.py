"""Scenarios drawn from a seed alone: the evaluation's randomised settings.

- ``random_scenario``: the random default. ``agents`` agents starting anywhere (half a sensing
  square inside the area, so their first scan is all in the area), 2 to 10 targets (uniform)
  born at uniform steps in [1, 150], living 50-150 steps, starting anywhere and moving at
  near-constant velocity (N(0, 0.5) m/s per axis, as a walking person; the end point clipped
  into the area).
- ``paper_random_scenario``: the paper's setting as a distribution (issue 14, item 4): the
  paper scenario's agents, starts, area and truth process noise, and two targets born at
  uniform steps in [80, 150] (the paper's are born at k = 104 and 144), living 30-80 steps
  (its live 76 and 39), starting anywhere and moving at a velocity drawn as above, redrawn
  until the path stays in the area (the paper's targets cross the area, they do not bounce).
- ``long_mission_scenario``: the random default carried on for a whole mission of any length
  (issue 15: drones have to keep finding people who appear after the first pass). The same
  agents and starts per seed; targets drawn as the random default's, born at uniform steps in
  [1, steps - 50] (each lives at least its shortest life in the mission, as the random default's
  last births at k = 150 of 200 do), their count Poisson with the random default's mean birth
  rate (6 targets over its 150 steps of births: 0.04 a step, 38 on average over 1,000 steps).

The random default's and the paper setting's draws do not depend on the number of steps: a
shorter run (``--quick``) keeps the targets born by its last step. A long mission's do, as its
births span the mission.

Each draw has its own random stream, ``SeedSequence([SCENARIO_SALT, setting, seed])``, apart from
the world's and the agents' streams (spawned from the scenario's seed, world_model.py). The
starts and the targets are drawn from two children of that stream, so the targets of a seed do
not depend on the team size: a team of 2 and a team of 8 meet the same truth (paired
comparisons across team sizes), and the first agents of a larger team start where the smaller
team does.
"""

import numpy as np

from sat_world_sim.scenario import Scenario, scenario_from_mapping

SCENARIO_SALT = 0x5A7E
# The second word of each setting's stream, so two settings never share targets by accident.
RANDOM_STREAM, PAPER_RANDOM_STREAM, LONG_MISSION_STREAM = 1, 2, 3
SPEED_STD = 0.5
# As in the paper's scenario: near-constant velocity.
TRUTH_PROCESS_NOISE = 1e-5
EDGE = 5.0

RANDOM_TARGETS = (2, 10)
RANDOM_BORN = (1, 150)
RANDOM_LIFETIME = (50, 150)
# Targets born per step in a long mission: the random default's mean count over its births' span.
LONG_MISSION_BIRTH_RATE = (RANDOM_TARGETS[0] + RANDOM_TARGETS[1]) / 2 / (
    RANDOM_BORN[1] - RANDOM_BORN[0] + 1)

PAPER_RANDOM_TARGETS = 2
PAPER_RANDOM_BORN = (80, 150)
PAPER_RANDOM_LIFETIME = (30, 80)
# Velocity draws tried per target before the path is clipped into the area instead; from a
# corner with an 80-step life about a quarter of the draws stay inside, so 64 never run out in
# practice.
VELOCITY_DRAWS = 64


def _streams(setting: int, seed: int):
    starts, targets = np.random.SeedSequence([SCENARIO_SALT, setting, int(seed)]).spawn(2)
    return np.random.default_rng(starts), np.random.default_rng(targets)


def random_scenario(seed: int, agents: int, steps: int, width: float = 100.0,
                    height: float = 100.0) -> Scenario:
    """Draw the random default's scenario (module docstring) from the seed alone."""
    starts, rng = _streams(RANDOM_STREAM, seed)
    area = np.array([width, height])
    targets = [_target(target_id, *random_target(rng, area)) for target_id in
               range(1, int(rng.integers(RANDOM_TARGETS[0], RANDOM_TARGETS[1] + 1)) + 1)]
    return _scenario('random', seed, steps, _random_team(starts, agents, width, height),
                     targets, TRUTH_PROCESS_NOISE, width, height)


def long_mission_scenario(seed: int, agents: int, steps: int, width: float = 100.0,
                          height: float = 100.0) -> Scenario:
    """Draw a long mission's scenario (module docstring) from the seed alone."""
    # The random default's team and starts for the seed; targets from a stream of their own.
    starts, _ = _streams(RANDOM_STREAM, seed)
    _, rng = _streams(LONG_MISSION_STREAM, seed)
    area = np.array([width, height])
    last_birth = max(1, steps - RANDOM_LIFETIME[0])
    count = int(rng.poisson(LONG_MISSION_BIRTH_RATE * last_birth))
    targets = [_target(target_id, *random_target(rng, area, (1, last_birth)))
               for target_id in range(1, count + 1)]
    return _scenario('long', seed, steps, _random_team(starts, agents, width, height),
                     targets, TRUTH_PROCESS_NOISE, width, height)


def _random_team(start_rng: np.random.Generator, agents: int, width: float, height: float):
    starts = start_rng.uniform((EDGE, EDGE), (width - EDGE, height - EDGE), size=(agents, 2))
    return [{'id': i + 1, 'start': p.tolist()} for i, p in enumerate(starts)]


def random_target(rng: np.random.Generator, area: np.ndarray, born_in=RANDOM_BORN):
    """Draw one target of the random default: (born, died, start, end), module docstring.

    born_in: the first and last step it may be born at (a long mission's span).
    """
    born = int(rng.integers(born_in[0], born_in[1] + 1))
    died = born + int(rng.integers(RANDOM_LIFETIME[0], RANDOM_LIFETIME[1] + 1)) - 1
    start = rng.uniform((0.0, 0.0), area)
    end = np.clip(start + rng.normal(0.0, SPEED_STD, 2) * (died - born), 0.0, area)
    return born, died, start, end


def paper_random_scenario(seed: int, paper: Scenario, steps: int, width: float = 100.0,
                          height: float = 100.0) -> Scenario:
    """Draw the randomised paper setting's scenario (module docstring) from the seed alone."""
    _, rng = _streams(PAPER_RANDOM_STREAM, seed)
    area = np.array([width, height])
    targets = []
    for target_id in range(1, PAPER_RANDOM_TARGETS + 1):
        born = int(rng.integers(PAPER_RANDOM_BORN[0], PAPER_RANDOM_BORN[1] + 1))
        died = born + int(rng.integers(PAPER_RANDOM_LIFETIME[0],
                                       PAPER_RANDOM_LIFETIME[1] + 1)) - 1
        start = rng.uniform((0.0, 0.0), area)
        ends = start + rng.normal(0.0, SPEED_STD, (VELOCITY_DRAWS, 2)) * (died - born)
        inside = np.flatnonzero(np.all((ends >= 0.0) & (ends <= area), axis=1))
        end = ends[inside[0]] if inside.size else np.clip(ends[0], 0.0, area)
        targets.append(_target(target_id, born, died, start, end))
    agents = [{'id': a.agent_id, 'start': list(a.start)} for a in paper.agents]
    return _scenario('paper_random', seed, steps, agents, targets, paper.truth_process_noise,
                     width, height)


def _target(target_id: int, born: int, died: int, start, end) -> dict:
    return {'id': target_id, 'born': born, 'died': died, 'start': np.asarray(start).tolist(),
            'end': np.asarray(end).tolist()}


def _scenario(name, seed, steps, agents, targets, noise, width, height) -> Scenario:
    return scenario_from_mapping({
        'name': name, 'seed': int(seed), 'steps': int(steps),
        'truth_process_noise': float(noise), 'agents': agents,
        # A target born after the last step never exists (short --steps runs).
        'targets': [t for t in targets if t['born'] <= steps]}, width, height)
