"""Each span's own inputs given its W: the paper's Bayesian step, span by span.

The identification gives the laws of a span type's inputs ``X = [L_1 … L_n, T_MW, ΔH]`` (one ΔH
per mast in ``independent`` mode); a span's corrected W then tells more about *its* inputs. With
the identified laws as the prior and a Gaussian measurement error ``ε ~ N(0, Σ)`` on W,

    p(x | W) ∝ p(x) · exp(−½ (W − f(x))ᵀ Σ⁻¹ (W − f(x)))

with ``f`` the fast static model of the identification (:class:`~catenary.physics.fast.FastSpanModel`,
same neighbours, exact to the FE model), its slack droppers solved: a dropper a centimetre or
two too long in the middle of a span goes slack (N2's dropper 5 at +1.1 cm), and W then no longer
depends on how much longer it is — its posterior is the prior beyond the length where it
slackens, which the fault component below makes a probability of being out of tolerance.

The prior, its fault component, the laws' uncertainty and the normal-score coordinates are
:mod:`.prior`'s.

Method: Laplace proposal, importance weights
--------------------------------------------
1. The mode ``ẑ`` of every span at once by Gauss–Newton (central-difference Jacobian of ``f`` in
   ``z``, one evaluation of the fast model for all spans and directions, a halving line search;
   the contaminated prior through its responsibilities, as in EM), started at the prior's
   centre and, with a fault component, at each dropper alone explaining the span
   (:func:`global_modes`); ``H = diag(λ) + J̃ᵀ J̃`` at the mode is the Laplace precision.
2. ``M`` draws from a multivariate Student t (``df`` degrees of freedom, scale ``H⁻¹``, one set of
   standard draws for all spans: common random numbers, one seed) centred on ``ẑ`` (and, with
   a fault component, half of them on the mode without it), weighted by
   posterior / proposal with the exact ``f``. The t's heavy tails keep the weights bounded where
   the posterior is wider than the Laplace approximation; the effective sample size
   ``(Σw)² / Σw²`` is written per span, and a span whose weights degenerate (ESS below
   :data:`MIN_EFFECTIVE_FRACTION` of ``M``) says so in its ``status``.

W is nearly linear in the inputs over a span's posterior (its width is the measurement's), so
the Laplace step alone is close; the weights remove what is left of the Gamma laws' skew and of
the fast model's curvature in T_MW. Accuracy is measured against a long random-walk Metropolis
chain on the same posterior (``tests/test_maintenance.py``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy import stats

from catenary.plumbing.workers import map_blocks
from .prior import SpanPrior, output_names

__all__ = ["MIN_EFFECTIVE_FRACTION", "Posterior", "global_modes", "posterior_modes", "span_posteriors",
           "weighted_quantiles"]

#: A span whose effective sample size falls below this fraction of the draws is marked.
MIN_EFFECTIVE_FRACTION = 0.05
#: A span whose whitened residual at the mode, ``|L⁻¹(W − f(x̂))|²``, exceeds the χ²_n quantile
#: at 1 − this is marked: no taut span of the model explains its W (a slack dropper, a fault
#: the fast model cannot carry, or an effect it does not have).
MISFIT_LEVEL = 1e-3
#: Spans per block of :func:`span_posteriors` (its unit of work for the worker processes): enough
#: rows for the vectorised Gauss–Newton (128 spans × 10 starts × 22 Jacobian points) and few
#: enough that 2 workers share the 500 spans of a 1 000-span line's span type evenly.
BLOCK_SPANS = 128
#: Central-difference step of the Jacobian in normal scores (W is linear in z to 1e-3 of its
#: change over this step: the inputs move by 1e-3 of their σ).
JACOBIAN_STEP = 1e-3


@dataclass
class Posterior:
    """Per span and input, the posterior of a span's inputs (:func:`span_posteriors`).

    Attributes
    ----------
    names : tuple of str
        The inputs and the dropper forces, :func:`output_names` order (q = d + n of them).
    mean, q05, q95 : numpy.ndarray, shape (K, q)
        Posterior mean and 5 % / 95 % quantiles, in each one's unit.
    p_outside : numpy.ndarray, shape (K, q)
        Posterior probability of lying outside ``[lower, upper]`` (NaN where no limit is given).
    mode_z : numpy.ndarray, shape (K, d)
        Posterior mode in normal scores (the Laplace centre).
    mode_converged : numpy.ndarray of bool, shape (K,)
        Gauss–Newton reached its tolerance.
    effective_samples : numpy.ndarray, shape (K,)
        ``(Σw)² / Σw²`` of the importance weights.
    n_samples : int
        Draws per span.
    misfit_p_value : numpy.ndarray, shape (K,)
        P(χ²_n > the whitened residual at the mode): below :data:`MISFIT_LEVEL`, the span's W is
        not what any taut span of the model gives.
    draws_z : numpy.ndarray, shape (K, m, d), optional
        ``m`` equally weighted draws per span from its posterior, in normal scores (the weighted
        draws resampled); None unless asked for.
    """

    names: tuple[str, ...]
    mean: np.ndarray
    q05: np.ndarray
    q95: np.ndarray
    p_outside: np.ndarray
    mode_z: np.ndarray
    mode_converged: np.ndarray
    effective_samples: np.ndarray
    n_samples: int
    misfit_p_value: np.ndarray
    draws_z: np.ndarray | None = None

    def with_rows(self, rows: np.ndarray, other: "Posterior") -> "Posterior":
        """A copy with the spans ``rows`` taken from ``other`` (their posteriors under other laws)."""
        out = {}
        for name in ("mean", "q05", "q95", "p_outside", "mode_z", "mode_converged", "effective_samples",
                     "misfit_p_value", "draws_z"):
            mine, theirs = getattr(self, name), getattr(other, name)
            if mine is None or theirs is None:
                out[name] = None if mine is None else mine
                continue
            mine = mine.copy()
            mine[rows] = theirs
            out[name] = mine
        return Posterior(names=self.names, n_samples=self.n_samples, **out)

    @property
    def status(self) -> np.ndarray:
        """Per span: ``ok``, or why its posterior is not to be trusted as written."""
        out = np.full(self.mean.shape[0], "ok", dtype=object)
        low = self.effective_samples < MIN_EFFECTIVE_FRACTION * self.n_samples
        out[low] = "few effective samples"
        out[self.misfit_p_value < MISFIT_LEVEL] = "W not explained by a taut span"
        out[~self.mode_converged] = "mode not converged"
        return out


def weighted_quantiles(values: np.ndarray, weights: np.ndarray, levels: tuple[float, ...]) -> np.ndarray:
    """Quantiles of weighted samples along the last-but-one axis.

    ``values`` (K, M, d), ``weights`` (K, M) summing to one per span; returns (len(levels), K, d).
    The empirical CDF puts each sample at the middle of its weight (the Hazen rule), and the
    quantile is interpolated linearly between samples.
    """
    order = np.argsort(values, axis=1)
    v = np.take_along_axis(values, order, axis=1)
    w = np.take_along_axis(np.broadcast_to(weights[:, :, None], values.shape), order, axis=1)
    cdf = np.cumsum(w, axis=1) - 0.5 * w
    out = np.empty((len(levels), values.shape[0], values.shape[2]))
    for a, level in enumerate(levels):
        idx = np.clip(np.sum(cdf < level, axis=1), 1, values.shape[1] - 1)          # (K, d)
        c0 = np.take_along_axis(cdf, idx[:, None, :] - 1, axis=1)[:, 0]
        c1 = np.take_along_axis(cdf, idx[:, None, :], axis=1)[:, 0]
        v0 = np.take_along_axis(v, idx[:, None, :] - 1, axis=1)[:, 0]
        v1 = np.take_along_axis(v, idx[:, None, :], axis=1)[:, 0]
        t = np.clip((level - c0) / np.where(c1 > c0, c1 - c0, 1.0), 0.0, 1.0)
        out[a] = v0 + t * (v1 - v0)
    return out


def _whitened(prior: SpanPrior, z: np.ndarray, w_obs: np.ndarray, l_inv: np.ndarray):
    """Whitened residuals L⁻¹(W − f) (K, n) and the bad-point flag (K,) at z (K, d)."""
    f, bad = prior.deflections(z)
    return np.einsum("kij,kj->ki", l_inv, w_obs - f), bad


def _objective(prior, z, r, bad):
    return np.where(bad, np.inf, prior.neg_log_prior(z)[0] + 0.5 * np.sum(r * r, axis=1))


def _jacobian(prior: SpanPrior, z: np.ndarray, l_inv: np.ndarray) -> np.ndarray:
    """Whitened Jacobian ``L⁻¹ ∂f/∂z`` (K, n, d) by central differences, all spans at once."""
    k, d = z.shape
    eye = np.eye(d)
    h = JACOBIAN_STEP
    steps = np.concatenate([z[:, None, :] + h * eye, z[:, None, :] - h * eye], axis=1)       # (K, 2d, d)
    f, _ = prior.deflections(steps.reshape(-1, d))
    f = f.reshape(k, 2 * d, -1)
    return np.einsum("kij,kjd->kid", l_inv, (f[:, :d] - f[:, d:]).transpose(0, 2, 1) / (2 * h))


def posterior_modes(prior: SpanPrior, w_obs: np.ndarray, l_inv: np.ndarray, *, start: np.ndarray | None = None,
                    max_iterations: int = 40, tolerance: float = 1e-7
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Local modes of every span's posterior in normal scores, by vectorised Gauss–Newton (the
    contaminated droppers' prior by its responsibilities, as in EM).

    Parameters
    ----------
    start : numpy.ndarray, shape (K, d), optional
        Starting points (default: the prior's centre, z = 0).

    Returns
    -------
    z : numpy.ndarray, shape (K, d)
    precision : numpy.ndarray, shape (K, d, d)
        ``diag(λ) + J̃ᵀ J̃`` at the mode (the Laplace approximation's inverse covariance).
    objective : numpy.ndarray, shape (K,)
        −log posterior at the mode, up to a constant.
    converged : numpy.ndarray of bool, shape (K,)
        The last step was below ``tolerance`` (in normal scores), or no step lowered the
        objective beyond rounding (a stationary point).
    """
    k, d = w_obs.shape[0], prior.dimension
    z = np.zeros((k, d)) if start is None else np.array(start, dtype=float)
    r, bad = _whitened(prior, z, w_obs, l_inv)
    phi = _objective(prior, z, r, bad)
    converged = np.zeros(k, dtype=bool)
    eye = np.eye(d)
    for _ in range(max_iterations):
        # Only the spans still moving are evaluated: a span's iterations are its own, so the cost
        # is the sum of the spans' iterations, not the slowest span's times every span.
        a = np.flatnonzero(~converged)
        if a.size == 0:
            break
        za, ra = z[a], r[a]
        jw = _jacobian(prior, za, l_inv[a])
        lam = prior.neg_log_prior(za)[1]
        precision = lam[:, :, None] * eye + np.einsum("kid,kie->kde", jw, jw)
        gradient = np.einsum("kid,ki->kd", jw, ra) - lam * za                                  # −∇φ
        step = np.linalg.solve(precision, gradient[:, :, None])[:, :, 0]
        scale = np.ones(a.size)
        floor = 1e-10 * (1.0 + np.abs(phi[a]))                                                  # rounding of φ
        for _ in range(20):                                                                     # halve until φ falls
            trial = za + scale[:, None] * step
            r_t, bad_t = _whitened(prior, trial, w_obs[a], l_inv[a])
            phi_t = _objective(prior, trial, r_t, bad_t)
            worse = ~(phi_t <= phi[a] + floor)
            if not worse.any():
                break
            scale[worse] *= 0.5
        moved = phi_t <= phi[a] + floor
        small = np.max(np.abs(scale[:, None] * step), axis=1) < tolerance
        converged[a] = small | ~moved
        z[a[moved]], r[a[moved]], phi[a[moved]] = trial[moved], r_t[moved], phi_t[moved]
    # The Laplace precision at the mode itself.
    jw = _jacobian(prior, z, l_inv)
    lam = prior.neg_log_prior(z)[1]
    precision = lam[:, :, None] * eye + np.einsum("kid,kie->kde", jw, jw)
    return z, precision, phi, converged


