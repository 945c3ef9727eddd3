"""The Rerun logger: rerun_view on synthetic messages, and the logger node in a live swarm."""

from array import array
from collections import defaultdict
import math
import subprocess

from geometry_msgs.msg import Point
import pytest
from rerun.chunk import RrdReader
from ros_harness import executable, PARAMS, REPO, scaled, started, wait_exit

from sat_agent.density_codec import encode_density
from sat_msgs.msg import (AgentStatus, AgentTruth, GridInfo, GroundTruth, RadioTraffic,
                          SearchDensity, TargetEstimate, TargetTruth, WorldStep)
from sat_world_sim import rerun_view

AGENTS = (1, 2)
PER_STEP = ['map/world/truth', 'map/world/radio/links', 'map/world/density/fused',
            'plots/ospa/total', 'plots/ospa/localisation', 'plots/ospa/cardinality',
            'plots/count/true', 'plots/count/estimated', 'plots/searched_pct', 'status']
PER_AGENT = ['position', 'square', 'plan', 'estimates', 'spread', 'particles']
STATIC = ['map/world', 'map/world/area', 'plots/ospa/total', 'plots/mode/agent_1']


def rrd_contents(path):
    """Return ({entity: sorted steps it was logged at}, {static entities}) of a .rrd file."""
    steps, static = defaultdict(set), set()
    for chunk in RrdReader(path).store().stream().to_chunks():
        entity = chunk.entity_path.lstrip('/')
        if chunk.is_static:
            static.add(entity)
            continue
        if 'step' in chunk.timeline_names:
            batch = chunk.to_record_batch()
            steps[entity].update(int(s) for s in batch.column('step').to_pylist())
    return {e: sorted(s) for e, s in steps.items()}, static


def expected_per_step(agent_ids):
    """Entities that must be logged at every step of a run with these agents."""
    paths = list(PER_STEP)
    for i in agent_ids:
        paths += [f'map/world/agent_{i}/{name}' for name in PER_AGENT]
        paths += [f'map/world/density/agent_{i}', f'plots/mode/agent_{i}']
    return paths


def _point(x, y):
    return Point(x=float(x), y=float(y), z=0.0)


def synthetic_step(step):
    """Return (truth, traffic, statuses, densities) of a made-up step with two agents."""
    positions = {1: (10.0 + step, 60.0), 2: (60.0, 10.0 + 2 * step)}
    truth = GroundTruth(step=step, searched_fraction=0.01 * step)
    truth.targets = [TargetTruth(id=1, alive=True, position=_point(50 + step, 69)),
                     TargetTruth(id=2, alive=step > 2, position=_point(41, 29))]
    truth.agents = [AgentTruth(id=i, position=_point(*p), active=True)
                    for i, p in positions.items()]
    traffic = RadioTraffic(step=step, link_a=[1], link_b=[2], sender=[1, 2], receiver=[2, 1],
                           messages=[3 * step, 3 * step], bytes=[100 * step, 90 * step])
    statuses, densities = {}, {}
    for i, (x, y) in positions.items():
        status = AgentStatus(agent_id=i, step=step, mode=AgentStatus.MODE_TRACK if i == 1 else 0,
                             position=_point(x, y), group=[1, 2])
        status.plan = [_point(x + 10, y), _point(x + 10, y + 10)]
        estimate = TargetEstimate(position=_point(50.5 + step, 69.2), weight=0.9)
        covariance = [0.0] * 16
        covariance[0], covariance[2], covariance[8], covariance[10] = 1.0, 0.3, 0.3, 0.5
        estimate.covariance = covariance
        status.estimate.targets = [estimate] if i == 1 else []
        status.particle_xy = [50.0 + step, 69.0, 50.5 + step, 69.5, 51.0 + step, 68.5]
        status.particle_weights = [0.3, 0.3, 0.3]
        statuses[i] = status
        values = [0.0] * (20 * 10)
        values[step * i] = 1.0
        densities[i] = SearchDensity(
            agent_id=i, step=step, values_zlib=array('B', encode_density(values)),
            grid=GridInfo(origin_x=0.0, origin_y=0.0, resolution=5.0, width=20, height=10))
    return truth, traffic, statuses, densities


