"""Parameters of the SAT problem and of the agent, with the paper's defaults.

Every number the paper gives (Section "Experimental Setup") is a default here; every number it
leaves open is a default chosen and justified next to its field. Each field is written once,
with ``param`` (sat_agent.parameter_schema): default, description, allowed range or choices,
and ``live`` when it may change mid-run. ``SatParams.from_mapping`` reads the nested YAML form
(``config/paper.yaml``) or ROS 2's flattened dotted names (``sensor.square_side``) and refuses
unknown keys and out-of-range values with a message naming the key, the value and what is
allowed; the ROS descriptors come from the same fields (sat_agent.ros.ros_params).

Two kinds of departure from the paper, kept apart:

- *Additions*: behaviour the paper does not have. Each is one bool of ``AdditionsParams``
  (group ``additions``) and one module of ``sat_agent/beyond_paper/``; ``config/paper.yaml``
  switches the detection chain's on, ``config/paper_strict.yaml`` all off, and
  ``config/persistent.yaml`` adds persistent search-and-track (regrowing density, persistent
  planning, track release, track coasting, kernel likelihood, heavy-peak confirmation, track
  probation, track revisit; search while tracking is built and left off) to paper.yaml's. Their
  numeric tunables (e.g. ``search.investigate_steps``) tune an addition but cannot switch it
  off.
- *Interpretations*: where the paper is silent or a literal reading cannot run, the simplest
  reading, in both profiles, no switch (each is stated where it is implemented, too):

  - birth model: uniform births plus measurement-driven births (``phd``), particle budgets;
  - beta, node spacing, lattice spacing, the OSPA cut-off c, Q_Th and its window, the track
    timeout (``search``, ``cooperation``);
  - n-hat of the predicted multi-target state X-hat_{k|k-1} (overlap test, tracking control)
    is the PHD mass over the sensing area, as for X-hat_k (Section Search-and-Track Density):
    over the whole state space the diffuse birth mass (~1 at steady state) would count as a
    target (state_extraction);
  - a peak of the particle PHD is the densest 1 m cell (3 x 3 smoothed) refined by mean shift;
    its region is ``phd.peak_radius`` around it (state_extraction);
  - the exchanged predicted states X-hat_{k|k-1} are the sender's k-1 estimates moved by
    x + v T, the peak means under the motion model (agent_core, tracking_overlap);
  - Eqn. pims only for the targets in u's square: p_D is 0 outside it (tracking_control);
  - a node whose centre is in view is visited (the paper's "marked as visited"): a new walk
    drops the nodes in view at once, and an exhaustion replan leaves them out
    (search_planning);
  - xi_search is the distance from the pose an action leads to, to the next node (the paper's
    "current position" would score every action alike) (search_planning);
  - when a walk is exhausted the agent plans a new one from where it is, alone; a joint plan
    is made at first contact, when a member leaves SEARCH and on a return to SEARCH, from the
    members' k-1 reports; leaving radio range keeps the joint walks (search_planning,
    agent_core);
  - V-bar empty (no node at or below beta): the closed walk over no node is s_k itself, so the
    agent holds until a node decays below beta (search_planning);
  - the overlap leaver is the higher id; a step where either predicted set is empty scores inf
    (tracking_overlap);
  - a neighbour's search density of step j < k is predicted to k before the max: one step of
    Eqn. satphd_predict with the sender's pose s_j, then J per further step (its later poses are
    unknown) (search_density).
"""

from dataclasses import dataclass, fields
import math
from typing import Any, Mapping

from sat_agent.node_params import check_node_settings
from sat_agent.parameter_schema import (build, group, param, ParameterError, validate,
                                        with_overrides)

SEARCH_POLICIES = ('sat', 'lawnmower', 'random_walk', 'phd_voronoi', 'thompson')
SEARCH_PLANNERS = ('greedy', 'ortools')
BIRTH_PRIORS = ('uniform', 'undetected')
SCAN_DETECTIONS = ('square', 'births')
COAST_BOUNDARIES = ('drop', 'reflect', 'bounce', 'clamp')
COAST_REPORTS = ('survival', 'ospa')
PEAK_LOOKS = ('track', 'keep')
SPOT_MOVES = ('any', 'full')
TRACK_SEARCH_SCOPES = ('all', 'track')
# Upper bound of the counts below: far beyond any run, low enough to catch a typo.
MANY = 10000


@dataclass(frozen=True)
class AreaParams:
    """The surveillance region A = [0, width] x [0, height] (metres)."""

    width: float = param(100.0, 'width of the area A (m)', low=0, low_open=True)
    height: float = param(100.0, 'height of the area A (m)', low=0, low_open=True)

    @property
    def size(self) -> float:
        """|A|, the area of the region in square metres."""
        return self.width * self.height


@dataclass(frozen=True)
class MotionParams:
    """Near-constant-velocity target model (Section Evaluation: F, Q with T = 1 s)."""

    dt: float = param(1.0, 'T: seconds per step', low=0, low_open=True)
    p_survival: float = param(0.99, 'p_S: probability that a target survives a step',
                              low=0, high=1, low_open=True)
    process_noise: float = param(1.0, "scale of the paper's Q (1 is the paper's model)", low=0)


