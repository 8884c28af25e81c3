"""The front page of the HTML report: per span type, what a reader asks first.

``make run`` ends by writing ``results/report.html`` (``--report … --report-after-run``); the
report's opening panel is the reStructuredText this module writes (rule ``front_page``): the method in a few lines (from
``workflow/report/workflow.rst``), then per span type the spans used and rejected, the dynamic
correction's convergence, what a maintainer came for (the maintenance list's headline and its
most likely five, what fixing them buys, the contact-force verdict per speed against EN 50367),
the paper's Table 2 analogue with standard errors and the diagnosis' verdict at each step. It only
reads the pipeline's own outputs, and speaks an engineer's units: lengths, deflections and heights
in mm, chainages in m, tensions and forces in N.

Every table is narrow enough for the report's text column (≈ 510 px beside the workflow graph at
a 1 400 px window): the identification's total intervals stand in a second table rather than in
three more columns.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd

from catenary.physics.names import engineer_input
from catenary.stages.contact_force.runs import VIOLATIONS
from catenary.stages.contact_force.settings import Limits
from catenary.stages.contact_force.summary import violation_labels
from catenary.stages.diagnosis.candidates import CANDIDATES, format_magnitude
from catenary.stages.diagnosis.recommend import describe_measurement

__all__ = ["SpanTypePage", "front_page", "read_span_type_page", "write_front_page"]

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


def _mm(value_m: float) -> str:
    """A length in mm: to 0.1 mm below 10 mm, to the mm above."""
    mm = 1e3 * float(value_m)
    return f"{mm:.1f}" if abs(mm) < 10 else f"{mm:.0f}"


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
            rms = float(np.sqrt(np.mean(registered["support_std_m"] ** 2)))
            text += (f"; the mast table is accurate to {_mm(accuracy.min())}–{_mm(accuracy.max())} mm as the run "
                     f"measures it (prior ``mast_table_std_m`` {_mm(prior_std_m)} mm), the masts placed to "
                     f"{_mm(rms)} mm (RMS standard error)")
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


def _in_unit(value: float, factor: float, unit: str) -> str:
    """A value in an engineer's unit: 0.1 mm, 1 N."""
    if value is None or not np.isfinite(value):
        return "–"
    x = float(value) * factor
    return f"{x:.1f}" if unit == "mm" else f"{x:.0f}" if unit == "N" else _number(x)


def _effect_size(effect: str, name: str, value: float, se: float) -> str:
    """A named effect's magnitude as the diagnosis reports it: its label and, in an engineer's unit
    (mm, N, %), its estimate ± standard error (a plug-in's magnitude by its keyword's suffix)."""
    known = {p.name: p for p in CANDIDATES[effect].parameters} if effect in CANDIDATES else {}
    if name in known:
        return f"{known[name].label} = {format_magnitude(value, known[name].unit, se, name=name)}"
    unit = "m" if name.endswith("_m") else "N" if name.endswith("_n") else "-"
    return f"{name} = {format_magnitude(value, unit, se, name=name)}"


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
        dominant = {(r.parameter, r.statistic): (r.dominant_source, r.systematic) for r in model_error.itertuples()}
    rows, totals = [], []
    for r in s_opt.itertuples():
        fixed = bool(getattr(r, "mu_fixed", False))
        label, factor, unit = engineer_input(r.parameter)
        value = partial(_in_unit, factor=factor, unit=unit)
        rows.append([f"{label} [{unit}]", value(r.mu), "held fixed" if fixed else value(r.mu_se), value(r.sigma),
                     value(r.sigma_se)])
        if budget:
            row = [f"{label} [{unit}]"]
            for statistic in ("mu", "sigma"):
                low, high = getattr(r, f"{statistic}_total_low"), getattr(r, f"{statistic}_total_high")
                row.append("–" if not np.isfinite(low) else f"[{value(low)}, {value(high)}]")
            row.append("; ".join(f"{stat}: {dominant[(r.parameter, key)][0]}" for key, stat in (("mu", "μ"), ("sigma", "σ"))
                                 if dominant.get((r.parameter, key), ("", 0))[0]))
            totals.append(row)
    lines += _table(["input", "μ", "s.e. of μ", "σ", "s.e. of σ"], rows)
    if budget:
        lines += ["The 95 % total intervals add to the statistical one the correction's model error (the "
                  "measuring car's force, pantograph, speed and the catenary's damping, each at its declared "
                  "uncertainty; *Identification* › *model error*); the dominant source is the one that moves "
                  "the parameter most.", ""]
        lines += _table(["input", "μ, 95 % total", "σ, 95 % total", "dominant model error"], totals)
    return lines


