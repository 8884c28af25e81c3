"""Tests of :mod:`catenary.stages.identification.normality` (Henze–Zirkler multivariate normality test)."""

import numpy as np
import pytest
from scipy.stats import binom

from catenary.stages.identification import normality
from catenary.stages.identification.normality import HenzeZirklerResult, henze_zirkler


def _reference_samples():
    """The three reference samples, drawn in this exact order from one seeded generator."""
    rng = np.random.default_rng(0)
    gaussian = rng.normal(size=(117, 9))
    gamma = rng.gamma(2.0, size=(117, 9))
    mixed = np.column_stack([rng.normal(size=(117, 8)), rng.exponential(size=117)])
    return gaussian, gamma, mixed


def test_reference_values():
    # Values from an independent implementation (explicit pseudo-inverse and full n×n
    # distance matrix, as in pingouin / R MVN).
    gaussian, gamma, mixed = _reference_samples()
    expected = [(gaussian, 0.973945, 0.365, dict(abs=5e-4)),  # p given to 3 digits only
                (gamma, 1.064276, 1.031e-07, dict(rel=1e-3)),
                (mixed, 1.013237, 0.006086, dict(rel=1e-3))]
    for sample, hz, p, p_tol in expected:
        result = henze_zirkler(sample)
        assert isinstance(result, HenzeZirklerResult)
        assert result.statistic == pytest.approx(hz, abs=1e-5)
        assert result.p_value == pytest.approx(p, **p_tol)
        assert (result.n_samples, result.dimension, result.alpha) == (117, 9, 0.05)
        assert result.normal == (result.p_value >= 0.05)
    assert henze_zirkler(gaussian).normal
    assert not henze_zirkler(gamma).normal
    assert not henze_zirkler(mixed).normal


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_affine_invariance(seed):
    rng = np.random.default_rng(seed)
    sample = rng.gamma(2.0, size=(80, 4))  # non-Gaussian, so HZ is not near its null value
    a = rng.normal(size=(4, 4)) + 4.0 * np.eye(4)   # invertible, moderately conditioned
    b = rng.normal(scale=100.0, size=4)
    transformed = sample @ a.T + b                   # x -> A x + b, row-wise
    assert np.linalg.cond(a) < 1e3
    original = henze_zirkler(sample)
    assert henze_zirkler(transformed).statistic == pytest.approx(original.statistic, rel=1e-9)
    # Pure rescaling by very different units is also exact to rounding.
    rescaled = sample * np.array([1e-6, 1.0, 1e3, 1e8])
    assert henze_zirkler(rescaled).statistic == pytest.approx(original.statistic, rel=1e-9)


def test_blocked_equals_unblocked(monkeypatch):
    rng = np.random.default_rng(4)
    z = rng.normal(size=(203, 3))
    c = 0.7
    # Independent unblocked reference: full n×n matrix of squared differences.
    full = np.exp(-c * ((z[:, None, :] - z[None, :, :]) ** 2).sum(axis=-1)).sum()
    for block_rows in (1, 2, 7, 64, 203, 1000):
        assert normality._pairwise_kernel_sum(z, c, block_rows) == pytest.approx(full, rel=1e-12)

    # End to end: a tiny block budget (1–2 rows per block) against the default (one block).
    sample = rng.exponential(size=(203, 3))
    default = henze_zirkler(sample)
    monkeypatch.setattr(normality, "_BLOCK_BYTES", 8 * 203 + 1)
    tiny = henze_zirkler(sample)
    assert tiny.statistic == pytest.approx(default.statistic, rel=1e-12)
    assert tiny.p_value == pytest.approx(default.p_value, rel=1e-12)


def test_calibration_under_null():
    rng = np.random.default_rng(5)
    n_rep, level = 200, 0.05
    rejections = sum(not henze_zirkler(rng.normal(size=(100, 3)), alpha=level).normal
                     for _ in range(n_rep))
    # If the test has its nominal size, the number of rejections is Binomial(200, 0.05):
    # the band is the central 99.9% interval of that distribution, so it allows for Monte
    # Carlo noise only, and a correctly sized test would fail it for < 1 seed in 1000 (the
    # seed is fixed, so the test is deterministic). A mis-sized p-value (e.g. wrong lognormal
    # moments, wrong β) moves the rate well outside [2, 21] of 200.
    low, high = binom.interval(0.999, n_rep, level)
    assert low <= rejections <= high


@pytest.mark.parametrize("sample, expected", [
    (np.arange(10.0), "2-D array"),
    (np.random.default_rng(6).normal(size=(3, 3)), "more observations than dimensions"),
    (np.random.default_rng(6).normal(size=(2, 5)), "more observations than dimensions"),
    (np.zeros((0, 2)), "more observations than dimensions"),
])
def test_shape_errors(sample, expected):
    with pytest.raises(ValueError, match=expected):
        henze_zirkler(sample)


def test_value_errors():
    rng = np.random.default_rng(7)
    sample = rng.normal(size=(50, 3))
    with_nan = sample.copy()
    with_nan[4, 1] = np.nan
    with pytest.raises(ValueError, match=r"expected finite values.*row\(s\) \[4\]"):
        henze_zirkler(with_nan)
    constant = sample.copy()
    constant[:, 2] = 0.1   # 0.1 is not exact in binary: the centred column is ~1e-17, not 0
    with pytest.raises(ValueError, match=r"expected every column to vary.*\[2\]"):
        henze_zirkler(constant)
    dependent = sample.copy()
    dependent[:, 2] = 2.0 * sample[:, 0] - sample[:, 1]
    with pytest.raises(ValueError, match="expected a non-singular covariance"):
        henze_zirkler(dependent)
    with pytest.raises(ValueError, match=r"alpha: expected a level in \(0, 1\)"):
        henze_zirkler(sample, alpha=1.5)