@dataclass(frozen=True)
class SensorParams:
    """Range/bearing sensor with a square field of view (Eqn. sensing_model)."""

    square_side: float = param(10.0, 'a: the sensing area S_a is an a x a square (m)',
                               low=0, low_open=True)
    p_detect: float = param(0.99, 'p_D^max inside the square (0 outside)',
                            low=0, high=1, low_open=True)
    sigma_range_0: float = param(1.0, 'zeta_0 (m): sigma_r = zeta_0 + beta_zeta d^2',
                                 low=0, low_open=True)
    sigma_range_slope: float = param(5e-3, 'beta_zeta (1/m)', low=0)
    sigma_bearing_0: float = param(math.pi / 180.0, 'phi_0 (rad): sigma_b = phi_0 + beta_phi d',
                                   low=0, high=math.pi, low_open=True)
    sigma_bearing_slope: float = param(1e-5, 'beta_phi (rad/m)', low=0)
    # The filter's model only: the simulated sensor draws with the sigmas above.
    likelihood_bandwidth: float = param(
        0.3, "additions.kernel_likelihood: h (m), the filter's g(z | x) is that of a Gaussian "
        'kernel of this spread around each particle', low=0, high=10, low_open=True)
    clutter_rate: float = param(10.0, 'lambda: Poisson mean of false alarms per scan',
                                low=0, high=1e4)
    # The paper's measurement space is that of h over the area: 141.42 m, the diagonal of its
    # 100 m x 100 m area, so ~0.5 of the 10 false alarms per scan fall near the square. 0 means
    # the square's half diagonal: all 10 around the agent, a reading under which the paper's
    # results cannot be reached (README, "Clutter").
    clutter_max_range: float = param(
        141.42, "r_c: clutter is uniform over [0, r_c] x [-pi, pi) (m); 0: the square's half "
        'diagonal', low=0)

    @property
    def max_range(self) -> float:
        """Largest range inside the sensing square (its half diagonal)."""
        return self.square_side / math.sqrt(2.0)

    @property
    def clutter_range(self) -> float:
        """r_c: clutter_max_range, or max_range when that is 0."""
        return self.clutter_max_range or self.max_range


@dataclass(frozen=True)
class ActionParams:
    """Agent control set of Eqn. controlVectors: 1 + N_R * N_theta admissible displacements."""

    radial_step: float = param(2.0, 'Delta_R (m)', low=0, low_open=True)
    n_radial: int = param(2, 'N_R: radial steps', low=1, high=16)
    n_angular: int = param(8, 'N_theta: headings', low=1, high=64)

    @property
    def count(self) -> int:
        """Number of actions, including 'stay' (17 with the paper's values)."""
        return 1 + int(self.n_radial) * int(self.n_angular)


