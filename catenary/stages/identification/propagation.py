"""From the shift of the corrected W to the shift of every identified μ and σ, and the 95 % total
intervals.

The identified laws ``θ̂`` maximise ``J(θ; W)`` for the corrected deflections ``W`` of a span
type. A systematic ``δW`` of the correction's model (one standard uncertainty of a source,
:mod:`~catenary.stages.model_error.correction`) moves the maximum, to first order, by

    δθ = (−∇²J)⁻¹ ∇_θ ∂J/∂W · δW ≈ C · [∇_θ J(θ̂; W + δW) − ∇_θ J(θ̂; W − δW)] / 2,

with ``C`` the observed-information covariance the identification already computed, and the
gradients by central differences in θ at the identification's Hessian step (4p evaluations of J
per source, p free coordinates; the symmetric difference in W cancels the gradient the
optimiser left at θ̂ and the second-order term in δW). A coordinate at its lower bound (a σ
the data cannot resolve) is held there. The accuracy of this linearisation against a full
re-identification on shifted data is measured in ``tests/test_model_error.py``.

Every source's shift is one standard uncertainty, independent of the others and shared by every
span: the systematic standard uncertainty of a parameter is the root sum of squares of its
shifts, and the 95 % total interval widens each side of the statistical interval (the profile
interval where there is one, else ±1.96 standard errors) in quadrature with 1.96 times it::

    low_total = est − √((est − low)² + (1.96 u_sys)²),  high_total = est + √((high − est)² + (1.96 u_sys)²)

so it always contains the statistical interval (a σ's low end is held at 0).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np
import pandas as pd
from scipy.stats import norm

from .fit import ScaledProblem, evaluate_points

__all__ = ["MODEL_ERROR_COLUMNS", "SpanShifts", "Z95", "budget_table", "parameter_shifts", "span_shifts", "total_intervals"]

#: Columns of the parameter budget every source adds ``shift_<source>`` to (:func:`budget_table`).
MODEL_ERROR_COLUMNS = ("parameter", "statistic", "estimate", "systematic", "dominant_source")

#: Two-sided 95 % normal quantile.
Z95 = 1.959963984540054


@dataclass(frozen=True)
class SpanShifts:
    """The budget's shifts of one span type's identified W (:func:`span_shifts`).

    Attributes
    ----------
    w_m : dict
        Source → array (K, n): shift of each identified span's W for one standard uncertainty [m].
    filled : dict
        Source → spans with no measured shift of their own, given the others' mean per dropper.
    unmeasured : dict
        Source → why no span of the type has a shift: left out of the propagation and named in
        the report, never counted as zero.
    """

    w_m: dict
    filled: dict
    unmeasured: dict

    def covariance_m2(self) -> np.ndarray | None:
        """The sources' covariance of one span's W, summed over the sources [m²]: each source's
        mean over the spans of its shifts' outer product; None without a measured source."""
        if not self.w_m:
            return None
        return sum((b.T @ b) / b.shape[0] for b in self.w_m.values())


