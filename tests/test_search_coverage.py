"""The search-coverage diagnostic: synthetic targets scored against flown squares."""

from pathlib import Path
import runpy

import numpy as np
import pytest

from sat_world_sim.random_scenarios import RANDOM_BORN, RANDOM_LIFETIME
from sat_world_sim.search_coverage import area_seen, coverage, first_held, synthetic_targets
from sat_world_sim.search_coverage import SyntheticTargets

SCRIPT = runpy.run_path(str(Path(__file__).resolve().parents[1] / 'scripts' /
                            'search_coverage.py'))
SIDE = 10.0


def targets(*rows):
    """Return SyntheticTargets of (born, died, start, end) rows."""
    born, died, start, end = zip(*rows)
    return SyntheticTargets(np.array(born), np.array(died), np.array(start, dtype=float),
                            np.array(end, dtype=float))


def test_a_target_counts_from_the_first_square_that_holds_it_while_it_lives():
    walkers = targets((1, 100, (20.0, 20.0), (20.0, 20.0)),     # waits where a square passes
                      (50, 100, (20.0, 20.0), (20.0, 20.0)),    # born after that square
                      (1, 101, (0.0, 50.0), (100.0, 50.0)))     # walks 1 m a step along y = 50
    elsewhere = {1: np.array([90.0, 90.0]), 2: np.array([90.0, 10.0])}
    squares = [(k, elsewhere) for k in range(1, 120)]
    squares[9] = (10, {1: np.array([20.0, 20.0]), 2: np.array([90.0, 10.0])})
    squares[29] = (30, {1: np.array([60.0, 50.0])})      # the walker is at x = 29 then
    squares[60] = (61, {2: np.array([64.0, 54.0])})      # at x = 60: 4 m from its centre
    np.testing.assert_array_equal(first_held(walkers, squares, SIDE), [10, -1, 61])
    found = coverage(walkers, squares, SIDE)
    assert found.held_share == pytest.approx(2 / 3)
    assert found.mean_delay == pytest.approx(((10 - 1) + (61 - 1)) / 2)


def test_a_target_is_not_held_before_its_birth_or_after_its_death():
    walker = targets((20, 30, (50.0, 50.0), (50.0, 50.0)))
    over = {1: np.array([50.0, 50.0])}
    assert first_held(walker, [(19, over), (31, over)], SIDE)[0] == -1
    assert first_held(walker, [(19, over), (30, over)], SIDE)[0] == 30
    nothing = coverage(walker, [(25, {})], SIDE)
    assert nothing.held_share == 0.0 and np.isnan(nothing.mean_delay)


def test_area_seen_counts_each_cell_from_the_first_square_that_holds_it():
    # A 20 m x 10 m area of 1 m cells: one square over the left half at step 3, then one over
    # the middle at step 5 (the right half's cells from x = 10 to 15), never the right edge.
    seen = area_seen([(1, {}), (3, {1: np.array([5.0, 5.0])}), (5, {2: np.array([10.0, 5.0])})],
                     SIDE, 20.0, 10.0)
    assert seen.first.shape == (200,)
    assert seen.share_by(2) == 0.0
    assert seen.share_by(3) == pytest.approx(0.5)
    assert seen.share_by(5) == pytest.approx(0.75)
    # Unseen by step 5: the 5 columns x > 15. Within 2 m of the border: the columns x > 18
    # (2 x 10 cells) and the rows y < 2 or y > 8 of the other three (3 x 4); farther: 3 x 6.
    near, farther = seen.unseen_by(5, 2.0)
    close = seen.border_distance <= 2.0
    assert close.sum() == 200 - 16 * 6
    assert near == pytest.approx(32 / close.sum())
    assert farther == pytest.approx(18 / (200 - close.sum()))
    assert seen.border_distance.min() == pytest.approx(0.5)


def test_a_cells_longest_wait_runs_from_the_start_between_squares_and_to_the_end():
    # The squares of the test above, the run ending at step 8: the columns x < 5 are held at
    # step 3 only (waits 3, then 9 - 3), x 5-10 at 3 and 5 (3, 2, 4), x 10-15 at 5 (5, 4), and
    # the columns x > 15 never (the whole run plus one).
    seen = area_seen([(1, {}), (3, {1: np.array([5.0, 5.0])}), (5, {2: np.array([10.0, 5.0])}),
                      (8, {})], SIDE, 20.0, 10.0)
    columns = np.repeat([6, 4, 5, 9], 5)
    np.testing.assert_array_equal(seen.longest_wait.reshape(10, 20), np.tile(columns, (10, 1)))
    # Within 2 m of the border (104 cells) 64 waited more than 5 steps: the columns x < 2 and
    # x > 18 whole, the border rows of x 2-5 and 15-18; farther in (96) the 2 x 18 others.
    assert seen.waits(2.0, 5) == (9.0, 9.0, pytest.approx(64 / 104), pytest.approx(36 / 96))