@dataclass(frozen=True)
class PhdParams:
    """SMC-PHD budgets and birth model; the paper leaves all of these open."""

    # The paper's run has 2 births in 200 steps, so 0.01 matches its rate; the mass stays
    # diffuse (1e-6 per m^2). The random default's is ~0.04 (6 targets over steps 1-150): the
    # search density only scales with it (beyond_paper/regrowing_density.py), and session 43
    # measured the rest (docs/persistent_trials.md).
    birth_rate: float = param(0.01, 'uniform births over A: expected new targets per step',
                              low=0, high=10)
    birth_particles_uniform: int = param(2000, 'particles per step for the uniform births',
                                         low=0, high=1e6)
    # Adaptive birth (Ristic et al. 2012): a measurement z at range r seeds mass
    # m_b (r / r_max) (1 - tau(z) / (kappa + tau(z))) (phd_filter.py). With the paper's clutter
    # ~0.4 false alarms fall in the square per scan, far more than the ~0.03 targets a square
    # holds at the random default, so a measurement seen once is mostly clutter; 0.5 still lets
    # a target that a searching agent passes reach round(mass) = 1 on its 2-3 scans (0.3
    # misses seed 0 of single_target.yaml), and the confirmation sorts out the clutter. Under
    # the dense reading of the clutter (all 10 around the agent, config/dense_clutter.yaml)
    # 0.12: there 0.15-0.2 made false tracks on consecutive scans.
    birth_mass_measurement: float = param(
        0.5, 'm_b: birth mass a measurement in the sensing square may seed', low=0, high=10)
    # 'undetected' moves a square's seeded mass to where its search density holds undetected
    # targets (beyond_paper/undetected_birth_prior.py). Session 24 (persistent profile, random,
    # fresh dev seeds 4001-4300): detected -3.7, tracked -3.1 points (p 0.005); with the blur of
    # 1.125 m and search.scan_detection 'births' (4301-4600) +0.5 and +0.2: not kept
    # (docs/persistent_trials.md).
    birth_prior: str = param(
        'uniform', 'where the measurement-driven births assume undetected targets: '
        "'uniform' over the sensing square (phd_filter), 'undetected' as the search density "
        'holds them (beyond_paper/undetected_birth_prior.py)', choices=BIRTH_PRIORS)
    birth_prior_blur: float = param(
        0.0, "phd.birth_prior 'undetected': the undetected density is read at a measurement "
        'through a Gaussian blur of this spread (m; 0: its own cell)', low=0, high=100)
    # Persistent profile, paired (rules 39-40, docs/persistent_trials.md): 400 (fresh dev seeds
    # 22295-22894) OSPA +0.12 m (p 0.022), with particles_per_target 4000 tracked -2.0 points
    # (p 0.030); 50 (22895-23494) detected -2.4 (p 0.007). Not kept.
    birth_particles_per_measurement: int = param(100, 'particles per measurement-driven birth',
                                                 low=0, high=1e5)
    birth_velocity_std: float = param(1.0, "prior spread of a newborn's velocity (m/s)",
                                      low=0, high=100)
    particles_per_target: int = param(2000, 'resampling budget per unit of PHD mass',
                                      low=1, high=1e6)
    # Any change to a run moves the agents' paths, so two runs of one seed meet the same truth
    # but little else; a trial whose difference is not larger than such an A/A trial's is
    # noise (README, Evaluation, "How large seed noise is", has the measured figures).
    filter_stream: int = param(
        0, "the agents' filter random streams: runs that differ only here share the scenario "
        "and the world's random streams but not the filter's particles (an A/A trial)", low=0,
        high=MANY)
    min_particles: int = param(2000, 'fewest particles after resampling', low=1, high=1e7)
    max_particles: int = param(20000, 'most particles after resampling', low='min_particles',
                               high=1e7)
    # A target moves ~1 m/step and the agent up to 4 m/step, so 5 m keeps a tracked target in
    # the region for a step even when it leaves the square.
    extraction_margin: float = param(
        5.0, 'additions.extraction_margin: extraction looks at the sensing square grown by '
        'this (m)', low=0, high=100, low_open=True)
    # A target's predicted cloud under the paper's Q is ~1.3 m (1 sigma), so 3 m holds ~90 % of
    # its mass.
    peak_radius: float = param(3.0, "a PHD peak's region: particles within this of it (m)",
                               low=0, high=100, low_open=True)
    # Under the dense reading of the clutter (config/dense_clutter.yaml) a tracked target's PHD
    # mass settles at ~0.3-0.6 (0.99 - kappa / g_bar), below the 0.5 that round(mass) needs, so
    # a target is kept down to 0.2; below that it is lost.
    continue_threshold: float = param(
        0.2, 'additions.peak_extraction: a target of k-1 continues while its peak keeps this '
        'mass', low=0, high=0.5)
    # A walking target moves ~1 m/step, its estimate errs ~1 m.
    continue_gate: float = param(
        3.0, 'additions.peak_extraction: the continuing peak lies within this of x + v T (m)',
        low=0, high=100)
    # Clutter-born peaks rarely stay that heavy twice.
    confirm_scans: int = param(
        2, 'additions.confirmation: scans in a row with round(mass) >= 1 a new target needs',
        low=2, high=100)
    confirm_gate: float = param(
        3.0, 'additions.confirmation: the confirming peaks lie within this of each other (m)',
        low=0, high=100)
    confirm_mass: float = param(
        0.8, 'additions.heavy_peak_confirmation: a peak with at least this PHD mass is a target '
        'on its first scan with round(mass) >= 1', low=0, high=100, low_open=True)
    tentative_threshold: float = param(
        0.2, 'additions.investigation: unconfirmed peaks in the square with this mass are '
        'tentative', low=0, high=0.5)
    # 20 estimates erring 1 m pin a straight walk's velocity to ~4 cm/s; 50 keeps what later
    # passes over the target add.
    coast_history: int = param(
        50, 'additions.track_coasting: latest estimates of a track its constant-velocity fit '
        'uses', low=2, high=MANY)
    # A target walks ~1 m/step; its estimate errs ~1 m.
    coast_gate: float = param(
        4.0, 'additions.track_coasting: an estimate continues a track within this of the '
        "track's fit (m)", low=0, low_open=True, high=100)
    # 1/2 is the paper's n_hat = round(mass) rule for a target that existed: p_S^t >= 1/2 for
    # t <= 68 steps at p_S = 0.99.
    coast_survival: float = param(
        0.5, 'additions.track_coasting: a track is reported while p_S^t, t steps after its last '
        'estimate, is at least this', low=0, high=1, low_open=True)
    # 'ospa' (beyond_paper/coast_report.py), persistent profile, paired: at random (dev seeds
    # 4901-5200) OSPA -0.02 m (p 0.028), tracked -0.20 points (p < 0.001); not kept.
    coast_report: str = param(
        'survival', "additions.track_coasting: when a coasted track is reported: 'survival' "
        "while p_S^t >= phd.coast_survival, 'ospa' while reporting lowers the expected OSPA: "
        "p_S^t >= tau / (1 - (1 - tau) E / c^2), tau = phd.coast_survival, E the fit's "
        'expected squared error cut at cooperation.ospa_cutoff c', choices=COAST_REPORTS)
    # 2 with the measurement fit (persistent profile, random, dev seeds 6841-7140, paired):
    # tracked +0.36 points (p < 0.001), OSPA +0.10 m (p < 0.001), 16 more false-track steps.
    coast_min_estimates: int = param(
        3, 'additions.track_coasting: estimates a track needs before it is coasted', low=2,
        high=MANY)
    # p_D = 0.99 and two scans to confirm: a target there is estimated within two scans. 1
    # (persistent profile, random, fresh dev seeds 12351-12650, paired; rule 26): false-track
    # steps -5.0 per run (p < 0.001), tracked -1.0 points (p < 0.001), OSPA +0.03 m; not kept.
    coast_misses: int = param(
        2, "additions.track_coasting: steps a coasted position may lie in the agent's or a "
        "neighbour's square without an estimate of it before the track is dropped", low=0,
        high=MANY)
    # Persistent profile, paired (docs/persistent_trials.md): 'reflect' at random (dev seeds
    # 4601-4900) tracked +1.70 points (p < 0.001), OSPA +0.07 m (p 0.08), but at paper_random
    # (2001-2200) OSPA +0.08 m (p < 0.001); 'bounce' at random (4901-5200) tracked +0.99,
    # OSPA +0.15 m (both p < 0.001): folded fits also report dead targets. 'clamp' (session
    # 33) at random (8101-8400) tracked +0.70 (p < 0.001), OSPA +0.01 m, but at paper_random
    # OSPA +0.02 m (p < 0.001). Not kept.
    coast_boundary: str = param(
        'drop', "additions.track_coasting: a coasted fit that leaves the area: 'drop' ends the "
        "track, 'reflect' folds the walk back into the area as the world's targets bounce, "
        "'bounce' also fits the estimates after a bounce on the unfolded walk, 'clamp' reports "
        'it at its nearest point of the area while it lies outside by at most its drift '
        'spread', choices=COAST_BOUNDARIES)


