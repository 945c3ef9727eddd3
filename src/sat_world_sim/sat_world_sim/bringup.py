"""Bring up a whole swarm as separate OS processes and wait for the run to finish.

Starts, each as its own process running the installed executable (as ``ros2 run`` would):
``world_sim`` (truth, sensors, radio), ``metrics`` (metrics.json and plots), ``recorder`` (every
topic into ``<run-dir>/bag``, unless ``--no-record``), ``logger`` (Rerun: ``<run-dir>/run.rrd``,
and a live viewer with ``--view viewer|web``; none with ``--no-view``) and one ``agent`` per
scenario agent (or all agents in one ``agents_composed`` process with ``--composed``).
Every process gets the same parameter file, a private ROS_DOMAIN_ID (unless one is given) and
localhost-only discovery; their output goes to ``<run-dir>/logs/<name>.log`` and (unless
``--quiet``) to stderr with a ``[name]`` prefix.

The run ends when ``metrics`` has written ``metrics.json``; then every process still running is
stopped (SIGINT, then SIGKILL after a grace period). Ctrl-C stops everything the same way. The
exit code is 0 only if the world and the metrics finished cleanly; with ``--respawn`` a crashed
agent is restarted and rejoins. The run directory is printed as the last line on stdout.

    swarm --scenario config/scenarios/paper.yaml --params config/paper.yaml --run-dir runs/x
"""

import argparse
from dataclasses import dataclass, field
import os
from pathlib import Path
import signal
import subprocess
import sys
import threading
import time
from typing import List, Optional

from ament_index_python.packages import get_package_prefix, get_package_share_directory

from sat_agent.config import load_params_file, ParameterError

from sat_world_sim.domain_ids import claim_domain_id, NoFreeDomain
from sat_world_sim.scenario import load_scenario, ScenarioError

STOP_GRACE_S = 5.0
MAX_RESPAWNS = 5


def executable(package: str, name: str) -> str:
    """Path of an installed executable, found as `ros2 run` finds it (lib/<package>/<name>)."""
    path = Path(get_package_prefix(package)) / 'lib' / package / name
    if not path.is_file():
        raise FileNotFoundError(f'{path} not found: build the workspace first (make test)')
    return str(path)


@dataclass
class Child:
    """One managed process."""

    name: str
    command: List[str]
    respawn: bool = False
    # Observers (metrics, recorder, logger) end the run: it is over when they all exited.
    observer: bool = False
    process: Optional[subprocess.Popen] = None
    respawns: int = 0
    pumps: List[threading.Thread] = field(default_factory=list)

    def start(self, env: dict, log_dir: Path, echo: bool):
        self.process = subprocess.Popen(self.command, env=env, stdout=subprocess.PIPE,
                                        stderr=subprocess.STDOUT, text=True, bufsize=1,
                                        start_new_session=True)
        log = open(log_dir / f'{self.name}.log', 'a', encoding='utf-8')
        pump = threading.Thread(target=_prefix_lines,
                                args=(self.name, self.process.stdout, log, echo), daemon=True)
        pump.start()
        self.pumps.append(pump)

    @property
    def pid(self) -> int:
        return self.process.pid

    def poll(self) -> Optional[int]:
        return self.process.poll()

    def stop(self):
        """Stop the process (and anything it started): SIGINT, SIGKILL after STOP_GRACE_S."""
        if self.process is not None:
            stop_group(self.process)


def stop_group(process: subprocess.Popen, first=signal.SIGINT, grace: float = STOP_GRACE_S):
    """Stop the process group of a process started with start_new_session=True.

    Sends first, then SIGKILL after grace seconds, and reaps the process: nothing is left
    running. A process that already ended is fine.
    """
    if process.poll() is not None:
        return
    try:
        os.killpg(process.pid, first)
        process.wait(timeout=grace)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
    except ProcessLookupError:
        process.wait()


def _prefix_lines(name: str, stream, log, echo: bool):
    """Copy a child's output into its log file and, with echo, to stderr with a prefix."""
    with log:
        for line in stream:
            log.write(line)
            if echo:
                sys.stderr.write(f'[{name}] {line}')
    stream.close()