def test_fresh_area_counts_what_no_square_held_in_the_window_before():
    # A 100 m x 10 m area: a square at x = 5 (100 cells, never seen), one 4 m on (40 new
    # cells), the same pose again (nothing new), then, after six steps without agents, there
    # once more: new for a 5-step window, not for a 10-step one.
    at = {1: np.array([5.0, 5.0])}
    on = {1: np.array([9.0, 5.0])}
    seen = area_seen([(1, at), (2, on), (3, on), (4, {}), (10, on)], SIDE, 100.0, 10.0,
                     windows=(1, 5, 10))
    assert seen.fresh_by(1) == pytest.approx((100 + 40 + 0 + 100) / 4)
    assert seen.fresh_by(5) == pytest.approx((100 + 40 + 0 + 100) / 4)
    assert seen.fresh_by(10) == pytest.approx((100 + 40 + 0 + 0) / 4)
    # Two agents on one square bring its cells in once, over two agent-steps.
    both = area_seen([(1, {1: at[1], 2: at[1]})], SIDE, 100.0, 10.0, windows=(1,))
    assert both.fresh_by(1) == pytest.approx(100 / 2)
    assert area_seen([(1, at)], SIDE, 100.0, 10.0).fresh == ()
    with pytest.raises(ValueError, match='at least 1'):
        area_seen([(1, at)], SIDE, 100.0, 10.0, windows=(0,))


def test_synthetic_targets_are_drawn_as_the_random_default_draws_them():
    drawn = synthetic_targets(2000, 7, 100.0, 80.0)
    assert drawn is synthetic_targets(2000, 7, 100.0, 80.0)      # one draw per worker
    life = drawn.died - drawn.born + 1
    assert drawn.born.min() >= RANDOM_BORN[0] and drawn.born.max() <= RANDOM_BORN[1]
    assert life.min() >= RANDOM_LIFETIME[0] and life.max() <= RANDOM_LIFETIME[1]
    for ends in (drawn.start, drawn.end):
        assert np.all((ends >= 0.0) & (ends <= [100.0, 80.0]))
    assert np.abs(drawn.end - drawn.start).mean() > 10.0        # they walk
    static = synthetic_targets(2000, 7, 100.0, 80.0, static=True)
    np.testing.assert_array_equal(static.end, static.start)
    np.testing.assert_array_equal(static.start, drawn.start)
    _, halfway = drawn.alive_at(100)
    assert np.all((halfway >= 0.0) & (halfway <= [100.0, 80.0]))


def test_the_script_scores_a_tour_and_refuses_what_it_cannot_run(capsys):
    assert SCRIPT['main'](['--pattern', 'tour', '--seeds', '1', '--synthetic', '300',
                           '--jobs', '1']) == 0
    out = capsys.readouterr().out
    share = float(out.split('held by a square ')[1].split(' %')[0])
    assert 50.0 < share <= 100.0
    # The tour sweeps every lane by k = 100 (README: the oracle tour).
    assert 'k = 150 100.0' in out and 'border 0.0' in out
    # Evenly phased on one closed tour, each step brings in nearly a square's v a = 40 m^2
    # that no square held for 60 steps (the lap's period over four agents is 64).
    fresh = float(out.split('W = 60 ')[1].split(' ')[0])
    assert 30.0 < fresh <= 40.0
    # Over a run three times its first sweep (--steps) no cell waits longer than that sweep
    # (about 80 steps), let alone a lone sweep of the profile's walks.
    assert SCRIPT['main'](['--pattern', 'tour', '--seeds', '1', '--synthetic', '300',
                           '--jobs', '1', '--steps', '250']) == 0
    waits = capsys.readouterr().out.split('longest wait of a cell')[1]
    near, farther = (float(waits.split(part)[1].split(' ')[0].rstrip(',;'))
                     for part in ('of the border ', 'farther in '))
    assert 60.0 < near <= 100.0 and 60.0 < farther <= 100.0
    assert '(357 steps), % of each: 0.0 and 0.0' in waits
    with pytest.raises(SystemExit):
        SCRIPT['main'](['--pattern', 'strips', '--with-targets'])
    with pytest.raises(SystemExit):
        SCRIPT['main'](['--set', 'search.no_such_parameter=1'])
    with pytest.raises(SystemExit):
        SCRIPT['main'](['--steps', '0'])
