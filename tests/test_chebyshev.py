"""Chebyshev interpolation and the stacked matrix map the fast model applies per sample."""

import numpy as np

from catenary.chebyshev import BasisCache, StackedMap, fit_chebyshev


def _matrix_function(n_out, n_in, seed=0):
    """An analytic matrix function of (s, c, d): entries a + b / (1 + s) + e·c² + f·sin(d)."""
    rng = np.random.default_rng(seed)
    a, b, e, f = (rng.standard_normal((n_out, n_in)) for _ in range(4))

    def fun(p):
        return (a + b / (1.0 + p[0]) + e * p[1] ** 2 + f * np.sin(p[2])).ravel()
    return fun


def test_interpolant_converges_to_an_analytic_function():
    fun = _matrix_function(3, 2)
    lower, upper = [0.2, -1.0, 0.0], [0.8, 1.0, 0.5]
    points = np.random.default_rng(1).uniform(lower, upper, (200, 3))
    exact = np.array([fun(p) for p in points])
    # 1/(1+s) on [0.2, 0.8] has its pole 1.2 away: the error falls by ≈ 0.1 per degree; the
    # quadratic in c is exact from degree 2, sin(d) on [0, 0.5] is within 1e-9 at degree 6.
    errors = [np.abs(fit_chebyshev(fun, lower, upper, (d, 2, 6))(points) - exact).max() for d in (4, 8, 12)]
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 1e-9


def test_stacked_map_is_the_interpolated_matrix_times_x():
    """StackedMap (one GEMM with the coefficients side by side, then a compiled sum over the
    basis) against the interpolated matrix assembled per sample and applied by matmul; a
    constant dimension (lower = upper) and bases lent by a cache to a lower degree."""
    n_out, n_in, n = 4, 5, 1000
    fun = _matrix_function(n_out, n_in, seed=2)
    lower, upper = [0.2, 0.3, -0.5], [0.8, 0.3, 0.5]          # the second dimension constant
    rng = np.random.default_rng(3)
    points = rng.uniform(lower, upper, (n, 3))
    x = rng.standard_normal((n, n_in))
    high = fit_chebyshev(fun, lower, upper, (12, 5, 6))
    low = fit_chebyshev(fun, lower, upper, (5, 5, 3))
    assert high.degrees == (12, 0, 6)
    # high first: the low map takes truncated cached bases; low first: the cache must
    # recompute its rows at the higher degree the high map asks for
    for order in ((high, low), (low, high)):
        cache = BasisCache(points)
        for interp in order:
            per_sample = interp(points).reshape(n, n_out, n_in) @ x[:, :, None]
            mapped = StackedMap(interp, n_out, n_in)(points, x, cache)
            # both sum the same products in another order: rounding only (values of order 10)
            np.testing.assert_allclose(mapped, per_sample[:, :, 0], rtol=0, atol=1e-12)
            np.testing.assert_array_equal(interp.basis(points, cache), interp.basis(points))
