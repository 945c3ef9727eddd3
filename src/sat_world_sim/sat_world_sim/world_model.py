"""Ground truth of a run, transport-free: targets, agent poses, scans, radio range, coverage.

The in-process swarm and the ROS ``world_sim`` node both drive this one object, so a seed gives the
same truth and the same measurement sets whatever carries the messages. One step of a run is::

    scans = world.scan_all()              # Z_k of every agent at s_k
    ... agents choose actions ...
    moves = world.apply_actions(actions)  # s_{k+1}, inadmissible actions refused (agent holds)
    world.advance()                       # truth k -> k+1

Targets follow the paper's near-constant-velocity model (F, Q of Section Evaluation, Q scaled by
the scenario's ``truth_process_noise``) and reflect off the area's boundary (position mirrored,
that velocity component negated); scripted targets turn at their waypoints (scenario.py).
Random streams: one for the truth and one per agent's sensor, spawned from the scenario seed, so
adding an agent does not change the others' clutter.
"""

from dataclasses import dataclass, replace
from typing import Dict, FrozenSet, Mapping, Tuple

import numpy as np

from sat_agent.actions import candidate_poses, fold, inside_area
from sat_agent.config import SatParams
from sat_agent.motion_model import POSITION, positions, propagate, VELOCITY
from sat_agent.sensor_model import simulate_scan

from sat_world_sim.radio import links_within
from sat_world_sim.scenario import Scenario

# Random targets get ids above every scripted id so both kinds can share one id space.
RANDOM_ID_BASE = 10_000


@dataclass(frozen=True)
class Truth:
    """The true targets alive at one step: ids (n,) and states (n, 4) rows [x, vx, y, vy]."""

    ids: np.ndarray
    states: np.ndarray

    @property
    def positions(self) -> np.ndarray:
        """(n, 2) true positions."""
        return positions(self.states)


@dataclass(frozen=True)
class Scan:
    """One agent's measurement set Z_k: (M, 2) [range, bearing] rows and their true sources.

    ``source_ids`` holds the id of the target behind each row or -1 for clutter (for evaluation
    only; agents never see it).
    """

    measurements: np.ndarray
    source_ids: np.ndarray


@dataclass(frozen=True)
class MoveResult:
    """What happened to one agent's commanded action."""

    agent_id: int
    action: int
    accepted: bool
    reason: str = ''


