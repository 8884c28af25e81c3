"""Checks of the pipeline's stages against the virtual campaign's truth (validation only).

The pipeline never reads the truth; these functions compare what it produced with what the
campaign planted (:mod:`catenary.campaign`): the registered masts with the true masts
(:func:`registration_round_trip`), the projected W with the true dynamic W of each run
(:func:`projection_round_trip`), the corrected W with the true static W
(:func:`correction_round_trip`), the identified laws with the realized truth
(:func:`identification_round_trip`). A span the pipeline names otherwise than the truth (a mast
the registration inserted, ``M0023+1``, is the truth's ``M0024``) is matched to the true span by
its masts' chainages (:func:`match_spans`).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["correction_round_trip", "identification_round_trip", "match_spans", "projection_round_trip",
           "realized_truth", "registration_round_trip"]

#: Largest distance between a span's registered masts and the true ones for the spans to be the
#: same [m] (a registration places masts to decimetres; spans are tens of metres).
MATCH_TOLERANCE_M = 3.0


def match_spans(spans: pd.DataFrame, truth: pd.DataFrame, tolerance_m: float = MATCH_TOLERANCE_M) -> np.ndarray:
    """The truth's ``span_id`` of each row of ``spans`` whose two masts lie within ``tolerance_m``
    of a true span's (``start_chainage_m``, ``end_chainage_m``), else "" (object array)."""
    a = truth["start_chainage_m"].to_numpy(dtype=float)
    b = truth["end_chainage_m"].to_numpy(dtype=float)
    ids = truth["span_id"].to_numpy(dtype=object)
    out = np.full(len(spans), "", dtype=object)
    for k, (x0, x1) in enumerate(zip(spans["start_chainage_m"].to_numpy(dtype=float),
                                     spans["end_chainage_m"].to_numpy(dtype=float))):
        d = np.maximum(np.abs(a - x0), np.abs(b - x1))
        j = int(np.argmin(d)) if d.size else -1
        if j >= 0 and d[j] <= tolerance_m:
            out[k] = ids[j]
    return out


def _w(table: pd.DataFrame, prefix: str = "") -> np.ndarray:
    n = len([c for c in table.columns if c.startswith(f"{prefix}w") and c.endswith("_m")
             and c[len(prefix) + 1:-2].isdigit()])
    return table[[f"{prefix}w{i}_m" for i in range(1, n + 1)]].to_numpy(dtype=float)


def _with_truth(rows: pd.DataFrame, truth: pd.DataFrame, truth_runs: pd.DataFrame | None = None) -> pd.DataFrame:
    """``rows`` (spans of the pipeline, one per span and run) matched to the true spans by position,
    with the truth's columns (and, with ``truth_runs``, the dynamic W of the same run)."""
    rows = rows.assign(truth_span_id=match_spans(rows, truth))
    rows = rows[rows["truth_span_id"] != ""]
    merged = rows.merge(truth.drop(columns=[c for c in truth.columns if c.startswith("dynamic_w")] if truth_runs
                                   is not None else []).rename(columns={"span_id": "truth_span_id"}),
                        on="truth_span_id", suffixes=("", "_truth"))
    if truth_runs is not None and "run_id" in rows.columns:
        runs = truth_runs[["span_id", "run_id"] + [c for c in truth_runs.columns if c.startswith("dynamic_w")]]
        merged = merged.merge(runs.rename(columns={"span_id": "truth_span_id"}), on=["truth_span_id", "run_id"])
    return merged


def projection_round_trip(spans: pd.DataFrame, truth: pd.DataFrame, truth_runs: pd.DataFrame | None = None
                          ) -> dict[str, float]:
    """Compare projected W with the truth's dynamic (of the same run) and static W of the same
    spans [m]; ``n_unmatched``: projected spans that are no true span (cut in the wrong place)."""
    merged = _with_truth(spans, truth, truth_runs)
    w, dyn, sta = _w(merged), _w(merged, "dynamic_"), _w(merged, "static_")
    return {
        "n_spans": float(len(merged)),
        "n_unmatched": float(len(spans) - len(merged)),
        "rms_vs_dynamic_m": float(np.sqrt(np.mean((w - dyn) ** 2))) if len(merged) else float("nan"),
        "max_abs_vs_dynamic_m": float(np.max(np.abs(w - dyn))) if len(merged) else float("nan"),
        "rms_vs_static_m": float(np.sqrt(np.mean((w - sta) ** 2))) if len(merged) else float("nan"),
    }


