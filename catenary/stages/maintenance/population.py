"""The population's posterior band: the spans of a span type as their measurement leaves them.

The band of Fig. 10 (:func:`catenary.stages.identification.band.deflection_band`) is where the CW of a
span drawn from the identified laws hangs: the prior. The paper's conclusion proposes a tighter
region from the Bayesian update of that prior by the measurement. Span by span, the update is
:func:`~.posterior.span_posteriors`; for the span type, the updated law of its inputs is the
mixture of its K measured spans' posteriors, each with weight 1/K — the hierarchical model's
posterior predictive with the laws held at s_opt (empirical Bayes: a new span of the line is
like one of its measured spans, known as well as its W tells). Its band of the CW deflection,
pointwise quantiles ``(1 − level)/2`` and ``(1 + level)/2`` at each abscissa as for Fig. 10 and
over the same abscissae, is the *posterior band*. Where the laws (independent Gamma inputs) put
mass where no measured span lies, it is narrower; where they miss a tail the spans have, it is
wider. Samples with a slack dropper are dropped from both bands (bands of taut spans).

Cross-validated coverage
------------------------
A band that only describes the spans it was built from proves nothing; it must hold spans it
did not see. Each span in turn is left out, the posterior band at the droppers is rebuilt from
the other spans' draws, and the left-out span's measured W is checked against it; every draw
carries a measurement error drawn with the left-out span's error covariance, so that the band
predicts a *measured* W. The prior band is checked the same way (as many random draws of the
laws as the band has, plus the same error), on all spans. Both coverages are written per dropper, against the nominal ``level``,
with the binomial standard error. The laws themselves were identified from every span
(13 parameters from K spans): this leaves a span out of the update, not of the identification.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from catenary.plumbing.workers import map_blocks
from catenary.stages.identification.band import DeflectionBand, deflection_band, sample_profiles
from catenary.stages.identification.design import map_inputs
from .prior import SpanPrior

__all__ = ["BAND_COLUMNS", "COVERAGE_COLUMNS", "PopulationBands", "leave_one_out_inside", "population_bands",
           "posterior_band"]

#: Columns of ``population_band.csv``: the two bands along the span [m].
BAND_COLUMNS = ("x_m", "prior_lower_m", "prior_median_m", "prior_upper_m", "posterior_lower_m",
                "posterior_median_m", "posterior_upper_m")
#: Columns of ``population_coverage.csv``: per dropper, the bands' widths and coverages.
COVERAGE_COLUMNS = ("dropper", "x_m", "level", "n_spans", "prior_width_m", "posterior_width_m", "width_ratio",
                    "prior_coverage", "posterior_coverage_loo", "coverage_se")


def _taut_profiles(prior: SpanPrior, operator, z: np.ndarray) -> tuple[np.ndarray, int]:
    x = map_inputs(z, prior.means, prior.sigmas, prior.system_height_mode)
    profiles, slack = sample_profiles(prior.model, operator, x.dropper_lengths_m, x.messenger_tension_n,
                                      x.system_height_left_m, x.system_height_right_m)
    return profiles[~slack], int(slack.sum())


def _dropper_w(prior: SpanPrior, z: np.ndarray) -> np.ndarray:
    """W at the droppers [m] of the inputs at normal scores ``z`` (M, d); NaN rows where a dropper
    would be slack (the bands are those of taut spans)."""
    x = map_inputs(z, prior.means, prior.sigmas, prior.system_height_mode)
    res = prior.model.evaluate(x.dropper_lengths_m, x.messenger_tension_n, x.system_height_left_m,
                               x.system_height_right_m)
    return np.where(res.slack[:, None], np.nan, res.w_m)


def _inside(pooled: np.ndarray, w: np.ndarray, level: float) -> np.ndarray:
    """Whether ``w`` (n,) lies within the pointwise ``level`` quantiles of ``pooled`` (M, n)
    (NumPy's linear quantiles, as :func:`numpy.quantile` gives them).

    Decided by counting: a quantile interpolated between the order statistics ``x_(j)`` and
    ``x_(j+1)`` lies below ``w`` when ``x_(j+1) ≤ w`` (``#(x ≤ w) ≥ j + 2``) and above it when
    ``x_(j) > w`` (``#(x ≤ w) ≤ j``); only a ``w`` between those two order statistics (a chance
    of ≈ 2 / M) needs the quantile itself — two comparisons a value instead of a selection."""
    m = pooled.shape[0]
    at_most = np.sum(pooled <= w, axis=0)
    below = np.sum(pooled < w, axis=0)
    j_low = int(np.floor((m - 1) * 0.5 * (1.0 - level)))
    j_high = int(np.floor((m - 1) * 0.5 * (1.0 + level)))
    above_low = at_most >= j_low + 2                        # w ≥ the lower quantile
    under_high = below <= j_high                             # w ≤ the upper quantile
    for column in np.flatnonzero((at_most == j_low + 1) | (below == j_high + 1)):
        lo, hi = np.quantile(pooled[:, column], [0.5 * (1.0 - level), 0.5 * (1.0 + level)])
        above_low[column], under_high[column] = w[column] >= lo, w[column] <= hi
    return above_low & under_high


#: Pooled posterior draws the band is drawn from, at most: beyond it, this many picked at random
#: (seeded), so the band's memory does not grow with the line (one profile of 235 abscissae per
#: draw: 564 MB for the 300 000 draws of 1 500 spans). Its 1 % and 99 % quantiles from 100 000
#: draws are exact to ±0.03 % in probability, against the ±0.5 % of a band of 200 spans.
BAND_POOL_DRAWS = 100_000


def posterior_band(prior: SpanPrior, operator, draws_z: np.ndarray, level: float, seed: int = 0) -> DeflectionBand:
    """Pointwise ``level`` band of the CW deflection over the pooled posterior draws (at most
    :data:`BAND_POOL_DRAWS` of them, picked with ``seed``).

    Parameters
    ----------
    prior : SpanPrior
        The laws the posteriors were drawn under (their normal scores map through them).
    operator : ProfileMap
        ``prior.model.profile_map(x_m)``.
    draws_z : numpy.ndarray, shape (K, m, d)
        Equally weighted posterior draws per span (:attr:`~.posterior.Posterior.draws_z`).
    level : float

    Raises
    ------
    ValueError
        If every draw has a slack dropper.
    """
    z = draws_z.reshape(-1, draws_z.shape[-1])
    if z.shape[0] > BAND_POOL_DRAWS:
        z = z[np.sort(np.random.default_rng(seed).choice(z.shape[0], BAND_POOL_DRAWS, replace=False))]
    taut, n_slack = _taut_profiles(prior, operator, z)
    if taut.shape[0] == 0:
        raise ValueError("every posterior draw has a slack dropper: no taut span to band")
    lower, median, upper = np.quantile(taut, [0.5 * (1.0 - level), 0.5, 0.5 * (1.0 + level)], axis=0)
    return DeflectionBand(x_m=operator.x_m, lower_m=lower, upper_m=upper, median_m=median, level=float(level),
                          n_samples=int(z.shape[0]), n_slack=n_slack)


#: Draws of the other spans a left-out span's band is built from, at most: beyond it, this many
#: drawn at random (with replacement, a stream of the span's own) from the others' draws, so the
#: check costs the same per span on a line of any length (all the others' draws made it grow
#: with the square of the spans: 165 s of the posteriors' job on 1 500 spans). The band's ends
#: are its 1 % and 99 % quantiles at the widest level (0.98): from 40 000 draws their probability
#: is exact to ±0.05 % (binomial standard error), against a coverage whose own standard error on
#: 250 spans, where the cap starts to act (200 draws per span), is 0.9 %.
LOO_POOL_DRAWS = 40_000
#: Spans per block of the coverage checks (each span's check is its own).
BLOCK_SPANS = 256


def leave_one_out_inside(draws_w: np.ndarray, w_obs: np.ndarray, noise_chol: np.ndarray, level: float,
                         seed: int, *, workers: int = 1) -> np.ndarray:
    """Whether each span's measured W falls inside the band of the other spans' draws.

    Parameters
    ----------
    draws_w : numpy.ndarray, shape (K, m, n)
        W at the droppers of each span's posterior draws [m] (NaN rows: slack draws, ignored).
    w_obs : numpy.ndarray, shape (K, n)
        Measured W [m].
    noise_chol : numpy.ndarray, shape (K, n, n)
        Cholesky factor of each span's W error covariance [m].
    level : float
    seed : int
        Seed of the standard normal errors added to the draws (and of the draws picked, when the
        others have more than :data:`LOO_POOL_DRAWS`).
    workers : int
        Processes over blocks of spans; each span's check is its own, so the result does not
        depend on them.

    Returns
    -------
    numpy.ndarray of bool, shape (K, n)
    """
    k, m, n = draws_w.shape
    pool = (k - 1) * m
    flat = draws_w.reshape(-1, n)
    e = np.random.default_rng(seed).standard_normal((min(pool, LOO_POOL_DRAWS), n))

    def block(start: int, stop: int) -> np.ndarray:
        inside = np.empty((stop - start, n), dtype=bool)
        for left_out in range(start, stop):
            if pool <= LOO_POOL_DRAWS:
                others = np.delete(draws_w, left_out, axis=0).reshape(-1, n)
            else:
                pick = np.random.default_rng([seed, left_out]).integers(0, pool, LOO_POOL_DRAWS)
                others = flat[pick + m * (pick >= left_out * m)]          # skip the left-out span's draws
            keep = np.all(np.isfinite(others), axis=1)
            inside[left_out - start] = _inside(others[keep] + e[:keep.size][keep] @ noise_chol[left_out].T,
                                               w_obs[left_out], level)
        return inside

    return np.concatenate(map_blocks(block, k, workers, BLOCK_SPANS))


def _prior_inside(prior_w: np.ndarray, w_obs: np.ndarray, noise_chol: np.ndarray, level: float,
                  seed: int, workers: int = 1) -> np.ndarray:
    """Whether each span's W falls inside the prior band at the droppers with its own error added."""
    e = np.random.default_rng(seed).standard_normal(prior_w.shape)

    def block(start: int, stop: int) -> np.ndarray:
        return np.array([_inside(prior_w + e @ noise_chol[k].T, w_obs[k], level) for k in range(start, stop)],
                        dtype=bool).reshape(-1, w_obs.shape[1])

    return np.concatenate(map_blocks(block, w_obs.shape[0], workers, BLOCK_SPANS))


@dataclass(frozen=True)
class PopulationBands:
    """Outputs of :func:`population_bands`: the two bands and the table per dropper."""

    prior: DeflectionBand
    posterior: DeflectionBand
    coverage: pd.DataFrame

    def band_table(self) -> pd.DataFrame:
        """:data:`BAND_COLUMNS`, one row per abscissa."""
        p, q = self.prior, self.posterior
        return pd.DataFrame(dict(zip(BAND_COLUMNS, (p.x_m, p.lower_m, p.median_m, p.upper_m, q.lower_m, q.median_m,
                                                    q.upper_m))))


def population_bands(prior: SpanPrior, draws_z: np.ndarray, w_obs: np.ndarray, noise_covariance_m2: np.ndarray, *,
                     x_m: np.ndarray, level: float, n_prior_samples: int, design_method: str,
                     seed: int, workers: int = 1) -> PopulationBands:
    """The prior band (Fig. 10's, same design and seed) and the posterior band, with coverages.

    Parameters
    ----------
    prior : SpanPrior
        The identified laws (their fault component, if any, is not part of the prior band: Fig. 10
        draws the laws alone).
    draws_z : numpy.ndarray, shape (K, m, d)
        Equally weighted posterior draws per span.
    w_obs : numpy.ndarray, shape (K, n)
        The spans' measured W [m].
    noise_covariance_m2 : numpy.ndarray, shape (K, n, n)
        Each span's W error covariance [m²].
    x_m : numpy.ndarray
        Abscissae of the bands [m] (they include the droppers').
    level : float
    n_prior_samples, design_method, seed
        The prior band's design (the identification's ``band_n_samples``, ``design`` and
        ``seed + 1`` give Fig. 10's band itself).
    workers : int
        Processes over blocks of spans for the coverages (the result does not depend on them).
    """
    operator = prior.model.profile_map(x_m)
    prior_band = deflection_band(prior.model, prior.means, prior.sigmas, x_m=x_m, n_samples=n_prior_samples,
                                 level=level, design_method=design_method, seed=seed,
                                 system_height_mode=prior.system_height_mode, operator=operator)
    post_band = posterior_band(prior, operator, draws_z, level, seed + 4)
    n = prior.n_droppers
    k, m, d = draws_z.shape
    chol = np.linalg.cholesky(np.broadcast_to(noise_covariance_m2, (k, n, n)))
    draws_w = _dropper_w(prior, draws_z.reshape(-1, d)).reshape(k, m, n)
    post_inside = leave_one_out_inside(draws_w, w_obs, chol, level, seed + 1, workers=workers)
    # The prior's W at the droppers: as many random draws of the laws as its band has.
    prior_w = _dropper_w(prior, np.random.default_rng(seed + 2).standard_normal((n_prior_samples, d)))
    prior_inside = _prior_inside(prior_w[np.all(np.isfinite(prior_w), axis=1)], w_obs, chol, level, seed + 3, workers)
    at = np.searchsorted(prior_band.x_m, prior.model.span_type.dropper_positions_m)
    prior_width = prior_band.upper_m[at] - prior_band.lower_m[at]
    post_width = post_band.upper_m[at] - post_band.lower_m[at]
    coverage = pd.DataFrame({
        "dropper": np.arange(1, n + 1), "x_m": prior_band.x_m[at], "level": level, "n_spans": k,
        "prior_width_m": prior_width, "posterior_width_m": post_width, "width_ratio": post_width / prior_width,
        "prior_coverage": prior_inside.mean(axis=0), "posterior_coverage_loo": post_inside.mean(axis=0),
        "coverage_se": np.sqrt(level * (1.0 - level) / k),
    }, columns=list(COVERAGE_COLUMNS))
    return PopulationBands(prior_band, post_band, coverage)
