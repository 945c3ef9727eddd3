"""The oracle sweep: the evaluation's physical ceiling on finding targets (issue 14, item 5).

About the best a team of this size and sensor can do with no prior on where targets appear:
the agents sweep disjoint strips with boustrophedon paths for ever, never track, and detect
perfectly, i.e. every agent reports exactly the true positions inside its a x a sensing square
(p_D = 1, no clutter, no estimation error). No filter, no radio: a run costs the truth's motion
and the metrics only. Its detected share (= its share of targets that entered a square) is the
ceiling every policy is measured against, per setting and team size.

- Lanes: the columns of sensing-square centres of the search map with node spacing a
  (search_map.py), x_j = a/2 + j a, so the squares of adjacent lanes tile the area; a lane runs
  from the lowest to the highest row of centres. The n agents (ascending ids) get contiguous
  blocks of lanes from left to right (numpy.array_split: sizes differ by at most one).
- Cycle: an agent's strip is one boustrophedon polyline (up its first lane, across, down the
  next, ...), flown forth and back for ever (ping-pong), so the cycle is closed and every lane
  is flown once in each direction per lap.
- Speed: at most v = N_R Delta_R per step (4 m, the action set's top speed, Eqn.
  controlVectors), in straight lines, not restricted to the action set's eight directions;
  each leg between waypoints takes ceil(length / v) steps and ends exactly on its waypoint.
  From its start an agent flies straight to the nearest waypoint of its cycle, then laps.
- Period of a strip of m lanes of length l, spaced a apart:
  P = 2 (m ceil(l / v) + (m - 1) ceil(a / v)) steps (for m = 1: 2 ceil(l / v)). Every lattice
  cell of the strip is in some square within any P consecutive steps of the lap; with
  v < a consecutive squares along a lane overlap, so no cell between them is skipped.
"""

import time
from typing import List, Optional

import numpy as np

from sat_agent.config import SatParams
from sat_agent.search_map import SearchMap
from sat_agent.sensor_model import in_sensing_square

from sat_world_sim.inprocess_swarm import SwarmRun
from sat_world_sim.metrics import StepRecord
from sat_world_sim.scenario import Scenario
from sat_world_sim.world_model import World

# What the records say the agents do: they search for ever.
MODE = 'SEARCH'


def sweep_speed(params: SatParams) -> float:
    """Return v, the largest displacement of one action (N_R Delta_R)."""
    return params.actions.n_radial * params.actions.radial_step


def strip_lanes(params: SatParams, agents: int) -> List[np.ndarray]:
    """Return the x of each agent's lanes (module docstring), per agent in ascending id order."""
    columns = np.unique(SearchMap.for_area(params.area, params.sensor.square_side).centers[:, 0])
    if agents > len(columns):
        raise ValueError(f'oracle sweep: {agents} agents for {len(columns)} lanes of '
                         f'sensor.square_side = {params.sensor.square_side} m: at most one '
                         'agent per lane')
    return np.array_split(columns, agents)


def lane_ends(params: SatParams) -> np.ndarray:
    """Return (low, high): y of a lane's ends, the lowest and highest row of square centres."""
    rows = SearchMap.for_area(params.area, params.sensor.square_side).centers[:, 1]
    return np.array([rows.min(), rows.max()])


def sweep_cycle(lanes: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Return (W, 2) waypoints of the closed ping-pong cycle (the first one not repeated)."""
    polyline = []
    for number, x in enumerate(lanes):
        polyline.extend([(x, y) for y in (ends if number % 2 == 0 else ends[::-1])])
    polyline = np.array(polyline, dtype=float)
    return np.vstack([polyline, polyline[-2:0:-1]])


def leg_positions(start, end, speed: float) -> np.ndarray:
    """Return (ceil(|end - start| / speed), 2) positions after each step of a straight leg."""
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    length = float(np.hypot(*(end - start)))
    count = int(np.ceil(length / speed - 1e-9))
    if count == 0:
        return np.zeros((0, 2))
    travelled = np.minimum(np.arange(1, count + 1) * speed, length)
    return start + np.outer(travelled / length, end - start)


def lap_positions(cycle: np.ndarray, speed: float) -> np.ndarray:
    """Return (P, 2) positions of one lap from cycle[0], ending on it: P is the period."""
    closed = np.vstack([cycle, cycle[:1]])
    return np.vstack([leg_positions(a, b, speed) for a, b in zip(closed[:-1], closed[1:])])


def sweep_positions(start, cycle: np.ndarray, speed: float, steps: int) -> np.ndarray:
    """Return (steps, 2) positions s_1 .. s_steps: start, leg to the nearest waypoint, laps."""
    start = np.asarray(start, dtype=float)
    entry = int(np.argmin(np.hypot(*(cycle - start).T)))
    lap = lap_positions(np.roll(cycle, -entry, axis=0), speed)
    approach = np.vstack([start[None, :], leg_positions(start, cycle[entry], speed)])
    laps = np.resize(lap, (max(steps - len(approach), 0), 2))
    return np.vstack([approach, laps])[:steps]


def run_oracle_sweep(scenario: Scenario, params: SatParams,
                     steps: Optional[int] = None) -> SwarmRun:
    """Run the oracle sweep over the scenario's truth; records as the in-process swarm's.

    The truth is the World's, so for a seed the oracle meets the same targets as every policy.
    final_density is the coverage (1 where some square has been).
    """
    steps = steps or scenario.steps
    started = time.perf_counter()
    world = World(scenario, params)
    ids = world.agent_ids
    speed = sweep_speed(params)
    ends = lane_ends(params)
    starts = {a.agent_id: a.start for a in scenario.agents}
    paths = {agent_id: sweep_positions(starts[agent_id], sweep_cycle(lanes, ends), speed, steps)
             for agent_id, lanes in zip(ids, strip_lanes(params, len(ids)))}
    side = params.sensor.square_side
    records = []
    for row in range(steps):
        truth = world.truth()
        poses = world.poses()
        records.append(StepRecord(
            step=world.step, truth_ids=truth.ids, truth_positions=truth.positions,
            agent_poses=poses, modes={a: MODE for a in ids},
            estimates={a: truth.positions[in_sensing_square(truth.positions, poses[a], side)]
                       for a in ids},
            searched_fraction=world.searched_fraction()))
        if row + 1 < steps:
            world.place_agents({a: paths[a][row + 1] for a in ids})
        world.advance()
    return SwarmRun(scenario, records, world.coverage.astype(float),
                    time.perf_counter() - started)