def ros_env(domain_id: Optional[int]) -> dict:
    """Return the children's environment: private domain, discovery on this host only.

    Fast DDS gets config/fastdds.xml (fast repair of lost samples, see the file) unless the
    user names a profile file of their own.
    """
    env = dict(os.environ)
    # The bring-up process holds the claimed id until it exits, after its children.
    env['ROS_DOMAIN_ID'] = str(domain_id if domain_id is not None else claim_domain_id())
    env.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    env.setdefault('RMW_IMPLEMENTATION', 'rmw_fastrtps_cpp')
    env.setdefault('FASTRTPS_DEFAULT_PROFILES_FILE', str(
        Path(get_package_share_directory('sat_world_sim')) / 'config' / 'fastdds.xml'))
    env['PYTHONUNBUFFERED'] = '1'
    return env


def build_children(args, agent_ids, scenario_seed: int) -> List[Child]:
    """Return the processes of one run (module docstring)."""
    params = ['--params-file', str(Path(args.params).resolve())]
    ids = '[' + ','.join(str(i) for i in agent_ids) + ']'
    run_dir = ['-p', f'run_dir:={Path(args.run_dir).resolve()}', '-p', f'agent_ids:={ids}']
    observers = [Child('metrics', [executable('sat_world_sim', 'metrics'), '--ros-args',
                                   *params, *run_dir], observer=True)]
    if not args.no_record:
        observers.append(Child('recorder', [executable('sat_world_sim', 'recorder'),
                                            '--ros-args', *run_dir], observer=True))
    if not args.no_view:
        observers.append(Child('logger', [executable('sat_world_sim', 'logger'), '--ros-args',
                                          *params, *run_dir, '-p', f'sink:={args.view}'],
                               observer=True))
    world = [executable('sat_world_sim', 'world_sim'), '--ros-args', *params,
             '-p', f'scenario:={Path(args.scenario).resolve()}', '-p', f'clock:={args.clock}',
             '-p', f'period:={args.period}', '-p', f'agent_timeout:={args.agent_timeout}',
             '-p', f'observers:={len(observers)}', '-p', f'radio.loss:={args.radio_loss}',
             '-p', f'radio.delay_steps:={args.radio_delay}']
    if args.seed is not None:
        world += ['-p', f'seed:={args.seed}']
    if args.steps is not None:
        world += ['-p', f'steps:={args.steps}']
    children = [Child('world_sim', world), *observers]
    # Agents draw from the run's seed, as in the in-process swarm (inprocess_swarm.py).
    seed = ['-p', f'seed:={args.seed if args.seed is not None else scenario_seed}']
    if args.composed:
        children.append(Child('agents', [executable('sat_agent', 'agents_composed'), '--ids',
                                         *map(str, agent_ids), '--ros-args', *params, *seed],
                              respawn=args.respawn))
    else:
        for i in agent_ids:
            children.append(Child(f'agent_{i}', [
                executable('sat_agent', 'agent'), '--ros-args', '-r', f'__ns:=/agent_{i}',
                *params, '-p', f'agent_id:={i}', *seed], respawn=args.respawn))
    return children


def supervise(children: List[Child], env: dict, timeout: float, log_dir: Path,
              echo: bool) -> int:
    """Run until every observer exited (or a failure/timeout); return the exit code."""
    by_name = {c.name: c for c in children}
    observers = [c for c in children if c.observer]
    deadline = time.monotonic() + timeout
    while True:
        codes = [c.poll() for c in observers]
        if all(code is not None for code in codes):
            failed = [c.name for c, code in zip(observers, codes) if code != 0]
            if failed:
                print(f'[swarm] {failed} failed', file=sys.stderr)
            return 1 if failed else 0
        world_code = by_name['world_sim'].poll()
        if world_code not in (None, 0):
            print(f'[swarm] world_sim failed with exit code {world_code}', file=sys.stderr)
            return 1
        for child in children:
            code = child.poll()
            if code is None or not child.respawn:
                continue
            if child.respawns < MAX_RESPAWNS:
                child.respawns += 1
                print(f'[swarm] {child.name} exited ({code}): respawn {child.respawns}',
                      file=sys.stderr)
                child.start(env, log_dir, echo)
        if time.monotonic() > deadline:
            print(f'[swarm] timeout after {timeout} s', file=sys.stderr)
            return 1
        time.sleep(0.1)