@dataclass(frozen=True)
class SearchParams:
    """Search density (virtual-target lattice) and search map; the paper gives only J."""

    decay: float = param(0.999, 'J_k(x), constant (Section Evaluation)', low=0, high=1)
    # Shared by every agent, so densities fuse elementwise.
    # 'births' counts a scan as detecting a target only where its measurement lands in the
    # square, where births are seeded (beyond_paper/regrowing_density.py). Session 24
    # (persistent profile, random, fresh dev seeds 4301-4600): detected -1.4, tracked -0.4
    # points, neither significant: not kept (docs/persistent_trials.md).
    scan_detection: str = param(
        'square', 'additions.regrowing_density: what a scan detects of the undetected targets: '
        "'square' p_D in every cell of the sensing square, 'births' p_D times the chance that "
        "the cell's target's measurement lands in the square", choices=SCAN_DETECTIONS)
    # The density's kernel is a Markov approximation (its spread grows like sqrt(t), a walker's
    # like t: beyond_paper/regrowing_density.py), so its best sigma_v need not be the filter's
    # newborn prior. Rule 24 (docs/persistent_trials.md; persistent profile, random, fresh dev
    # seeds 11451-11750) set the filter's at 0.5 and this at 1: detected +1.6 points (p 0.20),
    # OSPA -0.05 m; this alone at 0.5 (rule 25, 11851-12150): area by k = 100 +0.9 points,
    # detected -1.4, OSPA -0.01 m: not kept. config/persistent.yaml sets the pair with the rest
    # of arm S4 (rules 33-34).
    density_velocity_std: float = param(
        0.0, "additions.regrowing_density: the undetected targets' velocity spread sigma_v of "
        "its motion kernel K (m/s); 0: phd.birth_velocity_std's", low=0, high=100)
    lattice_spacing: float = param(1.0, 'spacing of the virtual-target lattice (m)',
                                   low=0, low_open=True)
    # One node per sensing footprint, so visiting every node sweeps the whole area once.
    node_spacing: float = param(10.0, 'spacing of the search-map nodes (m)',
                                low=0, low_open=True)
    # 0.5 means "less than half of its region seen recently"; a fully searched region takes
    # ln(0.5)/ln(0.999) ~ 693 steps to need a revisit.
    unvisited_threshold: float = param(
        0.5, 'beta: a node is unvisited when its search value is <= beta', low=0, high=1,
        high_open=True)
    # The paper marks a node visited once its centre is in the sensing square, so a walk turns
    # when the square's edge reaches the centre and may leave half of the node's region unseen:
    # after 150 steps the profile's squares had never held 4 % of the area, nine tenths of it
    # within 2 m of the border. 0.6 (rule 27, persistent profile, random, fresh dev seeds
    # 12811-13110, paired): searched by k = 100 +1.1 points (p < 0.001) but detected -1.1,
    # tracked -2.3 (p 0.049), OSPA +0.08 m: not kept (docs/persistent_trials.md, session 46).
    visit_share: float = param(
        1.0, "a walk's node counts as visited once its centre lies in the middle square of this "
        "share of the sensing square's side around the agent; 1: the whole square (the "
        "paper's)", low=0, high=1, low_open=True)
    # Targets are born at any time.
    revisit_share: float = param(
        0.5, 'additions.revisit_fallback: with no node unvisited, plan over this share of the '
        'least recently searched nodes', low=0, high=1, low_open=True)
    # Enough for confirm_scans more scans from a stand-off, short enough to keep the search
    # going. Read at every look, so a change applies from the next step.
    investigate_steps: int = param(
        4, 'additions.investigation: steps a searching agent may spend looking at one '
        'tentative peak', low=1, high=MANY, live=True)
    # One spot, the heaviest, of at least phd.tentative_threshold by default: the addition as it
    # was first measured. 3 spots at a share 0.5 (session 23, persistent profile, random, dev
    # seeds 3701-4000): fewer targets seen and never detected (116 to 98 of 1843) but fewer
    # seen at all (1429 to 1399), tracked -0.1 points; not kept (docs/persistent_trials.md).
    look_spots: int = param(
        1, 'additions.investigation: newborn spots a searching agent keeps in its next square, '
        'heaviest first, as many as one move can hold', low=1, high=MANY)
    look_spot_share: float = param(
        1.0, 'additions.investigation: a newborn spot is kept in view when its measurement '
        'seeds at least this share of phd.tentative_threshold', low=0, high=10, low_open=True)
    # 'track' is the addition as first measured. 'keep' (session 37) spends a look's steps on
    # the walk as a newborn spot's; rule 20 (persistent profile, random, fresh dev seeds
    # 9441-9740, paired): detected -1.1, tracked -0.7 points, OSPA +0.06 m, none significant:
    # not kept (docs/persistent_trials.md).
    peak_look: str = param(
        'track', 'additions.investigation: how a searching agent looks at a tentative peak: '
        "'track' holds its walk and places itself with the tracking control, 'keep' keeps the "
        'peak in its next square with the search move', choices=PEAK_LOOKS)
    # 'any' is the addition as first measured. Session 40 (persistent profile): kept spots
    # slowed the walk to 3.0 m/step on 18 % of the searching steps, but 'full' (rule 21, random,
    # fresh dev seeds 9851-10150, paired) detected -0.8, tracked -1.0 points, OSPA +0.05 m,
    # none significant: not kept (docs/persistent_trials.md).
    spot_move: str = param(
        'any', 'additions.investigation: the search move that keeps a newborn spot in view: '
        "'any' admissible move, 'full' only a move as long as the walk's (the walk may turn "
        'for a spot but never slows down or stands)', choices=SPOT_MOVES)
    # 1.2 in config/persistent.yaml, one of arm S4's levers (rules 31 and 33-34).
    sweep_slack: float = param(
        0.0, "how much farther (m) from the walk's next node than the nearest admissible "
        'pose a search move may end, to take the square holding the most undetected targets '
        "(0: the paper's xi_search; beyond_paper/sweeping_move.py)", low=0, high=MANY)
    # 1 in config/persistent.yaml: a lone agent sees every cell again within two sweeps, a
    # team of four within 391-435 steps over 1,500 (sessions 54, 62 and 63); a sweep is 357
    # steps there, so no run of 200 steps changes but for the radio's node views.
    overdue_sweeps: float = param(
        0.0, 'additions.persistent_planning: an agent takes first, and sees whole, the nodes '
        "with a cell no square it knows of (its own, its neighbours', their reports' node "
        'views) has held for this many sweeps of every node (0: never, and no node views on '
        'the radio; beyond_paper/overdue_nodes.py)', low=0, high=MANY)
    # Follows the regrowing density; 10 steps fly ~4 nodes at the top speed of 4 m/step.
    replan_period: int = param(
        10, 'additions.persistent_planning: every agent in SEARCH replans (jointly with the '
        'searching agents in range) at the steps k that are multiples of this', low=1,
        high=MANY)
    # The baselines are in sat_agent/baselines/: 'lawnmower' and 'random_walk' replace the
    # search moves only, 'phd_voronoi' (Dames 2020) and 'thompson' (DecSTER, Banerjee and
    # Schneider 2024) the whole controller. The filter, extraction and mode machine are the
    # same for all.
    policy: str = param('sat', "how the agent moves: 'sat' is the paper's (closed walks over "
                        'the search map, joint plans in range), the others baselines',
                        choices=SEARCH_POLICIES)
    planner: str = param('greedy', "how the 'sat' closed walks are made: 'greedy' is the "
                         "paper's path-cheapest-arc, 'ortools' improves them by OR-Tools local "
                         'search (routing.py)', choices=SEARCH_PLANNERS)