def diagnosis_lines(findings: pd.DataFrame | None) -> list[str]:
    """The diagnosis' verdict at each step, with the named effect's parameters."""
    if findings is None:
        return ["**Diagnosis:** not run for this span type.", ""]
    lines = ["**Diagnosis (missing physics):**", ""]
    for r in findings.itertuples():
        if r.verdict == "named":
            params = json.loads(r.parameters) if isinstance(r.parameters, str) and r.parameters else {}
            sizes = ", ".join(_effect_size(r.effect, k, v[0], v[1]) for k, v in params.items())
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


def _deviation(parameter: str, value: float) -> str:
    """A listed input's deviation from nominal in an engineer's unit, signed."""
    _, factor, unit = engineer_input(parameter)
    if value is None or not np.isfinite(value):
        return "–"
    x = float(value) * factor
    return f"{x:+.1f} {unit}" if unit == "mm" else f"{x:+.0f} {unit}"


def _plural(n: int, one: str, many: str | None = None) -> str:
    return f"{n} {one if n == 1 else (many or one + 's')}"


def maintenance_lines(listed: pd.DataFrame | None, n_most_likely: int = 5) -> list[str]:
    """The maintenance list's headline (``maintenance/maintenance.csv``): droppers to adjust,
    unloaded droppers, tensioning devices and spans to inspect, and the ``n_most_likely`` actions
    most likely needed, with their chainage. The spans the final model does not explain are
    counted apart: no adjustment is drawn from them."""
    if listed is None:
        return ["**Maintenance:** not part of this run (``maintenance.enabled``).", ""]
    status = listed["status"].fillna("").astype(str)
    action = listed["action"].fillna("").astype(str)
    acted = listed[status != "unexplained"]
    adjust = acted[action[status != "unexplained"].isin(["shorten", "lengthen"])]
    unloaded = acted[action[status != "unexplained"].str.startswith("unloaded dropper")]
    devices = listed[action.str.contains("tensioning device")]
    spans = listed[(status == "unexplained") & action.str.startswith("inspect span")]
    sections = listed[(status == "unexplained") & ~action.str.startswith("inspect span")
                      & ~action.str.contains("tensioning device")]
    if not len(listed):
        return ["**Maintenance:** nothing to do: no span input is more likely out of tolerance than the "
                "threshold (``maintenance.threshold``), and the model explains every span.", ""]
    parts = []
    if len(adjust):
        n_long = int((adjust["action"] == "lengthen").sum())
        parts.append(f"{_plural(len(adjust), 'dropper')} to adjust ({n_long} to lengthen, {len(adjust) - n_long} to "
                     f"shorten) in {_plural(adjust['span_id'].nunique(), 'span')}")
    if len(unloaded):
        parts.append(f"{_plural(len(unloaded), 'unloaded dropper')} to check")
    if len(devices):
        parts.append(f"{_plural(len(devices), 'tensioning device')} to inspect")
    if len(spans) or len(sections):
        parts.append(f"{_plural(len(spans) + len(sections), 'span or section', 'spans or sections')} to inspect "
                     "where the model does not explain the profile (no adjustment is drawn from them)")
    lines = ["**Maintenance:** " + "; ".join(parts or ["no action listed"]) + "."]
    few = int((acted["status"].astype(str) == "few effective samples").sum())
    if few:
        lines[0] += f" {few} of the listed probabilities rest on few effective samples."
    lines.append("")
    top = acted.sort_values("p_out_of_tolerance", ascending=False).head(n_most_likely)
    if len(top):
        lines += [f"The {_plural(len(top), 'action', 'actions')} most likely needed (*8 Maintenance* › list):", ""]
        rows = [[str(r.span_id), f"{r.start_chainage_m:.1f}–{r.end_chainage_m:.1f}", engineer_input(r.input)[0],
                 str(r.action), _deviation(r.input, r.deviation), f"{r.p_out_of_tolerance:.2f}"]
                for r in top.itertuples()]
        lines += _table(["span", "chainage [m]", "input", "action", "off nominal", "P(out)"], rows)
    return lines


