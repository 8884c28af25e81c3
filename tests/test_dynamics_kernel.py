"""The compiled kernels of the dynamic model against SciPy on the same matrices."""

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.linalg import cholesky_banded, solve

from catenary.dynamics_kernel import band_diagonals, band_rows, band_solve, banded_products


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


def test_banded_products_equal_the_sparse_products():
    n, kd = 150, 5
    m, c = spd_banded(n, kd, seed=3), spd_banded(n, 4, seed=4)   # C narrower than the band: zeros padded
    rng = np.random.default_rng(2)
    p, q, f = rng.normal(size=n), rng.normal(size=n), rng.normal(size=n)
    padded = [np.concatenate([np.zeros(kd), v, np.zeros(kd)]) for v in (p, q)]
    out = np.empty(n)
    banded_products(band_diagonals(m, kd), band_diagonals(c, kd), *padded, f, out)
    np.testing.assert_allclose(out, f + m @ p + c @ q, rtol=1e-13, atol=1e-12)


def test_band_diagonals_refuse_a_wider_matrix():
    with pytest.raises(ValueError, match="half-bandwidth 3"):
        band_diagonals(spd_banded(40, 5, seed=0), 3)
