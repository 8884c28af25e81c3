"""Could a named effect equally come from the correction's model?

A mismatch between the measuring car and the correction's model of it leaves a systematic in every
span's corrected W (:mod:`~catenary.model_error.correction`): the same shift of the mean W at each
dropper, ``−δ_j b_j`` for a car that differs from the correction's model by ``δ_j`` standard
uncertainties of source ``j`` (``b_j`` its shift of the corrected W per standard uncertainty). The
diagnosis may name a catenary effect for it. An effect it names moves the model's mean W by ``s``
per dropper (the mean residual before the step less the one after, the identification's free means
re-fitted both times, so that ``s`` holds only what they could not absorb). The effect is *alike*
the correction's model when

* its own mean shift is significant: ``sᵀ C⁻¹ s > χ²_{n−m}(level)``, ``C`` the covariance of the
  mean residual (S/ν) and ``m`` the free means — a mean shift that is not significant gives no
  ground to suspect a systematic; and
* a combination of the sources, each within ``bound`` standard uncertainties (2: their 95 %
  range), plus any move of the free means (their directions ``∂E[W]/∂μ``, unbounded: what the
  identification absorbs), reproduces it: ``min (r)ᵀ C⁻¹ (r) ≤ χ²_{n−m}(level)`` with
  ``r = −s − Σ_j δ_j b_j − D d`` (bounded linear least squares, whitened by C).

The fitted ``δ_j`` is how far the car would differ from the correction's model, in standard
uncertainties of each source. Then the verdict is written with the caveat, in ``findings.csv``
and in the reports.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.linalg import cholesky, solve_triangular
from scipy.optimize import lsq_linear
from scipy.stats import chi2

from ..config import Catenary, SpanType
from ..identification.fit import make_likelihood
from ..identification.settings import IdentificationSettings

__all__ = ["Alike", "BudgetSignatures", "budget_signatures", "correction_model_alike", "free_mean_directions",
           "read_budget"]


@dataclass(frozen=True)
class BudgetSignatures:
    """What the diagnosis compares a named effect with.

    Attributes
    ----------
    sources : dict
        Source → shift of the corrected W per dropper for one standard uncertainty [m]
        (:func:`budget_signatures`).
    absorbed : numpy.ndarray, shape (n, m)
        Directions of the identification's free means (:func:`free_mean_directions`).
    """

    sources: dict
    absorbed: np.ndarray


@dataclass(frozen=True)
class Alike:
    """Whether one named effect's mean signature is within the correction's budget.

    Attributes
    ----------
    alike : bool
    coefficients : dict
        Source → how far the car would differ from the correction's model, in standard
        uncertainties (the best combination).
    chi2_effect, chi2_left, threshold : float
        The effect's mean shift, what the combination leaves of it, and χ²_{n−m}(level).
    """

    alike: bool
    coefficients: dict
    chi2_effect: float
    chi2_left: float
    threshold: float

    def as_json(self) -> str:
        """The coefficients and the three χ² figures, for ``findings.csv``."""
        return json.dumps({"coefficients": {k: round(v, 3) for k, v in self.coefficients.items()},
                           "chi2_effect": round(self.chi2_effect, 3), "chi2_left": round(self.chi2_left, 3),
                           "threshold": round(self.threshold, 3)})


def read_budget(path) -> pd.DataFrame:
    """``correction/model_error_budget.csv`` (an empty table when no span had a measured shift)."""
    try:
        return pd.read_csv(path)
    except pd.errors.EmptyDataError:         # the correction wrote no row: nothing was measured
        return pd.DataFrame()


def budget_signatures(budget: pd.DataFrame, span_type: str) -> dict[str, np.ndarray]:
    """Per source, the mean shift of the corrected W per dropper for one standard uncertainty
    [m], from ``correction/model_error_budget.csv``; sources not measured (NaN) are left out."""
    if budget.empty or "span_type" not in budget:
        return {}
    rows = budget[budget["span_type"] == span_type].sort_values("dropper")
    out = {}
    for column in (c for c in rows.columns if c.startswith("shift_") and c.endswith("_m")):
        values = rows[column].to_numpy(dtype=float)
        if values.size and np.all(np.isfinite(values)):
            out[column.removeprefix("shift_").removesuffix("_m")] = values
    return out


def free_mean_directions(span_type: SpanType, catenary: Catenary, settings: IdentificationSettings) -> np.ndarray:
    """``∂E[W]/∂μ`` of every free mean of the identification, at its start laws, by central
    differences of one start σ on the fast model's design (N = 2000, the settings' seed):
    shape (n, m) [m per unit of each mean]."""
    start = settings.start_inputs(span_type, catenary)
    n = span_type.n_droppers
    lik = make_likelihood(span_type, catenary, np.zeros((2, n)), start=start, n_samples=2000,
                          design_method=settings.design, seed=settings.seed,
                          system_height_mode=settings.system_height_mode, neighbours=settings.neighbours)
    means = np.array([s.mean for s in start])
    sigmas = np.array([s.sigma for s in start])
    names = [s.name for s in start]

    def mean_w(m: np.ndarray) -> np.ndarray:
        sample = lik.model_sample(m, sigmas)
        return np.average(sample.w_m, axis=0, weights=sample.weight)

    columns = []
    for name in settings.free_mean_names(n):
        i = names.index(name)
        step = np.zeros(means.size)
        step[i] = sigmas[i]
        columns.append((mean_w(means + step) - mean_w(means - step)) / (2.0 * sigmas[i]))
    return np.column_stack(columns) if columns else np.zeros((n, 0))


def correction_model_alike(signature_m: np.ndarray, covariance_m2: np.ndarray, sources: dict[str, np.ndarray],
                           absorbed: np.ndarray | None = None, *, bound: float = 2.0, level: float = 0.95) -> Alike:
    """The test of the module docstring.

    Parameters
    ----------
    signature_m : numpy.ndarray, shape (n,)
        The named effect's shift of the mean W per dropper [m].
    covariance_m2 : numpy.ndarray, shape (n, n)
        Covariance of the mean residual [m²].
    sources : dict
        Source → shift of the corrected W per dropper for one standard uncertainty [m].
    absorbed : numpy.ndarray, shape (n, m), optional
        Directions of the identification's free means (:func:`free_mean_directions`).
    bound : float
        Largest multiple of a source's standard uncertainty in the combination.
    level : float
        Level of the two χ² tests.

    Returns
    -------
    Alike
    """
    s = np.asarray(signature_m, dtype=float)
    d = np.zeros((s.size, 0)) if absorbed is None else np.asarray(absorbed, dtype=float)
    lower = cholesky(np.asarray(covariance_m2, dtype=float), lower=True)
    white = solve_triangular(lower, -s, lower=True)
    threshold = float(chi2.ppf(level, s.size - d.shape[1]))
    chi2_effect = float(white @ white)
    if not sources:
        return Alike(False, {}, chi2_effect, chi2_effect, threshold)
    names = list(sources)
    design = solve_triangular(lower, np.column_stack([*(np.asarray(sources[k], dtype=float) for k in names), d]),
                              lower=True)
    inf = np.full(d.shape[1], np.inf)
    fit = lsq_linear(design, white, bounds=(np.r_[np.full(len(names), -bound), -inf],
                                            np.r_[np.full(len(names), bound), inf]))
    left = float(np.sum((white - design @ fit.x) ** 2))
    return Alike(bool(chi2_effect > threshold and left <= threshold), dict(zip(names, map(float, fit.x[:len(names)]))),
                 chi2_effect, left, threshold)
