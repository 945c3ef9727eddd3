"""One SAT agent without transport: (k, s_k, Z_k, neighbours' reports) -> action and report.

``Agent.step`` runs, at step k (the filter was predicted to k at the end of step k-1):

1. correct the SAT-PHD with Z_k at s_k (Eqn. satphd_correct) and extract X-hat_k with the
   extractor (state_extraction; it remembers what the next extraction needs); with
   additions.track_coasting, continue the agent's short tracks with X-hat_k, coast the others
   and add their next positions to the extraction's expected targets
   (beyond_paper/track_coasting.py);
2. fuse the neighbours' search densities into its own (elementwise max, "Cooperation"), each
   predicted from its step to k first (search_density);
3. tracking overlap: for every neighbour that, like this agent, was in TRACK at k-1, add the
   incremental score (Eqn. ospa) of the two agents' k-1 reports (poses s_{k-1} and predicted
   positions x + v T) to the window; leave TRACK when the window says overlap and this agent is
   the leaver;
4. update the mode (SEARCH/TRACK) from the number of targets in X-hat_k (with track coasting:
   of those whose tracks are still short; a tracker whose targets all have long tracks leaves
   TRACK as an overlap leaver does);
5. in SEARCH, mark the walk's nodes in view as visited and (re)plan when the rules of
   SearchPlanner say so, jointly with the searching agents in range;
6. predict the SAT-PHD to k+1 with s_k (Eqn. satphd_predict) and choose the action: the search
   control (nearest admissible pose to the next node) in SEARCH, the Renyi-divergence tracking
   control (Eqn. track_control) on the predicted PHD and the predicted multi-target state
   X-hat_{k+1|k} in TRACK; with additions.investigation, a searching agent may instead look at
   a tentative peak with the tracking control, or keep a newborn spot in its next square
   (beyond_paper/investigation.py), or, with additions.track_revisit, fly back over a target
   it left to its coasting before the fit drifts off it (beyond_paper/track_revisit.py). A
   baseline of ``search.policy`` (baselines/) replaces the search control, or the whole
   control (PHD-Voronoi, Thompson sampling);
7. publish the report of step k: search density, multi-target estimate, mode (what the paper
   exchanges) with agent id, step and pose as header. The coasted targets are in the output
   (``AgentOutput.reported_positions``), not in the report.

Agreeing on a joint plan without extra messages: every member of a group must compute the same
partition of the unvisited nodes. So a joint plan at step k is made only from the reports of
step k-1 of all members, the agent's *own* k-1 report included (not its newer state): the
starts are the members' k-1 poses and the node values come from the elementwise max of their
k-1 search densities, each predicted to k with its sender's pose. The group is this agent plus
the senders of the inbox's reports that were in SEARCH at k-1. Since radio range is symmetric,
two agents in range see each other's k-1 report at the same step and so see the same events: an
agent joining S_k, the set of agents in SEARCH by the k-1 reports (first contact, meeting again,
a return to SEARCH), or a member leaving SEARCH; both replan jointly at that step and compute
identical node partitions independently. Per pair, not per group: when A and B come into range
while both are already in range of C, A and B plan jointly over {A, B, C} and C, which sees no
new member, keeps its walk until its next replan of its own (with persistent planning within
``search.replan_period`` steps; session 73's review). Replans that only one agent makes (own
walk exhausted, own return to SEARCH) are made alone from its current state; leaving radio
range does not replan (the members keep their walks of the joint plan, as in the paper).

The components that implement additions to the paper are chosen once, here and in the
components' constructors, from ``params.additions`` (beyond_paper/__init__.py lists them);
``step`` does not branch on them.
"""

from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import List, Optional, Sequence

import numpy as np

from sat_agent.actions import candidate_poses
from sat_agent.baselines import baseline_policy
from sat_agent.baselines.interface import BaselineView
from sat_agent.beyond_paper.investigation import (
    Investigation, keep_in_view_action, Look, NO_LOOK)
