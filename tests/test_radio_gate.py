"""The radio's range gate (sat_world_sim.radio): a message's receivers, the links, loss draws.

ROS-free. world_sim gates each relayed message with receivers_within (one row of the gate);
the links it publishes and the in-process swarm's come from links_within: both must say the
same, to the bit at exactly C_R.
"""

import numpy as np
import pytest

from sat_world_sim.radio import links_within, Radio, receivers_within

C_R = 50.0


def brute_force_receivers(poses, sender, comm_range):
    """Return every other agent within C_R, by a plain loop (the gate as the paper words it)."""
    return sorted(j for j in poses if j != sender
                  and np.hypot(*(np.asarray(poses[j]) - poses[sender])) <= comm_range)


def random_poses(seed, count):
    rng = np.random.default_rng(seed)
    ids = rng.choice(np.arange(1, 200), size=count, replace=False)
    return {int(i): rng.uniform(0.0, 100.0, size=2) for i in ids}


@pytest.mark.parametrize('seed', range(6))
def test_receivers_are_every_other_agent_within_range_in_ascending_order(seed):
    poses = random_poses(seed, 2 + 6 * seed)
    for sender in poses:
        got = receivers_within(poses, sender, C_R)
        assert got == brute_force_receivers(poses, sender, C_R)
        assert got == sorted(got)


@pytest.mark.parametrize('seed', range(6))
def test_the_gate_is_symmetric_and_the_links_are_its_pairs(seed):
    poses = random_poses(100 + seed, 3 + 5 * seed)
    links = links_within(poses, C_R)
    for i in poses:
        for j in receivers_within(poses, i, C_R):
            assert i in receivers_within(poses, j, C_R)
            assert (min(i, j), max(i, j)) in links
    assert all(i < j and j in receivers_within(poses, i, C_R) for i, j in links)


def test_the_gate_includes_exactly_c_r_and_nothing_beyond():
    poses = {1: np.array([10.0, 10.0]), 2: np.array([60.0, 10.0]),
             3: np.array([10.0, np.nextafter(60.0, 61.0)]), 4: np.array([40.0, 50.0])}
    assert receivers_within(poses, 1, C_R) == [2, 4]       # 50 m and 50 m (3-4-5) away
    assert receivers_within(poses, 3, C_R) == [4]          # one ulp beyond 50 m from agent 1
    assert links_within(poses, C_R) == frozenset({(1, 2), (1, 4), (2, 4), (3, 4)})


def test_a_lone_or_unknown_sender_reaches_nobody():
    assert receivers_within({1: np.zeros(2)}, 1, C_R) == []
    assert receivers_within({1: np.zeros(2)}, 2, C_R) == []
    assert links_within({}, C_R) == frozenset()


def test_send_queues_one_delivery_per_receiver_with_one_loss_draw_each_in_id_order():
    poses = random_poses(7, 30)
    sender = min(poses)
    radio = Radio(C_R, loss=0.5, seed=3)
    queued = radio.send(4, sender, 'estimate', b'x', 10, poses)
    # The reference: one draw per receiver, ascending ids, from the same seeded stream.
    rng = np.random.default_rng(3)
    expected = [j for j in brute_force_receivers(poses, sender, C_R) if not rng.random() < 0.5]
    delivered = radio.due(5)
    assert [d.receiver for d in delivered] == expected
    assert queued == len(expected) and radio.dropped[sender] == len(
        brute_force_receivers(poses, sender, C_R)) - len(expected)
    assert all(radio.messages[(sender, j)] == 1 and radio.bytes[(sender, j)] == 10
               for j in expected)