def global_modes(prior: SpanPrior, w_obs: np.ndarray, l_inv: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """The posterior mode of every span, and the mode without the fault component.

    Without faults the posterior is log-concave to the fast model's curvature: one mode, from
    z = 0. A faulty dropper is a mode of its own, which Gauss–Newton from the no-fault mode does not
    reach (the narrow law holds it back): each dropper in turn is started where it alone would
    explain the span's W from the prior's centre (least squares along its column), and the
    lowest of these modes and the no-fault one kept.

    Returns
    -------
    z, precision, converged
        As :func:`posterior_modes`, at the lowest mode found.
    no_fault : (z, precision)
        The mode and precision with ``fault_probability`` 0 (a second centre for the proposal).
    """
    clean = dataclasses.replace(prior, fault_probability=0.0) if prior.fault_probability > 0 else prior
    z0, p0, _, c0 = posterior_modes(clean, w_obs, l_inv)
    if prior.fault_probability <= 0:
        return z0, p0, c0, (z0, p0)
    k, d = z0.shape
    n = prior.n_droppers
    centre = np.zeros((k, d))
    r_c, _ = _whitened(prior, centre, w_obs, l_inv)
    jw = _jacobian(prior, centre, l_inv)
    starts = np.repeat(z0[:, None, :], n + 1, axis=1)                                          # (K, n + 1, d)
    for j in range(n):
        col = jw[:, :, j]
        starts[:, j + 1] = 0.0
        starts[:, j + 1, j] = np.einsum("ki,ki->k", col, r_c) / np.einsum("ki,ki->k", col, col)
    z, p, phi, c = posterior_modes(prior, np.repeat(w_obs, n + 1, axis=0), np.repeat(l_inv, n + 1, axis=0),
                                   start=starts.reshape(-1, d))
    best = np.argmin(phi.reshape(k, n + 1), axis=1) + (n + 1) * np.arange(k)
    return z[best], p[best], c[best] & c0, (z0, p0)


def span_posteriors(prior: SpanPrior, w_obs: np.ndarray, noise_covariance_m2: np.ndarray, *,
                    lower: np.ndarray | None = None, upper: np.ndarray | None = None, n_samples: int = 4000,
                    seed: int = 0, df: float = 6.0, chunk_spans: int = 16, n_draws: int = 0,
                    workers: int = 1, block_spans: int = BLOCK_SPANS) -> Posterior:
    """The posterior of each span's inputs given its W (module docstring).

    Parameters
    ----------
    prior : SpanPrior
    w_obs : numpy.ndarray, shape (K, n)
        Corrected static W of the spans [m].
    noise_covariance_m2 : numpy.ndarray, shape (n, n) or (K, n, n)
        Covariance of each span's W error [m²] (positive definite).
    lower, upper : numpy.ndarray, shape (d + n,), optional
        Limits per input and dropper force (:func:`output_names`; NaN: none); ``p_outside`` is
        the posterior mass outside.
    n_samples : int
        Importance draws per span.
    seed : int
        Seed of the standard draws (shared by every span).
    df : float
        Degrees of freedom of the Student-t proposal.
    chunk_spans : int
        Spans weighted at once (bounds the memory to ``chunk_spans × n_samples × d`` floats).
    n_draws : int
        Equally weighted draws to keep per span (``Posterior.draws_z``; 0: none): the weighted
        draws resampled systematically (one uniform per span from ``seed + 1``), so that a draw
        of weight w appears about ``w · n_draws`` times.
    workers : int
        Processes over blocks of spans (:func:`catenary.plumbing.workers.map_blocks`). Each
        span's posterior is its own (its mode, its proposal, the shared standard draws) and the
        blocks are the same for any number of workers, so is the result, bit for bit.
    block_spans : int
        Spans per block (the modes are found for a block's spans at once).

    Returns
    -------
    Posterior
    """
    w_obs = np.atleast_2d(np.asarray(w_obs, dtype=float))
    k, n = w_obs.shape
    if n != prior.n_droppers:
        raise ValueError(f"w_obs: expected {prior.n_droppers} columns, got {n}")
    cov = np.broadcast_to(np.asarray(noise_covariance_m2, dtype=float), (k, n, n))
    l_inv = np.linalg.inv(np.linalg.cholesky(cov))
    d = prior.dimension
    q = d + n
    lower = np.full(q, np.nan) if lower is None else np.asarray(lower, dtype=float)
    upper = np.full(q, np.nan) if upper is None else np.asarray(upper, dtype=float)
    rng = np.random.default_rng(seed)
    t = rng.standard_normal((n_samples, d)) * np.sqrt(df / rng.chisquare(df, n_samples))[:, None]
    offsets = np.random.default_rng(seed + 1).random(k)

    def block(start: int, stop: int) -> dict:
        sl = slice(start, stop)
        return _block_posteriors(prior, w_obs[sl], l_inv[sl], lower, upper, t, df, chunk_spans, n_draws, offsets[sl])

    parts = map_blocks(block, k, workers, block_spans)
    out = {name: np.concatenate([p[name] for p in parts]) for name in parts[0] if parts[0][name] is not None}
    return Posterior(output_names(n, prior.system_height_mode), out["mean"], out["q05"], out["q95"],
                     out["p_outside"], out["mode_z"], out["mode_converged"], out["effective_samples"], n_samples,
                     out["misfit_p_value"], out.get("draws_z"))


def _block_posteriors(prior: SpanPrior, w_obs: np.ndarray, l_inv: np.ndarray, lower: np.ndarray,
                      upper: np.ndarray, t: np.ndarray, df: float, chunk_spans: int, n_draws: int,
                      offsets: np.ndarray) -> dict:
    """:func:`span_posteriors` of a block of spans (``l_inv`` the inverse Cholesky factors of their
    noise, ``t`` the shared standard Student-t draws, ``offsets`` the spans' resampling uniforms)."""
    k, n = w_obs.shape
    n_samples, d = t.shape
    q = d + n
    z_hat, precision, converged, (z0, precision0) = global_modes(prior, w_obs, l_inv)
    # The proposal: a Student t on the Laplace approximation at the mode; with a fault component
    # in the prior, half the draws around the mode without it too (the posterior may hold both).
    centres, chols = [z_hat], [np.linalg.cholesky(np.linalg.inv(precision))]
    if prior.fault_probability > 0:
        centres.append(z0)
        chols.append(np.linalg.cholesky(np.linalg.inv(precision0)))
    part = np.arange(n_samples) * len(centres) // n_samples                # draw s from component part[s]
    mean = np.empty((k, q))
    q05 = np.empty((k, q))
    q95 = np.empty((k, q))
    p_out = np.full((k, q), np.nan)
    ess = np.empty(k)
    limited = np.isfinite(lower) | np.isfinite(upper)
    draws = np.empty((k, n_draws, d)) if n_draws > 0 else None
    for start in range(0, k, chunk_spans):
        sl = slice(start, min(start + chunk_spans, k))
        m = sl.stop - sl.start
        z = np.empty((m, n_samples, d))
        for c, (centre, chol) in enumerate(zip(centres, chols)):
            z[:, part == c] = centre[sl, None, :] + np.einsum("kde,se->ksd", chol[sl], t[part == c])
        log_q = np.full((m, n_samples), -np.inf)
        for centre, chol in zip(centres, chols):
            # the scores of every draw under this component: L⁻¹ (z − centre), one inverse a span
            u = (z - centre[sl, None, :]) @ np.linalg.inv(chol[sl]).transpose(0, 2, 1)
            log_det = np.sum(np.log(np.diagonal(chol[sl], axis1=1, axis2=2)), axis=1)
            log_q = np.logaddexp(log_q, -0.5 * (df + d) * np.log1p(np.sum(u * u, axis=2) / df) - log_det[:, None])
        f, force, bad = prior.evaluate(z.reshape(-1, d))
        r = np.einsum("kij,kj->ki", np.repeat(l_inv[sl], n_samples, axis=0), np.repeat(w_obs[sl], n_samples, axis=0) - f)
        inputs = prior.inputs(z.reshape(-1, d))
        log_p = -_objective(prior, z.reshape(-1, d), r, bad) + prior.log_law_uncertainty_ratio(z.reshape(-1, d), inputs)
        log_w = log_p.reshape(m, n_samples) - log_q
        log_w -= np.max(log_w, axis=1, keepdims=True)
        w = np.exp(log_w)
        w /= np.sum(w, axis=1, keepdims=True)
        ess[sl] = 1.0 / np.sum(w * w, axis=1)
        if draws is not None:
            draws[sl] = _resample(z, w, offsets[sl], n_draws)
        x = np.concatenate([inputs, force], axis=1).reshape(m, n_samples, q)
        mean[sl] = np.einsum("ks,ksd->kd", w, x)
        q05[sl], q95[sl] = weighted_quantiles(x, w, (0.05, 0.95))
        if limited.any():
            outside = (x < np.where(np.isfinite(lower), lower, -np.inf)) | (x > np.where(np.isfinite(upper), upper,
                                                                                          np.inf))
            p_out[sl] = np.where(limited, np.einsum("ks,ksd->kd", w, outside.astype(float)), np.nan)
    r_hat, _ = _whitened(prior, z_hat, w_obs, l_inv)
    misfit = stats.chi2.sf(np.sum(r_hat * r_hat, axis=1), n)
    return {"mean": mean, "q05": q05, "q95": q95, "p_outside": p_out, "mode_z": z_hat, "mode_converged": converged,
            "effective_samples": ess, "misfit_p_value": misfit, "draws_z": draws}


def _resample(z: np.ndarray, w: np.ndarray, offsets: np.ndarray, n_draws: int) -> np.ndarray:
    """Systematic resampling: ``n_draws`` of the draws ``z`` (m, M, d) per span by their weights
    ``w`` (m, M, summing to one), at the points ``(offset + i) / n_draws``."""
    points = (offsets[:, None] + np.arange(n_draws)[None, :]) / n_draws
    cdf = np.cumsum(w, axis=1)
    cdf[:, -1] = 1.0
    idx = np.minimum(np.array([np.searchsorted(c, p, side="right") for c, p in zip(cdf, points)]), w.shape[1] - 1)
    return np.take_along_axis(z, idx[:, :, None], axis=1)


def prior_quantiles(prior: SpanPrior, levels: tuple[float, ...]) -> np.ndarray:
    """Quantiles of the prior laws per input (len(levels), d), for comparison with a posterior."""
    z = stats.norm.ppf(np.asarray(levels, dtype=float))[:, None] * np.ones((1, prior.dimension))
    return prior.inputs(z)
