"""Spans that share a mast: standard errors and intervals robust to that dependence.

J(s) = Σ_k ln p_W(W_k; s) treats the measured spans as independent draws (paper §2.2). In a
line they are not quite: two consecutive spans of a section hang from one mast, so the ΔH of
that mast enters both (the right end of one span, the left end of the next), and the wires are
continuous over it. J is then a *composite* (independence) likelihood: its maximum is still a
consistent estimate of s, but its curvature overstates the information. With the per-span
scores ``g_k = ∂ ln p_W(W_k; θ)/∂θ`` at θ̂ and the observed information ``H = −∂²J/∂θ²``,
the covariance of θ̂ is the sandwich (Godambe)

    V = H⁻¹ K H⁻¹,   K = Σ_k g_k g_kᵀ + Σ_(a,b) (g_a g_bᵀ + g_b g_aᵀ),

the second sum over the pairs (a, b) of spans that share a mast (dependence beyond the next
span is neglected: a mast's ΔH enters only its two spans, and a second neighbour changes W by
less than 1 µm). K also absorbs any misspecification of the Gaussian law of W. A profile
likelihood ratio of a composite likelihood is, for one parameter θ_i, ``λ_i χ²₁`` with
``λ_i = V_ii / (H⁻¹)_ii``: the profile interval ends where J has dropped by ``λ_i χ²₁(1−α)/2``
instead of ``χ²₁(1−α)/2`` (Chandler & Bate, Biometrika 2007; Varin, Reid & Firth, Statistica
Sinica 2011).

How it is used (:func:`widening`): the reported covariance is the observed-information one with
each variance multiplied by ``max(λ_i, 1)`` — the sandwich may widen an interval, never narrow
it. K is estimated from the K measured spans themselves, so a λ_i below 1 is as likely the noise
of that estimate as a real excess of information; over 40 replicate lines of the default
campaign (``docs/identification.md``, "Spans that share a mast") the dropper σ's had λ ≈ 0.92 on average while their
observed-information intervals already covered the truth in 93–100 % of the lines.

Which spans share a mast is read from the data: two spans of one section whose end and start
chainages meet (:func:`adjacent_span_pairs`).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

__all__ = ["adjacent_span_pairs", "robust_covariance", "sandwich_covariance", "span_scores", "variance_inflation", "widened_covariance",
           "widening"]


def adjacent_span_pairs(section_id, start_chainage_m, end_chainage_m, *, tolerance_m: float = 1e-3) -> np.ndarray:
    """Pairs of spans that share a mast: same section, one's end chainage at the other's start.

    Parameters
    ----------
    section_id : array_like of str, shape (K,)
    start_chainage_m, end_chainage_m : array_like, shape (K,)
        Chainages of each span's left and right mast [m].
    tolerance_m : float
        Largest distance between the two chainages of a shared mast [m].

    Returns
    -------
    numpy.ndarray of int, shape (P, 2)
        Row indices ``(a, b)`` into the inputs, ``a`` the span on the left of the shared mast.
    """
    section = np.asarray(section_id).astype(str)
    start = np.asarray(start_chainage_m, dtype=float)
    end = np.asarray(end_chainage_m, dtype=float)
    if not (section.shape == start.shape == end.shape and start.ndim == 1):
        raise ValueError(f"expected three arrays of one length, got shapes {section.shape}, {start.shape}, {end.shape}")
    order = np.lexsort((start, section))
    a, b = order[:-1], order[1:]
    shared = (section[a] == section[b]) & (np.abs(end[a] - start[b]) <= tolerance_m)
    return np.column_stack([a[shared], b[shared]]).astype(int).reshape(-1, 2)


def span_scores(log_density: Callable[[np.ndarray], np.ndarray | None], theta: np.ndarray,
                step: float, log_density_many: Callable[[list], list] | None = None) -> np.ndarray:
    """Per-span scores ``∂ ln p_W(W_k; θ)/∂θ_i`` by central differences.

    Parameters
    ----------
    log_density : callable
        θ ↦ ``ln p_W(W_k; θ)`` for every span (K,), or None where J is not finite.
    theta : numpy.ndarray, shape (p,)
    step : float
        Difference step in θ (the Hessian's).
    log_density_many : callable, optional
        The list of points (θ ± h e_i, i in order) ↦ their ``log_density`` at once (e.g. in
        worker processes); default: ``log_density`` at each in turn.

    Returns
    -------
    numpy.ndarray, shape (K, p)
        NaN in a column whose difference could not be formed.
    """
    points = []
    for i in range(theta.size):
        e = np.zeros(theta.size)
        e[i] = step
        points += [theta + e, theta - e]
    values = log_density_many(points) if log_density_many is not None else [log_density(x) for x in points]
    columns = []
    for i in range(theta.size):
        up, down = values[2 * i], values[2 * i + 1]
        if up is None or down is None:
            columns.append(None)
        else:
            columns.append((np.asarray(up) - np.asarray(down)) / (2.0 * step))
    k = next((c.size for c in columns if c is not None), 0)
    return np.column_stack([np.full(k, np.nan) if c is None else c for c in columns]) if k else np.empty((0, theta.size))


def sandwich_covariance(covariance: np.ndarray, scores: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """``V = H⁻¹ K H⁻¹`` (module docstring) from ``H⁻¹`` = ``covariance`` and the span scores.

    Parameters
    ----------
    covariance : numpy.ndarray, shape (p, p)
        Inverse observed information ``(−∂²J/∂θ²)⁻¹``.
    scores : numpy.ndarray, shape (K, p)
        Per-span scores at θ̂ (:func:`span_scores`).
    pairs : numpy.ndarray of int, shape (P, 2)
        Spans that share a mast (:func:`adjacent_span_pairs`); empty for independent spans.

    Returns
    -------
    numpy.ndarray, shape (p, p)
        NaN where ``covariance`` or the scores are not finite.
    """
    covariance = np.asarray(covariance, dtype=float)
    scores = np.asarray(scores, dtype=float)
    if not (np.all(np.isfinite(covariance)) and np.all(np.isfinite(scores))):
        return np.full(covariance.shape, np.nan)
    pairs = np.asarray(pairs, dtype=int).reshape(-1, 2)
    k = scores.T @ scores
    if pairs.size:
        cross = scores[pairs[:, 0]].T @ scores[pairs[:, 1]]
        k += cross + cross.T
    v = covariance @ k @ covariance
    return 0.5 * (v + v.T)


def variance_inflation(covariance: np.ndarray, robust: np.ndarray) -> np.ndarray:
    """``λ_i = V_ii / (H⁻¹)_ii`` per coordinate: the factor on the profile's critical drop."""
    naive = np.diag(np.asarray(covariance, dtype=float))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.diag(np.asarray(robust, dtype=float)) / naive


def widening(covariance: np.ndarray, robust: np.ndarray) -> np.ndarray:
    """``max(λ_i, 1)``: the factor applied to each variance (module docstring); 1 where λ is not finite."""
    lam = variance_inflation(covariance, robust)
    return np.where(np.isfinite(lam), np.maximum(lam, 1.0), 1.0)


def widened_covariance(covariance: np.ndarray, robust: np.ndarray) -> np.ndarray:
    """``D H⁻¹ D`` with ``D = diag(√max(λ_i, 1))``: the observed-information covariance with its
    correlations kept and each variance widened by the sandwich where that is wider."""
    d = np.sqrt(widening(covariance, robust))
    return np.asarray(covariance, dtype=float) * np.outer(d, d)


def robust_covariance(log_density: Callable[[np.ndarray], np.ndarray | None], theta: np.ndarray, step: float,
                      covariance: np.ndarray, interior: np.ndarray, pairs: np.ndarray,
                      log_density_many: Callable[[list], list] | None = None) -> np.ndarray:
    """The sandwich over the ``interior`` coordinates of θ, embedded in a (p, p) array (NaN
    elsewhere): per-span scores by :func:`span_scores` (2p evaluations of ``log_density``, or of
    ``log_density_many`` at once) and :func:`sandwich_covariance` with the observed-information
    ``covariance``."""
    interior = np.asarray(interior, dtype=bool)
    scores = span_scores(log_density, np.asarray(theta, dtype=float), step, log_density_many)
    inside = np.ix_(interior, interior)
    out = np.full((interior.size, interior.size), np.nan)
    out[inside] = sandwich_covariance(np.asarray(covariance)[inside], scores[:, interior], pairs)
    return out
