"""Hostile input at a live agent process: random and mutated messages on every subscription.

Hypothesis draws batches of recipes (which topic, valid or which defect); each is published to a
separate agent process over DDS. The agent must survive all of them, accept exactly the valid
ones and drop exactly the invalid ones, counting every drop under its reason on /diagnostics.
"""

from array import array
import math
import zlib

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Point
from hypothesis import given, HealthCheck, Phase, settings, strategies as st
import numpy as np
import pytest
from ros_harness import executable, PARAMS, ros_node, spin_until, started, wait_matched

from sat_agent.density_codec import encode_density, ENCODINGS, SMOOTH_TAG
from sat_msgs.msg import (AgentMode, MeasurementSet, MultiTargetEstimate, RangeBearing,
                          SearchDensity, TargetEstimate)

pytestmark = pytest.mark.ros
AGENT = 1
SENDER = 2
CELLS = 100 * 100
BATCHES = 50
BATCH = 200          # 50 x 200 = 10,000 messages
STALE_BY = 10        # older than the agent's window for late reports (MAX_REPORT_LAG)
RADIO_DEFECTS = ('own_report', 'unknown_sender', 'future_step', 'stale_step')
DENSITY_DEFECTS = ('nan', 'above_one', 'negative', 'wrong_length', 'grid_mismatch', 'not_zlib',
                   'zip_bomb', 'smooth_not_zlib', 'smooth_zip_bomb')
# 40 MB of zeros (1000 densities) in 39 kB: a decoder without a size cap would inflate it all.
ZIP_BOMB = zlib.compress(bytes(1000 * CELLS * 4), 9)
ESTIMATE_DEFECTS = ('nan_position', 'inf_weight', 'negative_cardinality', 'too_many_targets')
SCAN_DEFECTS = ('wrong_agent_id', 'stale_step', 'future_step', 'nan_detection',
                'negative_range', 'bearing', 'too_many_detections')
# Reasons the agent counts when a message is invalid, per defect.
REASON = {'nan': 'out_of_range', 'above_one': 'out_of_range', 'negative': 'out_of_range',
          'wrong_length': 'wrong_length', 'grid_mismatch': 'grid_mismatch',
          'not_zlib': 'bad_encoding', 'zip_bomb': 'wrong_length',
          'smooth_not_zlib': 'bad_encoding', 'smooth_zip_bomb': 'wrong_length',
          'nan_position': 'non_finite', 'inf_weight': 'non_finite',
          'negative_cardinality': 'out_of_range', 'too_many_targets': 'too_many_targets',
          'unknown_mode': 'unknown_mode', 'nan_detection': 'non_finite',
          'negative_range': 'out_of_range',
          'bearing': 'out_of_range', 'too_many_detections': 'too_many_detections',
          'wrong_agent_id': 'wrong_agent_id', 'stale_step': 'stale_step',
          'future_step': 'future_step', 'own_report': 'own_report',
          'unknown_sender': 'unknown_sender'}
# Drops that count reports or superseded scans, not invalid messages.
NOT_MESSAGE_REASONS = {'partial_report', 'superseded_scan'}

recipe = st.one_of(
    st.tuples(st.just('measurements'), st.sampled_from((None,) * 3 + SCAN_DEFECTS)),
    st.tuples(st.just('search_density'),
              st.sampled_from((None,) * 3 + DENSITY_DEFECTS + RADIO_DEFECTS)),
    st.tuples(st.just('estimate'),
              st.sampled_from((None,) * 3 + ESTIMATE_DEFECTS + RADIO_DEFECTS)),
    st.tuples(st.just('mode'), st.sampled_from((None, None, 'unknown_mode') +
                                               RADIO_DEFECTS)))