@dataclass(frozen=True)
class CooperationParams:
    """Radio range, tracking control and tracking-overlap parameters."""

    # world_sim's radio gates every message with it, from the next message on.
    comm_range: float = param(50.0, 'C_R: radio range (m)', low=0, live=True)
    renyi_alpha: float = param(0.5, 'alpha of Eqn. track_control', low=0, high=1,
                               low_open=True, high_open=True)
    # Twice the sensing square, so sets a square apart score c.
    ospa_cutoff: float = param(10.0, 'OSPA cut-off c of Eqn. ospa (m)', low=0, low_open=True)
    # 2 m per step is well above the spread of two agents' estimates of one target.
    overlap_window: int = param(5, 'steps of the cumulative overlap score', low=1, high=MANY)
    overlap_threshold: float = param(
        10.0, 'Q_Th: a cumulative score <= this means "same targets"', low=0)
    # Persistent profile, dev seeds 2001-2100 (random default), paired with 5: 10 detected -4.9
    # points [-8.6, -1.2] and tracked -2.4 (hovering over a lost track costs search time); 3
    # changed nothing (-2.0, -0.8, OSPA +0.01 m).
    track_timeout: int = param(
        5, 'TRACK falls back to SEARCH after this many steps with no estimated target',
        low=1, high=MANY)
    track_probation: int = param(
        3, 'additions.track_probation: a TRACK episode with fewer than this many steps with an '
        'estimated target falls back to SEARCH on its first step without one', low=2, high=MANY)
    # Up to 4 m/step of flight, far beyond the a/2 + extraction margin = 10 m it takes to get
    # the abandoned targets out of view.
    rejoin_cooldown: int = param(
        10, 'additions.rejoin_cooldown: after leaving TRACK for an overlap, ignore estimated '
        'targets for this many steps', low=1, high=MANY)
    # Clutter is kappa / d per m^2, so detections closer than ~3 m carry little evidence; a
    # target walks ~1 m/step and its estimate errs ~1 m. The edge margin also bounds where
    # additions.investigation keeps a spot seen once in the next square.
    track_standoff: float = param(
        3.0, 'additions.track_standoff: the tracking control keeps targets this far from the '
        'agent (m)', low=0, low_open=True)
    track_edge_margin: float = param(
        1.5, "additions.track_standoff: and this far inside the square's edge (m)", low=0)
    # Dev seeds 2001-2030 (random default): 0.1 / 0.3 / 0.5 gave detected 0.61 / 0.66 / 0.64,
    # entered 0.69 / 0.76 / 0.78, tracked 0.31 / 0.32 / 0.27, OSPA 6.76 / 6.70 / 7.06 m. The
    # persistent profile leaves the addition off (config/persistent.yaml says why).
    # A fixed count trades: dev seeds at random, paired with 20 alone, 10 alone detected +3.5
    # points and tracked -2.3 (2001-2100) and -3.1 (2201-2400). 8 and 4 cm/s (what 20
    # estimates erring 1 m give) detected as much more without that loss
    # (docs/persistent_trials.md).
    follow_steps: int = param(
        8, 'additions.track_coasting: a tracking agent returns to search once every target '
        'in its square has a track of at least this many estimates', low=2, high=MANY)
    # 0.025 m/s (session 31, dev seeds 6841-7140): tracked +0.29 points, n.s.; in
    # config/persistent.yaml with the rest of arm S4 (rules 33-34).
    follow_velocity_error: float = param(
        0.04, "additions.track_coasting: and the standard error of that track's fitted "
        'velocity is at most this (m/s; 0: the count alone)', low=0, high=100)
    # The mode counts the targets not yet followed, so a followed target cannot make the leaver
    # track again; a cooldown after such an exit only stops any other target and every look
    # (additions.investigation). 0 against 10 (rule 17, persistent profile, random, paired):
    # over dev seeds 7141-8060 (900) tracked +1.33 points (p 0.001), OSPA -0.10 m (p < 0.001),
    # false-track steps -3.8, detected +0.15; 5 moved nothing (session 31). The leaver's first
    # steps then track targets it has not followed itself (docs/persistent_trials.md).
    follow_cooldown: int = param(
        0, 'additions.track_coasting: with additions.rejoin_cooldown, a tracker that leaves '
        'TRACK because its targets are followed ignores estimated targets (and looks at '
        'nothing) for this many steps', low=0, high=MANY)
    # Dev seeds 2601-2700 at random, paired with the persistent profile: 0.05 / 0.1 / 0.2 gave
    # detected -2.5 / -4.3 / -3.6 points, tracked +0.4 / +0.9 / +0.0; 0.05 on fresh seeds
    # 2701-3000: detected -0.1, tracked +2.2 (p < 0.001), OSPA -0.16 m (docs/persistent_trials.md).
    # 0.02 (session 31, dev seeds 6841-7140): tracked +0.37 points, n.s.; in
    # config/persistent.yaml with the rest of arm S4 (rules 33-34).
    revisit_loss: float = param(
        0.05, 'additions.track_revisit: a searching agent flies back over a coasted target once '
        'the chance that its fit errs by more than phd.coast_gate when the agent gets there '
        'reaches this', low=0, high=1, low_open=True)
    # A revisit priced on drift alone leaves a well-fitted report unlooked-at until it ends
    # (68 steps): its target's death goes unseen. 0.2 (rule 23, persistent profile, random,
    # fresh dev seeds 11051-11350, paired): false-track steps -6.3*, but detected -3.7 points*,
    # tracked -1.2, OSPA +0.01 m: the flights cost the search what the checks save; not kept
    # (docs/persistent_trials.md, session 43).
    revisit_death: float = param(
        1.0, 'additions.track_revisit: a coasted target is also due for a revisit once the '
        'chance that it died since its last estimate, 1 - p_S^t at the meeting step, reaches '
        'this (1: never on that chance alone)', low=0, high=1, low_open=True)
    # No bound by default: at revisit_loss 0.1, bounds of 10 and 20 m left almost no revisit
    # (detected +0.7 and +0.0, tracked +0.3 and +0.1 on the same seeds).
    revisit_detour: float = param(
        float(MANY), 'additions.track_revisit: and flying over it lengthens the way to the '
        "walk's next node by at most this (m)", low=0, high=MANY)
    # Session 33: with phd.coast_boundary 'clamp' a target that died at the border is
    # reported there until its fit leaves by its drift spread. With 'clamp', at random (dev
    # seeds 8101-8400, paired with 'clamp' alone) tracked -0.12 points, OSPA -0.00 m,
    # area searched by k = 100 -0.15 (p < 0.001): not kept (docs/persistent_trials.md).
    revisit_border: bool = param(
        False, "additions.track_revisit: with phd.coast_boundary 'clamp', a coasted target "
        'whose fit has left the area since its last estimate (reported at the border) is due '
        'for a revisit whatever its drift')
    track_search_tolerance: float = param(
        0.3, 'additions.search_while_tracking: epsilon, the share of the best Renyi divergence '
        '(Eqn. track_control) a tracking agent may give up to cover search worth', low=0,
        high=1, high_open=True)
    # 'all' is the addition as built and as rule 28 measured it (session 48): there the targets
    # entered and not detected rose by 2.0 points of the targets (p 0.05; on its pilot's seeds
    # they fell by 2.6, p 0.04), and before its detection only a look steers an agent to a target.
    track_search_scope: str = param(
        'all', 'additions.search_while_tracking: where it applies: '
        "'all' in TRACK and in a searching agent's look at tentative peaks, 'track' in TRACK "
        'only (a look takes the best Renyi divergence)', choices=TRACK_SEARCH_SCOPES)