def test_rerun_view_logs_every_entity_at_every_step(tmp_path):
    path = tmp_path / 'run.rrd'
    recording = rerun_view.new_recording()
    recording.save(str(path), default_blueprint=rerun_view.default_blueprint(AGENTS))
    view = rerun_view.SwarmLogger(recording, AGENTS, area=(100.0, 50.0), square_side=10.0)
    steps = 4
    entries = [view.log_step(*synthetic_step(k)) for k in range(1, steps + 1)]
    recording.flush()
    recording.disconnect()
    logged, static = rrd_contents(path)
    for entity in expected_per_step(AGENTS):
        assert logged.get(entity) == list(range(1, steps + 1)), entity
    # Trajectories are one segment per step, from the second step on.
    for i in AGENTS:
        assert logged[f'map/world/agent_{i}/trajectory'] == list(range(2, steps + 1))
    assert set(STATIC) <= static
    # The project's metrics: two targets from step 3, one estimate (agent 1) near target 1.
    assert [e['n_true'] for e in entries] == [1, 1, 2, 2]
    assert [e['n_est'] for e in entries] == [1, 1, 1, 1]
    assert entries[0]['ospa'] == pytest.approx(math.hypot(0.5, 0.2), abs=1e-6)
    assert entries[-1]['ospa_card'] > 0
    assert entries[0]['modes'] == {'1': 'TRACK', '2': 'SEARCH'}


def synthetic_messages(steps):
    """Yield (topic, msg) of a made-up run as a bag would hold them, not in step order."""
    for k in range(1, steps + 1):
        truth, traffic, statuses, densities = synthetic_step(k)
        for i in AGENTS:
            yield f'/agent_{i}/radio/out/search_density', densities[i]
            yield f'/agent_{i}/status', statuses[i]
        yield '/world/radio', traffic
        yield '/world/truth', truth
        yield '/world/step', WorldStep(step=k, total_steps=steps, finished=k == steps)


def test_write_rrd_replays_topic_messages_in_step_order_and_skips_what_is_missing(tmp_path):
    steps = 5
    # Agent 2's status of step 3 is lost; an unknown agent's and topic's messages are ignored.
    messages = [(t, m) for t, m in synthetic_messages(steps)
                if not (t == '/agent_2/status' and m.step == 3)]
    messages.insert(0, ('/agent_9/status', AgentStatus(agent_id=9, step=1)))
    messages.insert(0, ('/world/ready', None))
    count = rerun_view.write_rrd(messages, tmp_path / 'run.rrd', AGENTS, area=(100.0, 50.0))
    assert count == steps
    logged, static = rrd_contents(tmp_path / 'run.rrd')
    assert logged['map/world/truth'] == list(range(1, steps + 1))
    assert logged['map/world/agent_1/estimates'] == list(range(1, steps + 1))
    assert logged['map/world/agent_2/coasted'] == [1, 2, 4, 5]     # empty lists, logged
    assert logged['map/world/agent_2/plan'] == [1, 2, 4, 5]
    assert not any('agent_9' in entity for entity in logged)
    assert 'map/world/area' in static


def test_write_rrd_takes_rosbags_deserialised_messages(tmp_path):
    from rclpy.serialization import serialize_message
    from sat_world_sim.bag_types import sat_typestore
    store = sat_typestore()
    steps = 3
    messages = []
    for topic, msg in synthetic_messages(steps):
        msgtype = f'sat_msgs/msg/{type(msg).__name__}'
        messages.append((topic, store.deserialize_cdr(serialize_message(msg), msgtype)))
    assert rerun_view.write_rrd(messages, tmp_path / 'run.rrd', AGENTS) == steps
    logged, _ = rrd_contents(tmp_path / 'run.rrd')
    for entity in expected_per_step(AGENTS):
        assert logged.get(entity) == list(range(1, steps + 1)), entity


