#!/usr/bin/env python3
"""Regenerate docs/viewer.png: a run.rrd in Rerun's web viewer, shot by headless Chromium.

    scripts/with_env.sh python scripts/screenshot_viewer.py runs/<name>/run.rrd [--step 160]

Needs Debian's ``chromium`` (``apt-get update && apt-get install -y chromium``; pass
``--install-chromium`` to have this script run exactly that when it is missing). Steps:

1. ``rerun rrd optimize`` compacts the recording (a live logger writes many small chunks, which
   the web viewer ingests slowly) and the layout stored in it is replaced by today's
   rerun_view.default_blueprint, set to loop playback over ``--step`` (the web viewer ignores
   ``#when=`` on a recording URL), so the time cursor sits at that step.
2. ``rerun --serve-web --bind 127.0.0.1 <rrd> <rbl>`` serves both (gRPC) and the web viewer
   (HTTP) on free loopback ports, with Rerun's config in a private temporary directory where
   analytics are disabled (sat_world_sim.rerun_view.private_rerun_env).
3. Headless Chromium (temporary profile, software WebGL) opens the viewer. It is driven over the
   DevTools protocol through a pipe
   (``--remote-debugging-pipe``): no debugging port is opened, and every host name other than
   127.0.0.1 resolves to nothing (``--host-resolver-rules``), so the page reaches loopback only.
4. After ``--wait`` seconds (software WebGL needs tens of them) ``Page.captureScreenshot``
   writes the PNG. Every process started here is stopped by its pid.
"""

import argparse
import base64
import json
import os
from pathlib import Path
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.parse
import urllib.request

from rerun.blueprint.components import AbsoluteTimeRange
from rerun.chunk import RrdReader

from sat_world_sim.bringup import stop_group
from sat_world_sim.rerun_view import default_blueprint, private_rerun_env, rerun_command

ROOT = Path(__file__).resolve().parents[1]
CHROMIUM_NAMES = ('chromium', 'chromium-browser')
CHROMIUM_FLAGS = [
    '--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
    '--disable-background-networking', '--disable-component-update', '--disable-sync',
    '--disable-default-apps', '--disable-extensions', '--mute-audio', '--hide-scrollbars',
    '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--disable-breakpad',
    '--disable-crash-reporter',
    '--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1',
]


def recording_only(source: Path, target: Path) -> str:
    """Copy the first recording of source (not its layouts) to target; return its app id."""
    reader = RrdReader(source)
    entries = reader.recordings()
    if not entries:
        raise SystemExit(f'screenshot_viewer: {source} holds no recording')
    entry = entries[0]
    reader.store(store=entry).write_rrd(target, application_id=entry.application_id,
                                        recording_id=entry.recording_id)
    return entry.application_id


def free_port() -> int:
    """Return a TCP port on 127.0.0.1 that nothing listens on right now."""
    with socket.socket() as probe:
        probe.bind(('127.0.0.1', 0))
        return probe.getsockname()[1]


def find_chromium(install: bool) -> str:
    """Return the chromium executable; install Debian's package first if asked and missing."""
    for name in CHROMIUM_NAMES:
        path = shutil.which(name)
        if path:
            return path
    if install:
        subprocess.run(['apt-get', 'update'], check=True)
        subprocess.run(['apt-get', 'install', '-y', 'chromium'], check=True)
        path = shutil.which('chromium')
        if path:
            return path
    raise SystemExit('screenshot_viewer: chromium not found. Install it with '
                     '`apt-get update && apt-get install -y chromium` (Debian), or pass '
                     '--install-chromium.')


