"""The front page of the HTML report: per span type, what a reader asks first.

``make run`` ends by writing ``results/report.html`` (``--report … --report-after-run``); the
report's opening panel is the reStructuredText this module writes (rule ``front_page``): the method in a few lines (from
``workflow/report/workflow.rst``), then per span type the spans used and rejected, the dynamic
correction's convergence, the paper's Table 2 analogue with standard errors and the diagnosis'
verdict at each step. It only reads the pipeline's own outputs.
"""

from __future__ import annotations

import json
import math
from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd

from catenary.stages.diagnosis.recommend import describe_measurement

# Snakemake renders the page with Jinja before docutils: no text of ours may hold Jinja markup.
_JINJA = ("{{", "}}", "{%", "%}", "{#", "#}")


def _number(value: float, digits: int = 4) -> str:
    """``value`` with ``digits`` significant digits, "–" for a missing value."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "–"
    return f"{float(value):.{digits}g}"


def _table(header: list[str], rows: list[list[str]]) -> list[str]:
    """An RST list-table."""
    lines = [".. list-table::", "   :header-rows: 1", ""]
    for row in [header] + rows:
        lines.append(f"   * - {row[0]}")
        lines.extend(f"     - {cell}" for cell in row[1:])
    return lines + [""]


def _heading(text: str, mark: str) -> list[str]:
    return [text, mark * len(text), ""]


def spans_lines(spans_report: pd.DataFrame, span_type: str) -> list[str]:
    """Spans of ``span_type`` used and rejected, with the count of each rejection reason."""
    rows = spans_report[spans_report["span_type"] == span_type]
    used = int((rows["status"] == "used").sum())
    rejected = rows[rows["status"] != "used"]
    text = f"**Spans:** {used} used, {len(rejected)} rejected"
    if len(rejected):
        reasons = rejected["reason"].fillna("no reason given").value_counts()
        text += " (" + "; ".join(f"{n} × {reason}" for reason, n in reasons.items()) + ")"
    return [text + ".", ""]


def registration_lines(sections: pd.DataFrame, prior_std_m: float) -> list[str]:
    """Per run, the mast table's accuracy as the run measured it (``registration/sections.csv``'s
    ``table_std_m``) against its prior, how well the masts are placed, and the sections refused
    with their reasons."""
    lines = []
    for run_id, rows in sections.groupby("run_id", sort=False):
        if (rows["status"] == "unregistered").all():
            lines += [f"**Registration, run {run_id}:** switched off: the masts file's chainages are taken as "
                      "they are.", ""]
            continue
        registered = rows[rows["status"] == "registered"]
        accuracy = registered["table_std_m"].dropna()
        text = f"**Registration, run {run_id}:** {len(registered)} of {len(rows)} sections registered"
        if len(accuracy):
            low, high = _number(float(accuracy.min()), 2), _number(float(accuracy.max()), 2)
            text += (f"; the mast table is accurate to {low}–{high} m as the run measures it "
                     f"(prior ``mast_table_std_m`` {_number(prior_std_m, 3)} m), the masts placed to "
                     f"{_number(float(np.sqrt(np.mean(registered['support_std_m'] ** 2))), 2)} m (RMS standard error)")
        refused = rows[rows["status"] == "refused"]
        if len(refused):
            text += "; refused: " + "; ".join(str(r) for r in refused["reason"])
        lines += [text + ".", ""]
    return lines


def correction_lines(summary: pd.DataFrame, span_type: str) -> list[str]:
    """The correction's convergence for ``span_type``."""
    rows = summary[summary["span_type"] == span_type]
    if rows.empty:
        return ["**Dynamic correction:** no span of this type was corrected.", ""]
    r = rows.iloc[0]
    return [f"**Dynamic correction:** {int(r.n_converged)} of {int(r.n_spans)} spans converged, "
            f"{_number(r.converged_within_3_percent, 3)} % within 3 passes, median {_number(r.median_iterations, 2)} "
            f"passes, largest final gap {_number(1e3 * r.max_gap_norm_m, 3)} mm.", ""]


#: How an engineer names each identified input and reads its values: label, factor from SI, unit.
_INPUTS = {"messenger_tension_n": ("messenger tension T_MW", 1.0, "N"),
           "contact_tension_n": ("contact tension T_CW", 1.0, "N"),
           "system_height_m": ("system height ΔH", 1e3, "mm")}


