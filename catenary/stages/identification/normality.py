"""Henze–Zirkler test of multivariate normality, vectorised and memory-bounded, and the
identification's tests of the model's law of W and of the data (:func:`normality_report`).

Reference: N. Henze and B. Zirkler (1990), "A class of invariant consistent tests for
multivariate normality", *Communications in Statistics – Theory and Methods* 19(10):3595–3617.

The statistic and its lognormal p-value approximation follow the usual implementation (R
package ``MVN``, ``pingouin.multivariate_normality``). For a sample ``x_1 … x_n`` in R^d with
mean ``x̄`` and biased (1/n) covariance ``S``, let ``D_ij = (x_i − x_j)ᵀ S⁻¹ (x_i − x_j)`` and
``D_i = (x_i − x̄)ᵀ S⁻¹ (x_i − x̄)``, and the smoothing parameter

    β = (1/√2) · (n (2d + 1) / 4)^(1/(d + 4)).

Then

    HZ = n · [ 1/n² Σ_ij exp(−β² D_ij / 2)
               − 2 (1 + β²)^(−d/2) · 1/n Σ_i exp(−β² D_i / (2 (1 + β²)))
               + (1 + 2β²)^(−d/2) ],

and under normality HZ is approximately lognormal with the first two moments given by
Henze & Zirkler; the p-value is the lognormal upper tail at HZ.

The statistic is affine invariant and has no units: any consistent unit system may be used for
the sample. ``S⁻¹`` is never formed: the data are whitened with the Cholesky factor of the
(column-scaled) covariance, so that the Mahalanobis distances are squared Euclidean distances of
the whitened points. The double sum costs O(n² d) operations; it is accumulated over blocks of
rows whose kernel matrix stays below ~64 MB, so memory is O(n d) plus that bound, whatever n.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_triangular
from scipy.stats import lognorm

from catenary.physics.fast import FastSpanModel
from .design import RandomInput
from .result import IdentificationResult
from .synthetic import simulate_deflections

__all__ = ["HenzeZirklerResult", "henze_zirkler", "normality_report", "normality_tests"]

#: Upper bound on the size of one block of the pairwise kernel matrix, in bytes.
_BLOCK_BYTES = 64 * 2**20


@dataclass(frozen=True)
class HenzeZirklerResult:
    """Outcome of :func:`henze_zirkler`.

    Attributes
    ----------
    statistic : float
        Henze–Zirkler statistic HZ (dimensionless, ≥ 0 up to rounding).
    p_value : float
        Upper-tail p-value from the lognormal approximation of the null distribution of HZ.
    normal : bool
        ``True`` if normality is not rejected at level ``alpha``, i.e. ``p_value >= alpha``.
    alpha : float
        Significance level used for ``normal``.
    n_samples : int
        Number of observations n.
    dimension : int
        Dimension d of each observation.
    """

    statistic: float
    p_value: float
    normal: bool
    alpha: float
    n_samples: int
    dimension: int


def _whiten(sample: np.ndarray) -> np.ndarray:
    """Centre and whiten ``sample`` so that Mahalanobis distances become Euclidean ones.

    Parameters
    ----------
    sample : numpy.ndarray
        Finite observations, shape (n, d), with n > d.

    Returns
    -------
    numpy.ndarray
        ``z`` of shape (n, d) with ``z_i = L⁻¹ (x_i − x̄)`` where ``S = L Lᵀ`` is the biased
        covariance, so that ``‖z_i − z_j‖² = D_ij`` and ``‖z_i‖² = D_i``.

    Raises
    ------
    ValueError
        If a column is constant or the covariance is singular to working precision.
    """
    n, d = sample.shape
    centred = sample - sample.mean(axis=0)
    # Scale columns to unit spread first (an affine map, so HZ is unchanged): the Cholesky
    # factorisation and the rank test then see a correlation matrix, independent of units.
    scale = np.sqrt(np.mean(centred**2, axis=0))
    magnitude = np.max(np.abs(sample), axis=0)
    constant = scale <= 8.0 * np.finfo(float).eps * np.maximum(magnitude, np.finfo(float).tiny)
    if np.any(constant):
        raise ValueError(f"sample: expected every column to vary, but column(s) "
                         f"{np.flatnonzero(constant).tolist()} are constant; the covariance "
                         f"matrix is singular")
    centred = centred / scale
    corr = centred.T @ centred / n
    corr = 0.5 * (corr + corr.T)
    eigenvalues = np.linalg.eigvalsh(corr)
    tolerance = eigenvalues[-1] * max(n, d) * np.finfo(float).eps
    if eigenvalues[0] <= tolerance:
        raise ValueError(f"sample: expected a non-singular covariance matrix, but its smallest "
                         f"eigenvalue (after scaling columns to unit variance) is "
                         f"{eigenvalues[0]:.3g} ≤ {tolerance:.3g}; the columns are linearly "
                         f"dependent")
    chol = np.linalg.cholesky(corr)
    return solve_triangular(chol, centred.T, lower=True, check_finite=False).T


def _pairwise_kernel_sum(z: np.ndarray, c: float, block_rows: int) -> float:
    """Σ_ij exp(−c ‖z_i − z_j‖²) over all ordered pairs, including i = j.

    Parameters
    ----------
    z : numpy.ndarray
        Points, shape (n, d).
    c : float
        Positive kernel rate.
    block_rows : int
        Number of rows of the kernel matrix evaluated at once (≥ 1).

    Returns
    -------
    float
        The double sum. By symmetry only the blocks on and right of the diagonal are
        evaluated (off-diagonal blocks counted twice), which halves the O(n² d) cost; memory
        is O(block_rows · n).
    """
    n = z.shape[0]
    sq = np.einsum("ij,ij->i", z, z)
    total = 0.0
    for start in range(0, n, block_rows):
        stop = min(start + block_rows, n)
        # ‖z_i − z_j‖² = ‖z_i‖² + ‖z_j‖² − 2 z_i·z_j, clipped at 0 against rounding.
        dist = z[start:stop] @ z[start:].T
        dist *= -2.0
        dist += sq[start:stop, None]
        dist += sq[None, start:]
        np.maximum(dist, 0.0, out=dist)
        dist *= -c
        np.exp(dist, out=dist)
        width = stop - start
        total += dist[:, :width].sum() + 2.0 * dist[:, width:].sum()
        del dist  # free this block before the next is allocated: one block alive at a time
    return float(total)


def _lognormal_p_value(statistic: float, n: int, d: int, beta: float) -> float:
    """Upper-tail p-value of HZ from Henze & Zirkler's lognormal approximation."""
    b2 = beta**2
    b4 = b2**2
    b8 = b4**2
    a = 1.0 + 2.0 * b2
    wb = (1.0 + b2) * (1.0 + 3.0 * b2)
    mu = 1.0 - a ** (-d / 2) * (1.0 + d * b2 / a + d * (d + 2) * b4 / (2.0 * a**2))
    si2 = (2.0 * (1.0 + 4.0 * b2) ** (-d / 2)
           + 2.0 * a ** (-d) * (1.0 + 2.0 * d * b4 / a**2 + 3.0 * d * (d + 2) * b8 / (4.0 * a**4))
           - 4.0 * wb ** (-d / 2) * (1.0 + 3.0 * d * b4 / (2.0 * wb)
                                     + d * (d + 2) * b8 / (2.0 * wb**2)))
    pmu = np.log(np.sqrt(mu**4 / (si2 + mu**2)))
    psi = np.sqrt(np.log1p(si2 / mu**2))
    # sf rather than 1 − cdf: keeps relative accuracy for very small p-values.
    return float(lognorm.sf(statistic, psi, scale=np.exp(pmu)))