from sat_agent.beyond_paper.overdue_nodes import node_views_defect
from sat_agent.beyond_paper.peak_extraction import PeakExtractor
from sat_agent.beyond_paper.persistent_planning import PersistentPlanner
from sat_agent.beyond_paper.sweeping_move import sweeping_action
from sat_agent.beyond_paper.track_coasting import NoCoasting, TrackCoasting
from sat_agent.beyond_paper.track_release import TrackRelease
from sat_agent.beyond_paper.track_revisit import NoRevisit, TrackRevisit
from sat_agent.config import ParameterError, SatParams
from sat_agent.density_codec import encode_density, PATCHES
from sat_agent.mode_machine import Mode, ModeMachine
from sat_agent.parameter_schema import changed_names, live_names
from sat_agent.phd_filter import BirthSpots, SatPhdFilter
from sat_agent.search_density import SearchDensity
from sat_agent.search_map import SearchMap
from sat_agent.search_planning import ReplanReason, SearchPlanner
from sat_agent.state_extraction import MultiTargetEstimate, NHatExtractor, predicted_positions
from sat_agent.tracking_control import TrackingControl
from sat_agent.tracking_overlap import OverlapMonitor

# Radio accounting: payload bytes of the three messages of a report (what the paper exchanges),
# without DDS/RTPS overhead. Every message carries agent id and step (uint32 each); the density
# is its compressed float32 cells (density_codec.py) and its node views (uint32 each, none
# without persistent planning's overdue rule); the estimate has the pose, the
# cardinality (float64) and per target position, velocity (2 float64 each), a 4 x 4 covariance
# and a weight (float64); the mode message has the mode (uint8) and the pose. The ROS radio
# counts with the same function.
REPORT_KINDS = ('search_density', 'estimate', 'mode')
_ID_STEP_BYTES = 4 + 4
_POSE_BYTES = 2 * 8
_TARGET_BYTES = 8 * (2 + 2 + 16 + 1)
_VIEW_BYTES = 4
# Spawn-key prefix of the agents' filter generators, plus phd.filter_stream. A world seeded with
# the same scenario seed spawns its truth and sensor streams with keys (0,), (1,), ...
# (SeedSequence.spawn); a filter keyed (agent_id,) would replay its own sensor's draws, so its
# noise would not be independent.
FILTER_STREAM = 2 ** 16
# Replans every searching member of a group sees at the same step, so they plan jointly.
JOINT_REASONS = (ReplanReason.NEW_NEIGHBOUR, ReplanReason.RELEASED, ReplanReason.PERIODIC)


def wire_bytes(kind: str, count: int = 0, views: int = 0) -> int:
    """Payload bytes of one radio message.

    count: encoded density bytes or estimated targets; views: the density's node views.
    """
    if kind == 'search_density':
        return _ID_STEP_BYTES + count + _VIEW_BYTES * views
    if kind == 'estimate':
        return _ID_STEP_BYTES + _POSE_BYTES + 8 + _TARGET_BYTES * count
    if kind == 'mode':
        return _ID_STEP_BYTES + 1 + _POSE_BYTES
    raise ValueError(f'unknown radio message kind {kind!r}: allowed are {REPORT_KINDS}')


