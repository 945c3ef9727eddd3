"""The logger node: streams the live graph into a Rerun recording (rerun_view has the layout).

Subscribes to ``/world/step``, ``/world/truth``, ``/world/radio`` and every agent's ``status``
and ``radio/out/search_density`` (the metrics node's subscription set and QoS,
sat_agent.ros.qos) and, like every observer, announces itself on ``/world/ready`` once they have
all matched (sat_agent.ros.readiness): world_sim counts it among its ``observers``. Messages are
grouped by step (rerun_view.StepBuffer, which an offline replay of a bag can use as well); a
step is logged, in order, once its truth, radio and the statuses and densities of its active
agents are in, or once a later step is complete (a lost status is then left out). After the
world's ``finished`` step it logs what is left (waiting at most FINAL_WAIT_S for the last
step's data), flushes and exits.

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
import urllib.parse

from rclpy.node import Node
import rerun as rr

from sat_agent.config import SatParams
from sat_agent.node_params import LoggerParams
from sat_agent.ros.node_runner import finish_run, run_nodes, steady_timer
from sat_agent.ros.ros_params import NodeParameters

from sat_world_sim import rerun_view
from sat_world_sim.ros.observer import watch_run

# After the world says "finished", wait at most this long for the last statuses.
FINAL_WAIT_S = 5.0


class LoggerNode(Node):
    """Logs one run to Rerun (module docstring)."""

    def __init__(self, **kwargs):
        super().__init__('logger', **kwargs)
        self.params, run = NodeParameters(self, (SatParams, LoggerParams)).values
        self.run_dir, self.agent_ids, sink = Path(run.run_dir), run.agent_ids, run.sink
        ports = {'viewer_port': run.viewer_port, 'web_port': run.web_port}
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
        self.buffer = rerun_view.StepBuffer(self.view)
        self._finished_at = None
        # world_sim starts step 1 once every subscription here has matched its publisher.
        self.ready = watch_run(self, self.agent_ids, self.buffer.add)
        steady_timer(self, 0.1, self._tick)
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
                f'web viewer (pid {self.viewer.pid}): '
                f'http://127.0.0.1:{web_port}/?url={urllib.parse.quote(url, safe="")}')
        else:
            self.get_logger().info(f'native viewer (pid {self.viewer.pid}) at {url}')
        return rr.GrpcSink(url)

    def _tick(self):
        self.buffer.log_ready()
        if self.buffer.final is None:
            return
        if self._finished_at is None:
            self._finished_at = time.monotonic()
        if not self.buffer.finished() and time.monotonic() - self._finished_at < FINAL_WAIT_S:
            return
        self.buffer.log_rest()
        self.finish()
        finish_run(self, 0)

    def finish(self):
        """Flush the recording to its sinks and close them (once)."""
        if self.recording is None:
            return
        self.recording.flush()
        self.recording.disconnect()
        self.recording = None
        self.get_logger().info(f'wrote {self.rrd_path}')

    def destroy_node(self):
        # Ctrl-C or an external shutdown still leaves a complete run.rrd of what was logged.
        self.finish()
        return super().destroy_node()


def main(args=None):
    return run_nodes('logger', LoggerNode, args)


if __name__ == '__main__':
    sys.exit(main())
