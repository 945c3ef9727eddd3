"""Bring up a whole swarm as separate OS processes and wait for the run to finish.

Starts, each as its own process running the installed executable (as ``ros2 run`` would):
``world_sim`` (truth, sensors, radio), ``metrics`` (metrics.json and plots), ``recorder`` (every
topic into ``<run-dir>/bag``, unless ``--no-record``), ``logger`` (Rerun: ``<run-dir>/run.rrd``,
and a live viewer with ``--view viewer|web``; none with ``--view none`` or ``--no-view``) and one
``agent`` per scenario agent (or all agents in one ``agents_composed`` process with
``--composed``). Every process gets the same parameter file, ``use_sim_time`` (world_sim's
``/clock``), the run's seed, the Fast DDS profile (``--fastdds-profile``), a private
ROS_DOMAIN_ID (unless one is given) and localhost-only discovery; their output goes to
``<run-dir>/logs/<name>.log`` and (unless ``--quiet``) to stderr with a ``[name]`` prefix.

One source of truth for what a run is: ``process_list`` turns the options into the processes
(package, executable, arguments), and both this bring-up and the launch file
(``launch/swarm.launch.py``, whose launch arguments are these options) start exactly those;
``--print-ros2-run`` prints them as ``ros2 run`` lines.

Authentication (sat_agent.message_auth): every run gets a fresh swarm key, written (mode 0600)
into a private temporary directory (mode 0700, outside the run directory, so neither the
recorded run nor a copy of it carries the key) and deleted when the run ends; every process
gets its path as the parameter ``auth_key_file``. ``--key-file`` uses a key file of your own
instead (to run agents on several machines, each with a copy of it); it is checked before
anything starts. Every signed run gets a new id (``--run-id`` to choose it), passed to every
process as ``auth_run_id``, that makes its signatures its own: a recording of another run under
the same key is refused (sat_agent.message_auth.run_key). ``--no-auth`` runs without
authentication, with a loud warning in every process.

``--netns`` (root only) places world_sim and the observers on one host and each agent process
on its own: Linux network namespaces on a private bridge (sat_world_sim.netns), DDS over UDP
only, discovery through static peers (sat_world_sim.dds_udp; the profile is written to
``<run-dir>/dds/udp.xml``). The run is the same run as on one host; only the transport differs.

The run ends when the observers (metrics, recorder, logger) have exited, after the world's last
step; then every process still running is stopped (SIGINT, then SIGKILL after a grace period).
The agents exit by themselves when the world says the run is finished. Ctrl-C stops everything
the same way. The exit code is 0 only if the world and the observers finished cleanly; with
``--respawn`` an agent that fails (non-zero exit, a signal) is restarted and rejoins. The run
directory is printed as the last line on stdout.

    swarm --scenario config/scenarios/paper.yaml --params config/paper.yaml --run-dir runs/x
"""

import argparse
from dataclasses import dataclass, field
import os
from pathlib import Path
import re
import secrets
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from typing import Callable, Dict, List, Mapping, Optional, Sequence, Tuple

from ament_index_python.packages import get_package_prefix, get_package_share_directory

from sat_agent.config import load_params_file, ParameterError
from sat_agent.message_auth import AUTH_OFF_WARNING, create_key_file, KeyFileError, load_key
from sat_agent.node_params import LIVE_SWITCH

from sat_world_sim import dds_udp, netns
from sat_world_sim.domain_ids import claim_domain_id, NoFreeDomain
from sat_world_sim.scenario import load_scenario, ScenarioError

STOP_GRACE_S = 5.0
MAX_RESPAWNS = 5
# Options of the supervision only (not of the run): the launch file has no use for them.
# (--netns places the processes itself; a launch file would use launch_ros's prefix.)
SUPERVISION_OPTIONS = ('timeout', 'quiet', 'print_ros2_run', 'netns')
# A run id goes on command lines (-p auth_run_id:='...', quoted so that YAML reads 42 or yes as
# a string): no spaces, quotes or ':=', and no leading '-' (an option to argparse and rcl).
RUN_ID = re.compile(r'[A-Za-z0-9_][A-Za-z0-9._-]{0,63}')


