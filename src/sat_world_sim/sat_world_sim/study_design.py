"""The evaluation's design: settings, cells (configurations) and the designs that group them.

Settings (a scenario per seed, ``scenario_for``):

- ``paper``: the paper's scenario (config/scenarios/paper.yaml, ``make run``'s: 2 agents at
  (10, 60) and (60, 10), targets born at k = 104 and 144), the seed varying sensor noise,
  clutter and filter draws only. A single truth: what it says is limited to that scenario.
- ``paper_random``: the paper's agents, starts, area and clutter with two targets drawn per
  seed (random_scenarios.paper_random_scenario: born in [80, 150], living 30-80 steps).
- ``random``: the random default (random_scenarios.random_scenario: 4 agents starting anywhere,
  2-10 targets born over steps 1-150).
- ``long``: a long mission (random_scenarios.long_mission_scenario: the random default's team
  and starts, targets born throughout the mission at the random default's mean rate). Run it
  with ``--steps`` (e.g. 1000): at 200 steps its births span steps 1-150 as the random
  default's do.

All: lambda = 10, C_R = 50 m, 200 steps unless a cell changes them.

A cell is a setting, a label (unique in its setting) and a configuration: a profile (parameter
file ``config/<profile>.yaml``), the search policy and planner, the clutter rate, the radio
range, the team size (random setting only: the paper settings have the paper's team) and any
further dotted parameters (``overrides``, e.g. ``additions.confirmation: False``).

Cells per setting (``policy_cells``): SAT-PHD cooperative (config/paper.yaml; the reference of
every paired comparison), SAT-PHD strict (config/paper_strict.yaml, the paper as written), no
radio (C_R = 0), lawnmower, random walk, SAT-PHD with OR-Tools walks, the oracle sweep
(oracle_sweep.py, the ceiling), the oracle sweep-and-track (the same oracle following what it
sees: a reference for the tracked share, not a ceiling) and issue 15's cells: the persistent
profile (config/persistent.yaml) and the PHD-Voronoi and Thompson-sampling PHD baselines
(``search.policy`` FIELD_BASELINES). The ablation (``ablation_cells``): the default profile with
each addition to the paper switched off alone, one cell per bool field of the parameter group
``additions`` (sat_agent.config) that is on by default, so the study follows the core without a
second list; the persistent profile's ablation (``persistent_ablation_cells``, in ``full``):
that profile with each addition that is off by default switched the other way alone, "without"
the ones it switches on and "with" the ones it leaves off (both cells are listed;
``prepare_cells`` skips the one that is the profile itself). Sweeps
around the random default (``sweep_cells``): 2 or 8 agents, lambda 0 or 30, C_R 25 m or
unlimited. The factorial (``factorial_cells``): agents {2, 4, 8} x lambda {0, 10, 30} x
C_R {0, 25, 50, unlimited} x the policies of FACTORIAL_POLICIES at the random setting, plus the
oracle sweep per team size (it neither hears clutter nor uses the radio).

Designs (``DESIGNS``): ``default`` is what ``make evaluate`` runs, chosen to fit 45 minutes on
2 cores with 50 seeds per cell; ``full`` adds what did not fit; ``factorial`` is the full
factorial. ``--only SETTING/LABEL`` picks cells from all of them. Measured CPU seconds per
200-step run (evaluation.csv's ``cpu_time_s``, seeds 1-4, with the core of issue 14's
additions; the machine shared, so ±20 %): SAT-PHD 2.7 at the paper setting, 2.1 at
paper_random, 6-7 at random; the strict profile and the ablation cells like SAT-PHD (1.7-2.3 at
paper_random); lawnmower, random walk and no radio 2.2-2.5 and 4.3-7.3; OR-Tools walks 3.1 and
9.7; 8 agents 12.8; the oracle sweep 0.1, sweep-and-track 0.2. The default design: at paper,
cooperative, strict and the two oracles; at paper_random, every policy cell and the ablation
(10 additions); at random, every policy cell; the policy cells include OR-Tools walks (issue 15
names them among the baselines the persistent profile must lead). 1800 runs took 37.6-42.1 min
on an idle machine (``evaluate --dry-run`` prints the estimate from the last study's costs). Not in
it, reachable with ``--design full`` or ``--only``: the paper setting's other policies, the
ablation at paper and random (+22 min at random), the persistent profile's ablation at random
(9 cells, ~+23 min), the sweeps (+18 min) and the long mission's policy cells.

Cells that cannot be built on this checkout (a profile file that does not exist yet, a policy
or parameter the core does not know yet, e.g. on an older checkout) are skipped with a
message, not an error (``prepare_cells``).

Reference of a paired comparison (``reference_of``): for a cell of another configuration than
cooperative SAT-PHD (profile ``paper``, policy ``sat``, greedy walks, no overrides), the
cooperative SAT-PHD cell of the same setting with the same team, clutter and radio range if
there is one (the factorial's policies at each of its combinations); else the setting's
cooperative SAT-PHD cell at its default team, clutter and range (policies, ablation, sweeps,
the factorial's SAT-PHD cells). That one has no reference. The persistent profile's ablation
cells are compared with the persistent profile of their setting (none when it did not run).
"""

