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

The oracle sweep-and-track (``run_oracle_sweep(..., follow=True)``): a reference for the
tracked share, which the sweep cannot give (a sweeper holds a target in view for a few steps).
The agents sweep as above, with the same perfect sensor; a sweeping agent that has a target in
its square which no agent follows follows it (the nearest; agents in ascending id order) and
holds it in view until it dies: each step it flies, at most v, towards the target's next true
position x + v T (inside the area), so a target slower than v never leaves its square. When its
target dies it flies back to its strip (the nearest waypoint of its cycle) and laps again. Its
strip is left unswept meanwhile: nobody takes it over. It is one reading of "sweep, and track
what you find", knowing the truth, not a bound: an oracle that released targets or shared
strips could trade tracked share for detected share differently. With ``follow_limit`` L an
agent follows a target for L steps at most, then releases it for good (nobody follows it again)
and flies back to its strip: L from 0 (the sweep) to the targets' lives traces how this oracle
trades detected for tracked share (scripts/oracle_frontier.py).

Two more readings of "sweep, and track what you find", for the same frontier: with
``followers`` F only the F highest ids may follow, the others sweep for ever (dedicated
searchers); with ``dispatch`` a free follower takes the nearest target, followed by nobody and
not released, that any agent has had in its square so far (not only one in its own square),
flies to it at most v a step and follows it from then on: the team knows where every target it
has seen is, as a swarm sharing perfect tracks would. Both keep the strips: an agent flies back
to its own when it stops following. docs/persistent_trials.md has their figures: none meets the
floors.

With ``tour`` (session 35) the agents do not fly strips: they ride one closed tour over every
lane, evenly phased, the cyclic strategy of persistent patrolling (Chevaleyre, "Theoretical
analysis of the multi-agent patrolling problem", IAT 2004), which keeps every cell's idle time
near P/n steps where a strip's ends wait a whole ping-pong lap:

- Tour (``tour_cycle``): up the first lane over every row, the other lanes snaked over every
  row but the lowest, back along the lowest row (closed, no lane flown twice, for an even lane
  count; an odd count flies the last lane down again; one lane or one row forth and back). At
  the default (10 lanes of 90 m, a = 10 m, v = 4 m) it is 1000 m, P = 256 steps.
- Slots: agent i of n (ascending ids, rank r = 0 .. n - 1) owns the slot at
  lap[(row + floor(r P / n)) mod P] at record row. From its start (and, following, when its
  target dies or is released) it flies straight at v to the first point of its slot it can
  reach (``tour_positions``), waits there for the slot, then rides it. A slot left by a
  follower stays empty; nobody closes the gap.

At the random default it finds more targets than the strips (+9 points over 300 fresh dev
seeds; docs/persistent_trials.md, sessions 34-35, have the paired
figures), but it is not a new yardstick: issue 8's ceiling, which issue 15's detected floor is
a share of, stays the strips' sweep.

With ``coast`` the agents also report the targets they saw and no longer see, as
additions.track_coasting does (beyond_paper/track_coasting.py) but knowing the velocity: an
agent that had a target in its square at step s reports x_s + v_s (k - s) T at k, while
k - s <= track_coasting.coast_steps (p_S^t >= phd.coast_survival), the target is in no square
(else the agent seeing it reports it), the point is not in the agent's own square (it would
see the target there) and inside the area. A target that died out of view is reported on (a
false track) until one of these ends it, as the addition's track would be.

