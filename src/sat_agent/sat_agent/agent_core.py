"""One SAT agent without transport: (k, s_k, Z_k, neighbours' reports) -> action and report.

``Agent.step`` runs, at step k (the filter was predicted to k at the end of step k-1):

1. correct the SAT-PHD with Z_k at s_k (Eqn. satphd_correct) and extract X-hat_k, with the
   targets and tentative peaks of k-1 predicted to k for track continuity and confirmation
   (state_extraction);
2. fuse the neighbours' search densities into its own (elementwise max, "Cooperation");
3. tracking overlap: for every neighbour that, like this agent, was in TRACK at k-1, add the
   incremental score (Eqn. ospa) of the two agents' k-1 reports (poses s_{k-1} and predicted
   positions x + v T) to the window; leave TRACK when the window says overlap and this agent is
   the leaver;
4. update the mode (SEARCH/TRACK) from the number of targets in X-hat_k;
5. in SEARCH, mark the walk's nodes in view as visited and (re)plan when the rules of
   SearchPlanner say so, jointly with the searching agents in range;
6. predict the SAT-PHD to k+1 with s_k (Eqn. satphd_predict) and choose the action: the search
   control (nearest admissible pose to the next node) in SEARCH, the Renyi-divergence tracking
   control (Eqn. track_control) on the predicted PHD and the predicted multi-target state
   X-hat_{k+1|k} in TRACK; in SEARCH with a tentative peak in view, the same tracking control
   on that peak for up to search.investigate_steps steps, and with only a measurement seen
   once (a newborn spot), the search move that keeps it in the next square
   (``Agent._investigation``);
7. publish the report of step k: search density, multi-target estimate, mode (what the paper
   exchanges) with agent id, step and pose as header.

Agreeing on a joint plan without extra messages: every member of a group must compute the same
partition of the unvisited nodes. So a joint plan at step k is made only from the reports of
step k-1 of all members, the agent's *own* k-1 report included (not its newer state): the
starts are the members' k-1 poses and the node values come from the elementwise max of their
k-1 search densities. The group is this agent plus the senders of the inbox's reports that were
in SEARCH at k-1. Since radio range is symmetric, two agents in range see each other's k-1
report at the same step and so see the same events: an agent joining S_k, the set of agents in
SEARCH by the k-1 reports (first contact, meeting again, a return to SEARCH), or a member
leaving SEARCH; both replan jointly at that step and compute identical node partitions
independently. Replans that only one agent makes (own walk exhausted, own return to SEARCH) are
made alone from its current state; leaving radio range does not replan (the members keep their
walks of the joint plan, as in the paper).
"""

from dataclasses import dataclass, replace
from functools import cached_property
from typing import List, Optional, Sequence

import numpy as np

from sat_agent.actions import candidate_poses
from sat_agent.config import SatParams
from sat_agent.density_codec import encode_density
from sat_agent.mode_machine import Mode, ModeMachine
from sat_agent.phd_filter import SatPhdFilter
from sat_agent.search_baselines import baseline_policy
from sat_agent.search_density import SearchDensity
from sat_agent.search_map import SearchMap
from sat_agent.search_planning import ReplanReason, search_action, SearchPlanner
from sat_agent.state_extraction import extract_targets, MultiTargetEstimate, TargetEstimate
from sat_agent.tracking_control import tracking_action
from sat_agent.tracking_overlap import OverlapMonitor

# Radio accounting: payload bytes of the three messages of a report (what the paper exchanges),
# without DDS/RTPS overhead. Every message carries agent id and step (uint32 each); the density
# is its zlib-compressed float32 cells (density_codec.py); the estimate has the pose, the
# cardinality (float64) and per target position, velocity (2 float64 each), a 4 x 4 covariance
# and a weight (float64); the mode message has the mode (uint8) and the pose. The ROS radio
# counts with the same function.
REPORT_KINDS = ('search_density', 'estimate', 'mode')
_ID_STEP_BYTES = 4 + 4
_POSE_BYTES = 2 * 8
_TARGET_BYTES = 8 * (2 + 2 + 16 + 1)
# Spawn-key prefix of the agents' filter generators. A world seeded with the same scenario seed
# spawns its truth and sensor streams with keys (0,), (1,), ... (SeedSequence.spawn); a filter
# keyed (agent_id,) would replay its own sensor's draws, so its noise would not be independent.
FILTER_STREAM = 2 ** 16