def engineer_input(parameter: str) -> tuple[str, float, str]:
    """An input's name as an engineer says it, the factor from its SI value and the unit read
    (``dropper_3_length_m`` → "dropper 3 length", 1000, "mm"); an unknown name stays as it is."""
    if parameter.startswith("dropper_") and parameter.endswith("_length_m"):
        return f"dropper {parameter.split('_')[1]} length", 1e3, "mm"
    return _INPUTS.get(parameter, (parameter, 1.0, "SI"))


def _in_unit(value: float, factor: float, unit: str) -> str:
    """A value in an engineer's unit: 0.1 mm, 1 N."""
    if value is None or not np.isfinite(value):
        return "–"
    x = float(value) * factor
    return f"{x:.1f}" if unit == "mm" else f"{x:.0f}" if unit == "N" else _number(x)


def _effect_size(name: str, value: float) -> str:
    """A named effect's parameter in an engineer's unit: lengths in mm, forces in N, fractions in %."""
    if name.endswith("_m"):
        return f"{1e3 * value:.3g} mm"
    if name.endswith("_n"):
        return f"{value:.4g} N"
    if name.endswith("_fraction"):
        return f"{100 * value:.3g} %"
    return _number(value)


def identification_lines(s_opt: pd.DataFrame, model_error: pd.DataFrame | None = None) -> list[str]:
    """The Table 2 analogue: μ and σ of every identified input with their standard errors and,
    where the correction's model-error budget was measured, the 95 % total intervals and the
    source that dominates each parameter's systematic."""
    status = sorted(set(s_opt["status"].astype(str)))
    converged = bool(s_opt["converged"].astype(bool).all())
    lines = [f"**Identification (Table 2 analogue):** optimiser {'converged' if converged else 'NOT converged'}, "
             f"status {', '.join(status)}. Lengths and heights in mm, tensions in N (the files keep SI); the "
             "dropper means are held at the nominal table unless configured free.", ""]
    budget = model_error is not None and len(model_error) > 0
    if budget:
        lines += ["The 95 % total intervals add to the statistical one the correction's model error (the "
                  "measuring car's force, pantograph, speed and the catenary's damping, each at its declared "
                  "uncertainty; *Identification* › *model error*); the dominant source is the one that moves "
                  "the parameter most.", ""]
        dominant = {(r.parameter, r.statistic): (r.dominant_source, r.systematic) for r in model_error.itertuples()}
    rows = []
    for r in s_opt.itertuples():
        fixed = bool(getattr(r, "mu_fixed", False))
        label, factor, unit = engineer_input(r.parameter)
        value = partial(_in_unit, factor=factor, unit=unit)
        row = [f"{label} [{unit}]", value(r.mu), "held fixed" if fixed else value(r.mu_se), value(r.sigma),
               value(r.sigma_se)]
        if budget:
            for statistic in ("mu", "sigma"):
                low, high = getattr(r, f"{statistic}_total_low"), getattr(r, f"{statistic}_total_high")
                row.append("–" if not np.isfinite(low) else f"[{value(low)}, {value(high)}]")
            row.append("; ".join(f"{stat}: {dominant[(r.parameter, key)][0]}" for key, stat in (("mu", "μ"), ("sigma", "σ"))
                                 if dominant.get((r.parameter, key), ("", 0))[0]))
        rows.append(row)
    header = ["input", "μ", "s.e. of μ", "σ", "s.e. of σ"]
    if budget:
        header += ["μ, 95 % total", "σ, 95 % total", "dominant model error"]
    return lines + _table(header, rows)


def diagnosis_lines(findings: pd.DataFrame | None) -> list[str]:
    """The diagnosis' verdict at each step, with the named effect's parameters."""
    if findings is None:
        return ["**Diagnosis:** not run for this span type.", ""]
    lines = ["**Diagnosis (missing physics):**", ""]
    for r in findings.itertuples():
        if r.verdict == "named":
            params = json.loads(r.parameters) if isinstance(r.parameters, str) and r.parameters else {}
            sizes = ", ".join(f"{k} = {_effect_size(k, v[0])} ± {_effect_size(k, v[1])}" for k, v in params.items())
            text = (f"step {r.step}: **{r.effect}** named (p = {_number(r.p_value, 2)}, runner-up {r.runner_up}"
                    f"{'; ' + sizes if sizes else ''})")
        elif r.verdict == "ambiguous":
            text = (f"step {r.step}: ambiguous between **{r.effect}** and **{r.runner_up}** "
                    f"(p = {_number(r.p_value, 2)}): the data cannot tell them apart")
            measurement = getattr(r, "recommended_measurement", "")
            if isinstance(measurement, str) and measurement:
                text += f"; to settle it, measure the {measurement}"
        else:
            text = f"step {r.step}: no missing effect detected"
        lines.append(f"- {text}")
    return lines + [""]