With ``scans`` N and ``window`` W (the sensor-limited reading, session 25) a target counts as
found only once one agent has had it in its square on N of that agent's last W steps, as the
filter needs more than one scan of a measurement among clutter to confirm a target
(additions.confirmation: two scans with round(mass) >= 1). From then on the team knows it: every
agent reports it (and may follow or coast it) whenever it is in that agent's square. Before,
nobody reports it, even in view. N = W = 1 is the perfect sensor above. The paths are the
sweep's: no agent turns back for a target seen once, as the filter's looks do, so this is the
ceiling of a sweep with a multi-scan detector, not of our policy.
"""

from functools import partial
import time
from typing import List, Optional

import numpy as np

from sat_agent.actions import inside_area, top_speed
from sat_agent.beyond_paper.track_coasting import coast_steps
from sat_agent.config import SatParams
from sat_agent.motion_model import POSITION, VELOCITY
from sat_agent.search_map import SearchMap
from sat_agent.sensor_model import in_sensing_square

from sat_world_sim.inprocess_swarm import SwarmRun
from sat_world_sim.metrics import StepRecord
from sat_world_sim.scenario import Scenario
from sat_world_sim.world_model import World

# What the records say the agents do: the sweep searches for ever; sweep-and-track follows.
MODE = 'SEARCH'
FOLLOW_MODE = 'TRACK'


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


def tour_cycle(centers: np.ndarray) -> np.ndarray:
    """Return (W, 2) waypoints of the closed tour over the square centres (module docstring).

    The first waypoint is the lowest row of the first lane; the lap closes back on it.
    """
    centers = np.asarray(centers, dtype=float).reshape(-1, 2)
    lanes, rows = np.unique(centers[:, 0]), np.unique(centers[:, 1])
    low, high = rows[0], rows[-1]
    if len(lanes) == 1 or len(rows) == 1:
        return np.array([[lanes[0], low], [lanes[-1], high]])
    second = rows[1]
    points = [(lanes[0], low), (lanes[0], high)]
    for number, x in enumerate(lanes[1:]):
        points.extend([(x, y) for y in ((high, second) if number % 2 == 0 else (second, high))])
    if points[-1][1] != second:
        points.append((lanes[-1], second))
    points.append((lanes[-1], low))
    return np.array(points)


def tour_lap(params: SatParams) -> np.ndarray:
    """Return (P, 2) positions of one lap of the tour over the search map's square centres."""
    tour = SearchMap.for_area(params.area, params.sensor.square_side)
    return lap_positions(tour_cycle(tour.centers), top_speed(params.actions))


def tour_positions(start, lap: np.ndarray, phase: int, speed: float, steps: int) -> np.ndarray:
    """Return (steps, 2) positions from start riding the slot that is at lap[phase] now.

    The first is start; the agent flies straight at speed to the slot's first point it can
    reach, lap[(phase + t) mod P] with the least t >= 1 within t speed, waits there until the
    slot arrives (row t) and rides it from then on.
    """
    start = np.asarray(start, dtype=float)
    period = len(lap)
    ahead = np.arange(1, period + 1)
    reach = np.hypot(*(lap[(phase + ahead) % period] - start).T) <= ahead * speed + 1e-9
    meet = int(ahead[np.argmax(reach)])
    approach = leg_positions(start, lap[(phase + meet) % period], speed)
    wait = np.repeat(lap[[(phase + meet) % period]], meet - len(approach), axis=0)
    ride = lap[(phase + meet + np.arange(1, max(steps - meet, 0) + 1)) % period]
    return np.vstack([start[None, :], approach, wait, ride])[:steps]


def follow_position(pose, state, speed: float, params: SatParams) -> np.ndarray:
    """Return a follower's next position: towards the target's x + v T inside the area, <= v.

    state: the target's [x, vx, y, vy] (motion_model order).
    """
    pose, state = np.asarray(pose, dtype=float), np.asarray(state, dtype=float)
    area = params.area
    aim = state[list(POSITION)] + params.motion.dt * state[list(VELOCITY)]
    aim = np.clip(aim, (0.0, 0.0), (area.width, area.height))
    offset = aim - pose
    length = float(np.hypot(*offset))
    return aim if length <= speed else pose + offset * (speed / length)


class _Sweeper:
    """One agent of the oracle: its route, the path it is on and the target it follows.

    route(start, row, count): the (count, 2) positions from start at record row on, flying its
    strip (sweep_positions) or riding its slot of the tour (tour_positions).
    """

    def __init__(self, start, route, steps: int):
        self.route = route
        self.path = route(start, 0, steps)
        self.cursor = 0
        self.target = None
        self.since = 0

    def resume(self, pose, row: int, steps_left: int) -> None:
        """Back to the route from pose at record row (its strip or its slot)."""
        self.path = self.route(pose, row, steps_left)
        self.cursor = 0
        self.target = None

    def next_sweep_position(self) -> np.ndarray:
        """Step along the path and return its next position."""
        self.cursor += 1
        return self.path[self.cursor]