class Fuzzer:
    """Publishes recipes to the agent and reads its /diagnostics counters."""

    def __init__(self, node):
        self.node = node
        self.scan_step = 0      # the last valid scan step sent
        self.counters = {}
        qos = 200
        self.pubs = {'measurements': node.create_publisher(
            MeasurementSet, f'/agent_{AGENT}/measurements', qos)}
        for kind, cls in (('search_density', SearchDensity), ('estimate', MultiTargetEstimate),
                          ('mode', AgentMode)):
            self.pubs[kind] = node.create_publisher(cls, f'/agent_{AGENT}/radio/in/{kind}', qos)
        node.create_subscription(DiagnosticArray, '/diagnostics', self.on_diagnostics, 50)

    def on_diagnostics(self, msg):
        for status in msg.status:
            if status.name == f'/agent_{AGENT}/agent: input':
                self.counters = {v.key: int(v.value) for v in status.values}

    def totals(self):
        accepted = sum(n for k, n in self.counters.items() if k.startswith('accepted.'))
        dropped = {k[len('dropped.'):]: n for k, n in self.counters.items()
                   if k.startswith('dropped.')}
        return accepted, dropped

    def send(self, topic, defect, rng):
        """Publish one message; return the reason the agent must count, or None if valid."""
        if topic == 'measurements':
            msg, reason = self.scan(defect, rng)
        else:
            msg, reason = self.radio(topic, defect, rng)
        self.pubs[topic].publish(msg)
        return reason

    def scan(self, defect, rng):
        if defect == 'stale_step' and self.scan_step == 0:
            defect = 'wrong_agent_id'
        step = {'stale_step': self.scan_step, 'future_step': self.scan_step + 5000}.get(
            defect, self.scan_step + 1)
        count = 10001 if defect == 'too_many_detections' else int(rng.integers(0, 20))
        z = np.column_stack([rng.uniform(0, 7, count), rng.uniform(-math.pi, math.pi, count)])
        if count and defect == 'nan_detection':
            z[0, 0] = math.nan
        if count and defect == 'negative_range':
            z[0, 0] = -1.0
        if count and defect == 'bearing':
            z[0, 1] = 4.0
        if not count and defect in ('nan_detection', 'negative_range', 'bearing'):
            defect = 'wrong_agent_id'
        msg = MeasurementSet(agent_id=SENDER if defect == 'wrong_agent_id' else AGENT, step=step,
                             agent_position=Point(x=50.0, y=50.0),
                             detections=[RangeBearing(range=r, bearing=b) for r, b in z])
        if defect is None:
            self.scan_step = step
        return msg, REASON.get(defect)

    def radio(self, kind, defect, rng):
        sender, step = SENDER, self.scan_step
        if defect == 'stale_step' and self.scan_step < STALE_BY:
            defect = 'future_step'
        if defect == 'own_report':
            sender = AGENT
        elif defect == 'unknown_sender':
            sender = 0
        elif defect == 'future_step':
            step = self.scan_step + 5
        elif defect == 'stale_step':
            step = self.scan_step - STALE_BY
        if kind == 'search_density':
            msg = density(sender, step, defect, rng)
        elif kind == 'estimate':
            msg = estimate(sender, step, defect, rng)
        else:
            msg = AgentMode(agent_id=sender, step=step, position=Point(x=1.0, y=2.0),
                            mode=7 if defect == 'unknown_mode' else int(rng.integers(0, 2)))
        return msg, REASON.get(defect)


def density(sender, step, defect, rng):
    values = rng.random(CELLS, dtype=np.float32)
    if defect == 'nan':
        values[5] = np.nan
    elif defect == 'above_one':
        values[5] = 1.5
    elif defect == 'negative':
        values[5] = -0.1
    elif defect == 'wrong_length':
        values = values[:-1]
    # Either radio layout (density_codec.py): the smooth one takes rows x columns.
    encoding = ENCODINGS[int(rng.integers(len(ENCODINGS)))]
    rows = values.reshape(100, 100) if values.size == CELLS else values.reshape(1, -1)
    not_zlib = b'\x78\x9c not zlib'
    encoded = {'not_zlib': not_zlib, 'zip_bomb': ZIP_BOMB,
               'smooth_not_zlib': SMOOTH_TAG + not_zlib,
               'smooth_zip_bomb': SMOOTH_TAG + ZIP_BOMB}.get(
        defect, encode_density(rows, encoding))
    msg = SearchDensity(agent_id=sender, step=step, values_zlib=array('B', encoded))
    msg.grid.resolution = 2.0 if defect == 'grid_mismatch' else 1.0
    msg.grid.width, msg.grid.height = 100, 100
    return msg


def estimate(sender, step, defect, rng):
    count = 1001 if defect == 'too_many_targets' else int(rng.integers(0, 4))
    targets = [TargetEstimate(position=Point(x=float(rng.uniform(0, 100)), y=1.0),
                              covariance=np.eye(4).ravel().tolist(), weight=1.0)
               for _ in range(count)]
    if defect == 'nan_position':
        targets = targets or [TargetEstimate(weight=1.0)]
        targets[0].position.x = math.nan
    if defect == 'inf_weight':
        targets = targets or [TargetEstimate()]
        targets[0].weight = math.inf
    return MultiTargetEstimate(agent_id=sender, step=step, targets=targets,
                               cardinality=-1.0 if defect == 'negative_cardinality' else 1.0)