def repair_lines(summary: pd.DataFrame | None) -> list[str]:
    """What fixing the listed droppers buys (``maintenance/repair_summary.csv``): per speed, the
    change of σ_F and of the margin of F_m − 3σ_F over the windows of spans holding them."""
    if summary is None:
        return []
    done = summary[summary["speed_kmh"].notna()]
    if done.empty:
        return ["**What fixing buys:** no window of spans holding a listed dropper could be run "
                "(*8 Maintenance* › repair).", ""]
    parts = []
    for speed, g in done.groupby("speed_kmh", sort=True):
        std, margin = g["std_force_change_n"].astype(float), g["statistical_min_margin_change_n"].astype(float)
        parts.append(f"at {speed:g} km/h σ_F changes by {std.mean():+.2f} N on average over "
                     f"{_plural(len(g), 'window')} ({std.min():+.2f} to {std.max():+.2f} N), the margin of "
                     f"F_m − 3σ_F by {margin.mean():+.2f} N")
    return ["**What fixing buys** (the listed droppers set to nominal, the contact force run again): "
            + "; ".join(parts) + ".", ""]


def contact_force_lines(summary: pd.DataFrame | None, limits: Limits | None) -> list[str]:
    """The contact-force verdict per speed against EN 50367 (``contact_force/summary.csv``): the
    share of random sections of the identified laws that violate each limit, with its 95 %
    interval."""
    if summary is None or limits is None:
        return ["**Contact force (EN 50367):** not part of this run (``make run`` runs the study; "
                "``make own-data`` leaves it out).", ""]
    lines = ["**Contact force (EN 50367)** over random sections drawn from the identified laws:", ""]
    rows = summary[summary["probability"].notna()]
    for speed, g in rows.groupby("speed_kmh", sort=True):
        g = g.set_index("quantity")
        labels = violation_labels(limits, speed)
        n = int(g["n_replicates"].max())
        failing = [name for name in VIOLATIONS if name in g.index and g.loc[name, "probability"] > 0]
        if not failing:
            high = max(float(g.loc[name, "probability_high"]) for name in VIOLATIONS if name in g.index)
            lines.append(f"- {speed:g} km/h: **meets** every limit in all {n} sections (the share that would "
                         f"fail is below {100 * high:.0f} % at 95 %)")
            continue
        worst = max(float(g.loc[name, "probability"]) for name in failing)
        verdict = "fails in most sections" if worst > 0.5 else "fails in some sections"
        said = "; ".join(f"{labels[name]} in {100 * g.loc[name, 'probability']:.0f} % "
                         f"[{100 * g.loc[name, 'probability_low']:.0f}, {100 * g.loc[name, 'probability_high']:.0f}]"
                         for name in failing)
        lines.append(f"- {speed:g} km/h: **{verdict}**: {said} of {n} sections; the other limits met in all")
    return lines + [""]


@dataclass
class SpanTypePage:
    """What the front page reads of one measured span type; None where that stage was not part
    of the run.

    Attributes
    ----------
    s_opt : DataFrame
        ``identification/s_opt.csv``.
    findings, model_error, spans_check, sections_check, recommendations : DataFrame or None
        ``diagnosis/findings.csv``, ``identification/model_error.csv``, ``diagnosis/spans.csv``,
        ``diagnosis/sections.csv``, ``diagnosis/recommendations.csv``.
    maintenance, repair : DataFrame or None
        ``maintenance/maintenance.csv``, ``maintenance/repair_summary.csv``.
    contact_force : DataFrame or None
        ``contact_force/summary.csv``.
    limits : Limits or None
        The type's EN 50367 limits (config ``contact_force.limits``).
    """

    s_opt: pd.DataFrame
    findings: pd.DataFrame | None = None
    model_error: pd.DataFrame | None = None
    spans_check: pd.DataFrame | None = None
    sections_check: pd.DataFrame | None = None
    recommendations: pd.DataFrame | None = None
    maintenance: pd.DataFrame | None = None
    repair: pd.DataFrame | None = None
    contact_force: pd.DataFrame | None = None
    limits: Limits | None = None