from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple

from sat_agent.config import load_params_file, ParameterError, SatParams

from sat_world_sim.random_scenarios import long_mission_scenario, paper_random_scenario
from sat_world_sim.random_scenarios import random_scenario
from sat_world_sim.scenario import Scenario

STEPS = 200
SEEDS = 50
# C_R standing for "unlimited": above the area's diagonal (141 m), so every pair is in range.
UNLIMITED = 1000.0
CLUTTER = 10.0
COMM_RANGE = 50.0

REFERENCE_PROFILE = 'paper'
STRICT_PROFILE = 'paper_strict'
PERSISTENT_PROFILE = 'persistent'
ORACLE = 'oracle_sweep'
ORACLE_TRACK = 'oracle_sweep_track'
ORACLES = (ORACLE, ORACLE_TRACK)
ADDITIONS_GROUP = 'additions'
# search.policy names of issue 15's baselines from the field (PHD-weighted Voronoi, Dames 2020;
# Thompson sampling, Banerjee & Schneider 2024; sat_agent/baselines/).
FIELD_BASELINES = ('phd_voronoi', 'thompson')

REFERENCE_LABEL = 'SAT-PHD (cooperative)'
STRICT_LABEL = 'SAT-PHD strict (paper as written)'
ORACLE_LABEL = 'oracle sweep'
ORACLE_TRACK_LABEL = 'oracle sweep-and-track'
PERSISTENT_LABEL = 'SAT-PHD persistent'


@dataclass(frozen=True)
class Setting:
    """A family of scenarios; ``paper_team``: the paper scenario's agents, not a drawn team."""

    name: str
    title: str
    agents: int
    paper_team: bool


SETTINGS = {s.name: s for s in (
    Setting('paper', "paper's scenario (2 agents, 2 scripted targets)", 2, True),
    Setting('paper_random', 'randomised paper setting (2 agents, 2 drawn targets)', 2, True),
    Setting('random', 'random default (4 agents, 2-10 targets)', 4, False),
    Setting('long', 'long mission (4 agents, targets born throughout)', 4, False))}


@dataclass(frozen=True)
class Cell:
    """One configuration of the study (module docstring); ``name`` is SETTING/LABEL."""

    setting: str
    label: str
    profile: str = REFERENCE_PROFILE
    policy: str = 'sat'
    planner: str = 'greedy'
    agents: int = 4
    clutter: float = CLUTTER
    comm_range: float = COMM_RANGE
    overrides: Tuple[Tuple[str, Any], ...] = ()
    steps: int = STEPS

    @property
    def name(self) -> str:
        """SETTING/LABEL, as ``--only`` takes it."""
        return f'{self.setting}/{self.label}'

    @property
    def is_oracle(self) -> bool:
        """Whether this is an oracle: the sweep or sweep-and-track (no filter, oracle_sweep.py)."""
        return self.policy in ORACLES

    @property
    def is_reference_kind(self) -> bool:
        """Cooperative SAT-PHD's configuration, whatever the team, clutter and range."""
        return (self.profile, self.policy, self.planner, self.overrides) == (
            REFERENCE_PROFILE, 'sat', 'greedy', ())

    def params(self, profile: SatParams) -> SatParams:
        """Return the profile's parameters with this cell's values (validated)."""
        values = {'sensor.clutter_rate': self.clutter, 'cooperation.comm_range': self.comm_range}
        if not self.is_oracle:
            values.update({'search.policy': self.policy, 'search.planner': self.planner})
        values.update(dict(self.overrides))
        return profile.with_overrides(values)

    def columns(self) -> Dict[str, Any]:
        """Return the configuration columns of evaluation.csv (CONFIG_COLUMNS)."""
        return {'setting': self.setting, 'label': self.label, 'profile': self.profile,
                'policy': self.policy, 'planner': self.planner, 'agents': self.agents,
                'clutter': self.clutter, 'comm_range': self.comm_range,
                'overrides': ';'.join(f'{key}={value}' for key, value in self.overrides),
                'steps': self.steps}


