"""Dropped-input bookkeeping shared by the nodes.

A counter per reason, rate-limited warnings, and the counters published on ``/diagnostics``
(diagnostic_msgs/DiagnosticArray) every ``diagnostics_period`` seconds (a node parameter,
sat_agent.node_params.SteppingParams), and once more when the node ends (``final`` = 1, sent by
node_runner.run_nodes and awaited until acknowledged): counts of a node's last moments are not
lost between its last period and its exit. Each status also carries ``peak_memory_kb``, the
peak resident memory of the node's process so far: what a bomb that got through would grow,
readable after the process has gone.
"""

from collections import Counter
import math
import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.duration import Duration

from sat_agent.ros.node_runner import steady_timer

LOG_THROTTLE_S = 5.0
# Upper bound on waiting for the readers' acknowledgement of the final counters at exit.
FINAL_DIAGNOSTICS_ACK_S = 2.0


class InputGuard:
    """Counts what a node accepted and what it dropped, and why; reports it on /diagnostics."""

    def __init__(self, node, hardware_id: str, period: float):
        self._node = node
        self._hardware_id = hardware_id
        self.accepted = Counter()    # topic kind -> messages taken
        self.dropped = Counter()     # reason -> messages dropped
        self._reported = 0
        self._last_warning = {}      # reason -> time.monotonic() of its last warning
        self._warned = Counter()     # reason -> drops counted at its last warning
        # 'on' / 'off' once the node verifies signed input (signed_io.VerifiedInput).
        self.auth = None
        self._publisher = node.create_publisher(DiagnosticArray, '/diagnostics', 10)
        steady_timer(node, period, self.publish)
        # run_nodes publishes every guard's final counters before it destroys the node.
        node.sat_guards = [*getattr(node, 'sat_guards', ()), self]

    def accept(self, kind: str):
        """Count one valid message of this kind."""
        self.accepted[kind] += 1

    def drop(self, reason: str, detail: str):
        """Count one dropped message and warn, at most once per LOG_THROTTLE_S per reason.

        The throttle is checked here, not by rclpy: rclpy's throttled logging still looks up
        its caller's frame and file on every call, which costs more than the message itself
        when a swarm drops thousands of late radio messages.
        """
        self.dropped[reason] += 1
        now = time.monotonic()
        if now - self._last_warning.get(reason, -math.inf) < LOG_THROTTLE_S:
            return
        self._last_warning[reason] = now
        unreported = self.dropped[reason] - self._warned[reason] - 1
        self._warned[reason] = self.dropped[reason]
        since = f' ({unreported} more since the last warning)' if unreported else ''
        self._node.get_logger().warning(f'dropped ({reason}): {detail}{since}')

    def status(self, final: bool = False) -> DiagnosticStatus:
        """Return the counters as one DiagnosticStatus (WARN while new drops keep coming)."""
        total = sum(self.dropped.values())
        level = DiagnosticStatus.WARN if total > self._reported else DiagnosticStatus.OK
        self._reported = total
        values = [KeyValue(key=f'accepted.{k}', value=str(n))
                  for k, n in sorted(self.accepted.items())]
        values += [KeyValue(key=f'dropped.{k}', value=str(n))
                   for k, n in sorted(self.dropped.items())]
        message = f'{total} message(s) dropped'
        values.append(KeyValue(key='peak_memory_kb', value=str(peak_memory_kb())))
        if final:
            values.append(KeyValue(key='final', value='1'))
        if self.auth is not None:
            values.append(KeyValue(key='authenticated', value=str(int(self.auth == 'on'))))
            if self.auth == 'off':
                # Unauthenticated input is a standing warning, not a passing one.
                level, message = DiagnosticStatus.WARN, f'auth off; {message}'
        name = f'{self._node.get_fully_qualified_name()}: input'
        return DiagnosticStatus(level=level, name=name, hardware_id=self._hardware_id,
                                message=message, values=values)

    def publish(self, final: bool = False):
        """Publish the counters on /diagnostics (final: the node's last ones)."""
        array = DiagnosticArray(status=[self.status(final)])
        # The node's clock: sim time (the last /clock) under use_sim_time.
        array.header.stamp = self._node.get_clock().now().to_msg()
        self._publisher.publish(array)

    def publish_final(self):
        """Publish the last counters and wait, bounded, until every reader acknowledged them."""
        self.publish(final=True)
        self._publisher.wait_for_all_acked(Duration(seconds=FINAL_DIAGNOSTICS_ACK_S))


def peak_memory_kb(pid='self') -> int:
    """Return a process's peak resident memory in kB (VmHWM; getrusage's ru_maxrss lags it)."""
    with open(f'/proc/{pid}/status', encoding='ascii') as status:
        return next(int(line.split()[1]) for line in status if line.startswith('VmHWM:'))