def executable(package: str, name: str) -> str:
    """Path of an installed executable, found as `ros2 run` finds it (lib/<package>/<name>)."""
    path = Path(get_package_prefix(package)) / 'lib' / package / name
    if not path.is_file():
        raise FileNotFoundError(f'{path} not found: build the workspace first (make test)')
    return str(path)


@dataclass(frozen=True)
class Process:
    """One process of a run: what `ros2 run` and a launch file's Node start.

    The command is ``<package's executable> *arguments --ros-args *ros_arguments``.
    """

    name: str
    package: str
    executable: str
    arguments: Tuple[str, ...] = ()
    ros_arguments: Tuple[str, ...] = ()
    respawn: bool = False
    # Observers (metrics, recorder, logger) end the run: it is over when they all exited.
    observer: bool = False

    def command(self) -> List[str]:
        """Return the command line with the installed executable's path."""
        return [executable(self.package, self.executable), *self.arguments, '--ros-args',
                *self.ros_arguments]

    def ros2_run(self) -> str:
        """Return the same process as a shell-quoted ``ros2 run`` line."""
        return shlex.join(['ros2', 'run', self.package, self.executable, *self.arguments,
                           '--ros-args', *self.ros_arguments])


def _same_host(argv: List[str]) -> List[str]:
    return argv


@dataclass
class Child:
    """One managed process; place wraps its command to run on its host (--netns)."""

    spec: Process
    process: Optional[subprocess.Popen] = None
    respawns: int = 0
    pumps: List[threading.Thread] = field(default_factory=list)
    place: Callable[[List[str]], List[str]] = _same_host
    env: Optional[dict] = None   # this child's environment, if not the run's

    @property
    def name(self) -> str:
        return self.spec.name

    def start(self, env: dict, log_dir: Path, echo: bool):
        self.process = subprocess.Popen(self.place(self.spec.command()),
                                        env=self.env or env, stdout=subprocess.PIPE,
                                        stderr=subprocess.STDOUT, text=True, bufsize=1,
                                        start_new_session=True)
        # Line-buffered: the log shows each line as it comes, not at the end of the run.
        log = open(log_dir / f'{self.name}.log', 'a', encoding='utf-8', buffering=1)
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


def default_fastdds_profile() -> str:
    """Return the user's FASTRTPS_DEFAULT_PROFILES_FILE, else the installed config/fastdds.xml.

    config/fastdds.xml makes reliable writers repair a lost sample within 100 ms (see the file).
    """
    return os.environ.get('FASTRTPS_DEFAULT_PROFILES_FILE') or str(
        Path(get_package_share_directory('sat_world_sim')) / 'config' / 'fastdds.xml')


def run_env(fastdds_profile: str, domain_id: Optional[int]) -> Dict[str, str]:
    """Return what a run adds to its processes' environment, in the bring-up and the launch.

    The Fast DDS profile, and the ROS_DOMAIN_ID when one is given.
    """
    env = {'FASTRTPS_DEFAULT_PROFILES_FILE': str(fastdds_profile)}
    if domain_id is not None:
        env['ROS_DOMAIN_ID'] = str(domain_id)
    return env


def ros_env(domain_id: Optional[int], fastdds_profile: Optional[str] = None) -> dict:
    """Return the bring-up children's environment: the user's, with run_env's additions.

    The domain is private to the run unless one is given, discovery stays on this host unless
    the user says otherwise, and Fast DDS gets fastdds_profile (default_fastdds_profile()).
    """
    env = dict(os.environ)
    # The bring-up process holds a claimed id (domain_ids) until it exits, after its children.
    env.update(run_env(fastdds_profile or default_fastdds_profile(),
                       domain_id if domain_id is not None else claim_domain_id()))
    env.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    env.setdefault('RMW_IMPLEMENTATION', 'rmw_fastrtps_cpp')
    env['PYTHONUNBUFFERED'] = '1'
    return env


