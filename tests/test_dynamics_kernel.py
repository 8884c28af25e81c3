"""The compiled kernels of the dynamic model against SciPy on the same matrices."""

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.linalg import cholesky_banded, solve

from catenary.physics.dynamics_kernel import _solve_small, band_diagonals, band_rows, band_solve, mass_band, symmetric_band_product


def spd_banded(n: int, kd: int, seed: int) -> sp.csr_matrix:
    """A random symmetric positive-definite matrix of half-bandwidth ``kd`` (diagonally dominant)."""
    rng = np.random.default_rng(seed)
    diagonals = [rng.normal(size=n - d) for d in range(1, kd + 1)]
    a = sp.diags(diagonals, list(range(1, kd + 1)), shape=(n, n))
    a = a + a.T
    return (a + sp.diags(np.abs(a).sum(axis=1).A1 + 1.0)).tocsr()


def lapack_band(matrix: sp.csr_matrix, kd: int) -> np.ndarray:
    n = matrix.shape[0]
    ab = np.zeros((kd + 1, n))
    for d in range(kd + 1):
        ab[kd - d, d:] = matrix.diagonal(d)
    return ab


@pytest.mark.parametrize("kd", [5, 7, 2])      # 5: the register path; others: the general loop
def test_band_solve_equals_a_dense_solve(kd):
    # Round-off of a well-conditioned system (diagonally dominant): 1e-12 relative.
    n = 203
    k = spd_banded(n, kd, seed=kd)
    rows, inv_diag_sq = band_rows(cholesky_banded(lapack_band(k, kd), lower=False))
    rhs = np.random.default_rng(1).normal(size=n)
    out = band_solve(rows, inv_diag_sq, rhs, np.empty(n))
    np.testing.assert_allclose(out, solve(k.toarray(), rhs, assume_a="pos"), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("kd, width", [(5, 5), (5, 4), (7, 7), (2, 2)])  # 5: the unrolled path
def test_symmetric_band_product_equals_the_sparse_product(kd, width):
    # A narrower matrix than the band (width 4 in a band of 5) leaves zero diagonals; round-off
    # of eleven terms of order 10: 1e-13 relative.
    n = 150
    m = spd_banded(n, width, seed=3)
    rng = np.random.default_rng(2)
    x, f = rng.normal(size=n), rng.normal(size=n)
    out = np.empty(n)
    symmetric_band_product(mass_band(m, kd), np.concatenate([np.zeros(kd), x, np.zeros(kd)]), f, out)
    np.testing.assert_allclose(out, f + m @ x, rtol=1e-13, atol=1e-12)


def test_band_diagonals_refuse_a_wider_matrix():
    with pytest.raises(ValueError, match="half-bandwidth 3"):
        band_diagonals(spd_banded(40, 5, seed=0), 3)


@pytest.mark.parametrize("n", [1, 4, 9])
def test_small_dense_solve_equals_numpy_and_flags_a_singular_system(n):
    # The active set's system (a few slack droppers and the contact): partial pivoting, so a
    # zero leading entry is no obstacle; round-off of a system of condition ≈ 10: 1e-13.
    rng = np.random.default_rng(n)
    a = rng.normal(size=(n, n)) + 3 * np.eye(n)
    if n > 1:
        a[0, 0] = 0.0
    b = rng.normal(size=n)
    x = np.empty(n)
    assert _solve_small(a.copy(), b.copy(), x)
    np.testing.assert_allclose(x, np.linalg.solve(a, b), rtol=1e-13, atol=1e-13)
    singular = a.copy()
    singular[-1] = 0.0
    assert not _solve_small(singular, b.copy(), np.empty(n))
