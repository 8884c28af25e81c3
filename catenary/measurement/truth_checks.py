"""Checks of the pipeline's stages against the virtual campaign's truth (validation only).

The pipeline never reads the truth; these functions compare what it produced with what the
campaign planted (:mod:`catenary.measurement.campaign`): the registered masts with the true masts
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
           "realized_truth", "registration_round_trip", "repeatability_round_trip", "span_accuracy_round_trip"]

#: A used span's W is "within" when its RMS over the droppers lies within this of the truth's
#: dynamic W of the same run [m] (issue [20]: twice the sensor's 0.47 mm as it reaches W).
W_WITHIN_M = 1e-3
#: P(|z| > 3) of a standard normal: the largest chance that a span's RMS W error exceeds three
#: times its stated RMS standard error, reached when the errors of its droppers are one
#: common error (for several independent parts the chance is smaller).
P_BEYOND_3_SIGMA = 0.0026998

#: Largest distance between a span's registered masts and the true ones for the spans to be the
#: same [m] (a registration places masts to decimetres; spans are tens of metres).
MATCH_TOLERANCE_M = 3.0


def match_spans(spans: pd.DataFrame, truth: pd.DataFrame, tolerance_m: float = MATCH_TOLERANCE_M,
                masts: pd.DataFrame | None = None, truth_runs: pd.DataFrame | None = None) -> np.ndarray:
    """The truth's ``span_id`` of each row of ``spans`` whose two masts lie within ``tolerance_m``
    of a true span's, else "" (object array).

    By default the spans' (``start_chainage_m``, ``end_chainage_m``) are compared with the truth's:
    the mast table's frame, which is the line's true chainage whenever there is a table. Given the
    registration's ``masts`` (``registration/masts.csv``) and the campaign's ``truth_runs``, the
    comparison is made in each run's recorded chainage instead (the masts' ``recorded_chainage_m``
    against the truth's ``recorded_start_chainage_m`` / ``recorded_end_chainage_m`` of the same
    run): frame-free, so that masts found from the trace without a table, whose chainage frame is
    the recording's and not the line's, are matched too.
    """
    if masts is not None and truth_runs is not None:
        recorded = masts.set_index(["run_id", "mast_id"])["recorded_chainage_m"]
        keys = spans["run_id"].astype(str).to_numpy()
        x0s = recorded.reindex(list(zip(keys, spans["left_mast_id"].astype(str)))).to_numpy(dtype=float)
        x1s = recorded.reindex(list(zip(keys, spans["right_mast_id"].astype(str)))).to_numpy(dtype=float)
        candidates = {run: (part["recorded_start_chainage_m"].to_numpy(dtype=float),
                            part["recorded_end_chainage_m"].to_numpy(dtype=float),
                            part["span_id"].to_numpy(dtype=object))
                      for run, part in truth_runs.groupby("run_id", sort=False)}
    else:
        keys = np.full(len(spans), "", dtype=object)
        x0s = spans["start_chainage_m"].to_numpy(dtype=float)
        x1s = spans["end_chainage_m"].to_numpy(dtype=float)
        candidates = {"": (truth["start_chainage_m"].to_numpy(dtype=float),
                           truth["end_chainage_m"].to_numpy(dtype=float), truth["span_id"].to_numpy(dtype=object))}
    out = np.full(len(spans), "", dtype=object)
    for k, (key, x0, x1) in enumerate(zip(keys, x0s, x1s)):
        if key not in candidates:
            continue
        a, b, ids = candidates[key]
        # a reverse run records its spans from the far mast: compare the span's ends as a set
        d = np.minimum(np.maximum(np.abs(a - x0), np.abs(b - x1)), np.maximum(np.abs(a - x1), np.abs(b - x0)))
        j = int(np.nanargmin(d)) if np.isfinite(d).any() else -1
        if j >= 0 and d[j] <= tolerance_m:
            out[k] = ids[j]
    return out


def _w(table: pd.DataFrame, prefix: str = "") -> np.ndarray:
    n = len([c for c in table.columns if c.startswith(f"{prefix}w") and c.endswith("_m")
             and c[len(prefix) + 1:-2].isdigit()])
    return table[[f"{prefix}w{i}_m" for i in range(1, n + 1)]].to_numpy(dtype=float)


def _with_truth(rows: pd.DataFrame, truth: pd.DataFrame, truth_runs: pd.DataFrame | None = None,
                masts: pd.DataFrame | None = None) -> pd.DataFrame:
    """``rows`` (spans of the pipeline, one per span and run) matched to the true spans by position
    (in each run's recorded chainage given ``masts``: :func:`match_spans`), with the truth's columns
    (and, with ``truth_runs``, the dynamic W of the same run)."""
    rows = rows.assign(truth_span_id=match_spans(rows, truth, masts=masts, truth_runs=truth_runs))
    rows = rows[rows["truth_span_id"] != ""]
    merged = rows.merge(truth.drop(columns=[c for c in truth.columns if c.startswith("dynamic_w")] if truth_runs
                                   is not None else []).rename(columns={"span_id": "truth_span_id"}),
                        on="truth_span_id", suffixes=("", "_truth"))
    if truth_runs is not None and "run_id" in rows.columns:
        runs = truth_runs[["span_id", "run_id"] + [c for c in truth_runs.columns if c.startswith("dynamic_w")]]
        merged = merged.merge(runs.rename(columns={"span_id": "truth_span_id"}), on=["truth_span_id", "run_id"])
    return merged


def projection_round_trip(spans: pd.DataFrame, truth: pd.DataFrame, truth_runs: pd.DataFrame | None = None,
                          masts: pd.DataFrame | None = None) -> dict[str, float]:
    """Compare projected W with the truth's dynamic (of the same run) and static W of the same
    spans [m]; ``n_unmatched``: projected spans that are no true span (cut in the wrong place).
    Given the registration's ``masts``, spans are matched in each run's recorded chainage
    (:func:`match_spans`)."""
    merged = _with_truth(spans, truth, truth_runs, masts)
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


def registration_round_trip(masts: pd.DataFrame, masts_truth: pd.DataFrame, truth_runs: pd.DataFrame,
                            tolerance_m: float = 2.0) -> pd.DataFrame:
    """The registered masts of each run against the true masts.

    Parameters
    ----------
    masts : pandas.DataFrame
        ``registration/masts.csv``.
    masts_truth : pandas.DataFrame
        The campaign's ``masts_truth.csv`` (true chainage and what the table did to each mast).
    truth_runs : pandas.DataFrame
        The campaign's truth per span and run (recorded chainages of the masts).

    Returns
    -------
    pandas.DataFrame
        Per run: ``n_true_masts``, ``n_registered`` (masts placed), ``n_found`` (placed within
        ``tolerance_m`` of a true mast), ``n_missing_planted`` / ``n_missing_found`` (masts left out
        of the table / inserted by the registration at a true mast), ``n_extra_planted`` /
        ``n_extra_dropped``, ``rms_error_m`` and ``max_error_m`` (placed minus true position in
        the run's recorded chainage, over the masts found; masts are matched in that chainage, so
        masts found from the trace without a table are checked too), and the same over the masts placed
        by the trace (``matched`` and inserted: ``rms_error_trace_m``) and by the table alone.
    """
    true = masts_truth[masts_truth["status"] != "extra_in_table"]
    rows = []
    for run_id, part in masts.groupby("run_id", sort=False):
        runs = truth_runs[truth_runs["run_id"] == run_id]
        # every true mast's position in this run's recorded chainage (the frame the trace gives,
        # whatever frame the table or its absence gives the registered chainage_m)
        x_recorded = np.unique(np.concatenate([runs["recorded_start_chainage_m"].to_numpy(dtype=float),
                                               runs["recorded_end_chainage_m"].to_numpy(dtype=float)]))
        placed = part[part["status"] != "extra_in_table"]
        errors, trace, table = [], [], []
        n_found = n_inserted = 0
        for r in placed.itertuples():
            if not np.isfinite(r.recorded_chainage_m):
                continue
            d = np.abs(x_recorded - r.recorded_chainage_m)
            j = int(np.argmin(d))
            if d[j] > tolerance_m:
                continue
            n_found += 1
            n_inserted += r.status == "missing_from_table"
            e = float(r.recorded_chainage_m - x_recorded[j])
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


def _pooled_within_rms(error: np.ndarray, groups: np.ndarray) -> tuple[float, int]:
    """RMS per dropper of the pooled within-group scatter of ``error`` (rows grouped by
    ``groups``: Σ (e − ē)² / Σ (k − 1), averaged over the columns, square-rooted) and its
    degrees of freedom Σ (k − 1)."""
    frame = pd.DataFrame(error).assign(group=groups)
    centred = error - frame.groupby("group").transform("mean").to_numpy()
    dof = int(len(frame) - frame["group"].nunique())
    return (float(np.sqrt(np.sum(centred ** 2) / (dof * error.shape[1]))) if dof > 0 else float("nan")), dof


def repeatability_round_trip(corrected: pd.DataFrame, spans: pd.DataFrame, truth: pd.DataFrame,
                             truth_runs: pd.DataFrame, masts: pd.DataFrame | None = None) -> dict[str, float]:
    """What the run-to-run scatter of the corrected W is made of, measured against the truth.

    Each converged run's error on a span, corrected W minus the truth's static W, splits into the
    sensor's part as it reaches W (projected W minus the same run's true dynamic W: noise,
    quantisation, spikes, the projection's local fits) and the correction's part (the rest: what
    the dropper-only correction leaves, which depends on the direction of travel and the speed).
    Pooled over the spans measured by several runs, the within-span scatter of each part is what
    the repeatability (:mod:`catenary.measurement.repeatability`) estimates in total [m, RMS per dropper].

    Returns
    -------
    dict
        ``n_spans`` (true spans with ≥ 2 converged runs), ``dof`` (Σ (k − 1)),
        ``within_total_m`` (the truth-side value of what the repeatability estimates),
        ``within_sensor_m`` (the planted noise's share: the reference for the repeatability of
        runs that the correction treats alike) and ``within_correction_m``.
    """
    measured = _with_truth(spans, truth, truth_runs, masts)        # corrected spans keep the projected span's ids
    n = _w(measured).shape[1]
    fixed = corrected.loc[corrected["converged"], ["span_id", "run_id"] + [f"w{i}_m" for i in range(1, n + 1)]]
    both = fixed.merge(measured.rename(columns={f"w{i}_m": f"w{i}_m_projected" for i in range(1, n + 1)}),
                       on=["span_id", "run_id"])
    several = both.groupby("truth_span_id")["run_id"].transform("nunique") >= 2
    both = both[several]
    if both.empty:
        return {"n_spans": 0.0, "dof": 0.0, "within_total_m": float("nan"), "within_sensor_m": float("nan"),
                "within_correction_m": float("nan")}
    projected = both[[f"w{i}_m_projected" for i in range(1, n + 1)]].to_numpy(dtype=float)
    total = _w(both) - _w(both, "static_")
    sensor = projected - _w(both, "dynamic_")
    groups = both["truth_span_id"].to_numpy()
    within_total, dof = _pooled_within_rms(total, groups)
    return {"n_spans": float(both["truth_span_id"].nunique()), "dof": float(dof), "within_total_m": within_total,
            "within_sensor_m": _pooled_within_rms(sensor, groups)[0],
            "within_correction_m": _pooled_within_rms(total - sensor, groups)[0]}


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
        (estimate − realized) / standard_error, ``n_spans``, the run's ``status``, and where
        ``s_opt`` has them the 95 % intervals against the realized value: ``profile_low``,
        ``profile_high``, ``inside_profile`` (statistical) and ``total_low``, ``total_high``,
        ``inside_total`` (with the correction's model error; NaN/False when not measured).
    """
    from scipy.stats import norm

    z95 = float(norm.ppf(0.975))   # the identification's Z95 (its intervals' half-width in standard errors)
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
            ends = {}
            for kind in ("profile", "total"):
                low = float(getattr(r, f"{statistic}_{kind}_low", np.nan))
                high = float(getattr(r, f"{statistic}_{kind}_high", np.nan))
                if kind == "profile" and not np.isfinite(low):      # not profiled: the Wald interval
                    low, high = float(estimate) - z95 * float(se), float(estimate) + z95 * float(se)
                ends.update({f"{kind}_low": low, f"{kind}_high": high, f"inside_{kind}": bool(low <= true <= high)})
            rows.append({"parameter": r.parameter, "statistic": statistic, "estimate": float(estimate),
                         "standard_error": float(se), "realized": true,
                         "z": (float(estimate) - true) / float(se) if se > 0 else float("nan"),
                         "n_spans": int(len(used)), "status": r.status, **ends})
    return pd.DataFrame(rows, columns=["parameter", "statistic", "estimate", "standard_error", "realized", "z",
                                       "n_spans", "status", "profile_low", "profile_high", "inside_profile",
                                       "total_low", "total_high", "inside_total"])


def span_accuracy_round_trip(report: pd.DataFrame, spans: pd.DataFrame, sections: pd.DataFrame,
                             masts: pd.DataFrame, masts_truth: pd.DataFrame, truth: pd.DataFrame,
                             truth_runs: pd.DataFrame, planted_table_std_m: float) -> pd.DataFrame:
    """Per run, what a registration with a loose mast table makes of the spans (issue [20]).

    Parameters
    ----------
    report : pandas.DataFrame
        ``spans_report.csv``.
    spans : pandas.DataFrame
        Every span type's ``spans.parquet`` concatenated (the W columns of the longest type; a
        shorter type's missing columns NaN).
    sections, masts : pandas.DataFrame
        ``registration/sections.csv`` and ``registration/masts.csv``.
    masts_truth, truth, truth_runs : pandas.DataFrame
        The campaign's truth per mast, per span and per span and run.
    planted_table_std_m : float
        Standard deviation of the table's planted errors [m] (a uniform ±a: a/√3).

    Returns
    -------
    pandas.DataFrame
        One row per run: ``n_true_spans``, ``n_eligible`` (true spans whose masts are both in the
        table: not next to a mast missing from it), ``n_used_own_id`` (of those, used under their
        own id and cut at their own masts), ``n_within`` (of those, W within :data:`W_WITHIN_M`
        RMS of the truth's dynamic W) and ``fraction_within`` (over ``n_eligible``),
        ``n_true_length_mismatch`` (true spans rejected as a length mismatch), ``n_used``,
        ``n_beyond_3_sigma`` (used spans whose RMS W error exceeds three times their stated RMS
        standard error √(w_support_std_m² + w_noise_std_m²)) and ``expected_beyond_3_sigma_max``
        (at most that many by chance: :data:`P_BEYOND_3_SIGMA` per span), ``n_sections``,
        ``n_refused``, ``planted_table_std_m``, the sections' estimated ``table_std_min_m`` /
        ``table_std_max_m`` / ``table_std_pooled_m`` (RMS weighted by masts) and the realized
        error's ``realized_table_std_m`` (each section's listed masts' errors about their best
        line, what a section's map leaves of them, pooled), ``worst_table_std_ratio`` (the
        section estimate furthest from the planted value, as a ratio) and
        ``worst_realized_ratio`` (furthest from its own section's realized value).
    """
    missing = set(masts_truth.loc[masts_truth["status"] == "missing_from_table", "mast_id"].astype(str))
    listed = masts_truth[masts_truth["status"] == "listed"]
    by_section = {}
    for section_id, part in listed.groupby("section_id", sort=False):
        x = part["chainage_m"].to_numpy(dtype=float)
        deviation = part["table_chainage_m"].to_numpy(dtype=float) - x
        a = np.vander(x - x[0], 2)
        left = deviation - a @ np.linalg.lstsq(a, deviation, rcond=None)[0]
        by_section[str(section_id)] = (float(left @ left), max(len(x) - 2, 1))
    realized = float(np.sqrt(sum(v for v, _ in by_section.values()) / sum(n for _, n in by_section.values())))
    true_ids = truth["span_id"].astype(str)
    ends = true_ids.str.split("-", n=1, expand=True)
    eligible = set(true_ids[~(ends[0].isin(missing) | ends[1].isin(missing))])
    rows = []
    for run_id, part in report.groupby("run_id", sort=False):
        used = spans[spans["run_id"].astype(str) == str(run_id)]
        merged = _with_truth(used, truth, truth_runs, masts)
        error = _w(merged) - _w(merged, "dynamic_")
        rms = np.sqrt(np.nanmean(error ** 2, axis=1)) if len(merged) else np.zeros(0)
        own = merged["span_id"].astype(str).to_numpy() == merged["truth_span_id"].astype(str).to_numpy()
        good = own & np.isin(merged["span_id"].astype(str), list(eligible))
        stated = np.sqrt(np.nan_to_num(merged["w_support_std_m"].to_numpy(dtype=float)) ** 2
                         + merged["w_noise_std_m"].to_numpy(dtype=float) ** 2) if len(merged) else np.zeros(0)
        mismatch = part[(part["status"] != "used") & part["reason"].fillna("").str.contains("length mismatch")
                        & part["span_id"].astype(str).isin(set(true_ids))]
        secs = sections[sections["run_id"].astype(str) == str(run_id)]
        registered = secs[secs["status"] == "registered"]
        estimate = registered["table_std_m"].to_numpy(dtype=float)
        weights = registered["n_table_masts"].to_numpy(dtype=float)
        ratio = estimate / planted_table_std_m if estimate.size else np.array([np.nan])
        own = np.array([np.sqrt(by_section[str(k)][0] / by_section[str(k)][1]) if str(k) in by_section else np.nan
                        for k in registered["section_id"]])
        to_own = estimate / own if estimate.size else np.array([np.nan])
        rows.append({
            "run_id": run_id, "n_true_spans": int(len(truth)), "n_eligible": len(eligible),
            "n_used_own_id": int(good.sum()), "n_within": int((good & (rms <= W_WITHIN_M)).sum()),
            "fraction_within": float((good & (rms <= W_WITHIN_M)).sum() / max(len(eligible), 1)),
            "n_true_length_mismatch": int(len(mismatch)), "n_used": int(len(used)),
            "n_beyond_3_sigma": int((rms > 3.0 * stated).sum()),
            "expected_beyond_3_sigma_max": float(P_BEYOND_3_SIGMA * len(merged)),
            "n_sections": int(len(secs)), "n_refused": int((secs["status"] == "refused").sum()),
            "planted_table_std_m": planted_table_std_m,
            "table_std_min_m": float(np.min(estimate)) if estimate.size else float("nan"),
            "table_std_max_m": float(np.max(estimate)) if estimate.size else float("nan"),
            "table_std_pooled_m": float(np.sqrt(np.sum(weights * estimate ** 2) / np.sum(weights)))
            if estimate.size else float("nan"),
            "realized_table_std_m": realized,
            "worst_table_std_ratio": float(ratio[np.argmax(np.abs(np.log(ratio)))]),
            "worst_realized_ratio": float(to_own[np.nanargmax(np.abs(np.log(to_own)))])
            if np.isfinite(to_own).any() else float("nan"),
        })
    return pd.DataFrame(rows)