@dataclass(frozen=True, eq=False)
class AgentReport:
    """What one agent tells its neighbours at step k: search density, estimate and mode.

    agent_id, step and pose are header data; search_values is the (ny, nx) search density
    (values in [0, 1], search_density.py's convention) after fusion at step k; encoding: the
    radio's layout of it that the sender's density model suits (density_codec.py); node_views:
    the step of the oldest view of each search node's cells the sender knows of, or none
    (SearchPlanner.node_views; beyond_paper/overdue_nodes.py).
    """

    agent_id: int
    step: int
    pose: np.ndarray
    mode: Mode
    search_values: np.ndarray
    estimate: MultiTargetEstimate
    encoding: str = PATCHES
    node_views: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    @cached_property
    def encoded_search_values(self) -> bytes:
        """The search density as the radio carries it (density_codec.encode_density)."""
        return encode_density(self.search_values, self.encoding)

    @property
    def nbytes(self) -> int:
        """Payload bytes of the report's three radio messages (see wire_bytes)."""
        return (wire_bytes('search_density', len(self.encoded_search_values),
                           len(self.node_views))
                + wire_bytes('estimate', len(self.estimate.targets)) + wire_bytes('mode'))

    def target_positions(self) -> np.ndarray:
        """(n, 2) estimated target positions."""
        return self.estimate.positions()

    def predicted_positions(self, dt: float) -> np.ndarray:
        """(n, 2) positions one step ahead (x + v T): X-hat_{k+1|k} for the overlap test."""
        return predicted_positions(self.estimate.targets, dt)


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
    coasted: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))

    def reported_positions(self) -> np.ndarray:
        """(n, 2) the targets the agent reports: X-hat_k and its coasted tracks."""
        return np.vstack([self.report.target_positions(), self.coasted])


class NoInvestigation:
    """The paper's searching agent follows its walk: it looks at nothing."""

    def look(self, mode: Mode, estimate: MultiTargetEstimate, cooldown_left: int,
             birth_spots: BirthSpots) -> Look:
        """Return NO_LOOK."""
        return NO_LOOK


class KeepAll:
    """The paper's tracking agent steers for every target it estimates."""

    def keep(self, targets: MultiTargetEstimate, own: Optional[AgentReport],
             reports: Sequence[AgentReport]) -> MultiTargetEstimate:
        """Return targets unchanged."""
        return targets