def wait_http(url: str, timeout: float, process: subprocess.Popen):
    """Wait until url answers (or raise when process dies or timeout passes)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if process.poll() is not None:
            raise SystemExit(f'screenshot_viewer: the rerun server exited ({process.returncode})')
        try:
            with urllib.request.urlopen(url, timeout=2):
                return
        except (urllib.error.URLError, ConnectionError, OSError):
            time.sleep(0.3)
    raise SystemExit(f'screenshot_viewer: {url} did not answer in {timeout:.0f} s')


class DevTools:
    """A minimal Chrome DevTools protocol client over --remote-debugging-pipe (fds 3 and 4)."""

    def __init__(self, to_browser: int, from_browser: int):
        self.to_browser, self.from_browser = to_browser, from_browser
        self.next_id = 0
        self.buffer = b''

    def call(self, method: str, params=None, session=None, timeout: float = 60.0) -> dict:
        """Send a command and return its result (events in between are dropped)."""
        self.next_id += 1
        message = {'id': self.next_id, 'method': method, 'params': params or {}}
        if session:
            message['sessionId'] = session
        os.write(self.to_browser, json.dumps(message).encode() + b'\0')
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            reply = self._read()
            if reply.get('id') == self.next_id:
                if 'error' in reply:
                    raise RuntimeError(f'{method}: {reply["error"]}')
                return reply.get('result', {})
        raise TimeoutError(method)

    def _read(self) -> dict:
        while b'\0' not in self.buffer:
            chunk = os.read(self.from_browser, 1 << 20)
            if not chunk:
                raise ConnectionError('chromium closed the DevTools pipe')
            self.buffer += chunk
        message, self.buffer = self.buffer.split(b'\0', 1)
        return json.loads(message)


def screenshot(chromium: str, url: str, out: Path, size, wait: float, profile: Path, env: dict):
    """Open url in headless chromium, wait, and write a PNG screenshot to out.

    env should point XDG_CONFIG_HOME / XDG_CACHE_HOME at a temporary directory: chromium keeps
    its crash-report database there even with --user-data-dir, not in the user's ~/.config.
    """
    # Chromium reads commands from its fd 3 and writes replies to its fd 4.
    to_read, to_write = os.pipe()        # we write commands -> chromium reads (fd 3)
    from_read, from_write = os.pipe()    # chromium writes replies (fd 4) -> we read

    def child_fds():
        # Through fresh copies, so neither end is overwritten when it already is fd 3 or 4.
        read_copy, write_copy = os.dup(to_read), os.dup(from_write)
        os.dup2(read_copy, 3)
        os.dup2(write_copy, 4)

    command = [chromium, *CHROMIUM_FLAGS, f'--user-data-dir={profile}',
               f'--window-size={size[0]},{size[1]}', '--remote-debugging-pipe', 'about:blank']
    process = subprocess.Popen(command, preexec_fn=child_fds, pass_fds=(3, 4), env=env,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                               start_new_session=True)
    os.close(to_read)
    os.close(from_write)
    try:
        tools = DevTools(to_write, from_read)
        targets = tools.call('Target.getTargets')['targetInfos']
        page = next(t['targetId'] for t in targets if t['type'] == 'page')
        session = tools.call('Target.attachToTarget',
                             {'targetId': page, 'flatten': True})['sessionId']
        tools.call('Emulation.setDeviceMetricsOverride',
                   {'width': size[0], 'height': size[1], 'deviceScaleFactor': 1,
                    'mobile': False}, session)
        tools.call('Page.enable', session=session)
        tools.call('Page.navigate', {'url': url}, session)
        print(f'screenshot_viewer: waiting {wait:.0f} s for the viewer to render', flush=True)
        time.sleep(wait)
        shot = tools.call('Page.captureScreenshot', {'format': 'png'}, session, timeout=120)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_bytes(base64.b64decode(shot['data']))
    finally:
        os.close(to_write)
        os.close(from_read)
        stop_group(process, signal.SIGTERM)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('rrd', type=Path, help="the recording (a run directory's run.rrd)")
    parser.add_argument('--out', type=Path, default=ROOT / 'docs' / 'viewer.png')
    parser.add_argument('--step', type=int, default=160,
                        help='the step the time cursor is put at (default 160)')
    parser.add_argument('--wait', type=float, default=60.0,
                        help='seconds to let the viewer load and render (default 60)')
    parser.add_argument('--size', default='1600x1000', help='window size WxH')
    parser.add_argument('--agents', type=int, nargs='+', default=[1, 2],
                        help='agent ids, for the layout (default 1 2)')
    parser.add_argument('--area', type=float, nargs=2, default=[100.0, 100.0],
                        help='area width and height in metres (default 100 100)')
    parser.add_argument('--install-chromium', action='store_true',
                        help='apt-get install chromium if it is missing')
    args = parser.parse_args(argv)
    if not args.rrd.is_file():
        raise SystemExit(f'screenshot_viewer: {args.rrd} is not a file')
    size = tuple(int(v) for v in args.size.lower().split('x'))
    chromium = find_chromium(args.install_chromium)
    with tempfile.TemporaryDirectory(prefix='sat-viewer-shot-') as tmp:
        tmp = Path(tmp)
        env = private_rerun_env(tmp / 'rerun')
        grpc_port, web_port = free_port(), free_port()
        # Compacted (a live logger writes many small chunks), without the layout stored in it:
        # today's default layout, looping over the chosen step, is loaded beside it instead
        # (with two layouts in play, which one the viewer activates is a race).
        recording, blueprint = tmp / 'run.rrd', tmp / 'layout.rbl'
        subprocess.run([*rerun_command(), 'rrd', 'optimize', str(args.rrd.resolve()), '-o',
                        str(tmp / 'optimized.rrd')], env=env, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        application_id = recording_only(tmp / 'optimized.rrd', recording)
        # The viewer ignores a #when= fragment on a recording URL: loop the playback over the
        # chosen step instead, so the time cursor stays there.
        layout = default_blueprint(
            args.agents, args.area, play_state='playing', loop_mode='selection', fps=500.0,
            time_selection=AbsoluteTimeRange(args.step, args.step + 1))
        layout.save(application_id, str(blueprint))
        server = subprocess.Popen(
            [*rerun_command(), '--serve-web', '--bind', '127.0.0.1', '--port', str(grpc_port),
             '--web-viewer-port', str(web_port), str(recording), str(blueprint)],
            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            start_new_session=True)
        try:
            wait_http(f'http://127.0.0.1:{web_port}/', 60, server)
            data = urllib.parse.quote(
                f'rerun+http://127.0.0.1:{grpc_port}/proxy', safe='')
            url = f'http://127.0.0.1:{web_port}/?url={data}'
            print(f'screenshot_viewer: {url}', flush=True)
            screenshot(chromium, url, args.out, size, args.wait, tmp / 'chromium-profile', env)
        finally:
            stop_group(server, signal.SIGTERM)
    print(f'screenshot_viewer: wrote {args.out} ({args.out.stat().st_size} bytes)')
    return 0


if __name__ == '__main__':
    sys.exit(main())
