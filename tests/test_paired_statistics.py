import numpy as np
import pytest
from scipy import stats

from sat_world_sim.paired_statistics import ALPHA, BOOTSTRAP_SEED, paired_difference
from sat_world_sim.paired_statistics import paired_values, ratio_of_means

# Detected shares of two configurations on the same 12 seeds (made up, with ties and a zero
# difference, as real shares have).
X = np.array([0.5, 0.75, 1.0, 0.25, 0.5, 0.8, 0.6, 1.0, 0.4, 0.5, 0.7, 0.9])
R = np.array([0.25, 0.5, 1.0, 0.0, 0.5, 0.6, 0.2, 0.75, 0.4, 0.25, 0.5, 0.6])


def test_paired_difference_agrees_with_scipy_on_known_data():
    result = paired_difference(X, R)
    assert result.n == 12
    assert result.estimate == pytest.approx(np.mean(X - R))
    assert result.p_value == pytest.approx(stats.wilcoxon(X - R).pvalue)
    reference = stats.bootstrap((X, R), lambda a, b, axis: np.mean(a - b, axis=axis),
                                paired=True, vectorized=True, method='BCa',
                                rng=np.random.default_rng(BOOTSTRAP_SEED))
    assert (result.low, result.high) == pytest.approx(tuple(reference.confidence_interval))
    assert result.low < result.estimate < result.high


def test_wilcoxon_exact_p_of_ten_positive_differences():
    # Every one of the 2^10 sign patterns is equally likely under H0; all ten positive is the
    # most extreme of them on each side: p = 2 / 1024.
    result = paired_difference(np.arange(1.0, 11.0), np.zeros(10))
    assert result.p_value == pytest.approx(2.0 / 1024.0)
    assert result.significant and result.p_value < ALPHA


def test_all_zero_differences_give_p_one_and_a_point_interval():
    values = np.linspace(0.0, 1.0, 50)
    result = paired_difference(values, values.copy())
    assert (result.estimate, result.low, result.high, result.p_value) == (0.0, 0.0, 0.0, 1.0)
    assert not result.significant


def test_fewer_than_two_seeds_have_no_interval():
    assert np.isnan(paired_difference([], []).p_value)
    one = paired_difference([1.0], [0.5])
    assert one.estimate == 0.5 and np.isnan(one.low) and np.isnan(one.high)
    with pytest.raises(ValueError, match='length'):
        paired_difference([1.0, 2.0], [1.0])


def test_ratio_of_means_with_its_paired_bootstrap_interval():
    # Each seed's value is exactly half its reference: every resample's ratio is 0.5.
    reference = np.linspace(0.2, 1.0, 30)
    ratio = ratio_of_means(0.5 * reference, reference)
    assert (ratio.estimate, ratio.low, ratio.high) == pytest.approx((0.5, 0.5, 0.5))
    noisy = ratio_of_means(X, R)
    assert noisy.estimate == pytest.approx(np.mean(X) / np.mean(R))
    assert noisy.low < noisy.estimate < noisy.high
    assert np.isnan(ratio_of_means([1.0, 2.0], [0.0, 0.0]).estimate)


def test_paired_values_keep_the_seeds_both_sides_have():
    x, r = paired_values({1: 0.5, 2: None, 3: 0.2, 4: float('nan'), 5: 1.0},
                         {1: 0.1, 2: 0.3, 3: 0.4, 4: 0.5, 6: 0.9})
    np.testing.assert_array_equal(x, [0.5, 0.2])
    np.testing.assert_array_equal(r, [0.1, 0.4])
