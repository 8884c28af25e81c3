"""Spans that share a mast: adjacency, per-span scores and the sandwich covariance."""

import numpy as np
import pytest

from catenary.stages.identification.dependence import (adjacent_span_pairs, sandwich_covariance, span_scores,
                                                variance_inflation, widened_covariance, widening)


def test_adjacent_spans_are_those_of_one_section_that_meet_at_a_mast():
    # Rows out of order, two sections, and a hole in S1 (a span rejected upstream between 120 and
    # 180 m): only spans whose end and start chainages meet share a mast.
    section = ["S1", "S2", "S1", "S1", "S2", "S1"]
    start = [60.0, 1000.0, 0.0, 180.0, 1060.0, 240.0]
    end = [120.0, 1060.0, 60.0, 240.0, 1120.0, 300.0]
    pairs = adjacent_span_pairs(section, start, end)
    assert sorted(map(tuple, pairs.tolist())) == [(1, 4), (2, 0), (3, 5)]
    assert adjacent_span_pairs(["A"], [0.0], [60.0]).shape == (0, 2)
    with pytest.raises(ValueError, match="one length"):
        adjacent_span_pairs(["A", "B"], [0.0], [60.0, 120.0])


def test_span_scores_are_the_derivatives_of_each_log_density():
    # ln p_k(θ) = −(y_k − θ0)² / (2 e^{2θ1}) − θ1: analytic scores (y − θ0)/v and (y − θ0)²/v − 1.
    y = np.array([0.3, -1.2, 2.0, 0.7])
    theta = np.array([0.1, 0.2])

    def log_density(t):
        return -(y - t[0]) ** 2 / (2.0 * np.exp(2.0 * t[1])) - t[1]

    v = np.exp(2 * theta[1])
    expected = np.column_stack([(y - theta[0]) / v, (y - theta[0]) ** 2 / v - 1.0])
    # Central differences: error step² × third derivative / 6 (≤ 3e-5 here).
    np.testing.assert_allclose(span_scores(log_density, theta, 1e-3), expected, atol=1e-4)
    assert np.isnan(span_scores(lambda t: None if t[1] > 0.2 else log_density(t), theta, 1e-3)[:, 1]).all()


def test_sandwich_measures_the_variance_of_a_mean_over_spans_that_share_masts():
    # y_k = (a_k + a_{k+1}) / √2 with a i.i.d. N(0, 1) per mast: each span is N(μ, 1), but
    # neighbours are correlated ρ = 1/2, so var(ȳ) = (1 + 2ρ (K−1)/K)/K ≈ 2/K — twice what
    # the independence likelihood's curvature (1/K) says. The sandwich with the lag-1 cross
    # terms must find λ ≈ 2 and the variance of the estimate over replicates.
    rng = np.random.default_rng(7)
    k, n_rep = 200, 2000
    a = rng.standard_normal((n_rep, k + 1))
    y = (a[:, :-1] + a[:, 1:]) / np.sqrt(2.0)
    pairs = np.column_stack([np.arange(k - 1), np.arange(1, k)])
    naive = np.array([[1.0 / k]])                     # (−∂²J/∂μ²)⁻¹ with unit variance
    estimates = y.mean(axis=1)
    v = np.array([sandwich_covariance(naive, (yr - yr.mean())[:, None], pairs)[0, 0] for yr in y])
    exact = (1.0 + (k - 1) / k) / k
    # Monte Carlo: the empirical variance over 2000 replicates has a relative se of √(2/2000) ≈ 3 %;
    # the mean sandwich is downward biased by O(1/K) (centring at ȳ) and has its own ≈ 0.3 % se.
    assert estimates.var() == pytest.approx(exact, rel=0.1)
    assert v.mean() == pytest.approx(exact, rel=0.03)
    lam = variance_inflation(naive, np.array([[v.mean()]]))
    assert lam[0] == pytest.approx(2.0, rel=0.03)
    # Without the pairs, the sandwich is the independence one: λ ≈ 1 for these unit-variance spans.
    v0 = np.mean([sandwich_covariance(naive, (yr - yr.mean())[:, None], np.empty((0, 2), int))[0, 0] for yr in y])
    assert v0 == pytest.approx(1.0 / k, rel=0.03)


def test_widening_never_narrows_and_keeps_correlations():
    cov = np.array([[4.0, 1.0], [1.0, 1.0]])
    robust = np.array([[8.0, 0.0], [0.0, 0.5]])        # λ = 2 and 0.5
    np.testing.assert_allclose(widening(cov, robust), [2.0, 1.0])
    w = widened_covariance(cov, robust)
    np.testing.assert_allclose(np.diag(w), [8.0, 1.0])
    assert w[0, 1] / np.sqrt(w[0, 0] * w[1, 1]) == pytest.approx(cov[0, 1] / np.sqrt(cov[0, 0] * cov[1, 1]))
    assert sandwich_covariance(cov, np.full((3, 2), np.nan), np.empty((0, 2), int)).shape == (2, 2)
    np.testing.assert_allclose(widening(cov, np.full((2, 2), np.nan)), [1.0, 1.0])
