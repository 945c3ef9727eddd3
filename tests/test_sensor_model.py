"""The sensing-square gate and h(x, s) against their plain definitions (Eqn. sensing_model)."""

from hypothesis import given, strategies as st
import numpy as np

from sat_agent import sensor_model
from sat_agent.beyond_paper.kernel_likelihood import filter_bandwidth
from sat_agent.config import SatParams

SIDE = 10.0
POSE = np.array([50.0, 50.0])
# Coordinates on and next to the square's edges (a / 2 = 5 from the pose), far away,
# non-finite: the gate must agree with max(|dx|, |dy|) <= a / 2 on each of them.
EDGES = [POSE[0] + sign * (SIDE / 2.0) for sign in (-1.0, 1.0)]
coordinate = st.one_of(
    st.floats(0.0, 100.0),
    st.sampled_from(EDGES + [np.nextafter(e, d) for e in EDGES for d in (0.0, 100.0)]),
    st.sampled_from([np.nan, np.inf, -np.inf, -1e300, 1e300]))
points = st.lists(st.tuples(coordinate, coordinate), min_size=0, max_size=50)


def max_norm_gate(pts, pose, side):
    """Return the gate as its docstring states it: max(|dx|, |dy|) <= a / 2."""
    offset = np.abs(np.asarray(pts, dtype=float) - np.asarray(pose, dtype=float))
    return np.max(offset, axis=-1) <= side / 2.0


@given(points)
def test_the_square_gate_is_the_max_norm_test(pts):
    pts = np.array(pts, dtype=float).reshape(-1, 2)
    np.testing.assert_array_equal(sensor_model.in_sensing_square(pts, POSE, SIDE),
                                  max_norm_gate(pts, POSE, SIDE))


def test_the_square_gate_broadcasts_points_against_poses():
    """Baselines test every point against every pose: (1, N, 2) against (P, 1, 2)."""
    rng = np.random.default_rng(0)
    pts, poses = rng.uniform(0, 100, (40, 2)), rng.uniform(0, 100, (7, 2))
    mask = sensor_model.in_sensing_square(pts[None], poses[:, None], SIDE)
    assert mask.shape == (7, 40)
    np.testing.assert_array_equal(mask, max_norm_gate(pts[None], poses[:, None], SIDE))
    assert sensor_model.in_sensing_square(POSE + 5.0, POSE, SIDE)
    assert not sensor_model.in_sensing_square(POSE + [0.0, 5.001], POSE, SIDE)


@given(points)
def test_h_is_range_and_bearing_from_the_pose(pts):
    pts = np.array(pts, dtype=float).reshape(-1, 2)
    with np.errstate(invalid='ignore'):
        delta = pts - POSE
        expected = np.column_stack([np.hypot(delta[:, 0], delta[:, 1]),
                                    np.arctan2(delta[:, 1], delta[:, 0])])
        np.testing.assert_array_equal(sensor_model.measure(pts, POSE), expected)


def test_a_likelihood_bandwidth_is_the_likelihood_of_a_kernel_around_the_point():
    """The g of bandwidth h is g averaged over N(point, h^2 I) draws (to first order)."""
    sensor = SatParams().sensor
    h = filter_bandwidth(SatParams().with_overrides({'additions.kernel_likelihood': True}))
    assert h == sensor.likelihood_bandwidth == 0.3 and filter_bandwidth(SatParams()) == 0.0
    rng = np.random.default_rng(5)
    point = POSE + np.array([4.0, 3.0])                       # 5 m away
    offsets = np.array([[0.4, 0.03], [-0.8, -0.05], [0.0, 0.0]])   # [range, bearing]
    z = sensor_model.measure(point[None], POSE) + offsets
    draws = point + rng.normal(0.0, 0.3, (200_000, 2))
    averaged = sensor_model.likelihood(z, draws, POSE, sensor).mean(axis=0)
    np.testing.assert_allclose(sensor_model.likelihood(z, point[None], POSE, sensor, h)[0],
                               averaged, rtol=0.03)
    # At 2 m the kernel is wider than the bearing: a measurement 20 cm across the line of
    # sight is still explained, where the sensor's own g gives it nothing.
    near = POSE + np.array([2.0, 0.0])
    across = sensor_model.measure((near + [0.0, 0.2])[None], POSE)
    own = sensor_model.likelihood(across, near[None], POSE, sensor)[0, 0]
    kernel = sensor_model.likelihood(across, near[None], POSE, sensor, h)[0, 0]
    assert own < 1e-6 < 0.1 < kernel