def process_list(options, agent_ids: Sequence[int], scenario_seed: int) -> List[Process]:
    """Return the processes of one run (module docstring); paths are passed as given.

    Every node runs on world_sim's sim time and gets the run's seed explicitly, so a
    ``ros2 run`` of these lines is the same run as the bring-up's.
    """
    key = ('-p', f'auth_key_file:={options.key_file}') if options.key_file else ()
    if key and not options.run_id:
        raise ValueError('process_list: a key file and no run id (check_auth gives one)')
    key += ('-p', f"auth_run_id:='{options.run_id}'") if key else ()
    params = ('--params-file', str(options.params), '-p', 'use_sim_time:=true', *key)
    # What world_sim and the agents share (node_params.SteppingParams).
    stepping = ('-p', f'view_rate:={options.view_rate}') if options.view_rate is not None else ()
    stepping += ('-p', f'{LIVE_SWITCH}:=true') if options.live_params else ()
    roster = ('-p', 'agent_ids:=[' + ','.join(str(i) for i in agent_ids) + ']')
    run_dir = ('-p', f'run_dir:={options.run_dir}', *roster)
    observers = [Process('metrics', 'sat_world_sim', 'metrics', ros_arguments=(
        *params, *run_dir), observer=True)]
    if options.record:
        observers.append(Process('recorder', 'sat_world_sim', 'recorder', ros_arguments=(
            *params, *run_dir), observer=True))
    if options.view != 'none':
        observers.append(Process('logger', 'sat_world_sim', 'logger', ros_arguments=(
            *params, *run_dir, '-p', f'sink:={options.view}'), observer=True))
    # world_sim and the agents draw from the run's seed, as in the in-process swarm.
    seed = ('-p', f'seed:={options.seed if options.seed is not None else scenario_seed}')
    world = (*params, '-p', f'scenario:={options.scenario}', '-p', f'clock:={options.clock}',
             '-p', f'period:={options.period}', '-p', f'agent_timeout:={options.agent_timeout}',
             '-p', f'observers:={len(observers)}', '-p', f'radio.loss:={options.radio_loss}',
             '-p', f'radio.delay_steps:={options.radio_delay}', *seed, *stepping)
    if options.steps is not None:
        world += ('-p', f'steps:={options.steps}')
    processes = [Process('world_sim', 'sat_world_sim', 'world_sim', ros_arguments=world),
                 *observers]
    if options.composed:
        processes.append(Process('agents', 'sat_agent', 'agents_composed',
                                 arguments=('--ids', *map(str, agent_ids)),
                                 ros_arguments=(*params, *roster, *seed, *stepping),
                                 respawn=options.respawn))
    else:
        processes += [Process(f'agent_{i}', 'sat_agent', 'agent', ros_arguments=(
            '-r', f'__ns:=/agent_{i}', *params, '-p', f'agent_id:={i}', *roster, *seed,
            *stepping), respawn=options.respawn) for i in agent_ids]
    return processes


def ros2_run_lines(processes: Sequence[Process], env: Mapping[str, str]) -> List[str]:
    """Return a shell script's lines that start the processes as the bring-up does."""
    lines = [shlex.join(['export', *(f'{k}={v}' for k, v in sorted(env.items()))])]
    return lines + [f'{process.ros2_run()} &' for process in processes]


def supervise(children: List[Child], env: dict, timeout: float, log_dir: Path,
              echo: bool) -> int:
    """Run until every observer exited (or a failure/timeout); return the exit code."""
    by_name = {c.name: c for c in children}
    observers = [c for c in children if c.spec.observer]
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
            # A clean exit (an agent leaving a finished run) is not a crash.
            if code in (None, 0) or not child.spec.respawn:
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