def correction_round_trip(corrected: pd.DataFrame, spans: pd.DataFrame, truth: pd.DataFrame) -> dict[str, float]:
    """Corrected static W (converged spans) and the uncorrected projected W against the truth's
    static W of the same spans [m]: the correction's accuracy and the size of the correction.

    ``max_abs_mean_error_m`` and ``max_abs_mean_error_z`` look for a bias the RMS would hide: at
    each dropper the mean error over the spans, and that mean in units of its standard error
    (sample standard deviation / √n); the largest over the droppers. A correction with the
    wrong measuring force, for example, leaves a mid-span-heavy mean error.
    """
    merged = _with_truth(corrected[corrected["converged"]], truth)
    raw = _with_truth(spans, truth)
    error = _w(merged) - _w(merged, "static_")
    raw_error = _w(raw) - _w(raw, "static_")
    per_span = np.sqrt(np.mean(error ** 2, axis=1)) if len(merged) else np.zeros(0)
    if len(merged) > 1:
        mean_error = error.mean(axis=0)
        z = np.abs(mean_error) / (error.std(axis=0, ddof=1) / np.sqrt(len(merged)))
        bias_m, bias_z = float(np.max(np.abs(mean_error))), float(np.max(z))
    else:
        bias_m = bias_z = float("nan")
    return {
        "n_spans": float(len(corrected)),
        "n_converged": float(int(corrected["converged"].sum())),
        "rms_corrected_vs_static_m": float(np.sqrt(np.mean(error ** 2))) if len(merged) else float("nan"),
        "max_abs_corrected_vs_static_m": float(np.max(np.abs(error))) if len(merged) else float("nan"),
        "max_span_rms_corrected_vs_static_m": float(np.max(per_span)) if per_span.size else float("nan"),
        "max_abs_mean_error_m": bias_m,
        "max_abs_mean_error_z": bias_z,
        "rms_uncorrected_vs_static_m": float(np.sqrt(np.mean(raw_error ** 2))) if len(raw) else float("nan"),
    }


def registration_round_trip(masts: pd.DataFrame, masts_truth: pd.DataFrame, truth: pd.DataFrame,
                            truth_runs: pd.DataFrame, tolerance_m: float = 2.0) -> pd.DataFrame:
    """The registered masts of each run against the true masts.

    Parameters
    ----------
    masts : pandas.DataFrame
        ``registration/masts.csv``.
    masts_truth : pandas.DataFrame
        The campaign's ``masts_truth.csv`` (true chainage and what the table did to each mast).
    truth, truth_runs : pandas.DataFrame
        The campaign's truth per span and per span and run (recorded chainages of the masts).

    Returns
    -------
    pandas.DataFrame
        Per run: ``n_true_masts``, ``n_registered`` (masts placed), ``n_found`` (placed within
        ``tolerance_m`` of a true mast), ``n_missing_planted`` / ``n_missing_found`` (masts left out
        of the table / inserted by the registration at a true mast), ``n_extra_planted`` /
        ``n_extra_dropped``, ``rms_error_m`` and ``max_error_m`` (placed minus true position in
        the run's recorded chainage, over the masts found), and the same over the masts placed
        by the trace (``matched`` and inserted: ``rms_error_trace_m``) and by the table alone.
    """
    true = masts_truth[masts_truth["status"] != "extra_in_table"]
    x_true = true["chainage_m"].to_numpy(dtype=float)
    rows = []
    for run_id, part in masts.groupby("run_id", sort=False):
        runs = truth_runs[truth_runs["run_id"] == run_id].merge(truth[["span_id", "start_chainage_m", "end_chainage_m"]],
                                                                on="span_id")
        recorded = dict(zip(np.round(runs["start_chainage_m"], 3), runs["recorded_start_chainage_m"]))
        recorded.update(zip(np.round(runs["end_chainage_m"], 3), runs["recorded_end_chainage_m"]))
        placed = part[part["status"] != "extra_in_table"]
        errors, trace, table = [], [], []
        n_found = n_inserted = 0
        for r in placed.itertuples():
            d = np.abs(x_true - r.chainage_m)
            j = int(np.argmin(d))
            if d[j] > tolerance_m:
                continue
            n_found += 1
            n_inserted += r.status == "missing_from_table"
            true_recorded = recorded.get(round(float(x_true[j]), 3))
            if true_recorded is None or not np.isfinite(r.recorded_chainage_m):
                continue
            e = float(r.recorded_chainage_m - true_recorded)
            errors.append(e)
            (table if r.method == "table" else trace).append(e)
        rms = (lambda v: float(np.sqrt(np.mean(np.square(v)))) if v else float("nan"))
        rows.append({"run_id": run_id, "n_true_masts": int(len(true)), "n_registered": int(len(placed)),
                     "n_found": n_found,
                     "n_missing_planted": int((masts_truth["status"] == "missing_from_table").sum()),
                     "n_missing_found": n_inserted,
                     "n_extra_planted": int((masts_truth["status"] == "extra_in_table").sum()),
                     "n_extra_dropped": int((part["status"] == "extra_in_table").sum()),
                     "rms_error_m": rms(errors), "max_error_m": float(np.max(np.abs(errors))) if errors else float("nan"),
                     "rms_error_trace_m": rms(trace), "rms_error_table_m": rms(table)})
    return pd.DataFrame(rows)