class World:
    """Ground truth, true agent poses and coverage of one scenario (see the module docstring)."""

    def __init__(self, scenario: Scenario, params: SatParams):
        self.scenario = scenario
        self.params = params
        streams = np.random.SeedSequence(scenario.seed).spawn(1 + len(scenario.agents))
        self._truth_rng = np.random.default_rng(streams[0])
        self._scan_rngs = {agent_id: np.random.default_rng(stream)
                           for agent_id, stream in zip(scenario.agent_ids, streams[1:])}
        self._motion = replace(params.motion, process_noise=scenario.truth_process_noise)
        self._poses = {a.agent_id: np.array(a.start, dtype=float) for a in scenario.agents}
        self._ids = np.zeros(0, dtype=int)
        self._states = np.zeros((0, 4))
        self._next_random_id = RANDOM_ID_BASE
        spacing = params.search.lattice_spacing
        self._coverage = np.zeros((int(np.ceil(params.area.height / spacing)),
                                   int(np.ceil(params.area.width / spacing))), dtype=bool)
        self.step = 1
        self._spawn(self.step)
        self._mark_coverage()

    @property
    def agent_ids(self) -> Tuple[int, ...]:
        """Agent ids in ascending order."""
        return self.scenario.agent_ids

    def pose(self, agent_id: int) -> np.ndarray:
        """Return the true position s_k of one agent (a copy)."""
        return self._poses[agent_id].copy()

    def poses(self) -> Dict[int, np.ndarray]:
        """Return the true positions of every agent, by id (copies)."""
        return {agent_id: self.pose(agent_id) for agent_id in self.agent_ids}

    def truth(self) -> Truth:
        """Return the targets alive at the current step (copies)."""
        return Truth(self._ids.copy(), self._states.copy())

    def scan_all(self) -> Dict[int, Scan]:
        """Draw Z_k for every agent at its current pose (Eqn. sensing_model plus clutter)."""
        points = positions(self._states)
        scans = {}
        for agent_id in self.agent_ids:
            z, source = simulate_scan(points, self._poses[agent_id], self.params.sensor,
                                      self._scan_rngs[agent_id])
            ids = np.full(len(source), -1, dtype=int)
            hit = source >= 0
            ids[hit] = self._ids[source[hit]]
            scans[agent_id] = Scan(z, ids)
        return scans

    def links(self) -> FrozenSet[Tuple[int, int]]:
        """Pairs (i, j), i < j, whose true positions are within C_R (the radio can carry)."""
        return links_within({i: self._poses[i] for i in self.agent_ids},
                            self.params.cooperation.comm_range)

    def apply_actions(self, actions: Mapping[int, int]) -> Dict[int, MoveResult]:
        """Move every agent by its action index; refused or missing actions leave it in place.

        An action is refused when it is not an index of Eqn. controlVectors or when it would
        leave the area; the refusal (with its reason) is returned so the caller can record it.
        """
        results = {}
        candidates_per_agent = {}
        for agent_id in self.agent_ids:
            action = actions.get(agent_id)
            candidates = candidate_poses(self._poses[agent_id], self.params.actions)
            candidates_per_agent[agent_id] = candidates
            results[agent_id] = self._check_action(agent_id, action, candidates)
        for agent_id, result in results.items():
            if result.accepted:
                self._poses[agent_id] = candidates_per_agent[agent_id][result.action]
        self._mark_coverage()
        return results

    def place_agents(self, poses: Mapping[int, np.ndarray]) -> None:
        """Put every agent at the given position, bypassing the action set; mark coverage.

        For references that are not bound to Eqn. controlVectors (the evaluation's oracle
        sweep, oracle_sweep.py). Positions outside the area raise ValueError.
        """
        points = np.array([poses[agent_id] for agent_id in self.agent_ids], dtype=float)
        if not inside_area(points, self.params.area).all():
            raise ValueError(f'place_agents: positions {points.tolist()} leave the area '
                             f'[0, {self.params.area.width}] x [0, {self.params.area.height}]')
        self._poses = dict(zip(self.agent_ids, points))
        self._mark_coverage()

    def advance(self) -> None:
        """Move the truth from step k to k + 1: deaths, NCV motion with reflection, births."""
        next_step = self.step + 1
        keep = self._survivors(next_step)
        self._ids, self._states = self._ids[keep], self._states[keep]
        if len(self._states):
            self._states = reflect(propagate(self._states, self._motion, self._truth_rng),
                                   self.params.area.width, self.params.area.height)
        self.step = next_step
        self._turn(next_step)
        self._spawn(next_step)

    @property
    def coverage(self) -> np.ndarray:
        """(ny, nx) booleans: lattice cells whose centre has been inside some sensing square."""
        return self._coverage.copy()

    def searched_fraction(self) -> float:
        """Fraction of the area's lattice cells that have been inside some sensing square."""
        return float(self._coverage.mean())

    def _check_action(self, agent_id, action, candidates) -> MoveResult:
        count = len(candidates)
        if action is None:
            return MoveResult(agent_id, -1, False, 'no action received: agent holds')
        if isinstance(action, (bool, np.bool_)) or not isinstance(action, (int, np.integer)):
            return MoveResult(agent_id, -1, False,
                              f'action {action!r} is not an integer index: agent holds')
        if not 0 <= action < count:
            return MoveResult(agent_id, int(action), False,
                              f'action {action} outside [0, {count - 1}]: agent holds')
        if not inside_area(candidates[action], self.params.area)[0]:
            return MoveResult(agent_id, int(action), False,
                              f'action {action} leaves the area: agent holds')
        return MoveResult(agent_id, int(action), True)

    def _survivors(self, next_step: int) -> np.ndarray:
        """Mask of targets alive at next_step: scripted ones until their death step."""
        scripted = self._ids < RANDOM_ID_BASE
        died = {t.target_id: t.died for t in self.scenario.targets}
        lasts = np.array([died.get(int(i), 0) for i in self._ids], dtype=int)
        births = self.scenario.random_births
        survival = births.survival if births is not None else 1.0
        # Draw for every target so the stream does not depend on which targets are scripted.
        lucky = self._truth_rng.random(len(self._ids)) < survival
        return np.where(scripted, lasts >= next_step, lucky)

    def _turn(self, step: int) -> None:
        """Scripted targets at a waypoint's step head for their next point."""
        scripted = {t.target_id: t for t in self.scenario.targets if t.via}
        for row, target_id in enumerate(self._ids.tolist()):
            target = scripted.get(target_id)
            velocity = None if target is None else target.velocity_at(
                step, self._states[row, POSITION])
            if velocity is not None:
                self._states[row, VELOCITY] = velocity

    def _spawn(self, step: int) -> None:
        new_ids = [t.target_id for t in self.scenario.targets if t.born == step]
        new_states = [t.initial_state() for t in self.scenario.targets if t.born == step]
        births = self.scenario.random_births
        if births is not None:
            count = int(self._truth_rng.poisson(births.rate))
            area = self.params.area
            xy = self._truth_rng.uniform((0.0, 0.0), (area.width, area.height), size=(count, 2))
            velocity = self._truth_rng.normal(0.0, births.speed_std, size=(count, 2))
            new_states.extend(np.column_stack([xy[:, 0], velocity[:, 0], xy[:, 1],
                                               velocity[:, 1]]))
            new_ids.extend(range(self._next_random_id, self._next_random_id + count))
            self._next_random_id += count
        if new_ids:
            self._ids = np.concatenate([self._ids, np.asarray(new_ids, dtype=int)])
            self._states = np.vstack([self._states, np.asarray(new_states, dtype=float)])

    def _mark_coverage(self) -> None:
        spacing = self.params.search.lattice_spacing
        half = self.params.sensor.square_side / 2.0
        ny, nx = self._coverage.shape
        for pose in self._poses.values():
            # Cell i has its centre at (i + 0.5) * spacing; keep the centres within the square.
            lo = np.ceil((pose - half) / spacing - 0.5).astype(int)
            hi = np.floor((pose + half) / spacing - 0.5).astype(int)
            lo = np.maximum(lo, 0)
            hi = np.minimum(hi, (nx - 1, ny - 1))
            self._coverage[lo[1]:hi[1] + 1, lo[0]:hi[0] + 1] = True


def reflect(states: np.ndarray, width: float, height: float) -> np.ndarray:
    """Fold positions back into [0, width] x [0, height], negating the crossing velocity.

    Works for any overshoot: a position that crossed the boundaries b times is mirrored b times
    and its velocity component flipped b times.
    """
    out = states.copy()
    for pos_col, vel_col, upper in ((0, 1, width), (2, 3, height)):
        out[:, pos_col], crossings = fold(states[:, pos_col], upper)
        out[:, vel_col] = np.where(crossings % 2 == 1, -states[:, vel_col], states[:, vel_col])
    return out
