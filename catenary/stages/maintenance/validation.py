"""The per-span posteriors against a campaign's truth (validation only).

* :func:`coverage_check` — per span type and input, how often the 90 % interval ``[q05, q95]``
  holds the span's true value (nominal 0.90; for K spans its binomial standard error is
  ``√(0.09 / K)``), the median width, and the RMS error of the posterior mean beside the
  dropper-only inversion's (paper §4.1: every other input's variability folded into the droppers);
* :func:`list_check` — the maintenance list against the truth's out-of-tolerance set: precision
  and recall at every threshold of a grid (the ROC of the list).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["coverage_check", "list_check"]


def _with_truth(posterior: pd.DataFrame, truth: pd.DataFrame) -> pd.DataFrame:
    long = truth.set_index("span_id")
    names = [c for c in posterior["input"].unique() if c in long.columns]
    values = long[names].stack().rename("truth")
    values.index.names = ["span_id", "input"]
    return posterior.join(values, on=["span_id", "input"], how="inner")


def coverage_check(posterior: pd.DataFrame, truth: pd.DataFrame, span_type: str,
                   inversion: pd.DataFrame | None = None) -> pd.DataFrame:
    """One row per input: ``span_type``, ``input``, ``n_spans``, ``coverage_90``, ``coverage_se``,
    ``median_width``, ``rmse_posterior_mean``, ``rmse_dropper_only`` (droppers, when the
    inversion's ``droppers.parquet`` is given) — widths and errors in the input's unit."""
    both = _with_truth(posterior, truth)
    rows = []
    inv = inversion.set_index("span_id") if inversion is not None else None
    for name, part in both.groupby("input", sort=False):
        inside = (part["q05"] <= part["truth"]) & (part["truth"] <= part["q95"])
        row = {"span_type": span_type, "input": name, "n_spans": len(part), "coverage_90": float(inside.mean()),
               "coverage_se": float(np.sqrt(0.09 / len(part))),
               "median_width": float((part["q95"] - part["q05"]).median()),
               "rmse_posterior_mean": float(np.sqrt(np.mean((part["mean"] - part["truth"]) ** 2))),
               "rmse_dropper_only": np.nan}
        if inv is not None and name in inv.columns:
            common = part[part["span_id"].isin(inv.index)]
            err = inv.loc[common["span_id"], name].to_numpy() - common["truth"].to_numpy()
            row["rmse_dropper_only"] = float(np.sqrt(np.mean(err**2)))
        rows.append(row)
    return pd.DataFrame(rows)


def _dropper_of(name: str) -> str:
    """``dropper_3_force_n`` → ``dropper_3_length_m`` (a dropper's two rows are one item to act on)."""
    return name.replace("_force_n", "_length_m") if name.startswith("dropper_") else name


def list_check(posterior: pd.DataFrame, truth: pd.DataFrame, span_type: str,
               thresholds: np.ndarray | None = None) -> pd.DataFrame:
    """Precision and recall of the list against the inputs truly outside their tolerance, per
    threshold: ``span_type``, ``threshold``, ``n_out_true``, ``n_listed``, ``n_listed_true``,
    ``precision``, ``recall``, ``false_positive_rate``.

    A dropper is one item, listed when its length or its force row is (an unloaded dropper is
    acted on like a long one), and truly out when its length lies outside tolerance."""
    rows = posterior[np.isfinite(posterior["p_out_of_tolerance"])].assign(
        item=lambda d: d["input"].map(_dropper_of))
    p_item = rows.groupby(["span_id", "item"])["p_out_of_tolerance"].max().rename("p").reset_index()
    limits = posterior[~posterior["input"].str.endswith("_force_n")]
    both = _with_truth(limits, truth).merge(p_item, left_on=["span_id", "input"], right_on=["span_id", "item"])
    out = ((both["truth"] < both["lower"]) | (both["truth"] > both["upper"])).to_numpy()
    p = both["p"].to_numpy()
    thresholds = np.round(np.linspace(0.05, 0.95, 19), 2) if thresholds is None else np.asarray(thresholds)
    rows = []
    for t in thresholds:
        listed = p > t
        hit = int(np.sum(listed & out))
        rows.append({"span_type": span_type, "threshold": float(t), "n_out_true": int(out.sum()),
                     "n_listed": int(listed.sum()), "n_listed_true": hit,
                     "precision": hit / listed.sum() if listed.any() else np.nan,
                     "recall": hit / out.sum() if out.any() else np.nan,
                     "false_positive_rate": float(np.sum(listed & ~out) / max(int(np.sum(~out)), 1))})
    return pd.DataFrame(rows)
