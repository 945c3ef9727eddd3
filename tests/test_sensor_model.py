"""The sensing-square gate and h(x, s) against their plain definitions (Eqn. sensing_model)."""

from hypothesis import given, strategies as st
import numpy as np

from sat_agent import sensor_model

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