def henze_zirkler(sample: np.ndarray, alpha: float = 0.05) -> HenzeZirklerResult:
    """Henze–Zirkler test of the hypothesis that ``sample`` comes from a normal distribution.

    Parameters
    ----------
    sample : numpy.ndarray
        Observations, shape (n, d): one row per observation, one column per variable, all
        finite, with n > d and a non-singular covariance. Any units; the test is affine
        invariant.
    alpha : float, optional
        Significance level in (0, 1), default 0.05.

    Returns
    -------
    HenzeZirklerResult
        Statistic HZ, its p-value and the decision ``p_value >= alpha``.

    Raises
    ------
    ValueError
        If ``sample`` is not a finite 2-D array, if n ≤ d, if a column is constant or the
        covariance matrix is singular, or if ``alpha`` is not in (0, 1).

    Notes
    -----
    Cost is O(n² d) time (the double sum over pairs of observations) and O(n d) memory plus
    one block of the pairwise kernel matrix of at most ~64 MB; n = 10⁵ is feasible but takes
    on the order of a minute. See the module docstring for the definitions.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> henze_zirkler(rng.normal(size=(117, 9))).normal
    True
    """
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha: expected a level in (0, 1), got {alpha!r}")
    x = np.asarray(sample, dtype=float)
    if x.ndim != 2:
        raise ValueError(f"sample: expected a 2-D array of shape (n, d) (one row per "
                         f"observation), got {x.ndim} dimension(s) with shape {x.shape}")
    n, d = x.shape
    if d < 1 or n <= d:
        raise ValueError(f"sample: expected more observations than dimensions (n > d ≥ 1), "
                         f"got n = {n}, d = {d}")
    if not np.all(np.isfinite(x)):
        bad = np.flatnonzero(~np.all(np.isfinite(x), axis=1))
        raise ValueError(f"sample: expected finite values, found NaN or inf in row(s) "
                         f"{bad[:10].tolist()}{' …' if bad.size > 10 else ''}")

    z = _whiten(x)
    beta = (n * (2 * d + 1) / 4.0) ** (1.0 / (d + 4)) / np.sqrt(2.0)
    b2 = beta**2
    block_rows = max(1, min(n, _BLOCK_BYTES // (8 * n)))
    pair_sum = _pairwise_kernel_sum(z, b2 / 2.0, block_rows)
    centre_sum = float(np.sum(np.exp(-b2 / (2.0 * (1.0 + b2)) * np.einsum("ij,ij->i", z, z))))
    statistic = n * (pair_sum / n**2
                     - 2.0 * (1.0 + b2) ** (-d / 2) * centre_sum / n
                     + (1.0 + 2.0 * b2) ** (-d / 2))
    p_value = _lognormal_p_value(statistic, n, d, beta)
    return HenzeZirklerResult(statistic=float(statistic), p_value=p_value,
                              normal=bool(p_value >= alpha), alpha=float(alpha),
                              n_samples=int(n), dimension=int(d))


def _hz_dict(values: np.ndarray, alpha: float, description: str) -> dict:
    x = np.asarray(values, dtype=float)
    out = {"sample": description}
    if x.shape[0] <= x.shape[1]:
        out.update(statistic=None, p_value=None, normal=None, alpha=float(alpha), n_samples=int(x.shape[0]),
                   dimension=int(x.shape[1]),
                   reason=f"{x.shape[0]} observations for {x.shape[1]} variables: the test needs more "
                          "observations than variables")
        return out
    try:
        r = henze_zirkler(x, alpha=alpha)
    except ValueError as exc:          # e.g. a singular covariance: fewer random inputs than droppers
        out.update(statistic=None, p_value=None, normal=None, alpha=float(alpha), n_samples=int(x.shape[0]),
                   dimension=int(x.shape[1]), reason=str(exc))
        return out
    out.update(statistic=r.statistic, p_value=r.p_value, normal=r.normal, alpha=r.alpha, n_samples=r.n_samples,
               dimension=r.dimension)
    return out


def normality_report(model: FastSpanModel, start: tuple[RandomInput, ...], result: IdentificationResult,
                     data_w_m: np.ndarray, *, n_samples: int = 10_000, seed: int = 0,
                     system_height_mode: str = "shared", alpha: float = 0.05) -> dict:
    """Henze–Zirkler test of the model law of W at s0 and at s_opt, and of the data.

    The model samples are i.i.d.: ``n_samples`` taut spans drawn by plain Monte Carlo from the
    Gamma laws (:func:`.synthetic.simulate_deflections`, seed ``seed``, the same draws at s0 and
    s_opt). The test's null distribution assumes independent observations: a scrambled Sobol
    design is far more even than a random sample and gives p ≈ 1 whatever the law (HZ ≈ 0.96 at
    N = 1e4 for N2, where i.i.d. samples give ≈ 1.0), and a Latin hypercube, stratified in every
    input, is more even than a random sample too; so the design of J is not what is tested.

    Parameters
    ----------
    model : FastSpanModel
        Fast model of the span type.
    start : tuple of RandomInput
        s0.
    result : IdentificationResult
        Gives s_opt.
    data_w_m : numpy.ndarray, shape (K, n)
        Measured W [m].
    n_samples : int
        Size of each model sample.
    seed : int
        Seed of the model samples.
    system_height_mode : {"shared", "independent"}
    alpha : float
        Level of the decisions ``normal``.

    Returns
    -------
    dict
        ``model_s0``, ``model_s_opt``, ``data``: each ``sample`` (description), ``statistic``,
        ``p_value``, ``normal`` (normality not rejected at ``alpha``), ``alpha``, ``n_samples``,
        ``dimension``; the statistic, p-value and decision are ``None`` (with a ``reason``) when
        there are no more observations than variables.
    """
    return {name: test() for name, test in normality_tests(model, start, result, data_w_m, n_samples=n_samples, seed=seed,
                                                            system_height_mode=system_height_mode, alpha=alpha).items()}


def normality_tests(model: FastSpanModel, start: tuple[RandomInput, ...], result: IdentificationResult,
                    data_w_m: np.ndarray, *, n_samples: int = 10_000, seed: int = 0,
                    system_height_mode: str = "shared", alpha: float = 0.05) -> dict:
    """The three tests of :func:`normality_report` (its parameters), each a callable of nothing
    that returns its entry: to be run where the caller likes (in worker processes)."""
    mu0 = np.array([s.mean for s in start])
    sd0 = np.array([s.sigma for s in start])
    what = f"{n_samples} i.i.d. taut spans (plain Monte Carlo, seed {seed})"
    draw = dict(n_spans=n_samples, seed=seed, system_height_mode=system_height_mode)
    return {
        "model_s0": lambda: _hz_dict(simulate_deflections(model, mu0, sd0, **draw), alpha, f"model W at s0: {what}"),
        "model_s_opt": lambda: _hz_dict(simulate_deflections(model, result.means, result.sigmas, **draw), alpha,
                                        f"model W at s_opt: {what}"),
        "data": lambda: _hz_dict(data_w_m, alpha, "measured W (converged spans of corrected.parquet)"),
    }