def _assign_followers(team, truth, poses, in_view: dict, row: int, released: set,
                      known: Optional[set]) -> None:
    """Free agents (ascending id) follow the nearest target nobody follows or released.

    The candidates: the targets in the agent's square (in_view: agent id -> mask over the truth
    rows), or with known (dispatch) the targets some agent has seen so far. team holds the
    agents that may follow.
    """
    followed = {s.target for s in team.values() if s.target is not None} | released
    for agent_id in sorted(team):
        sweeper = team[agent_id]
        if sweeper.target is not None:
            continue
        if known is None:
            candidates = in_view[agent_id]
        else:
            candidates = np.isin(truth.ids, list(known))
        free = candidates & ~np.isin(truth.ids, list(followed))
        if free.any():
            distance = np.hypot(*(truth.positions - poses[agent_id]).T)
            # argmin returns the first minimum: equal distances go to the lower id's row.
            pick = int(np.argmin(np.where(free, distance, np.inf)))
            sweeper.target, sweeper.since = int(truth.ids[pick]), row
            followed.add(sweeper.target)


def run_oracle_sweep(scenario: Scenario, params: SatParams, steps: Optional[int] = None,
                     follow: bool = False, follow_limit: Optional[int] = None,
                     followers: Optional[int] = None, dispatch: bool = False,
                     coast: bool = False, scans: int = 1, window: int = 1,
                     tour: bool = False) -> SwarmRun:
    """Run the oracle sweep (follow: sweep-and-track) over the scenario's truth (docstring).

    follow_limit: the most steps an agent follows one target (None: until it dies).
    followers: how many agents may follow, the highest ids (None: all of them).
    dispatch: free followers take any target seen so far, not only one in their square.
    coast: report the targets seen before and out of view now (module docstring).
    scans, window: a target is found once one agent had it in view on scans of its last window
    steps (module docstring; 1 and 1: at first sight).
    tour: ride evenly phased slots of one closed tour instead of strips (module docstring).

    Records as the in-process swarm's. The truth is the World's, so for a seed the oracle meets
    the same targets as every policy. final_density is the coverage (1 where some square has
    been).
    """
    steps = steps or scenario.steps
    started = time.perf_counter()
    world = World(scenario, params)
    ids = world.agent_ids
    speed = top_speed(params.actions)
    starts = {a.agent_id: a.start for a in scenario.agents}
    team = {agent_id: _Sweeper(starts[agent_id], route, steps)
            for agent_id, route in zip(ids, _routes(params, len(ids), speed, tour))}
    side = params.sensor.square_side
    limit = np.inf if follow_limit is None else follow_limit
    count = len(ids) if followers is None else followers
    if not 0 <= count <= len(ids):
        raise ValueError(f'oracle sweep: followers = {followers} for a team of {len(ids)}: '
                         f'must be 0 to {len(ids)}')
    chasers = {agent_id: team[agent_id] for agent_id in sorted(ids)[len(ids) - count:]}
    released = set()
    known = set() if dispatch else None
    coasting = _Coasting(params) if coast else None
    confirmation = Confirmation(scans, window)
    records = []
    for row in range(steps):
        truth = world.truth()
        poses = world.poses()
        in_view = confirmation.found_in_view(world.step, truth.ids, {
            a: in_sensing_square(truth.positions, poses[a], side) for a in ids})
        if dispatch:
            known.update(truth.ids[np.any(list(in_view.values()), axis=0)].tolist())
        if follow:
            alive = set(truth.ids.tolist())
            for agent_id, sweeper in chasers.items():
                if sweeper.target is None:
                    continue
                if row - sweeper.since >= limit:
                    released.add(sweeper.target)
                elif sweeper.target in alive:
                    continue
                sweeper.resume(poses[agent_id], row, steps - row)
            _assign_followers(chasers, truth, poses, in_view, row, released, known)
        records.append(StepRecord(
            step=world.step, truth_ids=truth.ids, truth_positions=truth.positions,
            agent_poses=poses,
            modes={a: MODE if team[a].target is None else FOLLOW_MODE for a in ids},
            estimates={a: truth.positions[in_view[a]] for a in ids} if coasting is None
            else coasting.estimates(world.step, truth, poses, in_view),
            searched_fraction=world.searched_fraction()))
        if row + 1 < steps:
            world.place_agents({a: _next_position(team[a], poses[a], truth, speed, params)
                                for a in ids})
        world.advance()
    return SwarmRun(scenario, records, world.coverage.astype(float),
                    time.perf_counter() - started)


