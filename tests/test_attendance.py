"""Lock-step attendance: a silent agent is let go and rejoins with any answer sent since."""

import pytest
from rclpy.serialization import serialize_message

from sat_agent.message_auth import AuthError, MessageVerifier, Signer
from sat_msgs.msg import ControlCommand
from sat_world_sim.attendance import (Attendance, deadline_after_stall, REJOIN_STEPS,
                                      WORLD_STALL_S)
from sat_world_sim.ros.world_sim_node import WINDOW

KEY = bytes(range(32))


def test_every_agent_is_waited_for_until_let_go():
    attendance = Attendance([1, 2, 3])
    assert attendance.active == {1, 2, 3}
    assert not attendance.heard(2, 5)   # active already: nothing to rejoin
    attendance.let_go([2, 3], 7)
    assert attendance.active == {1} and attendance.let_go_at == {2: 7, 3: 7}


def test_what_an_agent_said_before_it_was_let_go_does_not_bring_it_back():
    attendance = Attendance([1, 2])
    attendance.let_go([2], 7)
    assert not attendance.heard(2, 6)
    assert attendance.active == {1}
    assert attendance.heard(2, 7)       # its late answer to the scan it was let go at
    assert attendance.active == {1, 2} and attendance.let_go_at == {}
    assert not attendance.heard(2, 9)   # once back, it is simply active


@pytest.mark.parametrize('agent_step', [1, 2, 3, 7])
def test_an_agent_slower_than_the_world_rejoins_with_its_first_answer(agent_step):
    """The world steps every tick without the agent; the agent takes agent_step ticks a step.

    Each answer is to the newest scan the agent held when it began, agent_step steps behind the
    world when it arrives. The rule before 2026-12 (the current step or the one before) took no
    answer more than one step behind, so an agent with agent_step >= 2 stayed out for good.
    """
    attendance = Attendance([1, 2])
    attendance.let_go([2], 30)
    world, rejoined_at = 30, None
    began_on = world + 1                  # the respawned agent's first scan
    while rejoined_at is None and world < 120:
        world += 1
        if world - began_on == agent_step:
            if attendance.heard(2, began_on):
                rejoined_at = world
            began_on = world
    assert rejoined_at == 31 + agent_step


def test_a_stalled_world_gives_the_agents_the_time_it_did_not_run():
    # Ticks every 20 ms: the deadline stays; a world suspended for 10 s moves it by as much,
    # less the WORLD_STALL_S a tick counts for.
    assert deadline_after_stall(103.0, 100.0, 100.02) == 103.0
    assert deadline_after_stall(103.0, 100.0, 100.0 + WORLD_STALL_S) == 103.0
    assert deadline_after_stall(103.0, 100.0, 110.0) == pytest.approx(113.0 - WORLD_STALL_S)


def test_a_world_starved_for_good_still_lets_a_silent_agent_go():
    """Every tick a second late: each still counts WORLD_STALL_S, so the deadline comes."""
    deadline, tick = 3.0, 0.0
    while tick < deadline:
        deadline = deadline_after_stall(deadline, tick, tick + 1.0)
        tick += 1.0
        assert tick < 100, 'the deadline never came'
    assert tick == pytest.approx(3.0 / WORLD_STALL_S)


def signed_cmd(step: int) -> bytes:
    data = serialize_message(ControlCommand(agent_id=2, step=step))
    return Signer(KEY, 2).sign('/agent_2/cmd', data, step)


def test_world_sims_window_reaches_back_as_far_as_a_rejoin_and_no_further():
    verifier = MessageVerifier(KEY, [1, 2], WINDOW)
    verifier.step = 500
    old = signed_cmd(500 - REJOIN_STEPS)
    assert verifier.verify('/agent_2/cmd', old).step == 500 - REJOIN_STEPS
    # The window is wide; a copy of a genuine message is still refused, by its counter.
    with pytest.raises(AuthError, match='replayed'):
        verifier.verify('/agent_2/cmd', old)
    with pytest.raises(AuthError, match='out_of_window'):
        verifier.verify('/agent_2/cmd', signed_cmd(500 - REJOIN_STEPS - 1))
    with pytest.raises(AuthError, match='out_of_window'):
        verifier.verify('/agent_2/cmd', signed_cmd(501))
