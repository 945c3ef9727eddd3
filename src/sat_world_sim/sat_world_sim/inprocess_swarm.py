r"""Run a scenario with N agents and the world in one process, no ROS: the reference loop.

Each step k::

    scans = world.scan_all()                           # Z_k at s_k
    outputs[i] = agent_i.step(k, s_k, Z_k, inbox_i)    # inbox_i: reports of step k-1 from the
                                                       # agents within C_R of i at step k-1
    world.apply_actions(actions); world.advance()      # s_{k+1}, truth k+1

The radio is the world's range gate: a report sent at step k reaches every agent within
``cooperation.comm_range`` of the sender at step k (true positions) and is read at step k+1.
Every step is recorded as a plain ``metrics.StepRecord``.

Command line::

    python -m sat_world_sim.inprocess_swarm --scenario config/scenarios/paper.yaml \\
        --params config/paper.yaml --out runs/<name> [--seed N] [--steps N]

writes ``metrics.json`` and ``plots/*.png`` into the run directory and prints its path last.
"""

import argparse
from dataclasses import dataclass
from pathlib import Path
import sys
import time
from typing import Callable, Dict, List, Optional

import numpy as np

from sat_agent.agent_core import Agent, AgentOutput, AgentReport, REPORT_KINDS
from sat_agent.config import load_params_file, ParameterError, SatParams

from sat_world_sim.metrics import compute_metrics, StepRecord, write_metrics
from sat_world_sim.plots import write_plots
from sat_world_sim.scenario import load_scenario, Scenario, ScenarioError
from sat_world_sim.world_model import World


@dataclass
class SwarmRun:
    """The result of one in-process run: records, last outputs and the final fused density."""

    scenario: Scenario
    records: List[StepRecord]
    final_density: np.ndarray
    seconds: float


class InProcessSwarm:
    """The world and one Agent per scenario agent, stepped together (module docstring)."""

    def __init__(self, scenario: Scenario, params: SatParams):
        self.scenario = scenario
        self.params = params
        self.world = World(scenario, params)
        self.agents: Dict[int, Agent] = {
            a.agent_id: Agent(a.agent_id, params, a.start, seed=scenario.seed)
            for a in scenario.agents}
        self._links = frozenset()
        # Each agent's output of the last step: its report is what the radio carries to the
        # agents in range, and tools read its estimate (with tentative peaks) and plan.
        self.last_outputs: Dict[int, AgentOutput] = {}

    def inbox(self, agent_id: int) -> List[AgentReport]:
        """Return the reports of step k-1 from the agents within C_R of agent_id at step k-1."""
        return [output.report for sender, output in sorted(self.last_outputs.items())
                if tuple(sorted((sender, agent_id))) in self._links]

    def step(self) -> StepRecord:
        """Run one step of every agent and the world; return its record."""
        k = self.world.step
        truth = self.world.truth()
        poses = self.world.poses()
        searched = self.world.searched_fraction()
        scans = self.world.scan_all()
        outputs: Dict[int, AgentOutput] = {}
        for agent_id, agent in self.agents.items():
            outputs[agent_id] = agent.step(k, poses[agent_id], scans[agent_id].measurements,
                                           self.inbox(agent_id))
        links = self.world.links()
        moves = self.world.apply_actions({a: o.action for a, o in outputs.items()})
        self.world.advance()
        self.last_outputs = outputs
        self._links = links
        receivers = {a: sum(1 for pair in links if a in pair) for a in outputs}
        return StepRecord(
            step=k,
            truth_ids=truth.ids,
            truth_positions=truth.positions,
            agent_poses=poses,
            modes={a: o.mode.name for a, o in outputs.items()},
            estimates={a: o.reported_positions() for a, o in outputs.items()},
            plans={a: o.plan for a, o in outputs.items()},
            searched_fraction=searched,
            radio_messages={a: len(REPORT_KINDS) * receivers[a] for a in outputs},
            radio_bytes={a: receivers[a] * o.report.nbytes for a, o in outputs.items()},
            overlap_events=[{'step': k, 'agent': a, 'left_for': o.left_overlap_with}
                            for a, o in outputs.items() if o.left_overlap_with is not None],
            refused_actions={a: m.reason for a, m in moves.items() if not m.accepted},
            replans={a: o.replan.name for a, o in outputs.items() if o.replan})

    def fused_density(self) -> np.ndarray:
        """Elementwise max of every agent's search density (for display)."""
        return np.maximum.reduce([agent.filter.search.values for agent in self.agents.values()])


def run_swarm(scenario: Scenario, params: SatParams, steps: Optional[int] = None,
              prepare: Optional[Callable[[InProcessSwarm], None]] = None) -> SwarmRun:
    """Run the scenario for its steps (or `steps`) and return the records.

    prepare(swarm), if given, is called once before the first step (a diagnostic's hook, e.g.
    triage_oracle.oracle_triage).
    """
    swarm = InProcessSwarm(scenario, params)
    if prepare is not None:
        prepare(swarm)
    started = time.perf_counter()
    records = [swarm.step() for _ in range(steps or scenario.steps)]
    return SwarmRun(scenario, records, swarm.fused_density(), time.perf_counter() - started)


def write_run(run: SwarmRun, params: SatParams, out_dir) -> dict:
    """Write metrics.json and plots/*.png of a run into out_dir; return the metrics."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    metrics = compute_metrics(run.records, run.scenario.name, run.scenario.seed)
    write_metrics(metrics, out / 'metrics.json')
    write_plots(metrics, run.records, out / 'plots',
                area=(params.area.width, params.area.height), final_density=run.final_density)
    return metrics


def main(argv=None) -> int:
    """Command-line entry point (module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--scenario', required=True, help='scenario YAML file')
    parser.add_argument('--params', required=True, help='ROS 2 parameter file (config/paper.yaml)')
    parser.add_argument('--out', required=True, help='run directory to write')
    parser.add_argument('--seed', type=int, default=None, help="override the scenario's seed")
    parser.add_argument('--steps', type=int, default=None, help="override the scenario's steps")
    args = parser.parse_args(argv)
    try:
        params = load_params_file(args.params)
        scenario = load_scenario(args.scenario, params.area.width, params.area.height)
        if args.seed is not None:
            scenario = scenario.with_seed(args.seed)
    except (ParameterError, ScenarioError, OSError) as error:
        print(f'error: {error}', file=sys.stderr)
        return 2
    if args.steps is not None and args.steps < 1:
        print(f'error: --steps = {args.steps}: must be >= 1', file=sys.stderr)
        return 2
    run = run_swarm(scenario, params, args.steps)
    metrics = write_run(run, params, args.out)
    summary = metrics['summary']
    tracking = summary['mean_ospa_tracking']
    tracking = 'n/a (no agent tracked)' if tracking is None else f'{tracking:.2f} m'
    print(f'{scenario.name} seed {scenario.seed}: {len(run.records)} steps in '
          f"{run.seconds:.1f} s, searched {summary['final_searched_pct']:.1f} %, "
          f'mean OSPA while tracking {tracking}', file=sys.stderr)
    print(Path(args.out))
    return 0


if __name__ == '__main__':
    sys.exit(main())
