"""Could a named effect equally come from the correction's model?

A mismatch between the measuring car and the correction's model of it leaves a systematic in every
span's corrected W (:mod:`~catenary.model_error.correction`): the same shift of the mean W at each
dropper. The diagnosis may name a catenary effect for it. An effect the diagnosis names moves the
model's mean W by ``s`` per dropper (the mean residual before the step less the one after); the
budget's sources move it by ``b_j`` per standard uncertainty. The effect is *alike* the
correction's model when

* its own mean signature is significant: ``Σ (s_i / se_i)² > χ²_n(level)``, with ``se_i`` the
  standard error of the mean residual at dropper ``i`` (from its 95 % interval) — an effect that
  acts on the spread of W, not its mean, no systematic can mimic; and
* some combination of the sources, each within ``bound`` standard uncertainties (2: their 95 %
  range), reproduces it: ``min Σ ((s_i − Σ_j c_j b_ij) / se_i)² ≤ χ²_n(level)`` over
  ``|c_j| ≤ bound`` (bounded linear least squares).

Then the verdict is written with the caveat, in ``findings.csv`` and in the reports.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.optimize import lsq_linear
from scipy.stats import chi2

__all__ = ["Alike", "budget_signatures", "correction_model_alike"]


@dataclass(frozen=True)
class Alike:
    """Whether one named effect's mean signature is within the correction's budget.

    Attributes
    ----------
    alike : bool
    coefficients : dict
        Source → standard uncertainties of the best combination.
    chi2_effect, chi2_left, threshold : float
        The effect's signature, what the combination leaves of it, and χ²_n(level).
    """

    alike: bool
    coefficients: dict
    chi2_effect: float
    chi2_left: float
    threshold: float

    def as_json(self) -> str:
        return json.dumps({"coefficients": {k: round(v, 3) for k, v in self.coefficients.items()},
                           "chi2_effect": round(self.chi2_effect, 3), "chi2_left": round(self.chi2_left, 3),
                           "threshold": round(self.threshold, 3)})


def budget_signatures(budget: pd.DataFrame, span_type: str) -> dict[str, np.ndarray]:
    """Per source, the mean shift of the corrected W per dropper for one standard uncertainty
    [m], from ``correction/model_error_budget.csv``; sources not measured (NaN) are left out."""
    rows = budget[budget["span_type"] == span_type].sort_values("dropper")
    out = {}
    for column in (c for c in rows.columns if c.startswith("shift_") and c.endswith("_m")):
        values = rows[column].to_numpy(dtype=float)
        if values.size and np.all(np.isfinite(values)):
            out[column.removeprefix("shift_").removesuffix("_m")] = values
    return out


def correction_model_alike(signature_m: np.ndarray, standard_error_m: np.ndarray, sources: dict[str, np.ndarray],
                           *, bound: float = 2.0, level: float = 0.95) -> Alike:
    """The test of the module docstring.

    Parameters
    ----------
    signature_m : numpy.ndarray, shape (n,)
        The named effect's shift of the mean W per dropper [m].
    standard_error_m : numpy.ndarray, shape (n,)
        Standard error of the mean residual per dropper [m].
    sources : dict
        Source → shift of the mean W per dropper for one standard uncertainty [m].
    bound : float
        Largest multiple of a source's standard uncertainty in the combination.
    level : float
        Level of the two χ² tests.
    """
    s = np.asarray(signature_m, dtype=float)
    se = np.asarray(standard_error_m, dtype=float)
    threshold = float(chi2.ppf(level, s.size))
    chi2_effect = float(np.sum((s / se) ** 2))
    if not sources:
        return Alike(False, {}, chi2_effect, chi2_effect, threshold)
    names = list(sources)
    b = np.column_stack([np.asarray(sources[k], dtype=float) for k in names]) / se[:, None]
    fit = lsq_linear(b, s / se, bounds=(-bound, bound))
    left = float(np.sum((s / se - b @ fit.x) ** 2))
    return Alike(bool(chi2_effect > threshold and left <= threshold), dict(zip(names, map(float, fit.x))),
                 chi2_effect, left, threshold)