def next_measurement_lines(recommendations: pd.DataFrame | None) -> list[str]:
    """How many candidates W cannot see at their realistic size, and how many of them a listed
    measurement would settle (each with its measurement in the diagnosis summary; ambiguous
    steps carry theirs in :func:`diagnosis_lines`; the car is :func:`car_lines`)."""
    if recommendations is None or recommendations.empty:
        return []
    chosen = recommendations[recommendations["recommended"].astype(str).str.lower() == "true"]
    hidden = chosen[chosen["kind"] == "undetectable"]
    if not len(hidden):
        return []
    settled = hidden[hidden["enough"].astype(str).str.lower() == "true"]
    return [f"**Undetectable at a realistic size with the height alone:** {len(hidden)} candidate "
            f"magnitude(s); {len(settled)} of them a listed measurement would settle (*6 Diagnosis* › "
            "summary, *What to measure next*).", ""]


def car_lines(recommendations: dict[str, pd.DataFrame | None] | None) -> list[str]:
    """The measuring car's caveat, said once for the whole page (the car is the same for every
    span type), with the measurement that settles it and its predicted power per type."""
    rows = []
    for span_type, table in (recommendations or {}).items():
        if table is None or table.empty:
            continue
        chosen = table[(table["recommended"].astype(str).str.lower() == "true") & (table["kind"] == "car")]
        rows += [(span_type, r) for r in chosen.to_dict("records")]
    if not rows:
        return []
    first = rows[0][1]
    powers = ", ".join(f"{float(r['power'] if str(r['enough']).lower() == 'true' else r['power_full']):.2f} on "
                       f"{span_type}" for span_type, r in rows)
    what = describe_measurement(first["quantity"], first["per"], int(first["extent"]), float(first["cost_h"]))
    return _heading("The measuring car", "-") + [
        f"W alone cannot tell {first['question']} (the model-error budget's 95 % bound) from the catenary: the "
        "free means absorb the uplift it leaves in every span. This concerns every finding alike, none in "
        "particular; the 95 % total intervals above hold what it would move. To settle it: "
        f"{what}, predicted power {powers} (diagnosis summary, *What to measure next*).", ""]


def unexplained_lines(spans: pd.DataFrame | None, sections: pd.DataFrame | None) -> list[str]:
    """How many spans the final model does not explain, and where (the diagnosis' per-span check)."""
    if spans is None:
        return []
    flag = spans["unexplained"].astype(str).str.lower() == "true"
    by = spans["explained_by"].fillna("").astype(str) if "explained_by" in spans else pd.Series("", index=spans.index)
    if not (flag | (by != "")).any():
        return [f"**Spans the model does not explain:** none of {len(spans)} (W at the droppers and the whole "
                "profile between them, false-discovery rate per diagnosis.fdr).", ""]
    lines = [f"**Spans the model does not explain:** {int(flag.sum())} of {len(spans)}"
             + (f"; {int((by != '').sum())} more explained only by an effect of your own" if (by != "").any() else "")
             + ". No law, named effect or maintenance action is drawn from them:", ""]
    groups = sections[sections["unexplained"].astype(str).str.lower() == "true"] if sections is not None else None
    for g in (groups.itertuples() if groups is not None else []):
        what = (f"a T_MW offset of {_number(g.messenger_tension_offset_n, 4)} ± "
                f"{_number(g.messenger_tension_offset_se_n, 2)} N — inspect its tensioning device"
                if str(g.tension_offset).lower() == "true" else "a shared departure — inspect the section")
        lines.append(f"- section {g.section_id}: its {g.n_spans} spans depart together, {what}")
    alone = spans[(flag | (by != "")) & (spans["group"].fillna("").astype(str) == "")]
    for r in alone.itertuples():
        where = (f"at chainage {_number(r.peak_chainage_m, 7)} m ({_number(r.peak_size_mm, 2)} mm)"
                 if np.isfinite(r.peak_chainage_m) else "at its droppers")
        own = f", explained by {r.explained_by}" if getattr(r, "explained_by", "") else ""
        lines.append(f"- span {r.span_id}: its profile departs {where}{own}")
    return lines + [""]


