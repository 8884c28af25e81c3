"""The budget at the level of W: per span type, dropper and source, the mean shift of the corrected
W per standard uncertainty, against the size of the correction itself (the paper's assumption 1,
§2.2: the corrected bias is much larger than the remaining model uncertainty)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from catenary.measurement.repeatability import w_columns

__all__ = ["w_budget"]


def w_budget(shifts: pd.DataFrame, corrected: pd.DataFrame, spans: pd.DataFrame) -> pd.DataFrame:
    """The W-level budget table.

    Parameters
    ----------
    shifts : pandas.DataFrame
        The sections' model-error tables (:func:`catenary.stages.model_error.correction.run_shifts`).
    corrected : pandas.DataFrame
        Corrected spans of every type (``span_type``, ``span_id``, ``run_id``, ``converged``, W).
    spans : pandas.DataFrame
        The projected spans the correction started from (same keys, measured W).

    Returns
    -------
    pandas.DataFrame
        One row per span type and dropper: ``n_spans`` (converged spans and runs with a measured
        shift), ``correction_mean_m`` (mean of corrected minus projected W: the bias the correction
        removes), ``shift_<source>_m`` (mean shift of the corrected W for +1 standard uncertainty
        of each source), ``systematic_m`` (their root sum of squares: one standard uncertainty of
        the corrected W from the car's model, shared by every span), ``correction_over_systematic``
        and ``dominant_source``. Spans whose shift could not be measured (``status``) are left out
        and counted in ``n_not_measured``.
    """
    keys = ["span_type", "span_id", "run_id"]
    ok = shifts[shifts["status"] == ""]
    converged = corrected[corrected["converged"]]
    rows = []
    for span_type, part in converged.groupby("span_type", sort=True):
        cols = [c for c in w_columns(part) if part[c].notna().any()]
        measured = spans[spans["span_type"] == span_type]
        both = part[keys + cols].merge(measured[keys + cols], on=keys, suffixes=("", "_measured"))
        correction = both[cols].to_numpy(dtype=float) - both[[f"{c}_measured" for c in cols]].to_numpy(dtype=float)
        mine = ok[ok["span_type"] == span_type].merge(part[keys], on=keys)
        sources = list(dict.fromkeys(shifts["source"]))
        n_not = int(shifts[(shifts["span_type"] == span_type) & (shifts["status"] != "")][keys].drop_duplicates()
                    .shape[0])
        for i, c in enumerate(cols):
            row = {"span_type": span_type, "dropper": i + 1,
                   "n_spans": int(mine[keys].drop_duplicates().shape[0]), "n_not_measured": n_not,
                   "correction_mean_m": float(np.mean(correction[:, i])) if len(correction) else float("nan")}
            means = {s: float(mine.loc[mine["source"] == s, c].mean()) for s in sources}
            row.update({f"shift_{s}_m": v for s, v in means.items()})
            row["systematic_m"] = float(np.sqrt(np.nansum(np.square(list(means.values())))))
            row["correction_over_systematic"] = (abs(row["correction_mean_m"]) / row["systematic_m"]
                                                 if row["systematic_m"] > 0 else float("nan"))
            finite = {s: abs(v) for s, v in means.items() if np.isfinite(v)}
            row["dominant_source"] = max(finite, key=finite.get) if finite else ""
            rows.append(row)
    return pd.DataFrame(rows)