def build_parser() -> argparse.ArgumentParser:
    """Return the bring-up's options; the launch file declares one launch argument per run option.

    Options left out (None) get the installed paper files and a time-stamped run directory.
    """
    parser = argparse.ArgumentParser(prog='swarm', description=__doc__.split('\n')[0])
    parser.add_argument('--scenario', help='scenario YAML (default: the paper scenario)')
    parser.add_argument('--params', help='ROS 2 parameter file (default: config/paper.yaml)')
    parser.add_argument('--run-dir', help='directory the run is written to '
                                          '(default: runs/swarm-<UTC time>)')
    parser.add_argument('--clock', choices=('lock_step', 'real_time'), default='lock_step',
                        help='lock_step (as fast as the agents answer) or real_time')
    parser.add_argument('--period', type=float, default=1.0, help='real-time step period (s)')
    parser.add_argument('--agent-timeout', type=float, default=5.0,
                        help='seconds before a silent agent is marked inactive (lock-step)')
    parser.add_argument('--seed', type=int, default=None, help="override the scenario's seed")
    parser.add_argument('--steps', type=int, default=None, help="override the scenario's steps")
    parser.add_argument('--radio-loss', type=float, default=0.0, help='packet loss in [0, 1)')
    parser.add_argument('--radio-delay', type=int, default=0, help='radio latency in steps')
    parser.add_argument('--composed', action='store_true',
                        help='all agents in one process (one executor)')
    parser.add_argument('--respawn', action='store_true', help='restart agents that fail')
    parser.add_argument('--record', action=argparse.BooleanOptionalAction, default=True,
                        help='record every topic into <run-dir>/bag (the recorder)')
    parser.add_argument('--view', choices=('file', 'viewer', 'web', 'none'), default='file',
                        help='Rerun logger: run.rrd only, also a native viewer, also the web '
                             'viewer on 127.0.0.1, or no logger')
    parser.add_argument('--no-view', dest='view', action='store_const', const='none',
                        help='no Rerun logger (--view none)')
    parser.add_argument('--view-rate', type=float, default=None,
                        help='standard views (RViz2/Foxglove) per second of sim time, 0 = none '
                             "(default: the nodes' view_rate)")
    parser.add_argument('--live-params', action='store_true',
                        help="let 'ros2 param set' change world_sim's and the agents' live "
                             'parameters while they run (default: read-only, since anyone on '
                             'the ROS domain can call parameter services)')
    parser.add_argument('--fastdds-profile', default=None,
                        help='Fast DDS XML profile (default: $FASTRTPS_DEFAULT_PROFILES_FILE, '
                             'else the installed config/fastdds.xml)')
    parser.add_argument('--domain-id', type=int, default=None,
                        help='ROS_DOMAIN_ID (default: one no other run on this machine holds, '
                             'from 1..89; sat_world_sim/domain_ids.py)')
    parser.add_argument('--key-file', default=None,
                        help="swarm key file (>= 32 random bytes, mode 0600, yours or root's) "
                             'to sign with, e.g. shared by the machines of one swarm (default: a '
                             'new key per run)')
    parser.add_argument('--run-id', default=None,
                        help="this run's id, bound into every signature so that a recording of "
                             'another run under the same key is refused; give every machine of '
                             'one run the same (1-64 of A-Z a-z 0-9 . _ -, not starting with . '
                             'or -; default: a new one per run)')
    parser.add_argument('--netns', action='store_true',
                        help='world_sim and the observers on one network namespace, each agent '
                             'process on its own, DDS over UDP between them (root only)')
    parser.add_argument('--no-auth', action='store_true',
                        help='no message authentication: any process on the ROS domain can '
                             'forge commands, scans and reports (default: on)')
    parser.add_argument('--timeout', type=float, default=900.0, help='give up after (s)')
    parser.add_argument('--quiet', action='store_true',
                        help="only write the processes' output to <run-dir>/logs/, not stderr")
    parser.add_argument('--print-ros2-run', action='store_true',
                        help='print the run as `ros2 run` lines (paths as given) and exit')
    return parser


def parse_args(argv) -> argparse.Namespace:
    """Parse the options and fill the defaults left open (build_parser)."""
    options = build_parser().parse_args(argv)
    share = Path(get_package_share_directory('sat_world_sim')) / 'config'
    options.scenario = options.scenario or str(share / 'scenarios' / 'paper.yaml')
    options.params = options.params or str(share / 'paper.yaml')
    options.run_dir = options.run_dir or time.strftime('runs/swarm-%Y%m%d-%H%M%S', time.gmtime())
    options.fastdds_profile = options.fastdds_profile or default_fastdds_profile()
    return options