def parse_args(argv):
    parser = argparse.ArgumentParser(prog='swarm', description=__doc__.split('\n')[0])
    parser.add_argument('--scenario', required=True, help='scenario YAML (config/scenarios)')
    parser.add_argument('--params', required=True, help='ROS 2 parameter file (config/paper.yaml)')
    parser.add_argument('--run-dir', required=True, help='directory the run is written to')
    parser.add_argument('--clock', choices=('lock_step', 'real_time'), default='lock_step')
    parser.add_argument('--period', type=float, default=1.0, help='real-time step period (s)')
    parser.add_argument('--agent-timeout', type=float, default=5.0,
                        help='seconds before a silent agent is marked inactive (lock-step)')
    parser.add_argument('--seed', type=int, default=None, help="override the scenario's seed")
    parser.add_argument('--steps', type=int, default=None, help="override the scenario's steps")
    parser.add_argument('--radio-loss', type=float, default=0.0, help='packet loss in [0, 1)')
    parser.add_argument('--radio-delay', type=int, default=0, help='radio latency in steps')
    parser.add_argument('--composed', action='store_true',
                        help='all agents in one process (one executor)')
    parser.add_argument('--respawn', action='store_true', help='restart crashed agents')
    parser.add_argument('--no-record', action='store_true', help='do not record a bag')
    parser.add_argument('--view', choices=('file', 'viewer', 'web'), default='file',
                        help='Rerun sink: run.rrd only, a native viewer, or the web viewer '
                             'on 127.0.0.1 (run.rrd is written in every case)')
    parser.add_argument('--no-view', action='store_true', help='no Rerun logger')
    parser.add_argument('--domain-id', type=int, default=None,
                        help='ROS_DOMAIN_ID (default: one no other run on this machine holds, '
                             'from 1..89; sat_world_sim/domain_ids.py)')
    parser.add_argument('--timeout', type=float, default=900.0, help='give up after (s)')
    parser.add_argument('--quiet', action='store_true',
                        help="only write the processes' output to <run-dir>/logs/, not stderr")
    return parser.parse_args(argv)


def main(argv=None) -> int:
    args = parse_args(sys.argv[1:] if argv is None else argv)
    try:
        params = load_params_file(args.params)
        scenario = load_scenario(args.scenario, params.area.width, params.area.height)
        children = build_children(args, scenario.agent_ids, scenario.seed)
        env = ros_env(args.domain_id)
    except (ParameterError, ScenarioError, OSError, NoFreeDomain) as error:
        print(f'swarm: {error}', file=sys.stderr)
        return 2
    print(f"[swarm] ROS_DOMAIN_ID={env['ROS_DOMAIN_ID']}: {len(scenario.agent_ids)} agents, "
          f'{args.clock}, run dir {args.run_dir}', file=sys.stderr)
    log_dir = Path(args.run_dir) / 'logs'
    log_dir.mkdir(parents=True, exist_ok=True)
    code = 1
    try:
        for child in children:
            child.start(env, log_dir, not args.quiet)
        code = supervise(children, env, args.timeout, log_dir, not args.quiet)
    except KeyboardInterrupt:
        print('[swarm] interrupted: stopping every process', file=sys.stderr)
        code = 130
    finally:
        # Agents first (they stop stepping), then the world and the metrics.
        for child in reversed(children):
            child.stop()
        for child in children:
            for pump in child.pumps:
                pump.join(timeout=1.0)
    if code == 0 and not (Path(args.run_dir) / 'metrics.json').is_file():
        print('[swarm] metrics.json was not written', file=sys.stderr)
        code = 1
    print(Path(args.run_dir))
    return code


if __name__ == '__main__':
    sys.exit(main())