def _switch(description: str):
    return param(True, description)


@dataclass(frozen=True)
class AdditionsParams:
    """Switches of the additions to the paper (module docstring; one module each in beyond_paper/).

    True is config/paper.yaml (our detection chain), False is the paper as written
    (config/paper_strict.yaml); the persistent search-and-track additions (the last ten) are
    False in both, and config/persistent.yaml switches on all of them but search_while_tracking.
    Each switch is the only way to turn its addition off.
    """

    peak_extraction: bool = _switch(
        'per-peak counting with track continuity instead of n-hat = round(PHD mass in the '
        'sensing area): diffuse clutter-born mass is not counted as a target and a tracked '
        'target survives a light scan (beyond_paper/peak_extraction.py)')
    extraction_margin: bool = _switch(
        'extraction over the sensing square grown by phd.extraction_margin instead of '
        'S_a(s_k): a tracked target that leaves the square for a step is not dropped '
        '(beyond_paper/extraction_margin.py)')
    confirmation: bool = _switch(
        'a new target needs round(mass) >= 1 on phd.confirm_scans scans in a row instead of '
        'TRACK on the first estimate (beyond_paper/confirmation.py)')
    investigation: bool = _switch(
        'a searching agent holds its walk for up to search.investigate_steps steps to look at '
        'a tentative peak, and keeps a measurement seen once in its next square '
        '(beyond_paper/investigation.py)')
    newborn_gate: bool = _switch(
        'measurement-driven newborns the next sensing square does not cover are dropped: they '
        'would linger as ghost mass (beyond_paper/newborn_gate.py)')
    track_standoff: bool = _switch(
        "the tracking control's argmax runs over the actions keeping every target "
        'cooperation.track_standoff from the agent and cooperation.track_edge_margin inside '
        'the square (beyond_paper/track_standoff.py)')
    revisit_fallback: bool = _switch(
        'with no node at or below beta, plan over the search.revisit_share least searched '
        'nodes instead of holding (beyond_paper/revisit_fallback.py)')
    rejoin_cooldown: bool = _switch(
        'after leaving TRACK because of an overlap, ignore estimated targets for '
        'cooperation.rejoin_cooldown steps (beyond_paper/rejoin_cooldown.py)')
    exhaustion_claims: bool = _switch(
        'an exhaustion replan leaves out the nodes the last joint plan gave the other members '
        'while any other node is unvisited (beyond_paper/exhaustion_claims.py)')
    drop_searched_nodes: bool = _switch(
        'a walk drops the nodes whose fused search value shows another agent searched them '
        'since the plan (beyond_paper/drop_searched_nodes.py)')
    # Beyond the paper, off here and on in config/persistent.yaml (issue 15):
    regrowing_density: bool = param(
        False, "the search density regrows as the filter's model says targets can appear: an "
        "unobserved cell's value is P(no undetected target there now), predicted with the "
        'uniform birth intensity, p_S and the NCV motion, corrected with p_D, instead of a '
        'constant J (beyond_paper/regrowing_density.py)')
    persistent_planning: bool = param(
        False, "walks collect the nodes' worth (expected undetected targets) per distance over "
        'the whole mission, replanned jointly every search.replan_period steps, instead of '
        'path-cheapest-arc over V-bar (beyond_paper/persistent_planning.py)')
    search_while_tracking: bool = param(
        False, 'a tracking agent takes, among the actions scoring at least (1 - epsilon) of the '
        'best Renyi divergence (epsilon = cooperation.track_search_tolerance), the one whose '
        'next square holds the most search worth (beyond_paper/search_while_tracking.py)')
    track_release: bool = param(
        False, 'a tracking agent with several targets leaves out of its tracking control the '
        'ones a neighbour in range tracks with a tighter estimate '
        '(beyond_paper/track_release.py)')
    track_coasting: bool = param(
        False, 'a target an agent estimated and no longer sees is still reported, where the '
        "constant-velocity fit of its recent estimates puts it, until the agent's square or a "
        'neighbour shows otherwise or p_S^t falls below phd.coast_survival; a tracking agent '
        'returns to search once its targets have cooperation.follow_steps estimates and a '
        'velocity known to cooperation.follow_velocity_error '
        '(beyond_paper/track_coasting.py)')
    kernel_likelihood: bool = param(
        False, "the filter's g(z | x) is the likelihood of a Gaussian kernel of spread "
        "sensor.likelihood_bandwidth around each particle instead of the sensor's own "
        '(beyond_paper/kernel_likelihood.py)')
    heavy_peak_confirmation: bool = param(
        False, 'with additions.confirmation, a peak of PHD mass phd.confirm_mass is a target on '
        'its first scan instead of after phd.confirm_scans (beyond_paper/'
        'heavy_peak_confirmation.py)')
    track_probation: bool = param(
        False, 'a TRACK episode with fewer than cooperation.track_probation steps with an '
        'estimated target ends on its first step without one instead of after '
        'cooperation.track_timeout (beyond_paper/track_probation.py)')
    track_revisit: bool = param(
        False, 'with additions.track_coasting, a searching agent flies back over a target it '
        'left to its coasting once the fit may have drifted beyond phd.coast_gate with '
        'probability cooperation.revisit_loss, instead of meeting it again by chance '
        '(beyond_paper/track_revisit.py)')
    measurement_fit: bool = param(
        False, "with additions.track_coasting, a track's constant-velocity walk is fitted to "
        "the agent's measurement of each estimate, weighted by the sensor's covariance, "
        'instead of to the estimates by least squares (beyond_paper/measurement_fit.py)')