def span_shifts(shifts: pd.DataFrame, span_type: str, span_ids: np.ndarray, n_droppers: int,
                corrected: pd.DataFrame | None = None) -> SpanShifts:
    """The shift of each identified span's W per source, as the identification averages W.

    Parameters
    ----------
    shifts : pandas.DataFrame
        The correction's model-error table (:func:`~catenary.stages.model_error.correction.run_shifts`).
    span_type : str
    span_ids : numpy.ndarray of str, shape (K,)
        The identified spans, in the order of the identification's data.
    n_droppers : int
    corrected : pandas.DataFrame, optional
        The corrected spans (``span_id``, ``run_id``, ``converged``): only converged runs are
        averaged, as :func:`~catenary.stages.identification.data.read_corrected` does.

    Returns
    -------
    SpanShifts
        A span with no measured shift of its own (the correction's run failed, or the budget was
        measured on other sections: ``model_error.sections_per_span_type``) takes the mean shift
        of the others per dropper: the source is a systematic of the car, the same in every span
        up to each profile's own part.
    """
    cols = [f"w{i + 1}_m" for i in range(n_droppers)]
    mine = shifts[(shifts["span_type"] == span_type) & (shifts["status"] == "")]
    if corrected is not None and "converged" in corrected:
        keys = corrected.loc[corrected["converged"].astype(bool), ["span_id", "run_id"]].astype(str)
        mine = mine.assign(span_id=mine["span_id"].astype(str), run_id=mine["run_id"].astype(str)).merge(
            keys, on=["span_id", "run_id"])
    out, filled, unmeasured = {}, {}, {}
    for source in dict.fromkeys(shifts["source"]):
        part = mine[mine["source"] == source]
        per_span = part.groupby(part["span_id"].astype(str))[cols].mean()
        w = np.array(per_span.reindex([str(s) for s in span_ids]).to_numpy(dtype=float))
        missing = ~np.all(np.isfinite(w), axis=1)
        if missing.all():
            mine_all = shifts[(shifts["span_type"] == span_type) & (shifts["source"] == source)]
            reasons = sorted(set(mine_all["status"].astype(str)) - {""})
            unmeasured[source] = "; ".join(reasons) or "no identified span was measured"
            continue
        w[missing] = np.nanmean(w[~missing], axis=0)
        out[source] = w
        filled[source] = int(missing.sum())
    return SpanShifts(out, filled, unmeasured)


def parameter_shifts(problem: ScaledProblem, theta_opt: np.ndarray, covariance: np.ndarray,
                     w_shifts: Mapping[str, np.ndarray], step: float, workers: int = 1) -> dict[str, np.ndarray]:
    """Shift of the optimiser's coordinates θ per source (module docstring).

    The model sample at each θ ± h e_i does not depend on the data: its moments are computed
    once (in ``workers`` processes, :func:`.fit.evaluate_points`) and every source's shifted
    data read under them (:meth:`.likelihood.Likelihood.value_of`).

    Parameters
    ----------
    problem : ScaledProblem
        The identification's J in θ, on the measured data.
    theta_opt : numpy.ndarray, shape (p,)
    covariance : numpy.ndarray, shape (p, p)
        (−∇²J)⁻¹ in θ (NaN rows and columns for coordinates at a bound).
    w_shifts : mapping
        Source → shift of the data, shape (K, n) [m].
    step : float
        Central-difference step in θ.
    workers : int
        Processes over the points θ ± h e_i (the same shifts for any number).

    Returns
    -------
    dict
        Source → δθ, shape (p,) (0 for coordinates at a bound; NaN everywhere when J is not
        finite at a shifted evaluation).
    """
    theta = np.asarray(theta_opt, dtype=float)
    interior = np.isfinite(np.diag(covariance))            # a coordinate at a bound has NaN row and column
    c = np.where(np.outer(interior, interior), np.nan_to_num(covariance), 0.0)
    base = problem.likelihood
    coordinates = np.flatnonzero(interior)
    points = [theta + sign * step * np.eye(theta.size)[i] for i in coordinates for sign in (1.0, -1.0)]
    moments = evaluate_points(lambda t: base.moments(*problem.laws(t)), points, workers)
    out = {}
    for source, dw in w_shifts.items():
        grads = []
        for sign in (1.0, -1.0):
            shifted = base.with_data(base.data_w_m + sign * dw)
            j = np.array([-np.inf if m is None else shifted.value_of(m).j for m in moments])
            g = np.zeros(theta.size)
            g[coordinates] = (j[0::2] - j[1::2]) / (2.0 * step)
            grads.append(g)
        out[source] = c @ (0.5 * (grads[0] - grads[1]))
    return out


