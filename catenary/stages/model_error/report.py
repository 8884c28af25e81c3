"""The model-error section of an identification report (Markdown)."""

from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["model_error_lines"]


def model_error_lines(budget: pd.DataFrame | None, s_opt: pd.DataFrame, shifts, n_spans: int, label) -> list[str]:
    """Markdown lines: per identified parameter, its shift for one standard uncertainty of each
    source, the systematic, the 95 % total interval and the dominant source.

    Parameters
    ----------
    budget : pandas.DataFrame or None
        :func:`catenary.stages.identification.propagation.budget_table` (None: not measured).
    s_opt : pandas.DataFrame
        The s_opt table with its total intervals.
    shifts : SpanShifts or None
        :func:`catenary.stages.identification.propagation.span_shifts` (spans filled, sources not measured).
    n_spans : int
        Spans identified.
    label : callable
        ``label(parameter)`` → (name, μ unit, μ scale, σ unit, σ scale), as the report prints.
    """
    lines = ["## Model error of the correction", ""]
    unmeasured = shifts.unmeasured if shifts is not None else {}
    gaps = ["**Not in the budget** (no shift could be measured; the total intervals leave these sources out): "
            + "; ".join(f"`{s}` — {why}" for s, why in unmeasured.items()) + ".", ""] if unmeasured else []
    if budget is None or not len(budget):
        if unmeasured:
            return lines + gaps
        return lines + ["Not measured (`model_error.enabled: false`, or the identification's status is not ok): "
                        "the intervals above are statistical only; they say nothing of how far the measuring "
                        "car's model, which the correction inverts, is from the car.", ""]
    sources = [c.removeprefix("shift_") for c in budget.columns if c.startswith("shift_")]
    lines += ["Each source of the correction's model (config `model_error`) moved by one standard uncertainty "
              "moves every corrected W (`correction/model_error.parquet`) and so every identified parameter "
              "(linearised at s_opt through the likelihood's curvature; within 1 % of a full "
              "re-identification on T_MW's mean and 0.01 standard errors on every σ where tested). The sources are independent and shared by every span: their "
              "root sum of squares is the parameter's systematic standard uncertainty, and the 95 % total "
              "interval widens each side of the statistical one (profile, else ±1.96 se) in quadrature with "
              "1.96 times it. Machine-readable: `model_error.csv`, and `s_opt.csv` (`*_systematic`, "
              "`*_total_low`, `*_total_high`).", ""]
    lines += gaps
    if shifts is not None and any(shifts.filled.values()):
        lines += ["Spans with no measured shift of their own (`model_error.sections_per_span_type`, or a run the "
                  "correction failed) take the measured spans' mean per dropper: "
                  + ", ".join(f"{s} {n} of {n_spans}" for s, n in shifts.filled.items()) + ".", ""]
    lines += ["| parameter | statistic | estimate | " + " | ".join(sources) + " | systematic | 95 % total | "
              "dominant | unit |", "|---|---|---:|" + "---:|" * len(sources) + "---:|---|---|---|"]
    table = s_opt.set_index("parameter")
    for r in budget.itertuples():
        name, mu_unit, mu_scale, sd_unit, sd_scale = label(r.parameter)
        unit, scale = (mu_unit, mu_scale) if r.statistic == "mu" else (sd_unit, sd_scale)
        low = table.loc[r.parameter, f"{r.statistic}_total_low"] * scale
        high = table.loc[r.parameter, f"{r.statistic}_total_high"] * scale
        moved = " | ".join(f"{getattr(r, f'shift_{s}') * scale:+.3g}" for s in sources)
        total = f"[{low:.5g}, {high:.5g}]" if np.isfinite(low) else "–"
        lines.append(f"| {name} | {'μ' if r.statistic == 'mu' else 'σ'} | {r.estimate * scale:.5g} | {moved} | "
                     f"{r.systematic * scale:.3g} | {total} | {r.dominant_source} | {unit} |")
    return lines + [""]
