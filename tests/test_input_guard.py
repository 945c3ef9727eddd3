"""InputGuard: each drop is counted; warnings are rate-limited per reason, say what they hid."""

from sat_agent.ros import input_guard
from sat_agent.ros.input_guard import InputGuard


class FakeNode:
    """Just what InputGuard uses of an rclpy Node."""

    def __init__(self):
        self.warnings = []

    def create_publisher(self, *args):
        return None

    def create_timer(self, *args):
        return None

    def get_logger(self):
        return self

    def warning(self, text):
        self.warnings.append(text)


def test_warnings_are_throttled_per_reason_and_count_what_they_skipped(monkeypatch):
    clock = [100.0]
    monkeypatch.setattr(input_guard.time, 'monotonic', lambda: clock[0])
    node = FakeNode()
    guard = InputGuard(node, 'test', 1.0)
    for _ in range(5):
        guard.drop('stale_step', 'old')
    guard.drop('nan', 'bad')
    assert guard.dropped == {'stale_step': 5, 'nan': 1}
    assert node.warnings == ['dropped (stale_step): old', 'dropped (nan): bad']
    clock[0] += input_guard.LOG_THROTTLE_S
    guard.drop('stale_step', 'older')
    assert node.warnings[-1] == 'dropped (stale_step): older (4 more since the last warning)'
    guard.drop('stale_step', 'again')
    assert len(node.warnings) == 3