@pytest.fixture(scope='module')
def fuzz(tmp_path_factory):
    log = tmp_path_factory.mktemp('fuzz') / 'agent.log'
    command = [executable('sat_agent', 'agent'), '--ros-args', '-r', f'__ns:=/agent_{AGENT}',
               '--params-file', str(PARAMS), '-p', f'agent_id:={AGENT}',
               '-p', 'diagnostics_period:=0.1']
    with ros_node('fuzzer') as node, started(command, log) as agent:
        fuzzer = Fuzzer(node)
        # What is published before a writer matched the agent's reader never reaches it.
        wait_matched(node, fuzzer.pubs.values(), 60, "the test's writers matching the agent")
        fuzzer.agent = agent
        fuzzer.sent = {'valid': 0, 'invalid': {}}
        fuzzer.batches = 0
        yield fuzzer


def send_and_count(fuzz, items, rng):
    """Publish items, then wait until the agent's counters account for everything sent so far.

    Radio messages are checked against the agent's step, so they are sent while no scan is in
    flight (the agent's step is then the last scan step sent): DDS does not order messages
    across topics, and a scan overtaking a report would turn a valid step into a stale one.
    """
    for topic, defect in items:
        reason = fuzz.send(topic, defect, rng)
        if reason is None:
            fuzz.sent['valid'] += 1
        else:
            fuzz.sent['invalid'][reason] = fuzz.sent['invalid'].get(reason, 0) + 1
    expected_total = fuzz.sent['valid'] + sum(fuzz.sent['invalid'].values())

    def counted():
        accepted, dropped = fuzz.totals()
        return accepted + sum(n for k, n in dropped.items()
                              if k not in NOT_MESSAGE_REASONS) >= expected_total
    spin_until(fuzz.node, counted, 60,
               f"the agent's /diagnostics counting all {expected_total} messages sent",
               (fuzz.agent,))


# Generate only: the examples share one live agent, which a shrinking pass would replay from a
# later state, hiding the first failure behind others.
@pytest.mark.timeout(900)
@settings(max_examples=BATCHES, deadline=None, phases=[Phase.generate],
          suppress_health_check=list(HealthCheck))
@given(batch=st.lists(recipe, min_size=BATCH, max_size=BATCH), seed=st.integers(0, 2 ** 31))
def test_agent_survives_and_counts_every_invalid_message(fuzz, batch, seed):
    rng = np.random.default_rng(seed)
    send_and_count(fuzz, [item for item in batch if item[0] != 'measurements'], rng)
    send_and_count(fuzz, [item for item in batch if item[0] == 'measurements'], rng)
    assert fuzz.agent.poll() is None, 'the agent died'
    accepted, dropped = fuzz.totals()
    counted = {k: n for k, n in dropped.items() if k not in NOT_MESSAGE_REASONS}
    assert accepted == fuzz.sent['valid']
    assert counted == fuzz.sent['invalid']
    fuzz.batches += 1


def test_ten_thousand_messages_were_thrown(fuzz):
    """Guard: the property test above really ran its batches (it runs first, same module)."""
    assert fuzz.batches == BATCHES
    assert fuzz.sent['valid'] + sum(fuzz.sent['invalid'].values()) >= 10_000


def test_whole_reports_with_malformed_node_views_are_dropped_and_counted(fuzz):
    """Node views are checked with the whole report, when the agent steps.

    Not one per node of its search map, or one after the report's step, drops the report under
    that reason (persistent planning's overdue rule, beyond_paper/overdue_nodes.py).
    """
    rng = np.random.default_rng(7)
    accepted, dropped = fuzz.totals()
    step = fuzz.scan_step
    for sender, views in ((2, [0, 1, 2]), (3, [step + 1] * 100)):
        msg = density(sender, step, None, rng)
        msg.node_views = array('I', views)
        fuzz.pubs['search_density'].publish(msg)
        fuzz.pubs['estimate'].publish(estimate(sender, step, None, rng))
        fuzz.pubs['mode'].publish(AgentMode(agent_id=sender, step=step,
                                            position=Point(x=1.0, y=2.0)))
    # Every message is valid on its own; the scan of the next step makes the agent read them.
    spin_until(fuzz.node, lambda: fuzz.totals()[0] >= accepted + 6, 60,
               'the agent accepting the six messages', (fuzz.agent,))
    fuzz.send('measurements', None, rng)

    def counted():
        now = fuzz.totals()[1]
        return all(now.get(reason, 0) >= dropped.get(reason, 0) + 1
                   for reason in ('wrong_length', 'out_of_range'))
    spin_until(fuzz.node, counted, 60, 'the two reports dropped as wrong_length, out_of_range',
               (fuzz.agent,))
    assert fuzz.agent.poll() is None, 'the agent died'