def wire_bytes(kind: str, count: int = 0) -> int:
    """Payload bytes of one radio message: count = encoded density bytes or estimated targets."""
    if kind == 'search_density':
        return _ID_STEP_BYTES + count
    if kind == 'estimate':
        return _ID_STEP_BYTES + _POSE_BYTES + 8 + _TARGET_BYTES * count
    if kind == 'mode':
        return _ID_STEP_BYTES + 1 + _POSE_BYTES
    raise ValueError(f'unknown radio message kind {kind!r}: allowed are {REPORT_KINDS}')


@dataclass(frozen=True, eq=False)
class AgentReport:
    """What one agent tells its neighbours at step k: search density, estimate and mode.

    agent_id, step and pose are header data; search_values is the (ny, nx) search density
    (values in [0, 1], search_density.py's convention) after fusion at step k.
    """

    agent_id: int
    step: int
    pose: np.ndarray
    mode: Mode
    search_values: np.ndarray
    estimate: MultiTargetEstimate

    @cached_property
    def encoded_search_values(self) -> bytes:
        """The search density as the radio carries it (density_codec.encode_density)."""
        return encode_density(self.search_values)

    @property
    def nbytes(self) -> int:
        """Payload bytes of the report's three radio messages (see wire_bytes)."""
        return (wire_bytes('search_density', len(self.encoded_search_values))
                + wire_bytes('estimate', len(self.estimate.targets)) + wire_bytes('mode'))

    def target_positions(self) -> np.ndarray:
        """(n, 2) estimated target positions."""
        return self.estimate.positions()

    def predicted_positions(self, dt: float) -> np.ndarray:
        """(n, 2) positions one step ahead (x + v T): X-hat_{k+1|k} for the overlap test."""
        targets = self.estimate.targets
        if not targets:
            return np.zeros((0, 2))
        return np.array([t.position + dt * t.velocity for t in targets], dtype=float)


@dataclass(frozen=True, eq=False)
class AgentOutput:
    """The result of one step: the action for the world and the report for the neighbours.

    goal is the point the action steers to (next walk node in SEARCH, the chosen pose in TRACK);
    plan is the remaining walk as (K, 2) points ending with its start (empty in TRACK);
    left_overlap_with is the neighbour whose tracking overlap made this agent leave TRACK at
    this step, else None.
    """

    action: int
    goal: np.ndarray
    report: AgentReport
    estimate: MultiTargetEstimate
    plan: np.ndarray
    mode: Mode
    left_overlap_with: Optional[int] = None
    replan: ReplanReason = ReplanReason.NONE


def _predicted_positions(targets: Sequence[TargetEstimate], dt: float) -> np.ndarray:
    """(n, 2) positions x + v T of the estimated targets one step ahead."""
    if not targets:
        return np.zeros((0, 2))
    return np.array([t.position + dt * t.velocity for t in targets], dtype=float)