@dataclass(frozen=True)
class SatParams:
    """All parameters of one agent (and of the world it assumes)."""

    area: AreaParams = group(AreaParams)
    motion: MotionParams = group(MotionParams)
    sensor: SensorParams = group(SensorParams)
    actions: ActionParams = group(ActionParams)
    phd: PhdParams = group(PhdParams)
    search: SearchParams = group(SearchParams)
    cooperation: CooperationParams = group(CooperationParams)
    additions: AdditionsParams = group(AdditionsParams)

    def validate(self) -> 'SatParams':
        """Check every group; raise ParameterError naming the first bad key."""
        return validate(self)

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> 'SatParams':
        """Build from nested groups ({'sensor': {'square_side': 10}}) or dotted keys.

        Keys outside the known groups and fields raise ParameterError.
        """
        return build(cls, values)

    def with_overrides(self, values: Mapping[str, Any]) -> 'SatParams':
        """Return a copy with some dotted or nested values replaced (validated)."""
        return with_overrides(self, values)


def read_yaml(path, error=ParameterError):
    """Parse a YAML file; a syntax error becomes `error` naming the file and the position."""
    import yaml

    with open(path, encoding='utf-8') as stream:
        try:
            return yaml.safe_load(stream)
        except yaml.YAMLError as problem:
            raise error(f'{path}: not valid YAML: {problem}') from None


def ros_parameters(path) -> dict:
    """Return the ``/**: ros__parameters:`` section of a ROS 2 parameter file."""
    document = read_yaml(path, ParameterError)
    try:
        section = document['/**']['ros__parameters']
    except (TypeError, KeyError):
        raise ParameterError(
            f"{path}: expected a '/**: ros__parameters:' section (ROS 2 parameter file)") from None
    if not isinstance(section, Mapping):
        raise ParameterError(f"{path}: '/**: ros__parameters:' must be a mapping")
    return dict(section)


def load_params_file(path) -> SatParams:
    """Read the SatParams groups of a ROS 2 parameter file's ``/**: ros__parameters:`` section.

    Keys of that section that are not SatParams groups are node-level settings, checked
    against the node schemas (sat_agent.node_params). Errors name the file.
    """
    section = ros_parameters(path)
    groups = {g.name for g in fields(SatParams)}
    check_node_settings({k: v for k, v in section.items() if k not in groups}, f'{path}: ')
    try:
        return SatParams.from_mapping({k: v for k, v in section.items() if k in groups})
    except ParameterError as error:
        raise ParameterError(f'{path}: {error}') from None