def realized_truth(truth: pd.DataFrame, span_ids) -> dict[str, tuple[float, float]]:
    """Sample mean and standard deviation (ddof 1) of the true inputs over the spans ``span_ids``.

    T_MW and every dropper length are per span; ΔH is per mast, so its figures are over the
    distinct masts of those spans (a mast shared by two spans counts once, identified by its
    chainage). Keys are the identification's input names (``messenger_tension_n``,
    ``system_height_m``, ``dropper_<i>_length_m``); values ``(mean, std)`` in SI units.
    """
    spans = truth[truth["span_id"].isin(list(span_ids))]
    masts = pd.concat([spans[["start_chainage_m", "system_height_left_m"]].set_axis(["chainage_m", "dh_m"], axis=1),
                       spans[["end_chainage_m", "system_height_right_m"]].set_axis(["chainage_m", "dh_m"], axis=1)])
    masts = masts.assign(chainage_m=masts["chainage_m"].round(6)).drop_duplicates("chainage_m")
    out = {"messenger_tension_n": (float(spans["messenger_tension_n"].mean()),
                                   float(spans["messenger_tension_n"].std(ddof=1))),
           "system_height_m": (float(masts["dh_m"].mean()), float(masts["dh_m"].std(ddof=1)))}
    for column in [c for c in truth.columns if c.startswith("dropper_") and c.endswith("_length_m")]:
        out[column] = (float(spans[column].mean()), float(spans[column].std(ddof=1)))
    return out


def identification_round_trip(s_opt: pd.DataFrame, corrected: pd.DataFrame, truth: pd.DataFrame) -> pd.DataFrame:
    """Identified laws against the realized truth of the spans they were identified from.

    Parameters
    ----------
    s_opt : pandas.DataFrame
        The identification's ``s_opt.csv`` (``parameter``, ``mu``, ``sigma``, ``mu_se``,
        ``sigma_se``, ``mu_fixed``, ``status``).
    corrected : pandas.DataFrame
        The span type's ``corrected.parquet``: its converged spans are those identified from.
    truth : pandas.DataFrame
        The campaign's truth table.

    Returns
    -------
    pandas.DataFrame
        One row per identified quantity (free means and σ): ``parameter``, ``statistic``
        (``mu`` or ``sigma``), ``estimate``, ``standard_error``, ``realized`` (sample mean or
        standard deviation over the spans used, :func:`realized_truth`), ``z`` =
        (estimate − realized) / standard_error, ``n_spans`` and the run's ``status``.
    """
    converged = corrected[corrected["converged"]]
    used = pd.Series(match_spans(converged, truth)).drop_duplicates()
    used = used[used != ""]
    realized = realized_truth(truth, used)
    rows = []
    for r in s_opt.itertuples(index=False):
        if r.parameter not in realized:
            continue
        stats = ([] if r.mu_fixed else [("mu", r.mu, r.mu_se, realized[r.parameter][0])])
        stats.append(("sigma", r.sigma, r.sigma_se, realized[r.parameter][1]))
        for statistic, estimate, se, true in stats:
            rows.append({"parameter": r.parameter, "statistic": statistic, "estimate": float(estimate),
                         "standard_error": float(se), "realized": true,
                         "z": (float(estimate) - true) / float(se) if se > 0 else float("nan"),
                         "n_spans": int(len(used)), "status": r.status})
    return pd.DataFrame(rows, columns=["parameter", "statistic", "estimate", "standard_error", "realized", "z",
                                       "n_spans", "status"])