def _routes(params: SatParams, agents: int, speed: float, tour: bool) -> list:
    """Return each agent's route (_Sweeper), in ascending id order: a strip or a tour slot."""
    if tour:
        lap = tour_lap(params)
        return [partial(_ride, lap=lap, offset=rank * len(lap) // agents, speed=speed)
                for rank in range(agents)]
    ends = lane_ends(params)
    return [partial(_fly_strip, cycle=sweep_cycle(lanes, ends), speed=speed)
            for lanes in strip_lanes(params, agents)]


def _ride(start, row: int, count: int, lap, offset: int, speed: float) -> np.ndarray:
    return tour_positions(start, lap, (offset + row) % len(lap), speed, count)


def _fly_strip(start, row: int, count: int, cycle, speed: float) -> np.ndarray:
    return sweep_positions(start, cycle, speed, count)


def _next_position(sweeper: _Sweeper, pose, truth, speed: float,
                   params: SatParams) -> np.ndarray:
    if sweeper.target is None:
        return sweeper.next_sweep_position()
    (row,) = np.flatnonzero(truth.ids == sweeper.target)
    return follow_position(pose, truth.states[row], speed, params)


class Confirmation:
    """Which targets the team has found: one agent had each in view on scans of its last window.

    Module docstring (the sensor-limited reading). Per agent, target id -> the steps it was in
    that agent's square within the window.
    """

    def __init__(self, scans: int, window: int):
        if not 1 <= scans <= window:
            raise ValueError(f'oracle sweep: scans = {scans}, window = {window}: need '
                             '1 <= scans <= window')
        self.scans, self.window = scans, window
        self.found = set()
        self.views = {}

    def found_in_view(self, step: int, ids: np.ndarray, in_view: dict) -> dict:
        """Return agent id -> mask over the truth rows: in its square and found by the team."""
        for agent_id in sorted(in_view):
            views = self.views.setdefault(agent_id, {})
            for target_id in ids[in_view[agent_id]].tolist():
                views[target_id] = [s for s in views.get(target_id, [])
                                    if s > step - self.window] + [step]
                if len(views[target_id]) >= self.scans:
                    self.found.add(target_id)
        known = np.isin(ids, list(self.found))
        return {agent_id: mask & known for agent_id, mask in in_view.items()}


class _Coasting:
    """The oracle's coasted reports (module docstring): per agent, target id -> (s, x_s, v_s)."""

    def __init__(self, params: SatParams):
        self.params = params
        self.seen = {}

    def estimates(self, step: int, truth, poses, in_view: dict) -> dict:
        """Return agent id -> its in-square true positions and its coasted points at step."""
        params = self.params
        in_any = np.any(list(in_view.values()), axis=0) if in_view else np.zeros(0, bool)
        visible = set(truth.ids[in_any].tolist())
        result = {}
        for agent_id in sorted(in_view):
            seen = self.seen.setdefault(agent_id, {})
            for row in np.flatnonzero(in_view[agent_id]):
                state = truth.states[row]
                seen[int(truth.ids[row])] = (step, state[list(POSITION)], state[list(VELOCITY)])
            coasted = []
            for target_id, (since, position, velocity) in list(seen.items()):
                if since == step:
                    continue
                point = position + velocity * (step - since) * params.motion.dt
                if (step - since > coast_steps(params) or target_id in visible
                        or in_sensing_square(point, poses[agent_id], params.sensor.square_side)
                        or not inside_area(point, params.area)[0]):
                    del seen[target_id]
                    continue
                coasted.append(point)
            result[agent_id] = np.vstack([truth.positions[in_view[agent_id]],
                                          np.reshape(coasted, (-1, 2))])
        return result
