"""The bring-up's key handling, and the paper run with authentication on and off (issue 17)."""

import os
from pathlib import Path
import re
import shutil
import stat
import subprocess
import sys
import time

import pytest
from ros_harness import executable, REPO, run_swarm
from test_launch_parity import LAUNCH_FILE, load_module

from sat_agent.message_auth import create_key_file
from sat_world_sim import bringup

PAPER = REPO / 'config' / 'scenarios' / 'paper.yaml'


def options(*argv):
    return bringup.absolute(bringup.parse_args(['--run-dir', '/tmp/unused-run', *argv]))


def test_a_run_key_is_made_in_a_private_directory_outside_the_run_and_passed_as_a_path():
    opts = options()
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


@pytest.mark.parametrize('content, mode, problem', [
    (None, None, 'cannot open it'), (b'short', 0o600, '5 bytes'),
    (os.urandom(32), 0o644, 'chmod 600')])
def test_a_bad_key_file_stops_the_bring_up_before_anything_starts(
        tmp_path, content, mode, problem):
    key = tmp_path / 'swarm.key'
    if content is not None:
        key.write_bytes(content)
        key.chmod(mode)
    run_dir = tmp_path / 'run'
    result = subprocess.run(
        [sys.executable, executable('sat_world_sim', 'swarm'), '--scenario', str(PAPER),
         '--run-dir', str(run_dir), '--key-file', str(key)],
        capture_output=True, text=True, timeout=60)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and str(key) in lines[0] and problem in lines[0], result.stderr
    assert not run_dir.exists()


def test_no_auth_and_a_key_file_together_are_refused(tmp_path):
    with pytest.raises(bringup.KeyFileError, match='choose one'):
        bringup.check_auth(options('--no-auth', '--key-file', str(tmp_path / 'k')))


def run_ids(opts) -> set:
    """Return the auth_run_id values the processes of opts get."""
    return {arg.split(':=', 1)[1] for p in bringup.process_list(opts, [1, 2], 1)
            for arg in p.ros_arguments if arg.startswith('auth_run_id:=')}


def test_every_signed_run_gets_a_new_id_and_every_process_the_same():
    first, second = options('--key-file', '/some/key'), options('--key-file', '/some/key')
    for opts in (first, second):
        bringup.run_identity(opts)
        assert len(run_ids(opts)) == 1 and re.fullmatch('[0-9a-f]{32}', opts.run_id)
        assert all('auth_run_id:=' in ' '.join(p.ros_arguments)
                   for p in bringup.process_list(opts, [1, 2], 1))
    assert first.run_id != second.run_id
    chosen = options('--key-file', '/some/key', '--run-id', 'mission-7')
    bringup.run_identity(chosen)
    assert run_ids(chosen) == {'mission-7'}
    # The bring-up's own key gets one too (run_identity runs before run_key); no key, none.
    own = options()
    bringup.run_identity(own)
    key_dir = bringup.run_key(own)
    try:
        assert run_ids(own) == {own.run_id}
    finally:
        shutil.rmtree(key_dir)
    off = options('--no-auth')
    bringup.run_identity(off)
    assert off.run_id is None and not run_ids(off)


def test_the_launch_gives_a_run_with_a_key_file_an_id_as_the_bring_up_does():
    launch = load_module(LAUNCH_FILE, 'swarm_launch')
    values = {'run_dir': 'runs/x', 'key_file': '/some/key'}
    ids = [{arg for p in launch.processes(values)[0] for arg in p.ros_arguments
            if arg.startswith('auth_run_id:=')} for _ in range(2)]
    assert all(len(each) == 1 for each in ids) and ids[0] != ids[1]
    processes, _ = launch.processes({**values, 'run_id': 'mission-7'})
    chosen = options('--run-dir', 'runs/x', '--key-file', '/some/key', '--run-id', 'mission-7')
    assert processes == bringup.load_run(bringup.parse_args(
        ['--run-dir', 'runs/x', '--key-file', '/some/key', '--run-id', 'mission-7']))
    assert run_ids(chosen) == {'mission-7'}


@pytest.mark.parametrize('argv, problem', [
    (('--no-auth', '--run-id', 'm1'), 'choose one'),
    (('--run-id', 'a b'), 'allowed: 1 to 64'), (('--run-id', 'x:=y'), 'allowed: 1 to 64'),
    (('--run-id', 'r' * 65), 'allowed: 1 to 64')])
def test_a_bad_run_id_is_refused_naming_it(argv, problem):
    with pytest.raises(bringup.RunIdError, match=problem):
        bringup.run_identity(options(*argv))


def test_a_bad_run_id_stops_the_bring_up_before_anything_starts(tmp_path):
    run_dir = tmp_path / 'run'
    result = subprocess.run(
        [sys.executable, executable('sat_world_sim', 'swarm'), '--scenario', str(PAPER),
         '--run-dir', str(run_dir), '--run-id', 'two words'],
        capture_output=True, text=True, timeout=60)
    assert result.returncode == 2
    assert result.stderr.strip() == ("swarm: --run-id 'two words': allowed: 1 to 64 of the "
                                     'characters A-Z a-z 0-9 . _ -'), result.stderr
    assert not run_dir.exists()


@pytest.mark.ros
@pytest.mark.timeout(300)
def test_the_paper_run_gives_the_same_metrics_with_authentication_on_and_off(tmp_path):
    texts, outputs = {}, {}
    key = str(create_key_file(tmp_path / 'swarm.key'))
    # With a key file of yours every process must get the run's one id, or nothing verifies.
    for name, flags in (('on', ()), ('off', ('--no-auth',)), ('own_key', ('--key-file', key))):
        code, metrics, outputs[name] = run_swarm(tmp_path / name, PAPER, '--steps', '40',
                                                 '--no-view', '--no-record', *flags)
        assert code == 0, outputs[name][-3000:]
        assert metrics['dropped'] == {}
        texts[name] = (tmp_path / name / 'metrics.json').read_text()
        log = (tmp_path / name / 'logs' / 'agent_1.log').read_text()
        assert ('authentication is OFF' in log) == (name == 'off')
    assert 'authentication is OFF' in outputs['off']   # the bring-up's own warning
    for name in ('on', 'own_key'):
        assert re.search(r', run id [0-9a-f]{32}\n', outputs[name])
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