CONFIG_COLUMNS = tuple(Cell('random', '').columns())


def default_cell(setting: str, label: str = REFERENCE_LABEL, **values) -> Cell:
    """Return a cell at the setting's default team, clutter and range (values: other fields)."""
    return Cell(setting, label, agents=SETTINGS[setting].agents, **values)


def policy_cells(setting: str) -> List[Cell]:
    """Return every policy and profile compared at one setting (module docstring)."""
    cell = default_cell
    cells = [cell(setting), cell(setting, STRICT_LABEL, profile=STRICT_PROFILE),
             cell(setting, 'SAT-PHD, no radio', comm_range=0.0),
             cell(setting, 'lawnmower', policy='lawnmower'),
             cell(setting, 'random walk', policy='random_walk'),
             cell(setting, 'SAT-PHD + OR-Tools', planner='ortools'),
             cell(setting, ORACLE_LABEL, policy=ORACLE, planner='none'),
             cell(setting, ORACLE_TRACK_LABEL, policy=ORACLE_TRACK, planner='none')]
    return cells + persistent_cells(setting)


def persistent_cells(setting: str) -> List[Cell]:
    """Return issue 15's cells: the persistent profile and two baselines (module docstring)."""
    return [default_cell(setting, PERSISTENT_LABEL, profile=PERSISTENT_PROFILE),
            default_cell(setting, 'PHD-Voronoi', policy=FIELD_BASELINES[0]),
            default_cell(setting, 'Thompson-sampling PHD', policy=FIELD_BASELINES[1])]


def addition_names(default: bool = True) -> List[str]:
    """Return the bool fields of SatParams' ``additions`` group whose default is ``default``.

    In order; none before the group exists.
    """
    group = next((f for f in fields(SatParams) if f.name == ADDITIONS_GROUP), None)
    if group is None:
        return []
    defaults = group.default_factory()
    return [f.name for f in fields(defaults) if getattr(defaults, f.name) is default]


def ablation_cells(setting: str) -> List[Cell]:
    """Return the default profile with each addition switched off alone (module docstring)."""
    return [default_cell(setting, f'without {name}',
                         overrides=((f'{ADDITIONS_GROUP}.{name}', False),))
            for name in addition_names()]


def persistent_ablation_cells(setting: str) -> List[Cell]:
    """Return the persistent profile with each addition off by default switched alone.

    Both ways for each (module docstring): the profile's yaml decides which one is a no-op.
    """
    return [default_cell(setting, f'{PERSISTENT_LABEL} {word} {name}',
                         profile=PERSISTENT_PROFILE,
                         overrides=((f'{ADDITIONS_GROUP}.{name}', value),))
            for name in addition_names(default=False)
            for word, value in (('without', False), ('with', True))]


def sweep_cells() -> List[Cell]:
    """Return cooperative SAT-PHD around the random default, one factor changed at a time."""
    default = default_cell('random')
    return ([replace(default, label=f'{n} agents', agents=n) for n in (2, 8)]
            + [replace(default, label=f'clutter {c:g}', clutter=float(c)) for c in (0, 30)]
            + [replace(default, label='C_R 25 m', comm_range=25.0),
               replace(default, label='C_R unlimited', comm_range=UNLIMITED)])