class Agent:
    """One agent's SAT-PHD filter, mode machine, planners and overlap monitor (module docstring).

    Same constructor arguments and same step inputs give the same outputs: the only randomness
    is the filter's, drawn from a generator seeded with (seed, FILTER_STREAM, agent_id).
    """

    def __init__(self, agent_id: int, params: SatParams, initial_pose, seed: int = 0):
        self.agent_id = int(agent_id)
        self.params = params
        self._rng = np.random.default_rng(np.random.SeedSequence(
            int(seed), spawn_key=(FILTER_STREAM, self.agent_id)))
        self.filter = SatPhdFilter(params, self._rng)
        self.search_map = SearchMap.for_area(params.area, params.search.node_spacing)
        self.planner = SearchPlanner(self.search_map, params)
        # The evaluation's baselines (search.policy); None for the paper's closed walks.
        self.baseline = baseline_policy(params, self.search_map, self.agent_id, initial_pose,
                                        seed)
        self.modes = ModeMachine(params)
        self.overlap = OverlapMonitor(params)
        self._scratch = SearchDensity(self.filter.search.lattice)
        self._last_report: Optional[AgentReport] = None
        self.dropped_reports = 0
        self._previous_searchers: frozenset = frozenset()
        self._expected = np.zeros((0, 2))
        self._candidates = (np.zeros((0, 2)), np.zeros(0, dtype=int))
        # Investigation in SEARCH: steps spent on a tentative peak or newborn spot, the spots
        # given up on.
        self._investigated = 0
        self._abandoned: list = []
        self._look: tuple = ()
        self._looking_at_newborn = False
        # Step 1 corrects a PHD predicted from "step 0": the births and the start pose.
        self.filter.predict(np.asarray(initial_pose, dtype=float))

    @property
    def mode(self) -> Mode:
        """Return the current mode, SEARCH or TRACK."""
        return self.modes.mode

    def step(self, step: int, pose, measurements, inbox: Sequence[AgentReport]) -> AgentOutput:
        """Run one step k (module docstring); inbox holds the neighbours' reports.

        Reports of step k-1 take part in everything; older ones (a radio with latency) only add
        their search density: the fusion by max is right whatever the density's age, whereas
        joint plans and the overlap test need the same step on every side.
        """
        pose = np.asarray(pose, dtype=float).reshape(2)
        measurements = np.asarray(measurements, dtype=float).reshape(-1, 2)
        late = self._valid_reports(step, inbox, late=True)
        reports = self._valid_reports(step, inbox)
        self.filter.correct(measurements, pose)
        estimate = extract_targets(self.filter.targets, pose, self.params,
                                   previous=self._expected, candidates=self._candidates)
        # Where this step's targets and heavy tentative peaks should be at k+1 (x + v T): the
        # track-continuity and confirmation gates of the next extraction (state_extraction).
        dt = self.params.motion.dt
        self._expected = _predicted_positions(estimate.targets, dt)
        self._candidates = (_predicted_positions(estimate.tentative, dt),
                            np.array(estimate.tentative_streaks, dtype=int))
        for report in late + reports:
            self.filter.search.fuse(report.search_values)
        searchers = self._searchers(reports)
        was_tracking = self.modes.mode == Mode.TRACK
        leaving_for = self._overlap_leaver(step, reports) if was_tracking else None
        mode = self.modes.update(len(estimate.targets), leaving_for is not None)
        replan = ReplanReason.NONE
        if mode == Mode.SEARCH and self.baseline is None:
            replan = self._search_plan(pose, reports, searchers, resumed=was_tracking)
        self._previous_searchers = searchers
        # The report carries the posterior (fused) density of step k, in float32 as on the wire,
        # so in-process and ROS runs exchange the very same values.
        report = AgentReport(self.agent_id, int(step), pose.copy(), mode,
                             self.filter.search.values.astype(np.float32), estimate)
        self.filter.predict(pose)
        look = self._investigation(mode, estimate)
        # A newborn spot only asks the search move to keep it in the next square.
        keep = look.positions() if look is not None and self._looking_at_newborn else None
        if look is not None and keep is None:
            action, _ = tracking_action(self.filter.targets, look, pose, self.params)
            goal = candidate_poses(pose, self.params.actions)[action]
            plan = self.planner.walk_points()
        elif mode == Mode.SEARCH and self.baseline is not None:
            action, goal, plan = self.baseline.choose(pose)
            if keep is not None:
                action = search_action(pose, goal, self.params, keep)
        elif mode == Mode.SEARCH:
            goal = self._search_goal(pose)
            action = search_action(pose, goal, self.params, keep)
            plan = self.planner.walk_points()
        else:
            predicted = extract_targets(self.filter.targets, pose, self.params,
                                        previous=self._expected, candidates=self._candidates)
            action, _ = tracking_action(self.filter.targets, predicted, pose, self.params)
            goal = candidate_poses(pose, self.params.actions)[action]
            plan = np.zeros((0, 2))
        self._last_report = report
        return AgentOutput(int(action), np.asarray(goal, dtype=float), report, estimate, plan,
                           mode, leaving_for, replan)

    def _investigation(self, mode: Mode, estimate: MultiTargetEstimate):
        """Tentative peaks or newborn spots to look at from SEARCH (their X-hat_{k+1|k}), or None.

        A design choice the paper leaves open: one pass of a searching agent gives a target
        2-3 scans, too few to confirm it under dense clutter (a tracked target's PHD mass
        grows by ~1 + g/kappa per scan, and not at all while the agent flies over it). So a
        searching agent that sees an unconfirmed peak holds its walk for up to
        ``search.investigate_steps`` steps and places itself with the tracking control (Eqn.
        track_control, with its stand-off) on the tentative peaks; a target then reaches
        round(mass) = 1 twice and the agent enters TRACK, a clutter cloud fades and the walk
        resumes. One spot at a time, the heaviest; the spot of a spent budget is abandoned:
        tentative peaks near it are ignored for 2 * investigate_steps steps.

        Without a tentative peak, the heaviest newborn spot of this scan (a measurement seeding
        at least phd.tentative_threshold of birth mass) gets one step of the budget, spent on
        the search move that keeps the spot in the next square (search_action): newborns the
        next square does not cover are dropped (phd_filter), so a target seen once at the
        trailing edge of a passing square would otherwise be forgotten. A real target is then a
        tentative peak; a false alarm leaves nothing and the walk resumes at once.
        """
        budget = self.params.search.investigate_steps
        self._abandoned = [(p, t - 1) for p, t in self._abandoned if t > 1]
        if mode != Mode.SEARCH or self.modes.cooldown_left > 0 or budget == 0:
            self._investigated = 0
            return None
        fresh = self._fresh(estimate.tentative)
        if fresh:
            look = (max(fresh, key=lambda t: t.weight),)   # the heaviest spot first
        elif self._investigated > 0 and not self._looking_at_newborn:
            look = self._look      # a peak can fade for a scan (a miss, a near pass): keep on
        else:
            self._investigated = 0
            look = self._fresh(self._newborn_spots())[:1]
            if not look:
                return None
        if self._investigated >= budget:
            self._abandoned += [(t.position, 2 * budget) for t in look]
            self._investigated = 0
            return None
        self._looking_at_newborn = not fresh
        self._investigated += 1
        dt = self.params.motion.dt
        self._look = tuple(replace(t, position=t.position + dt * t.velocity) for t in look)
        return MultiTargetEstimate(self._look, 0.0)

    def _fresh(self, spots: Sequence[TargetEstimate]) -> tuple:
        """Return the spots farther than phd.continue_gate from every abandoned spot."""
        gate = self.params.phd.continue_gate
        return tuple(t for t in spots if not any(
            np.hypot(*(t.position - p)) <= gate for p, _ in self._abandoned))

    def _newborn_spots(self) -> tuple:
        """Return this scan's birth spots of at least phd.tentative_threshold, heaviest first."""
        spots = self.filter.birth_spots
        order = np.argsort(-spots.masses, kind='stable')
        order = order[spots.masses[order] >= self.params.phd.tentative_threshold]
        return tuple(TargetEstimate(spots.positions[i].copy(), np.zeros(2), np.zeros((4, 4)),
                                    float(spots.masses[i])) for i in order)

    def _valid_reports(self, step: int, inbox: Sequence[AgentReport],
                       late: bool = False) -> List[AgentReport]:
        """Keep well-formed reports from other agents, one per sender, ordered by id.

        Reports of step k-1; with late, the newest older one of each sender instead. Malformed
        reports and second k-1 reports of a sender are counted in dropped_reports.
        """
        shape = self.filter.search.values.shape
        kept = {}
        for report in sorted(inbox, key=lambda r: -r.step):
            in_time = report.step < step - 1 if late else report.step == step - 1
            if not in_time or (late and report.agent_id in kept):
                continue
            good = (report.agent_id != self.agent_id
                    and report.agent_id not in kept
                    and np.shape(report.search_values) == shape
                    and np.all(np.isfinite(report.search_values))
                    and np.shape(report.pose) == (2,) and np.all(np.isfinite(report.pose)))
            if good:
                kept[report.agent_id] = report
            else:
                self.dropped_reports += 1
        return [kept[agent] for agent in sorted(kept)]

    def _overlap_leaver(self, step: int, reports: Sequence[AgentReport]) -> Optional[int]:
        """Feed the overlap windows with the k-1 reports; return the neighbour to yield to.

        Both sides use the two k-1 reports (the own one included), so they compute the same
        symmetric score and agree on who leaves (OverlapMonitor.leaver).
        """
        own = self._last_report
        if own is None or own.mode != Mode.TRACK:
            return None
        dt = self.params.motion.dt
        leave_for = None
        for report in reports:
            if report.mode != Mode.TRACK:
                continue
            self.overlap.observe(step, own.pose, own.predicted_positions(dt), report.agent_id,
                                 report.pose, report.predicted_positions(dt))
            overlapping = self.overlap.overlapping(report.agent_id)
            if overlapping and leave_for is None and (
                    self.overlap.leaver(self.agent_id, report.agent_id) == self.agent_id):
                leave_for = report.agent_id
        if leave_for is not None:
            for report in reports:
                self.overlap.reset(report.agent_id)
        return leave_for

    def _searchers(self, reports: Sequence[AgentReport]) -> frozenset:
        """S_k: the agents in SEARCH according to the k-1 reports, this agent's own included.

        Two agents in range build S_k from the same reports, so they see the same changes.
        """
        own = self._last_report
        members = [r for r in reports if r.mode == Mode.SEARCH]
        if own is not None and own.mode == Mode.SEARCH:
            members.append(own)
        return frozenset(r.agent_id for r in members)

    def _search_plan(self, pose: np.ndarray, reports: Sequence[AgentReport],
                     searchers: frozenset, resumed: bool) -> ReplanReason:
        """Mark visited nodes and replan when needed (module docstring).

        SearchPlanner's rules, plus one that keeps joint plans shared: a joint replan whenever
        an agent joins S_k (first contact, or back to SEARCH), an event every member of the
        group sees at the same step, whatever its own plan's group is.
        """
        own_values = self.search_map_values(self.filter.search.values)
        self.planner.mark_visited(pose, own_values)
        searching = [r for r in reports if r.mode == Mode.SEARCH]
        group = frozenset([self.agent_id] + [r.agent_id for r in searching])
        released = any(r.mode != Mode.SEARCH and r.agent_id in self.planner.group
                       for r in reports)
        reason = self.planner.needs_replan(group, released, resumed)
        joined = self.agent_id in searchers and bool(searchers - self._previous_searchers)
        if not reason and joined and searching:
            # The planner's last verdict is NONE, so plan() below makes a joint plan.
            reason = ReplanReason.NEW_NEIGHBOUR
        if not reason:
            return reason
        own = self._last_report
        joint = (searching and own is not None and own.mode == Mode.SEARCH
                 and reason in (ReplanReason.NEW_NEIGHBOUR, ReplanReason.RELEASED))
        if joint:
            members = [own] + searching
            starts = {r.agent_id: r.pose for r in members}
            fused = np.maximum.reduce([r.search_values for r in members])
            self.planner.plan(self.agent_id, starts, self.search_map_values(fused))
        else:
            self.planner.plan(self.agent_id, {self.agent_id: pose}, own_values)
        # The new walk may start with nodes already in view from s_k.
        self.planner.mark_visited(pose, own_values)
        return reason

    def _search_goal(self, pose: np.ndarray) -> np.ndarray:
        goal = self.planner.next_goal()
        return pose if goal is None else goal

    def search_map_values(self, density_values: np.ndarray) -> np.ndarray:
        """Eqn. search_value of every search-map node for a (ny, nx) search density."""
        self._scratch.values = density_values
        return self._scratch.node_values(self.search_map.centers, self.search_map.spacing)
