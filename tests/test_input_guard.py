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

    def get_fully_qualified_name(self):
        return '/test'

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


def test_each_status_carries_the_process_peak_memory():
    """A bomb that got through shows in the counters, even those of an exited node."""
    guard = InputGuard(FakeNode(), 'test', 1.0)
    ballast = bytearray(64 << 20)
    ballast[::4096] = b'x' * len(ballast[::4096])       # touched: resident now
    resident = resident_kb()
    values = {v.key: v.value for v in guard.status(final=True).values}
    assert resident >= 64 << 10
    # A peak: at least what is resident now (earlier tests may have held more).
    assert int(values['peak_memory_kb']) >= resident
    assert values['final'] == '1'
    del ballast


def resident_kb() -> int:
    """Return this process's resident memory (VmRSS) in kB."""
    with open('/proc/self/status', encoding='ascii') as status:
        return next(int(line.split()[1]) for line in status if line.startswith('VmRSS:'))