class Agent:
    """One agent's SAT-PHD filter, mode machine, planners and overlap monitor (module docstring).

    Same constructor arguments and same step inputs give the same outputs: the only randomness
    is the filter's, drawn from a generator seeded with (seed, FILTER_STREAM +
    phd.filter_stream, agent_id), and a random baseline's, seeded with (seed, agent_id, its
    stream) (baselines/interface.py).
    """

    def __init__(self, agent_id: int, params: SatParams, initial_pose, seed: int = 0):
        self.agent_id = int(agent_id)
        self.params = params
        self._rng = np.random.default_rng(np.random.SeedSequence(
            int(seed), spawn_key=(FILTER_STREAM + params.phd.filter_stream, self.agent_id)))
        self.filter = SatPhdFilter(params, self._rng)
        additions = params.additions
        self.extractor = (PeakExtractor if additions.peak_extraction else NHatExtractor)(params)
        self.search_map = SearchMap.for_area(params.area, params.search.node_spacing)
        self.planner = (PersistentPlanner if additions.persistent_planning
                        else SearchPlanner)(self.search_map, params)
        # The evaluation's baselines (search.policy, baselines/); None for the paper's policy.
        self.baseline = baseline_policy(params, self.search_map, self.agent_id, initial_pose,
                                        seed)
        self.modes = ModeMachine(params)
        self.overlap = OverlapMonitor(params)
        self.tracking = TrackingControl(params)
        self.investigation = (Investigation(params) if additions.investigation
                              else NoInvestigation())
        self.release = TrackRelease(params) if additions.track_release else KeepAll()
        self.coasting = TrackCoasting(params) if additions.track_coasting else NoCoasting()
        self.revisit = TrackRevisit(params) if additions.track_revisit else NoRevisit()
        self._scratch = SearchDensity(self.filter.search.lattice, params)
        self._last_report: Optional[AgentReport] = None
        self.dropped_reports = 0
        self._previous_searchers: frozenset = frozenset()
        # Step 1 corrects a PHD predicted from "step 0": the births and the start pose.
        self.filter.predict(np.asarray(initial_pose, dtype=float))

    def retune(self, params: SatParams) -> None:
        """Take new values of live parameters (parameter_schema.Spec.live) from the next step.

        Of those, search.investigate_steps is the core's: the investigation reads it at each
        look. A change to any other parameter raises ParameterError: the filter, the planners
        and the mode machine were built from them.
        """
        fixed = [name for name in changed_names(self.params, params)
                 if name not in live_names(SatParams)]
        if fixed:
            raise ParameterError(f'parameter(s) {fixed} are read-only: they are set at start-up')
        self.params = params
        if isinstance(self.investigation, Investigation):
            self.investigation.params = params

    @property
    def mode(self) -> Mode:
        """Return the current mode, SEARCH or TRACK."""
        return self.modes.mode

    def step(self, step: int, pose, measurements, inbox: Sequence[AgentReport]) -> AgentOutput:
        """Run one step k (module docstring); inbox holds the neighbours' reports.

        Reports of step k-1 take part in everything; older ones (a radio with latency) only add
        their search density, predicted to k like every received density: joint plans and the
        overlap test need the same step on every side.
        """
        pose = np.asarray(pose, dtype=float).reshape(2)
        measurements = np.asarray(measurements, dtype=float).reshape(-1, 2)
        late = self._valid_reports(step, inbox, late=True)
        reports = self._valid_reports(step, inbox)
        self.filter.correct(measurements, pose)
        estimate = self.extractor.extract(self.filter.targets, pose)
        coasting = self.coasting.update(
            step, pose, estimate.targets, [r.pose for r in reports], np.vstack(
                [np.zeros((0, 2))] + [r.predicted_positions(self.params.motion.dt)
                                      for r in reports]), measurements)
        if len(coasting.expected):
            self.extractor.memory = replace(self.extractor.memory, expected=np.vstack(
                [self.extractor.memory.expected, coasting.expected]))
        for report in late + reports:
            self.filter.search.fuse(self._density_at(step, report))
        searchers = self._searchers(reports)
        was_tracking = self.modes.mode == Mode.TRACK
        leaving_for = self._overlap_leaver(step, reports) if was_tracking else None
        # A tracker whose targets are all followed long enough searches on (track_coasting).
        followed = was_tracking and estimate.targets and not coasting.fresh
        mode = self.modes.update(coasting.fresh, leaving_for is not None, followed)
        replan = ReplanReason.NONE
        if mode == Mode.SEARCH and self.baseline is None:
            replan = self._search_plan(step, pose, reports, searchers, resumed=was_tracking)
        self._previous_searchers = searchers
        # The report carries the posterior (fused) density of step k, in float32 as on the wire,
        # so in-process and ROS runs exchange the very same values.
        report = AgentReport(self.agent_id, int(step), pose.copy(), mode,
                             self.filter.search.values.astype(np.float32), estimate,
                             self.filter.search.model.wire_encoding, self._node_views())
        self.filter.predict(pose)
        view = BaselineView(int(step), self.filter.targets, report, tuple(reports))
        action, goal, plan = self._control(mode, pose, estimate, view)
        self._last_report = report
        return AgentOutput(int(action), np.asarray(goal, dtype=float), report, estimate, plan,
                           mode, leaving_for, replan, coasting.coasted)

    def _node_views(self) -> np.ndarray:
        """Return the planner's node views for the report; none when a baseline searches."""
        return self.planner.node_views() if self.baseline is None else np.zeros(0, np.int64)

    def _control(self, mode: Mode, pose: np.ndarray, estimate: MultiTargetEstimate,
                 view: BaselineView):
        """Return (action, goal, plan) of step k, on the PHD predicted to k+1.

        A baseline that steers tracking too is the whole controller. Otherwise, TRACK or a look
        at tentative peaks from SEARCH: the tracking control on X-hat_{k+1|k} (the looked-at
        peaks; in SEARCH the walk is kept for later; in TRACK without the targets released to a
        neighbour, additions.track_release); else the search move (walk or baseline), kept to
        hold a newborn spot in view when the look asks it, or, for the walk, towards a coasted
        target due for a revisit (additions.track_revisit; the walk is kept for later).
        """
        if self.baseline is not None and self.baseline.steers_tracking:
            return self.baseline.choose(pose, view)
        look = self.investigation.look(mode, estimate, self.modes.cooldown_left,
                                       self.filter.birth_spots)
        if mode == Mode.TRACK or look.peaks is not None:
            targets = look.peaks if mode == Mode.SEARCH else self.release.keep(
                self.extractor.estimate(self.filter.targets, pose)[0], self._last_report,
                view.reports)
            action, _ = self.tracking.action(self.filter.targets, targets, pose,
                                             self.filter.search, look=mode == Mode.SEARCH)
            plan = self.planner.walk_points() if mode == Mode.SEARCH else np.zeros((0, 2))
            return action, candidate_poses(pose, self.params.actions)[action], plan
        if self.baseline is not None:
            action, goal, plan = self.baseline.choose(pose, view)
        else:
            action, goal, plan = self.planner.choose(pose)
            # A move that covers an overdue node's cells is taken exactly (overdue_nodes.py).
            if self.params.search.sweep_slack > 0.0 and not self.planner.covering:
                action = sweeping_action(pose, goal, self.params, self.filter.search)
            revisit = (self.revisit.revisit(view.step, pose, self.coasting.tracks, goal)
                       if look.keep is None else None)
            if revisit is not None:
                look, goal = replace(look, keep=revisit.keep), revisit.goal
        if look.keep is not None:
            action = keep_in_view_action(pose, goal, self.params, look.keep, look.full_speed)
        return action, goal, plan

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
                    and np.shape(report.pose) == (2,) and np.all(np.isfinite(report.pose))
                    and node_views_defect(report.node_views, self.search_map.size,
                                          report.step) is None)
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

    def _search_plan(self, step: int, pose: np.ndarray, reports: Sequence[AgentReport],
                     searchers: frozenset, resumed: bool) -> ReplanReason:
        """Mark visited nodes and replan when needed (module docstring).

        SearchPlanner's rules, plus one that keeps joint plans shared: a joint replan whenever
        an agent joins S_k (first contact, or back to SEARCH), an event both agents of the pair
        see at the same step (a third member in range of both does not: module docstring),
        unless the planner already replans alone.
        """
        own_values = self.search_map_values(self.filter.search.values)
        self.planner.mark_visited(pose, own_values)
        self.planner.hear_views([(r.pose, r.step, r.node_views) for r in reports])
        searching = [r for r in reports if r.mode == Mode.SEARCH]
        group = frozenset([self.agent_id] + [r.agent_id for r in searching])
        released = any(r.mode != Mode.SEARCH and r.agent_id in self.planner.group
                       for r in reports)
        reason = self.planner.needs_replan(group, released, resumed, step)
        joined = self.agent_id in searchers and bool(searchers - self._previous_searchers)
        if not reason and joined and searching:
            # The planner's last verdict is NONE, so plan() below makes a joint plan.
            reason = ReplanReason.NEW_NEIGHBOUR
        if not reason:
            return reason
        own = self._last_report
        joint = (searching and own is not None and own.mode == Mode.SEARCH
                 and reason in JOINT_REASONS)
        if joint:
            members = [own] + searching
            starts = {r.agent_id: r.pose for r in members}
            fused = np.maximum.reduce([self._density_at(step, r) for r in members])
            self.planner.plan(self.agent_id, starts, self.search_map_values(fused))
        else:
            self.planner.plan(self.agent_id, {self.agent_id: pose}, own_values)
        # The new walk may start with nodes already in view from s_k.
        self.planner.mark_visited(pose, own_values)
        return reason

    def _density_at(self, step: int, report: AgentReport) -> np.ndarray:
        """Return the report's search density predicted from its step to step (search_density)."""
        return self._scratch.predicted(report.search_values, report.pose, step - report.step)

    def search_map_values(self, density_values: np.ndarray) -> np.ndarray:
        """Return what the planner knows of each node for a (ny, nx) search density.

        Eqn. search_value; with additions.persistent_planning the node's worth
        (beyond_paper/persistent_planning.py).
        """
        self._scratch.values = density_values
        return self.planner.node_values(self._scratch)
