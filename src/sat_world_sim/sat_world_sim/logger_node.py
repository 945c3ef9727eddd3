"""The logger node: streams the live graph into a Rerun recording (rerun_view has the layout).

Subscribes to ``/world/step``, ``/world/truth``, ``/world/radio`` and every agent's ``status``
and ``radio/out/search_density`` (the metrics node's subscription set and QoS). Messages are
grouped by step; a step is logged, in order, once its truth, radio and the statuses and
densities of its active agents are in, or once a later step is complete (a late or lost status
is then left out). After the world's ``finished`` step it logs what is left, flushes and exits.

Parameters: ``run_dir`` (required), ``agent_ids`` (default [1, 2]) and ``sink``:

- ``file`` (default): write ``<run_dir>/run.rrd``; no viewer needed (open it later with
  ``rerun <run_dir>/run.rrd``).
- ``viewer``: also spawn the native viewer (bound to 127.0.0.1:``viewer_port``) and stream to it.
- ``web``: also serve the web viewer on 127.0.0.1 only (``rerun --serve-web --bind 127.0.0.1``,
  gRPC on ``viewer_port``, HTTP on ``web_port``) and stream to it; the URL is logged.

Every sink also writes run.rrd. Rerun analytics are off: this process and the viewers it spawns
use a private Rerun config under ``<run_dir>/.rerun`` (rerun_view.private_rerun_env).
"""

from pathlib import Path
import subprocess
import sys
import time

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
import rerun as rr

from sat_agent.node_runner import run_nodes, RunFinished
from sat_agent.ros_params import declare_sat_params
from sat_msgs.msg import AgentStatus, GroundTruth, RadioTraffic, SearchDensity, WorldStep

from sat_world_sim import rerun_view

WORLD_QOS = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL)
AGENT_QOS = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE)
# After the world says "finished", wait at most this long for the last statuses.
FINAL_WAIT_S = 5.0
SINKS = ('file', 'viewer', 'web')


class LoggerNode(Node):
    """Logs one run to Rerun (module docstring)."""

    def __init__(self, **kwargs):
        super().__init__('logger', **kwargs)
        self.params = declare_sat_params(self)
        run_dir = self.declare_parameter('run_dir', '').value
        if not run_dir:
            raise ValueError("parameter 'run_dir' is required: the directory to write run.rrd in")
        self.agent_ids = [int(i) for i in self.declare_parameter('agent_ids', [1, 2]).value]
        sink = self.declare_parameter('sink', 'file').value
        if sink not in SINKS:
            raise ValueError(f"parameter 'sink' = {sink!r}: must be one of {', '.join(SINKS)}")
        ports = {}
        for name, default in (('viewer_port', 9876), ('web_port', 9090)):
            value = self.declare_parameter(name, default).value
            if not isinstance(value, int) or not 1 <= value <= 65535:
                raise ValueError(f"parameter '{name}' = {value!r}: must be a port in 1..65535")
            ports[name] = value
        self.run_dir = Path(run_dir)
        self.run_dir.mkdir(parents=True, exist_ok=True)
        self.rrd_path = self.run_dir / 'run.rrd'
        env = rerun_view.disable_analytics(self.run_dir / '.rerun')
        self.viewer = None
        self.recording = rerun_view.new_recording(live=sink != 'file')
        blueprint = rerun_view.default_blueprint(
            self.agent_ids, (self.params.area.width, self.params.area.height))
        sinks = [rr.FileSink(str(self.rrd_path))]
        if sink != 'file':
            sinks.append(self._start_viewer(sink, env, **ports))
        self.recording.set_sinks(*sinks, default_blueprint=blueprint)
        self.view = rerun_view.SwarmLogger(
            self.recording, self.agent_ids,
            area=(self.params.area.width, self.params.area.height),
            square_side=self.params.sensor.square_side)
        self.truths, self.traffic, self.statuses, self.densities = {}, {}, {}, {}
        self.next_step = 1
        self.final = None
        self._final_at = None
        self.create_subscription(WorldStep, '/world/step', self.on_step, WORLD_QOS)
        self.create_subscription(GroundTruth, '/world/truth',
                                 lambda m: self.truths.__setitem__(int(m.step), m), WORLD_QOS)
        self.create_subscription(RadioTraffic, '/world/radio',
                                 lambda m: self.traffic.__setitem__(int(m.step), m), WORLD_QOS)
        for i in self.agent_ids:
            self.create_subscription(
                AgentStatus, f'/agent_{i}/status',
                lambda m, i=i: self.statuses.__setitem__((i, int(m.step)), m), AGENT_QOS)
            self.create_subscription(
                SearchDensity, f'/agent_{i}/radio/out/search_density',
                lambda m, i=i: self.densities.__setitem__((i, int(m.step)), m), AGENT_QOS)
        self.create_timer(0.1, self._tick)
        self.get_logger().info(f'logging to {self.rrd_path} (sink {sink})')

    def _start_viewer(self, sink: str, env: dict, viewer_port: int, web_port: int):
        command = [*rerun_view.rerun_command(), '--bind', '127.0.0.1', '--port', str(viewer_port)]
        if sink == 'web':
            command += ['--serve-web', '--web-viewer-port', str(web_port)]
        # Its own session: the viewer outlives the run until the user closes it.
        self.viewer = subprocess.Popen(command, env=env, start_new_session=True,
                                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        url = f'rerun+http://127.0.0.1:{viewer_port}/proxy'
        if sink == 'web':
            self.get_logger().info(
                f'web viewer (pid {self.viewer.pid}): http://127.0.0.1:{web_port}/?url={url}')
        else:
            self.get_logger().info(f'native viewer (pid {self.viewer.pid}) at {url}')
        return rr.GrpcSink(url)

    def on_step(self, msg: WorldStep):
        if msg.finished:
            self.final = msg
            self._final_at = time.monotonic()

    def _complete(self, step: int) -> bool:
        truth = self.truths.get(step)
        if truth is None or step not in self.traffic:
            return False
        active = [int(a.id) for a in truth.agents if a.active and int(a.id) in self.agent_ids]
        return all((i, step) in self.statuses and (i, step) in self.densities for i in active)

    def _log(self, step: int):
        statuses = {i: self.statuses.pop((i, step)) for i in self.agent_ids
                    if (i, step) in self.statuses}
        densities = {i: self.densities.pop((i, step)) for i in self.agent_ids
                     if (i, step) in self.densities}
        self.view.log_step(self.truths.pop(step), self.traffic.pop(step, None), statuses,
                           densities)

    def _tick(self):
        # Log every complete step in order; an incomplete one waits until a later one is in.
        while True:
            later = [s for s in self.truths if s > self.next_step]
            if self.next_step in self.truths and (
                    self._complete(self.next_step) or any(self._complete(s) for s in later)):
                self._log(self.next_step)
            elif self.next_step not in self.truths and any(self._complete(s) for s in later):
                pass    # a lost truth: skip the step
            else:
                break
            self.next_step += 1
        if self.final is None:
            return
        last = int(self.final.step)
        if self.next_step <= last and time.monotonic() - self._final_at < FINAL_WAIT_S:
            return
        for step in sorted(s for s in self.truths if self.next_step <= s <= last):
            self._log(step)
        self.finish()
        raise RunFinished(0)

    def finish(self):
        """Flush the recording to its sinks and close them."""
        self.recording.flush()
        self.recording.disconnect()
        self.get_logger().info(f'wrote {self.rrd_path}')


def main(args=None):
    return run_nodes('logger', LoggerNode, args)


if __name__ == '__main__':
    sys.exit(main())
