"""Tensor-product Chebyshev interpolation of vector-valued functions, evaluated in bulk.

Used to carry the tension dependence of the condensed static operator: the exact
operator is computed at Chebyshev nodes and interpolated between them, which converges
spectrally for the smooth (analytic) dependence on tension.

:class:`StackedMap` applies an interpolated matrix to one vector per sample, ``M(p_i) @ x_i``
for 10⁴ samples at once: one GEMM with every coefficient matrix side by side, then each
sample's sum over the basis (a compiled loop). Several maps evaluated at the same points share
their one-dimensional bases through a :class:`BasisCache`.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import product
from typing import Callable

import numpy as np
from numba import njit


@dataclass(frozen=True)
class ChebyshevInterpolant:
    """Interpolant of a function R^d → R^m on a box.

    Attributes
    ----------
    lower, upper : numpy.ndarray
        Box bounds, shape (d,); a dimension with ``lower == upper`` is constant (degree 0).
    degrees : tuple of int
        Polynomial degree per dimension.
    coefficients : numpy.ndarray
        Chebyshev coefficients, shape (K, m): one row per tensor term, all Π(degree + 1) of
        them C-ordered over the dimensions, or those of ``terms``.
    terms : numpy.ndarray or None
        The multi-indices (K, d) of the terms kept by :meth:`pruned`; None for the full
        tensor product.
    """

    lower: np.ndarray
    upper: np.ndarray
    degrees: tuple[int, ...]
    coefficients: np.ndarray
    terms: np.ndarray | None = None

    def basis(self, points: np.ndarray, cache: "BasisCache | None" = None) -> np.ndarray:
        """Tensor Chebyshev basis at ``points`` (N, d), shape (N, Π(degree + 1)).

        ``cache`` (built on the same ``points``) lends one-dimensional bases already computed
        for another interpolant on the same interval."""
        return self.basis_rows(points, cache).T

    def basis_rows(self, points: np.ndarray, cache: "BasisCache | None" = None) -> np.ndarray:
        """The same basis, one row per basis function: shape (Π(degree + 1), N)."""
        cache = BasisCache(points) if cache is None else cache
        out = None
        for dim, deg in enumerate(self.degrees):
            if deg == 0:                 # a constant dimension: a factor 1
                continue
            b = cache.rows(dim, self.lower[dim], self.upper[dim], deg)
            if self.terms is not None:
                b = b[self.terms[:, dim]]
                out = b if out is None else out * b
            else:
                out = b if out is None else (out[:, None, :] * b[None, :, :]).reshape(-1, b.shape[1])
        return np.ones((self.coefficients.shape[0], cache.points.shape[0])) if out is None else out

    def pruned(self, rtol: float) -> "ChebyshevInterpolant":
        """The interpolant without its smallest tensor terms: those, smallest first, whose
        largest coefficients sum to at most ``rtol`` times the largest coefficient of all.

        Since ``|T_k| ≤ 1`` on the box, no value moves by more than that sum (times the
        input's size, for a matrix applied to a vector). A product of Chebyshev series
        decays along every dimension, so its high-high corner holds terms far below the
        truncation error of either degree alone: those are the ones dropped.
        """
        magnitude = np.max(np.abs(self.coefficients), axis=1)
        order = np.argsort(magnitude, kind="stable")
        dropped = order[np.cumsum(magnitude[order]) <= rtol * magnitude.max()]
        if dropped.size == 0:
            return self
        keep = np.setdiff1d(np.arange(magnitude.size), dropped)
        grid = (np.argwhere(np.ones(tuple(d + 1 for d in self.degrees), dtype=bool)) if self.terms is None
                else self.terms)
        return ChebyshevInterpolant(self.lower, self.upper, self.degrees, self.coefficients[keep], grid[keep])

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """Interpolated values at ``points`` (N, d), shape (N, m)."""
        return self.basis(points) @ self.coefficients


class BasisCache:
    """One-dimensional Chebyshev bases of one set of points (N, d), computed once per dimension
    and interval at the largest degree asked and lent, truncated, to lower degrees (T_0…T_k are
    the first rows of T_0…T_K)."""

    def __init__(self, points: np.ndarray):
        self.points = np.atleast_2d(points)
        self._rows: dict = {}

    def rows(self, dim: int, lower: float, upper: float, degree: int) -> np.ndarray:
        """T_0…T_degree along dimension ``dim`` mapped from [lower, upper], shape (degree + 1, N)."""
        key = (dim, float(lower), float(upper))
        have = self._rows.get(key)
        if have is None or have.shape[0] <= degree:
            have = _chebyshev_rows(_to_unit(self.points[:, dim], lower, upper), degree)
            self._rows[key] = have
        return have[:degree + 1]


def _chebyshev_rows(t: np.ndarray, degree: int) -> np.ndarray:
    """Chebyshev polynomials T_0..T_degree at ``t`` ∈ [−1, 1], shape (degree + 1, N)."""
    t = np.asarray(t, dtype=float).ravel()
    # One contiguous row per degree (4× faster than writing strided columns at N = 10⁴), the
    # same arithmetic: T_j = 2 t T_(j−1) − T_(j−2).
    b = np.empty((degree + 1, t.size))
    b[0] = 1.0
    if degree >= 1:
        b[1] = t
    for j in range(2, degree + 1):
        np.multiply(t, b[j - 1], out=b[j])
        b[j] *= 2.0
        b[j] -= b[j - 2]
    return b


def fit_chebyshev(fun: Callable[[np.ndarray], np.ndarray], lower, upper, degrees) -> ChebyshevInterpolant:
    """Interpolate ``fun`` (point (d,) → values (m,)) at the tensor Chebyshev nodes of the first kind."""
    lower = np.atleast_1d(np.asarray(lower, dtype=float))
    upper = np.atleast_1d(np.asarray(upper, dtype=float))
    if np.any(upper < lower):
        raise ValueError(f"upper bounds {upper} below lower bounds {lower}")
    degrees = tuple(0 if upper[i] == lower[i] else int(d) for i, d in enumerate(np.broadcast_to(degrees, lower.shape)))
    nodes = [np.cos(np.pi * (np.arange(d + 1) + 0.5) / (d + 1)) for d in degrees]
    grid_points = [np.array([_from_unit(t, lower[i], upper[i]) for i, t in enumerate(combo)])
                   for combo in product(*nodes)]
    values = np.array([np.asarray(fun(p), dtype=float).ravel() for p in grid_points])
    shape = tuple(d + 1 for d in degrees)
    coef = values.reshape(shape + (values.shape[1],))
    for axis, d in enumerate(degrees):
        n = d + 1
        k = np.arange(n)
        transform = (2.0 / n) * np.cos(np.pi * np.outer(k, k + 0.5) / n)  # (j, node)
        transform[0] *= 0.5
        coef = np.moveaxis(np.tensordot(transform, coef, axes=([1], [axis])), 0, axis)
    return ChebyshevInterpolant(lower, upper, degrees, coef.reshape(-1, values.shape[1]))


def _to_unit(x: np.ndarray, lo: float, hi: float) -> np.ndarray:
    if hi == lo:
        return np.zeros_like(x, dtype=float)
    return (2.0 * x - (lo + hi)) / (hi - lo)


def _from_unit(t: float, lo: float, hi: float) -> float:
    return 0.5 * (lo + hi) + 0.5 * (hi - lo) * t


#: Size of the intermediate of one block of :class:`StackedMap` [bytes].
_BLOCK_BYTES = 2 ** 19


class StackedMap:
    """A matrix map ``x ↦ M(p) @ x``, M (n_out × n_in) interpolated in Chebyshev form,
    ``M(p) = Σ_k T_k(p) M_k`` over K terms.

    Two orders of the same sums, chosen by shape; both give ``M(p_i) @ x_i`` to rounding:

    * **K ≤ n_in** (few terms, a wide input): the coefficient matrices ``M_k`` are stacked side
      by side so that one GEMM applies all of them to a block of samples,
      ``Y = X [M_0ᵀ … M_(K−1)ᵀ]``; each sample's row of Y is then summed over the basis,
      ``Σ_k T_k(p_i) Y_ik`` (:func:`_sum_over_basis`, compiled). With the loop the whole
      force map takes 1.6 ms against 2.3 ms for NumPy's batched matmul (one-off measurement on
      random matrices of its shapes, N = 10⁴, one BLAS thread, 2026-11-27).
    * **K > n_in** (a 2-D interpolant: 1/T_MW with the CW clamp offset or T_CW): one GEMM
      forms each sample's matrix, ``M(p_i) = Σ_k T_k(p_i) M_k`` — an inner dimension of K, not
      n_in — and a compiled loop applies it (:func:`_apply_per_sample`). At the CW offset
      model's shapes it measured 1.6–1.8× faster (force map, K = 65, n_in = 12: 8.7–9.5 → 4.7–5.7 ms;
      compliance map, K = 25, n_in = 9: 2.5 → 1.5 ms; N = 10⁴, 2026-11-27).

    Several maps evaluated at the same points share their one-dimensional bases through a
    :class:`BasisCache`.
    """

    def __init__(self, interpolant: ChebyshevInterpolant, n_out: int, n_in: int):
        k = interpolant.coefficients.shape[0]
        self.interpolant = interpolant
        self.n_basis = k
        self.n_out = n_out
        self.basis_first = k > n_in
        if self.basis_first:
            self.stacked = np.ascontiguousarray(interpolant.coefficients)       # (K, n_out n_in)
        else:
            self.stacked = interpolant.coefficients.reshape(k, n_out, n_in).transpose(2, 0, 1).reshape(n_in, k * n_out)

    def __call__(self, points: np.ndarray, x: np.ndarray, cache: BasisCache | None = None) -> np.ndarray:
        """``M(points_i) @ x_i`` for every row i, shape (N, n_out); ``cache`` as in
        :meth:`ChebyshevInterpolant.basis`."""
        if self.n_basis == 1 and self.interpolant.terms is None:   # constant: K = 1 ≤ n_in
            return x @ self.stacked
        basis = self.interpolant.basis_rows(points, cache)
        out = np.empty((x.shape[0], self.n_out))
        # Blocks of rows whose intermediate (rows × its width) stays in a core's cache:
        # measured 1.4× faster than one pass over 10⁴ samples, whose intermediate is 11 MB.
        rows = max(64, _BLOCK_BYTES // (8 * self.stacked.shape[1]))
        for start in range(0, x.shape[0], rows):
            block = slice(start, start + rows)
            if self.basis_first:
                _apply_per_sample(basis[:, block].T @ self.stacked, x[block], out[block])
            else:
                _sum_over_basis(x[block] @ self.stacked, basis[:, block], out[block])
        return out


@njit(cache=True, nogil=True)
def _sum_over_basis(y, basis, out):       # pragma: no cover - compiled; tested through StackedMap
    """``out[i, o] = Σ_k basis[k, i] y[i, k n_out + o]`` (the basis sum of :class:`StackedMap`)."""
    n_out = out.shape[1]
    for i in range(y.shape[0]):
        for o in range(n_out):
            out[i, o] = 0.0
        for k in range(basis.shape[0]):
            b = basis[k, i]
            base = k * n_out
            for o in range(n_out):
                out[i, o] += b * y[i, base + o]


@njit(cache=True, nogil=True)
def _apply_per_sample(matrices, x, out):  # pragma: no cover - compiled; tested through StackedMap
    """``out[i, o] = Σ_j matrices[i, o n_in + j] x[i, j]``: each sample's own matrix (row-major)
    applied to its own vector."""
    n_out = out.shape[1]
    n_in = x.shape[1]
    for i in range(x.shape[0]):
        for o in range(n_out):
            base = o * n_in
            s = 0.0
            for j in range(n_in):
                s += matrices[i, base + j] * x[i, j]
            out[i, o] = s