def budget_table(problem: ScaledProblem, means: np.ndarray, sigmas: np.ndarray, names: list[str],
                 theta_shifts: Mapping[str, np.ndarray]) -> pd.DataFrame:
    """Per identified parameter and statistic: ``parameter``, ``statistic`` ("mu"/"sigma"),
    ``estimate``, ``shift_<source>`` (the parameter's shift for one standard uncertainty of the
    source, in the parameter's unit), ``systematic`` (their root sum of squares) and
    ``dominant_source``. Means the identification holds fixed have no row."""
    nm = problem.free_mean_idx.size
    rows = []
    coords = ([("mu", i, k) for k, i in enumerate(problem.free_mean_idx)]
              + [("sigma", i, nm + k) for k, i in enumerate(problem.free_sigma_idx)])
    for statistic, i, k in coords:
        row = {"parameter": names[i], "statistic": statistic,
               "estimate": float(means[i] if statistic == "mu" else sigmas[i])}
        for source, d in theta_shifts.items():
            row[f"shift_{source}"] = float(problem.mean_scale[i] * d[k] if statistic == "mu"
                                           else sigmas[i] * np.expm1(d[k]))
        values = {s: abs(row[f"shift_{s}"]) for s in theta_shifts}
        row["systematic"] = float(np.sqrt(sum(v ** 2 for v in values.values())))
        row["dominant_source"] = max(values, key=values.get) if values and row["systematic"] > 0 else ""
        rows.append(row)
    shifts = [f"shift_{s}" for s in theta_shifts]
    return pd.DataFrame(rows, columns=[*MODEL_ERROR_COLUMNS[:3], *shifts, *MODEL_ERROR_COLUMNS[3:]])


def total_intervals(s_opt: pd.DataFrame, budget: pd.DataFrame | None, profile_level: float = 0.95) -> pd.DataFrame:
    """``s_opt`` with the 95 % total intervals: ``mu_total_low``, ``mu_total_high``,
    ``sigma_total_low``, ``sigma_total_high`` (module docstring) and ``mu_systematic``,
    ``sigma_systematic`` (one standard uncertainty from the correction's model). Without a
    budget (``model_error`` off) these are NaN: a statistical interval is not a total one.
    Parameters not identified (a fixed mean) get NaN. A profile interval at another
    ``profile_level`` than 95 % has each side rescaled to 95 % (by the ratio of the normal
    quantiles) before it is widened."""
    to_95 = Z95 / float(norm.ppf(0.5 + 0.5 * profile_level))
    out = s_opt.copy()
    for statistic in ("mu", "sigma"):
        est = out[statistic].to_numpy(dtype=float)
        se = out[f"{statistic}_se"].to_numpy(dtype=float)
        low = out[f"{statistic}_profile_low"].to_numpy(dtype=float)
        high = out[f"{statistic}_profile_high"].to_numpy(dtype=float)
        low = np.where(np.isfinite(low), est - to_95 * (est - low), est - Z95 * se)
        high = np.where(np.isfinite(high), est + to_95 * (high - est), est + Z95 * se)
        sys = np.full(est.size, np.nan)
        if budget is not None and len(budget):
            rows = budget[budget["statistic"] == statistic].set_index("parameter")["systematic"]
            sys = out["parameter"].map(rows).to_numpy(dtype=float)
        half = Z95 * sys
        total_low = est - np.sqrt((est - low) ** 2 + half ** 2)
        total_high = est + np.sqrt((high - est) ** 2 + half ** 2)
        if statistic == "sigma":
            total_low = np.maximum(total_low, 0.0)
        fixed = out["mu_fixed"].to_numpy(dtype=bool) if statistic == "mu" else np.zeros(est.size, dtype=bool)
        out[f"{statistic}_systematic"] = np.where(fixed, np.nan, sys)
        out[f"{statistic}_total_low"] = np.where(fixed, np.nan, total_low)
        out[f"{statistic}_total_high"] = np.where(fixed, np.nan, total_high)
    return out