def front_page(intro: str, spans_report: pd.DataFrame, correction_summary: pd.DataFrame,
               s_opt: dict[str, pd.DataFrame], findings: dict[str, pd.DataFrame | None],
               model_error: dict[str, pd.DataFrame | None] | None = None,
               sections: pd.DataFrame | None = None, prior_std_m: float = float("nan"),
               checks: dict[str, tuple[pd.DataFrame, pd.DataFrame] | None] | None = None,
               recommendations: dict[str, pd.DataFrame | None] | None = None) -> str:
    """The report's front page (reStructuredText).

    Parameters
    ----------
    intro : str
        The method in a few lines (``workflow/report/workflow.rst``).
    spans_report, correction_summary : DataFrame
        ``spans_report.csv`` and ``correction/summary.csv``.
    s_opt, findings : dict
        Per measured span type: its ``s_opt.csv`` and its ``diagnosis/findings.csv`` (None when
        the diagnosis was not part of the run).
    model_error : dict, optional
        Per span type: its ``identification/model_error.csv`` (None or empty: not measured).
    sections : DataFrame, optional
        ``registration/sections.csv`` (:func:`registration_lines`).
    prior_std_m : float
        The configured ``registration.mast_table_std_m`` [m].
    checks : dict, optional
        Per span type: its ``diagnosis/spans.csv`` and ``sections.csv`` (None: not run).
    recommendations : dict, optional
        Per span type: its ``diagnosis/recommendations.csv`` (None: not run).
    """
    lines = [intro.rstrip(), ""]
    lines += _heading("Summary per span type", "-")
    n_used = int((spans_report["status"] == "used").sum())
    lines += [f"The recording held {len(spans_report)} spans: {n_used} used, {len(spans_report) - n_used} "
              "rejected (every rejection and its reason: *Whole recording* › *2 Projection*).", ""]
    if sections is not None and len(sections):
        lines += registration_lines(sections, prior_std_m)
    for span_type in s_opt:
        lines += _heading(span_type, "~")
        lines += spans_lines(spans_report, span_type)
        lines += correction_lines(correction_summary, span_type)
        lines += identification_lines(s_opt[span_type], (model_error or {}).get(span_type))
        lines += diagnosis_lines(findings.get(span_type))
        lines += next_measurement_lines((recommendations or {}).get(span_type))
        lines += unexplained_lines(*((checks or {}).get(span_type) or (None, None)))
    lines += car_lines(recommendations)
    text = "\n".join(lines) + "\n"
    for mark in _JINJA:
        text = text.replace(mark, " ".join(mark))
    return text


def write_front_page(path: str | Path, intro_path: str | Path, spans_report_path: str | Path,
                     correction_summary_path: str | Path, s_opt_paths: dict[str, str],
                     findings_paths: dict[str, str | None],
                     model_error_paths: dict[str, str | None] | None = None,
                     sections_path: str | Path | None = None, prior_std_m: float = float("nan"),
                     check_paths: dict[str, tuple[str, str] | None] | None = None,
                     recommendation_paths: dict[str, str | None] | None = None) -> Path:
    """Read the pipeline's outputs, write :func:`front_page` to ``path``."""
    text = front_page(
        Path(intro_path).read_text(encoding="utf-8"),
        pd.read_csv(spans_report_path, dtype={"span_id": str, "section_id": str, "reason": str}),
        pd.read_csv(correction_summary_path),
        {t: pd.read_csv(p) for t, p in s_opt_paths.items()},
        {t: (pd.read_csv(p) if p else None) for t, p in findings_paths.items()},
        {t: (pd.read_csv(p) if p else None) for t, p in (model_error_paths or {}).items()},
        pd.read_csv(sections_path, dtype={"run_id": str, "section_id": str, "reason": str},
                    keep_default_na=False, na_values={"table_std_m": [""], "support_std_m": [""]})
        if sections_path else None, prior_std_m,
        {t: ((pd.read_csv(p[0], dtype={"span_id": str, "section_id": str, "group": str, "explained_by": str},
                          keep_default_na=False, na_values={c: [""] for c in ("peak_chainage_m", "peak_size_mm")}),
              pd.read_csv(p[1], dtype={"section_id": str})) if p else None)
         for t, p in (check_paths or {}).items()},
        {t: (pd.read_csv(p) if p else None) for t, p in (recommendation_paths or {}).items()},
    )
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path
