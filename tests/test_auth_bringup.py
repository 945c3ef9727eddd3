"""The bring-up's key handling, and the paper run with authentication on and off (issue 17)."""

import json
import os
from pathlib import Path
import re
import shutil
import stat
import subprocess
import sys
import time

import pytest
from ros_harness import executable, REPO, ros_node, run_swarm, spin_until, started
from test_launch_parity import LAUNCH_FILE, load_module

from sat_agent.message_auth import create_key_file
from sat_agent.ros.msg_conversions import message_class
from sat_world_sim import bringup
from sat_world_sim.topics import graph_topics

PAPER = REPO / 'config' / 'scenarios' / 'paper.yaml'


def options(*argv):
    return bringup.absolute(bringup.parse_args(['--run-dir', '/tmp/unused-run', *argv]))


def test_a_run_key_is_made_in_a_private_directory_outside_the_run_and_passed_as_a_path():
    opts = options()
    bringup.check_auth(opts)
    key_dir = bringup.run_key(opts)
    try:
        assert stat.S_IMODE(key_dir.stat().st_mode) == 0o700
        assert stat.S_IMODE(Path(opts.key_file).stat().st_mode) == 0o600
        assert Path(opts.key_file).parent == key_dir
        assert not Path(opts.key_file).is_relative_to(opts.run_dir)
        processes = bringup.process_list(opts, [1, 2], 1)
        for process in processes:
            assert f'auth_key_file:={opts.key_file}' in process.ros_arguments, process.name
            # The key's path only: the key itself never appears on a command line.
            assert Path(opts.key_file).read_bytes().hex() not in ' '.join(process.command())
    finally:
        for path in (Path(opts.key_file), key_dir):
            path.unlink() if path.is_file() else path.rmdir()


def test_a_given_key_file_or_no_auth_makes_no_key():
    assert bringup.run_key(options('--no-auth')) is None
    given = options('--key-file', '/some/key')
    assert bringup.run_key(given) is None and given.key_file == '/some/key'
    assert not any('auth_key_file' in ' '.join(p.ros_arguments)
                   for p in bringup.process_list(options('--no-auth'), [1], 1))


@pytest.fixture
def key_file(tmp_path) -> str:
    return str(create_key_file(tmp_path / 'swarm.key'))


def run_ids(processes) -> set:
    """Return the auth_run_id arguments of the processes."""
    return {arg for p in processes for arg in p.ros_arguments if arg.startswith('auth_run_id:=')}


def checked(*argv):
    """Return the options of argv after check_auth (a signed run's id given)."""
    opts = options(*argv)
    bringup.check_auth(opts)
    return opts


def test_every_signed_run_gets_a_new_id_and_every_process_the_same(key_file):
    first, second = checked('--key-file', key_file), checked('--key-file', key_file)
    for opts in (first, second):
        assert re.fullmatch('[0-9a-f]{32}', opts.run_id)
        # Quoted: YAML would read an id such as 42 or yes as a number or a bool.
        assert run_ids(bringup.process_list(opts, [1, 2], 1)) == {
            f"auth_run_id:='{opts.run_id}'"}
    assert first.run_id != second.run_id
    chosen = checked('--key-file', key_file, '--run-id', '42')
    assert run_ids(bringup.process_list(chosen, [1, 2], 1)) == {"auth_run_id:='42'"}
    # The bring-up's own key gets one too (check_auth runs before run_key); no key, none.
    own = checked()
    key_dir = bringup.run_key(own)
    try:
        assert run_ids(bringup.process_list(own, [1], 1)) == {f"auth_run_id:='{own.run_id}'"}
    finally:
        shutil.rmtree(key_dir)
    off = checked('--no-auth')
    assert off.run_id is None and not run_ids(bringup.process_list(off, [1], 1))
    # A key file without an id (check_auth skipped) is a programming error, not id-less signing.
    with pytest.raises(ValueError, match='no run id'):
        bringup.process_list(options('--key-file', key_file), [1], 1)


def test_the_launch_gives_a_run_with_a_key_file_an_id_as_the_bring_up_does(key_file):
    launch = load_module(LAUNCH_FILE, 'swarm_launch')
    values = {'run_dir': 'runs/x', 'key_file': key_file}
    ids = [run_ids(launch.processes(values)[0]) for _ in range(2)]
    assert all(len(each) == 1 for each in ids) and ids[0] != ids[1]
    processes, _ = launch.processes({**values, 'run_id': 'mission-7'})
    same = bringup.parse_args(['--run-dir', 'runs/x', '--key-file', key_file,
                               '--run-id', 'mission-7'])
    bringup.check_auth(same)
    assert processes == bringup.load_run(same)
    # As the bring-up, the launch refuses a key with no_auth (it signed with the bare key).
    with pytest.raises(bringup.KeyFileError, match='choose one'):
        launch.processes({**values, 'no_auth': 'true'})
    with pytest.raises(bringup.RunIdError, match='allowed'):
        launch.processes({**values, 'run_id': '...'})


@pytest.mark.parametrize('argv, problem', [
    (('--no-auth', '--run-id', 'm1'), 'choose one'),
    (('--run-id', 'a b'), 'allowed: 1 to 64'), (('--run-id', 'x:=y'), 'allowed: 1 to 64'),
    (("--run-id='q'",), 'allowed: 1 to 64'), (('--run-id=-abc',), 'allowed: 1 to 64'),
    (('--run-id', '...'), 'allowed: 1 to 64'), (('--run-id', 'r' * 65), 'allowed: 1 to 64')])
def test_a_bad_run_id_is_refused_naming_it(argv, problem):
    with pytest.raises(bringup.RunIdError, match=problem):
        checked(*argv)