FACTORIAL_AGENTS = (2, 4, 8)
FACTORIAL_CLUTTER = (0.0, 10.0, 30.0)
FACTORIAL_RANGES = (0.0, 25.0, 50.0, UNLIMITED)
# (label, policy, planner) of the factorial's policies.
FACTORIAL_POLICIES = ((REFERENCE_LABEL, 'sat', 'greedy'), ('SAT-PHD + OR-Tools', 'sat', 'ortools'),
                      ('lawnmower', 'lawnmower', 'greedy'),
                      ('random walk', 'random_walk', 'greedy'),
                      ('PHD-Voronoi', FIELD_BASELINES[0], 'greedy'),
                      ('Thompson-sampling PHD', FIELD_BASELINES[1], 'greedy'))


def factorial_cells() -> List[Cell]:
    """Return the full factorial at the random setting (module docstring)."""
    cells = [Cell('random', f'{label}, {n} agents, lambda {c:g}, {range_label(r)}', policy=policy,
                  planner=planner, agents=n, clutter=c, comm_range=r)
             for n in FACTORIAL_AGENTS for c in FACTORIAL_CLUTTER for r in FACTORIAL_RANGES
             for label, policy, planner in FACTORIAL_POLICIES]
    return cells + [Cell('random', f'{ORACLE_LABEL}, {n} agents', policy=ORACLE, planner='none',
                         agents=n) for n in FACTORIAL_AGENTS]


def range_label(comm_range: float) -> str:
    """Return C_R as the tables print it."""
    return 'C_R unlimited' if comm_range >= UNLIMITED else f'C_R {comm_range:g} m'


def _designs() -> Dict[str, List[Cell]]:
    paper = [default_cell('paper'), default_cell('paper', STRICT_LABEL, profile=STRICT_PROFILE),
             default_cell('paper', ORACLE_LABEL, policy=ORACLE, planner='none'),
             default_cell('paper', ORACLE_TRACK_LABEL, policy=ORACLE_TRACK, planner='none')]
    fits = policy_cells('paper_random') + ablation_cells('paper_random') + policy_cells('random')
    full = (policy_cells('paper') + ablation_cells('paper') + policy_cells('paper_random')
            + ablation_cells('paper_random') + policy_cells('random') + ablation_cells('random')
            + persistent_ablation_cells('random') + sweep_cells() + policy_cells('long'))
    return {'default': paper + fits, 'full': _unique(full), 'factorial': factorial_cells()}


def _unique(cells: Sequence[Cell]) -> List[Cell]:
    seen = set()
    return [c for c in cells if not (c.name in seen or seen.add(c.name))]


DESIGNS = _designs()


def catalogue() -> List[Cell]:
    """Return every cell of every design (what ``--only`` can pick), each name once."""
    return _unique([cell for cells in DESIGNS.values() for cell in cells])


def select(names: Sequence[str]) -> List[Cell]:
    """Return the catalogue's cells named SETTING/LABEL, in order; ValueError if unknown."""
    cells = {cell.name: cell for cell in catalogue()}
    unknown = [name for name in names if name not in cells]
    if unknown:
        raise ValueError(f'--only {unknown}: no such cell; cells are SETTING/LABEL, one of '
                         f'{sorted(cells)}')
    return _unique([cells[name] for name in names])


def with_steps(cells: Sequence[Cell], steps: int) -> List[Cell]:
    """Return the cells with another run length (quick runs)."""
    return [replace(cell, steps=steps) for cell in cells]


def with_values(cells: Sequence[Cell], values: Sequence[Tuple[str, Any]]) -> List[Cell]:
    """Return the cells with further dotted parameters (``evaluate --set``), labelled by them.

    The label gains " with KEY=VALUE; ...", so rows of a trial never pass for the cell's own
    rows; a key the cell already sets takes the new value (later overrides win).
    """
    if not values:
        return list(cells)
    told = '; '.join(f'{key}={value}' for key, value in values)
    return [replace(cell, label=f'{cell.label} with {told}',
                    overrides=cell.overrides + tuple(values)) for cell in cells]