def launch_arguments() -> List[Tuple[str, str, str]]:
    """Return (name, default, description) of each run option, as launch arguments.

    Names are the options' names with _ (seed, clock, run_dir, record, ...); an empty default
    is the option's own default.
    """
    arguments = []
    for action in build_parser()._actions:
        alias = isinstance(action, argparse._StoreConstAction) and action.const == 'none'
        if action.dest in SUPERVISION_OPTIONS or action.dest == 'help' or alias:
            continue
        default = action.default
        if default is None:
            text = ''
        else:
            text = str(default).lower() if isinstance(default, bool) else str(default)
        arguments.append((action.dest, text, action.help or ''))
    return arguments


def options_from_launch(values: Mapping[str, str]) -> argparse.Namespace:
    """Return the options a launch file's argument values stand for (launch_arguments)."""
    argv = []
    for action in build_parser()._actions:
        value = str(values.get(action.dest, '')).strip()
        if action.dest in SUPERVISION_OPTIONS or not value or not action.option_strings:
            continue
        flag = action.option_strings[0]
        if isinstance(action, argparse.BooleanOptionalAction):
            argv.append(flag if value.lower() == 'true' else action.option_strings[1])
        elif isinstance(action, argparse._StoreTrueAction):
            argv += [flag] if value.lower() == 'true' else []
        elif not isinstance(action, argparse._StoreConstAction):
            argv += [flag, value]
    return parse_args(argv)


def absolute(options) -> argparse.Namespace:
    """Return a copy of the options with absolute paths (a child's working directory may vary)."""
    names = ('scenario', 'params', 'run_dir', 'fastdds_profile') + \
        (('key_file',) if options.key_file else ())
    paths = {name: str(Path(getattr(options, name)).resolve()) for name in names}
    return argparse.Namespace(**{**vars(options), **paths})


def host_of(process: Process) -> str:
    """Return the --netns host of a process: 'world' for world_sim and observers, else its name."""
    return process.name if process.package == 'sat_agent' else 'world'


def place_on_hosts(children: Sequence[Child], net, env: dict, run_dir: Path):
    """Run each child on its host of net (a NetnsBridge), talking DDS over UDP (dds_udp)."""
    profile = Path(run_dir) / 'dds' / 'udp.xml'
    profile.parent.mkdir(parents=True, exist_ok=True)
    profile.write_text(dds_udp.udp_profile_xml(Path(env['FASTRTPS_DEFAULT_PROFILES_FILE'])),
                       encoding='utf-8')
    for child in children:
        host = host_of(child.spec)
        child.place = lambda argv, host=host: net.command(host, argv)
        child.env = dds_udp.udp_env(env, profile, peers=net.peers_of(host))


def run(processes: Sequence[Process], env: dict, run_dir: Path, timeout: float,
        echo: bool, net=None) -> int:
    """Start the processes, supervise them until the run is over, stop what is left.

    net: a NetnsBridge with a host per host_of (--netns), None for this host.
    Returns the exit code (supervise; 130 on Ctrl-C; 1 when no metrics.json was written).
    """
    log_dir = Path(run_dir) / 'logs'
    log_dir.mkdir(parents=True, exist_ok=True)
    children = [Child(process) for process in processes]
    if net is not None:
        place_on_hosts(children, net, env, run_dir)
    code = 1
    try:
        for child in children:
            child.start(env, log_dir, echo)
        code = supervise(children, env, timeout, log_dir, echo)
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
    if code == 0 and not (Path(run_dir) / 'metrics.json').is_file():
        print('[swarm] metrics.json was not written', file=sys.stderr)
        code = 1
    return code


def profile_argument(value: str) -> Path:
    """Return the path of a script's --params (soak, bench_swarm) once the profile loads.

    Checked before the script starts a swarm, whose nodes would refuse it only later.
    """
    path = Path(value).resolve()
    try:
        load_params_file(path)
    except (ParameterError, OSError) as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    return path