def test_a_bad_run_id_stops_the_bring_up_before_anything_starts(tmp_path):
    run_dir = tmp_path / 'run'
    result = subprocess.run(
        [sys.executable, executable('sat_world_sim', 'swarm'), '--scenario', str(PAPER),
         '--run-dir', str(run_dir), '--run-id', 'two words'],
        capture_output=True, text=True, timeout=60)
    assert result.returncode == 2
    assert result.stderr.strip() == ("swarm: --run-id 'two words': allowed: 1 to 64 of the "
                                     "characters A-Z a-z 0-9 . _ -, not starting with '.' or "
                                     "'-'"), result.stderr
    assert not run_dir.exists()


@pytest.mark.ros
@pytest.mark.timeout(300)
def test_the_paper_run_gives_the_same_metrics_with_authentication_on_and_off(tmp_path):
    texts, outputs = {}, {}
    key = str(create_key_file(tmp_path / 'swarm.key'))
    # With a key file of yours every process must get the run's one id, or nothing verifies.
    # Run id 42: a node that read it as YAML would take a number and exit.
    for name, flags in (('on', ()), ('off', ('--no-auth',)),
                        ('own_key', ('--key-file', key, '--run-id', '42'))):
        code, metrics, outputs[name] = run_swarm(tmp_path / name, PAPER, '--steps', '40',
                                                 '--no-view', '--no-record', *flags)
        assert code == 0, outputs[name][-3000:]
        assert metrics['dropped'] == {}
        texts[name] = (tmp_path / name / 'metrics.json').read_text()
        log = (tmp_path / name / 'logs' / 'agent_1.log').read_text()
        assert ('authentication is OFF' in log) == (name == 'off')
    assert 'authentication is OFF' in outputs['off']   # the bring-up's own warning
    assert re.search(r', run id [0-9a-f]{32}\n', outputs['on'])
    assert ', run id 42\n' in outputs['own_key']
    assert ', run id' not in outputs['off']
    assert texts['on'] == texts['off'] == texts['own_key']
    # The run's key directory is gone; nothing of it is left in the run directory.
    assert not list((tmp_path / 'on').rglob('*.key'))


def test_a_childs_log_shows_each_line_while_the_child_runs(tmp_path):
    """Logs are line-buffered: runs/<name>/logs/ is readable during the run, not at its end."""
    class Talker:
        name = 'talker'

        def command(self):
            # Prints a line, then keeps running until stopped.
            return [sys.executable, '-c', 'import time; print("first line"); time.sleep(60)']

    child = bringup.Child(Talker())
    child.start(dict(os.environ, PYTHONUNBUFFERED='1'), tmp_path, echo=False)
    log = tmp_path / 'talker.log'
    try:
        deadline = time.monotonic() + 30
        while 'first line' not in log.read_text() and time.monotonic() < deadline:
            # Wait on the pump thread (it writes the log), not on a clock.
            child.pumps[0].join(timeout=0.05)
        assert 'first line' in log.read_text()
        assert child.poll() is None
    finally:
        child.stop()


# What a recording holds that the next run's nodes verify: the world's and one agent's topics.
SIGNED_TOPICS = ('/world/step', '/world/truth', '/world/radio', '/agent_1/measurements',
                 '/agent_1/cmd', '/agent_1/status', '/agent_1/radio/in/mode',
                 '/agent_2/radio/out/estimate')
TYPES = {topic.name: topic.msgtype for topic in graph_topics([1, 2])}


def without_drops(run_dir: Path) -> dict:
    metrics = json.loads((run_dir / 'metrics.json').read_text())
    return {key: value for key, value in metrics.items() if key != 'dropped'}


@pytest.mark.ros
@pytest.mark.timeout(600)
def test_a_recording_of_one_run_replayed_into_the_next_under_the_same_key_is_refused(tmp_path):
    # One key file for both runs, as on drones that keep theirs. Until the run id, the second
    # run's fresh replay counters took the first run's messages that came before the genuine
    # ones on their topic: its agents took run A's last /world/step and exited at once.
    key = str(create_key_file(tmp_path / 'swarm.key'))
    run = ('--steps', '30', '--no-view', '--key-file', key)
    code, _, output = run_swarm(tmp_path / 'a', PAPER, *run, '--run-id', 'mission-a')
    assert code == 0, output[-3000:]
    replay = [executable('sat_world_sim', 'replay'), str(tmp_path / 'a' / 'bag'), '--loop',
              '--rate', '5', '--match-timeout', '300', '--topics', *SIGNED_TOPICS]
    heard = []
    with ros_node('replay_listener') as node, \
            started(replay, tmp_path / 'replay.log') as replayer:
        # The replay publishes once every topic has a reader: this node's, until run B's come.
        for topic in SIGNED_TOPICS:
            node.create_subscription(message_class(TYPES[topic]), topic,
                                     lambda data, topic=topic: heard.append(topic), 10,
                                     raw=True)
        spin_until(node, lambda: set(heard) == set(SIGNED_TOPICS), 120,
                   'the replay of run A on every topic', [replayer])
        code, metrics, output = run_swarm(tmp_path / 'b', PAPER, *run, '--no-record',
                                          '--run-id', 'mission-b')
        replaying = replayer.poll() is None
    assert code == 0, output[-3000:]
    assert replaying, (tmp_path / 'replay.log').read_text()[-2000:]
    # The replayed messages (the only ones of another key) reached the metrics node, which
    # refused each for its signature, and the run is the unattacked one.
    assert set(metrics['dropped']) == {'bad_signature'} and metrics['dropped']['bad_signature']
    assert without_drops(tmp_path / 'b') == without_drops(tmp_path / 'a')