def prepare_cells(cells: Sequence[Cell], config_dir) -> Tuple[List[Tuple[Cell, SatParams]],
                                                              List[Tuple[Cell, str]]]:
    """Build each cell's parameters from ``config_dir/<profile>.yaml``.

    Returns (runnable cells with their parameters, skipped cells with the reason): a cell whose
    profile file is missing or whose values the core refuses (a policy or parameter it does
    not know yet) is skipped, and so is an ablation cell whose addition is already off in its
    profile (switching it off would rerun the reference).
    """
    profiles: Dict[str, Any] = {}
    runnable, skipped = [], []
    for cell in cells:
        path = Path(config_dir) / f'{cell.profile}.yaml'
        if cell.profile not in profiles:
            try:
                profiles[cell.profile] = load_params_file(path)
            except (OSError, ParameterError) as error:
                profiles[cell.profile] = f'{path}: {error}' if path.exists() else \
                    f'{path} does not exist (yet)'
        profile = profiles[cell.profile]
        if isinstance(profile, str):
            skipped.append((cell, profile))
            continue
        try:
            params = cell.params(profile)
        except ParameterError as error:
            skipped.append((cell, f'{path}: {error}'))
            continue
        if cell.overrides and params == replace(cell, overrides=()).params(profile):
            skipped.append((cell, f'{dict(cell.overrides)} is already so in {path}'))
            continue
        runnable.append((cell, params))
    return runnable, skipped


def reference_of(cell: Cell, cells: Sequence[Cell]) -> Optional[Cell]:
    """Return the cell it is compared with (module docstring); None for a setting's reference."""
    if is_setting_reference(cell):
        return None
    if is_persistent_ablation(cell):
        return next((c for c in cells if is_persistent(c) and c.setting == cell.setting), None)
    same = [c for c in cells if c.is_reference_kind and not cell.is_reference_kind
            and c.setting == cell.setting
            and (c.agents, c.clutter, c.comm_range) == (cell.agents, cell.clutter,
                                                        cell.comm_range)]
    return next(iter(same), None) or next(
        (c for c in cells if is_setting_reference(c) and c.setting == cell.setting), None)


def is_setting_reference(cell: Cell) -> bool:
    """Whether the cell is its setting's cooperative SAT-PHD at the default team and values."""
    return replace(cell, steps=STEPS) == default_cell(cell.setting)


def ceiling_of(cell: Cell, cells: Sequence[Cell]) -> Optional[Cell]:
    """Return the oracle sweep of the cell's setting and team (its ceiling) among cells."""
    return next((c for c in cells if c.policy == ORACLE and c.setting == cell.setting
                 and c.agents == cell.agents), None)


def is_persistent_ablation(cell: Cell) -> bool:
    """Whether the cell is the persistent profile with one addition switched the other way."""
    return replace(cell, steps=STEPS) in persistent_ablation_cells(cell.setting)


def is_persistent(cell: Cell) -> bool:
    """Whether the cell is a setting's persistent profile (issue 15) at its default values."""
    return replace(cell, steps=STEPS) == default_cell(cell.setting, PERSISTENT_LABEL,
                                                      profile=PERSISTENT_PROFILE)


def rivals_of(cell: Cell, cells: Sequence[Cell]) -> List[Cell]:
    """Return what the persistent profile must lead (issue 15) among cells, in their order.

    Every other policy and profile of the cell's setting (``policy_cells``: cooperative and
    strict SAT-PHD, no radio, lawnmower, random walk, OR-Tools walks, PHD-Voronoi, Thompson
    sampling), not the two oracles: references, not policies (they see the truth).
    """
    policies = [c for c in policy_cells(cell.setting)
                if not c.is_oracle and c != replace(cell, steps=STEPS)]
    return [c for c in cells if replace(c, steps=STEPS) in policies]


def scenario_for(cell: Cell, seed: int, params: SatParams, paper: Scenario) -> Scenario:
    """Return the cell's scenario for one seed (module docstring); paper: the paper's one."""
    width, height = params.area.width, params.area.height
    if cell.setting == 'paper':
        return replace(paper.with_seed(seed), steps=cell.steps)
    if cell.setting == 'paper_random':
        return paper_random_scenario(seed, paper, cell.steps, width, height)
    if cell.setting == 'long':
        return long_mission_scenario(seed, cell.agents, cell.steps, width, height)
    return random_scenario(seed, cell.agents, cell.steps, width, height)