def front_page(intro: str, spans_report: pd.DataFrame, correction_summary: pd.DataFrame,
               types: Mapping[str, SpanTypePage], sections: pd.DataFrame | None = None,
               prior_std_m: float = float("nan")) -> str:
    """The report's front page (reStructuredText).

    Parameters
    ----------
    intro : str
        The method in a few lines (``workflow/report/workflow.rst``).
    spans_report, correction_summary : DataFrame
        ``spans_report.csv`` and ``correction/summary.csv``.
    types : mapping of str to SpanTypePage
        Per measured span type, what its stages wrote.
    sections : DataFrame, optional
        ``registration/sections.csv`` (:func:`registration_lines`).
    prior_std_m : float
        The configured ``registration.mast_table_std_m`` [m].
    """
    lines = [intro.rstrip(), ""]
    lines += _heading("Summary per span type", "-")
    n_used = int((spans_report["status"] == "used").sum())
    lines += [f"The recording held {len(spans_report)} spans: {n_used} used, {len(spans_report) - n_used} "
              "rejected (every rejection and its reason: *Whole recording* › *2 Projection*).", ""]
    if sections is not None and len(sections):
        lines += registration_lines(sections, prior_std_m)
    for span_type, page in types.items():
        lines += _heading(span_type, "~")
        lines += spans_lines(spans_report, span_type)
        lines += correction_lines(correction_summary, span_type)
        lines += maintenance_lines(page.maintenance)
        lines += repair_lines(page.repair)
        lines += contact_force_lines(page.contact_force, page.limits)
        lines += identification_lines(page.s_opt, page.model_error)
        lines += diagnosis_lines(page.findings)
        lines += next_measurement_lines(page.recommendations)
        lines += unexplained_lines(page.spans_check, page.sections_check)
    lines += car_lines({t: page.recommendations for t, page in types.items()})
    text = "\n".join(lines) + "\n"
    for mark in _JINJA:
        text = text.replace(mark, " ".join(mark))
    return text


def _csv(path, **kwargs) -> pd.DataFrame | None:
    return pd.read_csv(path, **kwargs) if path else None


def read_span_type_page(inputs: Mapping[str, str], span_type: str, limits: Limits | None = None) -> SpanTypePage:
    """One span type's :class:`SpanTypePage` from the front-page rule's inputs, keyed
    ``<kind>_<span type>`` (``s_opt_N2``, ``maintenance_N2``, …); a missing key is a stage not run."""
    def get(kind: str) -> str | None:
        return inputs.get(f"{kind}_{span_type}")

    na_blank = {"keep_default_na": False}
    return SpanTypePage(
        s_opt=pd.read_csv(get("s_opt")),
        findings=_csv(get("findings")),
        model_error=_csv(get("model_error")),
        spans_check=_csv(get("spans"), dtype={"span_id": str, "section_id": str, "group": str, "explained_by": str},
                         na_values={c: [""] for c in ("peak_chainage_m", "peak_size_mm")}, **na_blank),
        sections_check=_csv(get("sections"), dtype={"section_id": str}),
        recommendations=_csv(get("recommendations")),
        maintenance=_csv(get("maintenance"), dtype={"span_id": str, "section_id": str, "input": str, "action": str,
                                                    "status": str}),
        repair=_csv(get("repair"), dtype={"section_id": str, "reason": str}),
        contact_force=_csv(get("contact_force")),
        limits=limits if get("contact_force") else None)


def write_front_page(path: str | Path, intro_path: str | Path, inputs: Mapping[str, str],
                     prior_std_m: float = float("nan"), limits: Mapping[str, Limits] | None = None) -> Path:
    """Read the pipeline's outputs named by the front-page rule's ``inputs`` (``spans_report``,
    ``correction_summary``, ``sections`` and per span type :func:`read_span_type_page`'s keys),
    write :func:`front_page` to ``path``."""
    types = [key.removeprefix("s_opt_") for key in inputs if key.startswith("s_opt_")]
    text = front_page(
        Path(intro_path).read_text(encoding="utf-8"),
        pd.read_csv(inputs["spans_report"], dtype={"span_id": str, "section_id": str, "reason": str}),
        pd.read_csv(inputs["correction_summary"]),
        {t: read_span_type_page(inputs, t, (limits or {}).get(t)) for t in types},
        pd.read_csv(inputs["sections"], dtype={"run_id": str, "section_id": str, "reason": str},
                    keep_default_na=False, na_values={"table_std_m": [""], "support_std_m": [""]})
        if inputs.get("sections") else None, prior_std_m)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path
