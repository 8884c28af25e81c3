"""Chebyshev interpolation and the stacked matrix map the fast model applies per sample."""

import numpy as np
import pytest

from catenary.physics.chebyshev import BasisCache, StackedMap, fit_chebyshev


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


@pytest.mark.parametrize("n_in", [5, 30])
def test_stacked_map_is_the_interpolated_matrix_times_x(n_in):
    """StackedMap against the interpolated matrix assembled per sample and applied by matmul;
    a constant dimension (lower = upper) and bases lent by a cache to a lower degree. With 5
    inputs both maps take the basis-first order (K > n_in); with 30 the low map (K = 24) takes
    the stacked GEMM and the compiled sum over the basis."""
    n_out, n = 4, 1000
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
    assert StackedMap(high, n_out, n_in).basis_first
    assert StackedMap(low, n_out, n_in).basis_first == (n_in == 5)


def test_pruning_drops_the_cross_terms_of_a_separable_function_and_keeps_its_bound():
    """A sum of a function of s and one of d has no s·d terms: pruning finds them at rounding
    level and drops them all. A product keeps its cross terms. Either way the values move by
    no more than the dropped coefficients' sum (|T_k| ≤ 1)."""
    rng = np.random.default_rng(4)
    a, b, f = (rng.standard_normal(6) for _ in range(3))
    lower, upper = [0.2, 0.0], [0.8, 0.5]
    points = rng.uniform(lower, upper, (500, 2))
    rtol = 1e-12
    separable = fit_chebyshev(lambda p: a + b / (1.0 + p[0]) + f * np.sin(p[1]), lower, upper, (10, 6))
    pruned = separable.pruned(rtol)
    assert pruned.terms is not None
    assert np.all((pruned.terms[:, 0] == 0) | (pruned.terms[:, 1] == 0))
    assert pruned.terms.shape[0] == 11 + 7 - 1          # every pure term is far above 1e-12
    bound = rtol * np.abs(separable.coefficients).max()
    assert np.abs(pruned(points) - separable(points)).max() <= bound
    product = fit_chebyshev(lambda p: a * np.exp(p[0]) * np.cos(p[1]), lower, upper, (10, 6))
    kept = product.pruned(rtol)
    assert np.any((kept.terms[:, 0] > 0) & (kept.terms[:, 1] > 0))
    assert np.abs(kept(points) - product(points)).max() <= rtol * np.abs(product.coefficients).max()
    # pruning a pruned interpolant works on its kept terms (their multi-indices, not the full
    # grid's) and keeps its bound; a map of kept terms is the same map
    again = kept.pruned(1e-9)
    assert {tuple(t) for t in again.terms} <= {tuple(t) for t in kept.terms}
    assert np.abs(again(points) - kept(points)).max() <= 1e-9 * np.abs(kept.coefficients).max()
    x = rng.standard_normal((500, 3))
    matrix = fit_chebyshev(lambda p: np.outer(a[:2], [1.0, p[0], p[1] ** 2]).ravel() * np.exp(p[0] * p[1]),
                           lower, upper, (10, 6)).pruned(rtol)
    per_sample = matrix(points).reshape(500, 2, 3) @ x[:, :, None]
    np.testing.assert_allclose(StackedMap(matrix, 2, 3)(points, x), per_sample[:, :, 0], rtol=0, atol=1e-12)
