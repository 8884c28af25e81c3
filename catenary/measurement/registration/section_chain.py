"""A section's supports as a chain on a grid of trial positions: its marginal likelihood and posteriors.

The probability model of :mod:`.section_fit` at a given map and pair of standard deviations:
each support's trace evidence and table term on its grid of trials, and each span's length
tying a support to the next (a Gaussian of the lag between their trials, truncated to the
grid). The forward pass (:func:`forward_pass`, compiled) gives the marginal likelihood, which
the section fit's search evaluates ≈ 220 times per section; each span's transitions are one lag
density divided by its rows' sums, so the pass is a correlation and never builds the
``n_trials × n_trials`` matrices. The posteriors (once per section, at the maximum) take one
forward–backward pass with the matrices (:meth:`SectionChain.transitions`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .mapping import ChainageMap

__all__ = ["UNDERFLOW_ROW_SUM", "SectionChain", "forward_pass"]

#: A transition row whose sum of the lag's density (scaled to 1 at its peak) is below this is
#: normalised in logarithms instead (its span's length puts it far off the grid).
UNDERFLOW_ROW_SUM = 1e-280


def _log_normal(z2: np.ndarray, variance: float) -> np.ndarray:
    return -0.5 * z2 / variance - 0.5 * np.log(2.0 * np.pi * variance)


@njit(cache=True, nogil=True)
def forward_pass(e: np.ndarray, log_steps: np.ndarray, tiny: float):
    """The forward pass of the section's chain, without its transition matrices.

    ``alpha[k]`` is support k's filtered law on the grid (normalised), ``norm[k]`` its
    normaliser: the marginal likelihood is ``Σ ln norm + Σ top``. A span's transition from trial
    ``a`` to ``b`` is ``g(b − a) / Σ_b' g(b' − a)`` (the lag's density truncated to the grid,
    ``g = exp(log_steps)``, :meth:`SectionChain.log_steps`), so the product with the filtered law is a
    correlation of ``alpha / row sums`` with ``g``: ``O(n s²)`` without building the ``s × s``
    matrices. A row whose sum underflows (below ``tiny``: the span's length puts it far off the
    grid) is normalised in logarithms. Returns ``(alpha, norm, found)``; ``found`` is False
    where a support's law vanishes (the marginal likelihood is 0).
    """
    n, s = e.shape
    alpha = np.zeros((n, s))
    norm = np.zeros(n)
    g = np.empty(2 * s - 1)
    totals = np.empty(s)
    a = e[0] / s                                                    # the first support: uniform over its grid
    for k in range(n):
        if k:
            steps = log_steps[k - 1]
            top = steps.max()
            for j in range(2 * s - 1):
                g[j] = np.exp(steps[j] - top)
            totals[:] = 0.0
            for b in range(s):                                      # each row's sum over b in order,
                for r in range(s):                                  # the rows side by side
                    totals[r] += g[s - 1 - r + b]
            a = np.zeros(s)
            for r in range(s):
                first = s - 1 - r                                   # g's column of lag −r (b = 0)
                total = totals[r]
                if total > tiny:
                    u = alpha[k - 1, r] / total
                    for b in range(s):
                        a[b] += u * g[first + b]
                else:
                    row_top = steps[first]
                    for b in range(1, s):
                        row_top = max(row_top, steps[first + b])
                    log_total = 0.0
                    for b in range(s):
                        log_total += np.exp(steps[first + b] - row_top)
                    log_total = np.log(log_total) + row_top
                    for b in range(s):
                        a[b] += alpha[k - 1, r] * np.exp(steps[first + b] - log_total)
            for b in range(s):
                a[b] *= e[k, b]
        total = a.sum()
        norm[k] = total
        if not total > 0.0:
            return alpha, norm, False
        alpha[k] = a / total
    return alpha, norm, True


class SectionChain:
    """The section's model at given map and standard deviations: forward–backward on the grid.

    Parameters
    ----------
    grid_m : numpy.ndarray
        ``(n_supports, n_trials)``: recorded chainage of each support's trial positions, one
        step apart [m].
    log_likelihood : numpy.ndarray
        ``(n_supports, n_trials)``: the trace's log-likelihood at each trial [-].
    table_m, listed, lengths_m : numpy.ndarray
        Each support's table chainage [m], whether the table lists it, each span's type's
        length [m of the table].
    """

    def __init__(self, grid_m: np.ndarray, log_likelihood: np.ndarray, table_m: np.ndarray, listed: np.ndarray,
                 lengths_m: np.ndarray):
        self.grid = np.asarray(grid_m, dtype=float)
        self.log_l = np.asarray(log_likelihood, dtype=float)
        self.t = np.asarray(table_m, dtype=float)
        self.listed = np.asarray(listed, dtype=bool)
        self.lengths = np.asarray(lengths_m, dtype=float)
        self.step = float(self.grid[0, 1] - self.grid[0, 0])
        n = self.grid.shape[1]
        # trial b of the next support minus trial a of this one is (b − a) steps: a Toeplitz matrix
        self.lags = np.arange(-(n - 1), n) * self.step
        self.toeplitz = np.arange(n)[None, :] - np.arange(n)[:, None] + n - 1

    def table_terms(self, chainage_map: ChainageMap, table_std_m: float) -> np.ndarray:
        """Log-likelihood of each listed mast's table chainage at each trial position [-]."""
        expected = chainage_map.to_recorded(self.t)
        slope = chainage_map.slope(self.t)
        variance = (slope * table_std_m) ** 2 + self.step ** 2 / 12.0          # + the cell's quantisation
        out = _log_normal((self.grid - expected[:, None]) ** 2, variance[:, None]) + np.log(slope)[:, None]
        return np.where(self.listed[:, None], out, 0.0)

    def log_steps(self, chainage_map: ChainageMap, length_std_m: float) -> np.ndarray:
        """Log-density (up to a constant) of each span's recorded length at each lag of the grid:
        ``(n_spans, 2 n_trials − 1)``, lag ``(b − a)`` steps at column ``b − a + n_trials − 1``
        for trial ``a`` of a support and ``b`` of the next."""
        middle = self.t[:-1] + 0.5 * self.lengths
        expected = chainage_map.slope(middle) * self.lengths
        variance = length_std_m ** 2 + self.step ** 2 / 6.0
        d = (self.grid[1:, 0] - self.grid[:-1, 0] - expected)[:, None] + self.lags[None, :]
        return -0.5 * d * d / variance

    def transitions(self, chainage_map: ChainageMap, length_std_m: float) -> np.ndarray:
        """P(next support's trial | this support's trial) of each span, truncated to the grid:
        ``(n_spans, n_trials, n_trials)``, every span at once."""
        log_g = self.log_steps(chainage_map, length_std_m)
        p = np.exp(log_g - log_g.max(axis=1, keepdims=True))[:, self.toeplitz]
        total = p.sum(axis=2, keepdims=True)
        with np.errstate(invalid="ignore", divide="ignore"):        # such rows are done again below
            out = p / total
        # a row the span's length puts far off the grid: normalised in logarithms
        for k in np.flatnonzero(~np.all(total > UNDERFLOW_ROW_SUM, axis=(1, 2))):
            log_p = log_g[k][self.toeplitz]
            out[k] = np.exp(log_p - np.logaddexp.reduce(log_p, axis=1, keepdims=True))
        return out

    def run(self, chainage_map: ChainageMap, table_std_m: float, length_std_m: float, posterior: bool = False):
        """Marginal log-likelihood; with ``posterior``, also each support's posterior on the grid,
        the covariances of neighbouring supports (pairwise posteriors) and the table terms."""
        table = self.table_terms(chainage_map, table_std_m)
        log_e = self.log_l + table
        top = log_e.max(axis=1, keepdims=True)
        e = np.exp(log_e - top)
        alpha, norm, found = forward_pass(e, self.log_steps(chainage_map, length_std_m), UNDERFLOW_ROW_SUM)
        if not found:
            return (-np.inf, None) if posterior else -np.inf
        log_likelihood = float(np.sum(np.log(norm)) + np.sum(top))
        if not posterior:
            return log_likelihood
        moves = self.transitions(chainage_map, length_std_m)
        n = e.shape[0]
        beta = np.ones_like(e)
        for k in range(n - 2, -1, -1):
            beta[k] = moves[k] @ (e[k + 1] * beta[k + 1]) / norm[k + 1]
        gamma = alpha * beta
        gamma /= gamma.sum(axis=1, keepdims=True)
        # Cov(x_k, x_{k+1}) about the posterior means (raw second moments of chainages of
        # kilometres would cancel to noise where a posterior sits on one node)
        centred = self.grid - (self.grid * gamma).sum(axis=1, keepdims=True)
        cross = np.full(n, np.nan)
        for k in range(n - 1):
            xi = alpha[k][:, None] * moves[k] * (e[k + 1] * beta[k + 1])[None, :]
            xi /= xi.sum()
            cross[k] = float(centred[k] @ xi @ centred[k + 1])
        return log_likelihood, (gamma, cross, table)
