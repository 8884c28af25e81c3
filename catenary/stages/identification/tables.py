"""The identification's tables: ``s_opt.csv`` (paper Table 2 with standard errors, profile and
total intervals) and the optimiser's trace (``trace.parquet``, explicit Arrow schema)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pyarrow as pa

from .propagation import total_intervals
from .profile import ProfileInterval
from .result import IdentificationResult

__all__ = ["LAWS_COMPARISON_COLUMNS", "S_OPT_COLUMNS", "laws_comparison", "s_opt_table", "trace_schema",
           "trace_table"]

S_OPT_COLUMNS = ("parameter", "mu", "sigma", "mu_se", "sigma_se", "mu_variance_widening", "sigma_variance_widening",
                 "mu_fixed", "mu_profile_low", "mu_profile_high", "sigma_profile_low", "sigma_profile_high",
                 "no_spread_detected", "converged", "status", "mu_systematic", "sigma_systematic",
                 "mu_total_low", "mu_total_high", "sigma_total_low", "sigma_total_high")


def s_opt_table(result: IdentificationResult, profiles: list[ProfileInterval] = (),
                model_error: pd.DataFrame | None = None, profile_level: float = 0.95) -> pd.DataFrame:
    """s_opt with standard errors: columns ``parameter``, ``mu``, ``sigma``, ``mu_se``, ``sigma_se``,
    ``mu_fixed`` (SI, in the unit of each parameter's name; se 0 where not identified, NaN where
    the information is singular), ``mu_variance_widening`` and ``sigma_variance_widening`` (the
    factor ``max(λ, 1)`` by which the sandwich over spans sharing a mast widened the variance:
    1 for the observed information alone, NaN where not identified), the profile-likelihood
    interval ends ``mu_profile_low`` …
    ``sigma_profile_high`` (NaN where not profiled; ``sigma_profile_low`` = 0 when the interval
    reaches no spread), ``no_spread_detected`` (the σ interval reaches 0), ``converged`` and
    ``status`` (:attr:`.result.IdentificationResult.status`, the same on every row), then the
    correction's model error: ``mu_systematic``, ``sigma_systematic`` (one standard uncertainty)
    and the 95 % total intervals ``mu_total_low`` … ``sigma_total_high``
    (:func:`catenary.stages.identification.propagation.total_intervals`; NaN without a budget)."""
    rows = result.table_rows()
    by_key = {(p.parameter, p.statistic): p for p in profiles}
    widening = dict(zip(result.free_parameters, result.variance_widening))
    for row in rows:
        for statistic in ("mu", "sigma"):
            row[f"{statistic}_variance_widening"] = widening.get(f"{row['parameter']}.{statistic}", np.nan)
        for statistic in ("mu", "sigma"):
            p = by_key.get((row["parameter"], statistic))
            row[f"{statistic}_profile_low"] = p.low if p else np.nan
            row[f"{statistic}_profile_high"] = p.high if p else np.nan
        sigma = by_key.get((row["parameter"], "sigma"))
        row["no_spread_detected"] = bool(sigma.no_spread_detected) if sigma else False
    return total_intervals(pd.DataFrame(rows, columns=list(S_OPT_COLUMNS[:-6])), model_error,
                           profile_level)[list(S_OPT_COLUMNS)]


def trace_schema(parameters: tuple[str, ...] | list[str]) -> pa.Schema:
    """Arrow schema of the J trace: ``evaluation``, ``j``, then ``mu_<input>``, ``sigma_<input>``
    per input (the unit is the input's, read from the name's suffix)."""
    fields = [pa.field("evaluation", pa.int64(), nullable=False), pa.field("j", pa.float64(), nullable=False)]
    for name in parameters:
        fields += [pa.field(f"mu_{name}", pa.float64(), nullable=False),
                   pa.field(f"sigma_{name}", pa.float64(), nullable=False)]
    return pa.schema(fields)


def trace_table(result: IdentificationResult) -> pd.DataFrame:
    """Every optimiser evaluation of J, in order: s (means and σ of every input) and J
    (−inf where the model sample was unusable). The Hessian's evaluations are not included."""
    names = [e.parameter for e in result.estimates]
    columns = {"evaluation": np.arange(1, result.n_evaluations + 1, dtype=np.int64), "j": result.trace_j}
    for k, name in enumerate(names):
        columns[f"mu_{name}"] = result.trace_means[:, k]
        columns[f"sigma_{name}"] = result.trace_sigmas[:, k]
    return pd.DataFrame(columns)


#: Columns of ``laws_comparison.csv``.
LAWS_COMPARISON_COLUMNS = ("parameter", "statistic", "all_spans", "all_spans_se", "explained_spans",
                           "explained_spans_se", "difference", "difference_se", "z", "n_all", "n_explained")


def laws_comparison(all_spans: pd.DataFrame, explained: pd.DataFrame, n_all: int, n_explained: int) -> pd.DataFrame:
    """The laws identified on every span against those on the spans the final model explains,
    per input and statistic (``mu``, ``sigma``): both with their standard errors, the difference
    and its standard error — for nested samples of an efficient estimator
    ``√(se_explained² − se_all²)`` (the part of the subset's variance the left-out spans would
    have removed; NaN where not positive) — and ``z`` = difference / its standard error."""
    a = all_spans.set_index("parameter")
    b = explained.set_index("parameter")
    rows = []
    for name in a.index:
        for stat in ("mu", "sigma"):
            x, sx = float(a.loc[name, stat]), float(a.loc[name, f"{stat}_se"])
            y, sy = float(b.loc[name, stat]), float(b.loc[name, f"{stat}_se"])
            var = sy ** 2 - sx ** 2
            se = float(np.sqrt(var)) if var > 0 else float("nan")
            rows.append({"parameter": name, "statistic": stat, "all_spans": x, "all_spans_se": sx,
                         "explained_spans": y, "explained_spans_se": sy, "difference": y - x, "difference_se": se,
                         "z": (y - x) / se if se > 0 else float("nan"), "n_all": n_all, "n_explained": n_explained})
    return pd.DataFrame(rows, columns=list(LAWS_COMPARISON_COLUMNS))