def load_run(options) -> List[Process]:
    """Check the parameter and scenario files and return the run's processes."""
    params = load_params_file(options.params)
    scenario = load_scenario(options.scenario, params.area.width, params.area.height)
    return process_list(options, scenario.agent_ids, scenario.seed)


def check_netns(options):
    """Check that --netns can make namespaces here (NetnsError says why not)."""
    reason = netns.unavailable() if options.netns else None
    if reason:
        raise netns.NetnsError(f'--netns: {reason}')


def run_on_hosts(processes: Sequence[Process], env: dict, options) -> int:
    """Run the processes on this host, or with --netns each on its host (host_of)."""
    args = (processes, env, Path(options.run_dir), options.timeout, not options.quiet)
    if not options.netns:
        return run(*args)
    hosts = sorted({host_of(p) for p in processes})
    with netns.NetnsBridge(hosts) as net:
        return run(*args, net=net)


class RunIdError(ValueError):
    """A --run-id that cannot be used; the message names it and what is allowed."""


def check_auth(options):
    """Check the authentication options before anything starts; give a signed run its id.

    Raises KeyFileError (naming the path) or RunIdError (module docstring).
    """
    if options.no_auth and options.key_file:
        raise KeyFileError(f'--no-auth and --key-file {options.key_file}: choose one')
    if options.key_file:
        load_key(options.key_file)
    if options.run_id is None:
        if not options.no_auth:
            options.run_id = secrets.token_hex(16)
        return
    if options.no_auth:
        raise RunIdError(f'--no-auth and --run-id {options.run_id}: a run id binds signatures; '
                         'choose one')
    if not RUN_ID.fullmatch(options.run_id):
        raise RunIdError(f'--run-id {options.run_id!r}: allowed: 1 to 64 of the characters '
                         "A-Z a-z 0-9 . _ -, not starting with '.' or '-'")


def run_key(options) -> Optional[Path]:
    """Create this run's key unless one was given or auth is off; return its private directory.

    mkdtemp makes the directory mode 0700 for this user only, outside the run directory (the
    recorded run must not carry the key); the caller removes it when the run ends.
    """
    if options.key_file or options.no_auth:
        return None
    directory = Path(tempfile.mkdtemp(prefix='sat-swarm-key-'))
    options.key_file = str(create_key_file(directory / 'swarm.key'))
    return directory


def main(argv=None) -> int:
    args = parse_args(sys.argv[1:] if argv is None else argv)
    options = args if args.print_ros2_run else absolute(args)
    try:
        check_auth(options)
        check_netns(options)
    except (KeyFileError, RunIdError, netns.NetnsError) as error:
        print(f'swarm: {error}', file=sys.stderr)
        return 2
    key_dir = None if args.print_ros2_run else run_key(options)
    try:
        try:
            processes = load_run(options)
            if args.print_ros2_run:
                env = run_env(options.fastdds_profile, options.domain_id)
                print('\n'.join(ros2_run_lines(processes, env)))
                return 0
            env = ros_env(options.domain_id, options.fastdds_profile)
        except (ParameterError, ScenarioError, OSError, NoFreeDomain) as error:
            print(f'swarm: {error}', file=sys.stderr)
            return 2
        if options.no_auth:
            print(f'[swarm] WARNING: {AUTH_OFF_WARNING}', file=sys.stderr)
        agents = sum(p.executable == 'agent' for p in processes) or 'composed'
        run_id = f', run id {options.run_id}' if options.run_id else ''
        print(f"[swarm] ROS_DOMAIN_ID={env['ROS_DOMAIN_ID']}: {agents} agents, "
              f'{options.clock}, run dir {args.run_dir}{run_id}', file=sys.stderr)
        code = run_on_hosts(processes, env, options)
    finally:
        if key_dir is not None:
            shutil.rmtree(key_dir, ignore_errors=True)
    print(Path(args.run_dir))
    return code


if __name__ == '__main__':
    sys.exit(main())