def test_density_image_keeps_row_zero_at_origin_y_and_scales_to_uint8():
    msg = SearchDensity(values_zlib=array('B', encode_density([0.0, 0.5, 1.0, 0.25, 0.0, 0.0])),
                        grid=GridInfo(origin_x=0.0, origin_y=0.0, resolution=1.0, width=3,
                                      height=2))
    image = rerun_view.density_image(msg)
    assert image.dtype.name == 'uint8'
    assert image.tolist() == [[0, 128, 255], [64, 0, 0]]


def test_two_sigma_ellipse_spans_two_standard_deviations():
    import numpy as np
    ellipse = rerun_view._ellipse([1.0, 2.0], np.diag([4.0, 1.0]))
    assert ellipse[:, 0].max() == pytest.approx(1.0 + 4.0, rel=1e-2)
    assert ellipse[:, 1].max() == pytest.approx(2.0 + 2.0, rel=1e-2)


def test_private_rerun_env_turns_analytics_off_outside_the_home_config(tmp_path):
    import json
    env = rerun_view.private_rerun_env(tmp_path / 'rr', base={'PATH': '/usr/bin'})
    assert env['XDG_CONFIG_HOME'] == str(tmp_path / 'rr' / 'config')
    config = json.loads((tmp_path / 'rr' / 'config' / 'rerun' / 'analytics.json').read_text())
    assert config['analytics_enabled'] is False


@pytest.mark.ros
@pytest.mark.timeout(240)
def test_logger_node_records_a_short_swarm_run(tmp_path):
    steps = 15
    scenario = REPO / 'config' / 'scenarios' / 'paper.yaml'
    run_dir = tmp_path / 'run'
    world = [executable('sat_world_sim', 'world_sim'), '--ros-args', '--params-file',
             str(PARAMS), '-p', f'scenario:={scenario}', '-p', f'steps:={steps}',
             '-p', 'observers:=1']
    logger = [executable('sat_world_sim', 'logger'), '--ros-args',
              '--params-file', str(PARAMS), '-p', f'run_dir:={run_dir}',
              '-p', 'agent_ids:=[1,2]']

    def agent(i):
        return [executable('sat_agent', 'agent'), '--ros-args', '-r', f'__ns:=/agent_{i}',
                '--params-file', str(PARAMS), '-p', f'agent_id:={i}']

    with started(logger, tmp_path / 'logger.log') as log_process, \
            started(world, tmp_path / 'world.log') as world_process, \
            started(agent(1), tmp_path / 'a1.log') as a1, \
            started(agent(2), tmp_path / 'a2.log') as a2:
        code = wait_exit(log_process, 200, 'the logger writing run.rrd after the run',
                         others=(world_process, a1, a2))
    assert code == 0, (tmp_path / 'logger.log').read_text()[-3000:]
    logged, static = rrd_contents(run_dir / 'run.rrd')
    for entity in expected_per_step(AGENTS):
        assert logged.get(entity) == list(range(1, steps + 1)), entity
    for i in AGENTS:
        assert logged[f'map/world/agent_{i}/trajectory'] == list(range(2, steps + 1))
    assert set(STATIC) <= static


@pytest.mark.ros
def test_logger_node_refuses_an_unknown_sink(tmp_path):
    command = [executable('sat_world_sim', 'logger'), '--ros-args',
               '-p', f'run_dir:={tmp_path}', '-p', 'sink:=screen']
    result = subprocess.run(command, capture_output=True, text=True, timeout=scaled(60))
    assert result.returncode == 2
    assert "parameter 'sink' = 'screen'" in result.stderr
    assert "allowed values are ['file', 'viewer', 'web']" in result.stderr


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(600)
def test_paper_run_recording_has_every_entity_at_every_step(paper_run):
    run_dir, code, _, output = paper_run
    assert code == 0, output[-3000:]
    logged, static = rrd_contents(run_dir / 'run.rrd')
    for entity in expected_per_step(AGENTS):
        assert logged.get(entity) == list(range(1, 201)), entity
    for i in AGENTS:
        assert logged[f'map/world/agent_{i}/trajectory'] == list(range(2, 201))
    assert set(STATIC) <= static
