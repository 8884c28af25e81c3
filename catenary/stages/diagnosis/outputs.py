"""Files of the diagnosis rule for one span type (``docs/diagnosis.md``).

``findings.csv`` (one row per step), ``candidates.csv`` (every candidate at every step),
``steps.json`` (everything located before and after each step), the four figures of
:mod:`.figures` and ``summary.md`` in plain words; with the per-span check, ``spans.csv``,
``sections.csv`` and ``spans.png``; ``recommendations.csv``: what to measure next for every
question W alone leaves open (:mod:`.recommend`).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd

from catenary.physics.names import engineer_input
from catenary.plumbing.workers import call_each
from .candidates import CANDIDATES, CandidateParameter, format_magnitude
from .figures import eigenvalue_figure, qq_figure, residual_figure, score_figure, spans_figure
from .recommend import RECOMMENDATION_COLUMNS, recommendation_text
from .runner import DiagnosisRun, LineDiagnosis
from .span_effects import SPAN_EFFECT_COLUMNS

__all__ = ["CANDIDATE_COLUMNS", "DiagnosisPaths", "FINDING_COLUMNS", "candidates_table", "findings_table",
           "next_measurements_markdown", "spans_markdown", "summary_markdown", "write_diagnosis",
           "write_line_diagnosis"]

FINDING_COLUMNS = ("step", "verdict", "effect", "runner_up", "delta_loglik", "p_value", "parameters",
                   "gap_closed_fraction", "bic_margin_to_runner_up", "j_before", "j_after", "top_eigenvalue_before",
                   "top_eigenvalue_after", "top_eigenvalue_band_after", "mahalanobis_cvm_p_before",
                   "mahalanobis_cvm_p_after", "converged", "recommended_measurement", "recommended_power",
                   "n_unexplained_left_out", "verdict_with_unexplained", "effect_with_unexplained",
                   "depends_on_unexplained")
CANDIDATE_COLUMNS = ("step", "effect", "n_parameters", "loglik", "delta_loglik", "lr_statistic", "lr_sandwich_factor",
                     "p_value", "p_adjusted", "aic", "bic", "parameters", "detectable_magnitude", "score_statistic",
                     "score_p_value", "score_z", "converged", "n_evaluations", "time_s")


@dataclass(frozen=True)
class DiagnosisPaths:
    """Where :func:`write_diagnosis` writes each output."""

    findings: Path
    candidates: Path
    steps: Path
    residuals: Path
    eigenvalues: Path
    qq: Path
    scores: Path
    summary: Path
    spans: Path | None = None
    sections: Path | None = None
    spans_figure: Path | None = None
    span_effects: Path | None = None
    recommendations: Path | None = None

    @classmethod
    def in_folder(cls, folder: str | Path) -> "DiagnosisPaths":
        f = Path(folder)
        return cls(findings=f / "findings.csv", candidates=f / "candidates.csv", steps=f / "steps.json",
                   residuals=f / "residuals.png", eigenvalues=f / "eigenvalues.png", qq=f / "mahalanobis_qq.png",
                   scores=f / "score_screen.png", summary=f / "summary.md", spans=f / "spans.csv",
                   sections=f / "sections.csv", spans_figure=f / "spans.png", span_effects=f / "span_effects.csv",
                   recommendations=f / "recommendations.csv")


def _json(value) -> str:
    def clean(v):
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        if isinstance(v, (float, np.floating)):
            return None if not np.isfinite(v) else float(v)
        return v
    return json.dumps(clean(value), ensure_ascii=False)


def _parameter(effect: str, name: str) -> CandidateParameter:
    return next(p for p in CANDIDATES[effect].parameters if p.name == name)


def _recommended(recommendations: pd.DataFrame | None, kind: str, step: int | None = None):
    """The recommended rows of one kind of question (and step)."""
    if recommendations is None or recommendations.empty:
        return recommendations.iloc[0:0] if recommendations is not None else pd.DataFrame(
            columns=list(RECOMMENDATION_COLUMNS))
    rows = recommendations[recommendations["recommended"].astype(bool) & (recommendations["kind"] == kind)]
    return rows if step is None else rows[rows["step"] == step]


def findings_table(run: DiagnosisRun, recommendations: pd.DataFrame | None = None,
                   with_unexplained: DiagnosisRun | None = None, n_unexplained: int = 0) -> pd.DataFrame:
    """One row per step (:data:`FINDING_COLUMNS`); an ambiguous step gives the measurement that
    would settle it and its predicted power (``recommended_measurement``, ``recommended_power``;
    :mod:`.recommend`). When ``n_unexplained`` spans were left out of ``run``, each step's verdict
    and effect with them kept (``with_unexplained``) are given beside, and
    ``depends_on_unexplained`` says where they differ."""
    other = {st.step: st for st in with_unexplained.steps} if with_unexplained is not None else {}
    rows = []
    for s in run.steps:
        rec = _recommended(recommendations, "ambiguous", s.step) if s.verdict == "ambiguous" else None
        rec = rec.iloc[0] if rec is not None and len(rec) else None
        lead = s.leading
        runner = next((c for c in s.candidates if c.effect == s.runner_up), None)
        after = s.after
        rows.append(dict(
            step=s.step, verdict=s.verdict, effect=s.effect or "", runner_up=s.runner_up or "",
            delta_loglik=lead.delta_loglik if lead else np.nan, p_value=lead.p_adjusted if lead else np.nan,
            parameters=_json({k: list(v) for k, v in lead.estimates.items()}) if lead else "{}",
            gap_closed_fraction=s.gap_closed_fraction,
            bic_margin_to_runner_up=(runner.bic - lead.bic) if (lead and runner) else np.nan,
            j_before=s.before.j, j_after=after.j if after else np.nan,
            top_eigenvalue_before=s.before.eigenvalues[0], top_eigenvalue_after=after.eigenvalues[0] if after else np.nan,
            top_eigenvalue_band_after=_json([after.eigen_low[0], after.eigen_high[0]]) if after else "",
            mahalanobis_cvm_p_before=s.before.cvm_p_value, mahalanobis_cvm_p_after=after.cvm_p_value if after else np.nan,
            converged=bool(lead.converged) if lead else True,
            recommended_measurement=recommendation_text(rec) if rec is not None else "",
            recommended_power=float(rec["power"] if rec["enough"] else rec["power_full"]) if rec is not None else np.nan,
            n_unexplained_left_out=n_unexplained,
            verdict_with_unexplained=other[s.step].verdict if s.step in other else "",
            effect_with_unexplained=(other[s.step].effect or "") if s.step in other else "",
            depends_on_unexplained=(s.step not in other or (other[s.step].verdict, other[s.step].effect)
                                    != (s.verdict, s.effect)) if with_unexplained is not None else False))
    return pd.DataFrame(rows, columns=list(FINDING_COLUMNS))


def candidates_table(run: DiagnosisRun) -> pd.DataFrame:
    rows = []
    for s in run.steps:
        for c in s.candidates:
            rows.append(dict(step=s.step, effect=c.effect, n_parameters=c.n_parameters, loglik=c.j,
                             delta_loglik=c.delta_loglik, lr_statistic=c.lr_statistic, lr_sandwich_factor=c.lr_factor,
                             p_value=c.p_value, p_adjusted=c.p_adjusted, aic=c.aic, bic=c.bic,
                             parameters=_json({k: list(v) for k, v in c.estimates.items()}),
                             detectable_magnitude=_json(c.detectable), score_statistic=c.score_statistic,
                             score_p_value=c.score_p_value, score_z=_json(c.score_z), converged=c.converged,
                             n_evaluations=c.n_evaluations, time_s=c.time_s))
    return pd.DataFrame(rows, columns=list(CANDIDATE_COLUMNS))


def _described(effect: str, estimates: dict) -> str:
    parts = []
    for name, (value, se) in estimates.items():
        p = _parameter(effect, name)
        parts.append(f"{p.label} = {format_magnitude(value, p.unit, se, name=name)}")
    return ", ".join(parts)


def _where(loc) -> list[str]:
    out = []
    off = [i for i in range(loc.residual_mean_m.size) if loc.residual_low_m[i] > 0 or loc.residual_high_m[i] < 0]
    if off:
        out.append("mean residuals outside their 95 % interval of 0 at dropper(s) "
                   + ", ".join(f"{i + 1} ({1e3 * loc.residual_mean_m[i]:+.2f} mm)" for i in off))
    else:
        out.append("no dropper's mean residual is significant (largest "
                   f"{1e3 * np.max(np.abs(loc.residual_mean_m)):.2f} mm)")
    inside = loc.top_eigenvalue_inside
    out.append(f"top whitened eigenvalue λ₁ = {loc.eigenvalues[0]:.2f}, "
               f"{'inside' if inside else 'outside'} its bootstrap 95 % range "
               f"[{loc.eigen_low[0]:.2f}, {loc.eigen_high[0]:.2f}]"
               + ("" if inside else ": the data vary along a direction the model does not"))
    out.append(f"Mahalanobis distances against χ²{loc.residual_mean_m.size}: Cramér–von Mises p = {loc.cvm_p_value:.3g}")
    return out


def summary_markdown(run: DiagnosisRun, *, figures: tuple[str, ...] = (),
                     recommendations: pd.DataFrame | None = None) -> str:
    """The plain-words report of a diagnosis run (``recommendations``: what to measure next,
    :mod:`.recommend`)."""
    s = run.settings
    lines = [f"# Diagnosis of span type {run.span_type}", ""]
    if not run.converged:
        lines += ["> **Warning: an optimiser did not converge** (`converged` in `findings.csv` and "
                  "`candidates.csv`); the figures below are those it stopped at.", ""]
    start = (", ".join(engineer_input(n)[0] for n in run.base.random_inputs) + " random; free means: "
             + (", ".join(engineer_input(n)[0] for n in run.base.free_means) or "none"))
    lines += [f"{run.n_spans} measured spans. Starting model: {start}; span model "
              f"{'pinned at its masts' if run.base.neighbours == 0 else 'in the line (wires continuous over the masts)'}"
              + (f"; effects {', '.join(s.start_effects)}" if s.start_effects else "") + ".",
              f"Tests at the {100 * s.level:g} % level, Bonferroni over the candidates of each step; the leader is named "
              f"only if the runner-up's BIC is at least {s.bic_margin:g} higher. Design N = {s.n_samples}; "
              f"{run.time_s:.0f} s.", ""]
    if run.skipped:
        lines += ["Candidates not tried: " + "; ".join(f"`{k}` ({v})" for k, v in run.skipped.items()) + ".", ""]
    lines += [f"> {note}" for note in run.notes] + ([""] if run.notes else [])
    for st in run.steps:
        lines += [f"## Step {st.step}", "",
                  f"Model: {', '.join(st.model_effects) or 'the starting model'} (J = {st.before.j:.2f}). "
                  "Where it disagrees with the data:", ""]
        lines += [f"- {w}" for w in _where(st.before)]
        lines += [f"- a free mean shift would gain {st.before.free_shift_gain:.1f} in J, a free Gaussian law of W "
                  f"{st.before.free_gaussian_gain:.1f} (the largest gain any model can show)", ""]
        lead = st.leading
        if st.verdict == "named":
            runner = next((c for c in st.candidates if c.effect == st.runner_up), None)
            lines += [f"**Named: `{st.effect}`** — {CANDIDATES[st.effect].summary}: "
                      f"{_described(st.effect, lead.estimates)}. J rose by {lead.delta_loglik:.1f} (LR "
                      f"{lead.lr_statistic:.1f}, adjusted p = {lead.p_adjusted:.2g}), "
                      f"{100 * st.gap_closed_fraction:.0f} % of the free Gaussian's gain"
                      + (f"; runner-up `{runner.effect}` with a BIC higher by {runner.bic - lead.bic:.1f}." if runner
                         else "."), ""]
            a = st.after
            lines += [f"After adding it: λ₁ = {a.eigenvalues[0]:.2f} "
                      f"({'inside' if a.top_eigenvalue_inside else 'still outside'} [{a.eigen_low[0]:.2f}, "
                      f"{a.eigen_high[0]:.2f}]), Mahalanobis CvM p = {a.cvm_p_value:.3g}, free Gaussian gain left "
                      f"{a.free_gaussian_gain:.1f}.", ""]
        elif st.verdict == "ambiguous":
            runner = next(c for c in st.candidates if c.effect == st.runner_up)
            lines += [f"**Ambiguous between `{st.effect}` and `{st.runner_up}`**: both explain the gap "
                      f"(Δℓ {lead.delta_loglik:.1f}: {_described(st.effect, lead.estimates)}; Δℓ {runner.delta_loglik:.1f}: "
                      f"{_described(runner.effect, runner.estimates)}); their BIC differ by only "
                      f"{runner.bic - lead.bic:.1f} (< {s.bic_margin:g}). W alone cannot tell them apart; nothing is "
                      "added."
                      + "".join(f" To settle it: {recommendation_text(r)} (*What to measure next*)."
                                for _, r in _recommended(recommendations, "ambiguous", st.step).iterrows()), ""]
        else:
            lines += ["**No missing effect detected**: no candidate improves J significantly"
                      + (f" (largest Δℓ {max(c.delta_loglik for c in st.candidates):.2f}, `"
                         f"{max(st.candidates, key=lambda c: c.delta_loglik).effect}`)." if st.candidates else "."), ""]
        lines += ["| candidate | Δℓ | LR | adjusted p | BIC | estimate | smallest detectable (realistic) |",
                  "|---|---:|---:|---:|---:|---|---|"]
        for c in sorted(st.candidates, key=lambda c: c.bic):
            det = "; ".join(
                f"{format_magnitude(v, _parameter(c.effect, k).unit, name=k)} "
                f"({format_magnitude(_parameter(c.effect, k).realistic, _parameter(c.effect, k).unit, name=k)}"
                f"{'' if v <= _parameter(c.effect, k).realistic else ': undetectable'})"
                for k, v in c.detectable.items())
            est = "; ".join(f"{format_magnitude(v, _parameter(c.effect, k).unit, se, name=k)}"
                            for k, (v, se) in c.estimates.items())
            lines.append(f"| `{c.effect}` | {c.delta_loglik:.2f} | {c.lr_statistic:.2f} | {c.p_adjusted:.2g} | "
                         f"{c.bic:.1f} | {est} | {det} |")
        lines.append("")
    undetectable = sorted({c.effect for st in run.steps[-1:] for c in st.candidates
                           if any(v > _parameter(c.effect, k).realistic for k, v in c.detectable.items())})
    lines += ["## Conclusion", ""]
    named = run.named
    lines.append(("Named, in order: " + ", ".join(f"`{n}`" for n in named) + ".") if named
                 else "No missing effect named.")
    last = run.steps[-1] if run.steps else None
    if last is not None and last.verdict == "ambiguous":
        lines.append(f"Then ambiguous between `{last.effect}` and `{last.runner_up}`.")
    if undetectable:
        lines.append("At a realistic size these cannot be seen in this data set (their smallest detectable "
                     "magnitude is larger): " + ", ".join(f"`{u}`" for u in undetectable)
                     + ". Undetectable, not absent.")
    if run.steps and run.steps[0].before.free_gaussian_gain > 0:
        first, final = run.steps[0].before, (last.after if last and last.after else last.before) if last else None
        lines.append(f"The gap to a free Gaussian law of W went from {first.free_gaussian_gain:.1f} to "
                     f"{final.free_gaussian_gain:.1f} in J.")
    lines.append("")
    lines += next_measurements_markdown(recommendations)
    if figures:
        lines += ["## Figures", ""] + [f"![{f}]({f})" for f in figures] + [""]
    return "\n".join(lines)


def next_measurements_markdown(recommendations: pd.DataFrame | None) -> list[str]:
    """What to measure next, question by question, and the measuring car's caveat said once."""
    if recommendations is None or recommendations.empty:
        return []
    lines = ["## What to measure next", "",
             "For every question W alone leaves open, each measurement on the menu (`measurements.options`) was "
             "simulated under the competing fitted models, on the diagnosis' own design: the smallest amount of it "
             "that settles the question at the diagnosis' level with the configured power, and its cost "
             "(`recommendations.csv` gives every option).", ""]
    kinds = {"ambiguous": "Ambiguous", "undetectable": "Undetectable at its realistic size", "car": "The measuring car"}
    for question, part in recommendations.groupby("question", sort=False):
        best = part[part["recommended"].astype(bool)].iloc[0]
        if best["kind"] == "car":
            continue
        lines.append(f"- {kinds[best['kind']]} — {question}: {recommendation_text(best)}.")
    car = recommendations[(recommendations["kind"] == "car") & recommendations["recommended"].astype(bool)]
    if len(car):
        best = car.iloc[0]
        lines += ["", f"**The measuring car.** W alone cannot tell {best['question']} (the model-error budget's "
                  "95 % bound on the force) from the catenary: the free means absorb the uplift it leaves in every "
                  "span. This concerns every "
                  "finding alike, none in particular; what a car within its declared uncertainty moves is in the "
                  "identified laws' 95 % total intervals. To settle it: " + recommendation_text(best) + "."]
    return lines + [""]


def write_diagnosis(run: DiagnosisRun, paths: DiagnosisPaths, recommendations: pd.DataFrame | None = None, *,
                    with_unexplained: DiagnosisRun | None = None, n_unexplained: int = 0,
                    extra_summary: list[str] | None = None, workers: int = 1) -> None:
    """Write every output of one span type's diagnosis (``recommendations``: what to measure next,
    :func:`.recommend.recommend`; ``with_unexplained``, ``n_unexplained``: :func:`findings_table`;
    ``extra_summary``: lines appended to ``summary.md``; ``workers``: processes drawing the
    figures and writing the tables side by side, the same files for any number)."""
    tasks = _diagnosis_writers(run, paths, recommendations, with_unexplained, n_unexplained, extra_summary)
    call_each(tasks, workers)


def _diagnosis_writers(run: DiagnosisRun, paths: DiagnosisPaths, recommendations: pd.DataFrame | None,
                       with_unexplained: DiagnosisRun | None, n_unexplained: int,
                       extra_summary: list[str] | None) -> list:
    """The writers of :func:`write_diagnosis`, each of its own files, the figures first (the
    longest): called in any order or process, they write the same files."""
    for p in paths.__dict__.values():
        if p is not None:
            Path(p).parent.mkdir(parents=True, exist_ok=True)
    title = f"{run.span_type}"
    figures = [partial(f, run, path, title) for f, path in ((residual_figure, paths.residuals),
                                                            (eigenvalue_figure, paths.eigenvalues),
                                                            (qq_figure, paths.qq), (score_figure, paths.scores))]
    return figures + [partial(_write_diagnosis_tables, run, paths, recommendations, with_unexplained, n_unexplained,
                              extra_summary)]


def _write_diagnosis_tables(run: DiagnosisRun, paths: DiagnosisPaths, recommendations: pd.DataFrame | None,
                            with_unexplained: DiagnosisRun | None, n_unexplained: int,
                            extra_summary: list[str] | None) -> None:
    """findings.csv, recommendations.csv, candidates.csv, steps.json and summary.md."""
    findings_table(run, recommendations, with_unexplained, n_unexplained).to_csv(paths.findings, index=False,
                                                                                 float_format="%.10g")
    if paths.recommendations is not None:
        (recommendations if recommendations is not None else pd.DataFrame(columns=list(RECOMMENDATION_COLUMNS))
         ).to_csv(paths.recommendations, index=False, float_format="%.6g")
    candidates_table(run).to_csv(paths.candidates, index=False, float_format="%.10g")
    steps = [{"step": s.step, "model_effects": list(s.model_effects), "verdict": s.verdict, "effect": s.effect,
              "runner_up": s.runner_up, "before": s.before.as_dict(), "after": s.after.as_dict() if s.after else None}
             for s in run.steps]
    Path(paths.steps).write_text(_json({"span_type": run.span_type, "n_spans": run.n_spans, "converged": run.converged,
                                        "skipped": run.skipped, "data_henze_zirkler": run.data_normality,
                                        "final_effects": list(run.final.effects), "time_s": run.time_s,
                                        "steps": steps}) + "\n")
    Path(paths.summary).write_text(summary_markdown(
        run, figures=tuple(Path(p).name for p in (paths.residuals, paths.eigenvalues, paths.qq, paths.scores)),
        recommendations=recommendations) + "\n\n" + "\n".join(extra_summary or []))


def spans_markdown(line: LineDiagnosis) -> list[str]:
    """The per-span check in plain words (summary.md's last section)."""
    check, run = line.check, line.run
    spans, sections = check.spans, check.sections
    n = len(spans)
    fdr = run.settings.fdr
    lines = ["## Spans the model does not explain", ""]
    lines.append(f"Every span's data — W at the droppers and its whole profile between them — were tested "
                 f"against the final model (identified laws, named effects, measurement noise, the "
                 f"correction's error), and every section's spans together; false-discovery rate "
                 f"{100 * fdr:g} % (Benjamini–Hochberg).")
    lines.append("")
    bad = spans[spans["unexplained"].astype(bool) | (spans["explained_by"].fillna("") != "")]
    if bad.empty:
        lines += [f"All {n} spans are explained (smallest q-value {spans['q_value'].min():.2g}).", ""]
    else:
        groups = sections[sections["unexplained"].astype(bool)]
        lines.append(f"**{len(bad)} of {n} spans are unexplained**"
                     + (f", {int(bad['group'].astype(bool).sum())} of them in "
                        + ", ".join(f"section {g}" for g in groups["section_id"]) + " whose spans depart together"
                        if len(groups) else "") + ". No law, named effect or maintenance action is drawn from "
                     "them: the maintenance list sends an inspection instead.")
        lines.append("")
        for g in groups.itertuples():
            lines.append(f"- Section {g.section_id} ({g.n_spans} spans, q = {g.q_value:.2g}): "
                         + (f"its spans share a T_MW offset of {g.messenger_tension_offset_n:+.0f} ± "
                            f"{g.messenger_tension_offset_se_n:.0f} N from the line's — its tensioning device."
                            if g.tension_offset else "its spans depart together, not as a T_MW offset would."))
        lines += ["", "| span | chainage [m] | q-value | where the profile departs | why |", "|---|---|---:|---|---|"]
        for r in bad.itertuples():
            where = (f"{r.peak_chainage_m:.1f} m, {r.peak_size_mm:+.1f} mm" if np.isfinite(r.peak_chainage_m) else "")
            lines.append(f"| {r.span_id} | {r.start_chainage_m:.1f}–{r.end_chainage_m:.1f} | {r.q_value:.2g} | "
                         f"{where} | {r.why} |")
        lines.append("")
    fitted = line.span_effects
    if fitted is not None and len(fitted):
        lines += _span_effects_markdown(line)
    if line.with_unexplained is not None:
        same = not line.depends_on_unexplained
        lines.append(f"The verdicts above are those of the {run.n_spans} spans the model explains. With the "
                     f"unexplained spans kept, the diagnosis named "
                     f"{', '.join(f'`{e}`' for e in line.with_unexplained.named) or 'nothing'}: "
                     + ("the same — what was named is carried by the bulk of the spans." if same else
                        "**a different verdict: it depended on the unexplained spans**, and is not kept."))
        lines.append("")
    lines.append("![spans](spans.png)")
    lines.append("")
    return lines


def _span_effects_markdown(line: LineDiagnosis) -> list[str]:
    """The user's span-scope effects, fitted on the spans unexplained alone: what each explains,
    with its magnitudes, and the gap before and after."""
    fitted = line.span_effects
    spans = line.check.spans
    before = int((spans["unexplained"].astype(bool) | (spans["explained_by"].fillna("") != "")).sum())
    after = int(spans["unexplained"].astype(bool).sum())
    lines = ["### Effects of your own, fitted span by span", ""]
    for name, rows in fitted.groupby("effect", sort=False):
        ok = rows[rows["explained"].astype(bool)]
        lines.append(f"`{name}` explains **{len(ok)} of the {len(rows)} spans** it was fitted on (significant at "
                     f"the {100 * line.run.settings.level:g} % level, and the profile left within the model):")
        lines.append("")
        lines += ["| span | magnitudes (± standard error) | LR | p | left: global p, local p | explains it |",
                  "|---|---|---:|---:|---|---|"]
        for r in rows.itertuples():
            mags = ", ".join(f"{k} {v[0]:.3g} ± {v[1]:.2g}" for k, v in json.loads(r.parameters).items())
            lines.append(f"| {r.span_id} | {mags} | {r.lr_statistic:.1f} | {r.p_value:.2g} | "
                         f"{r.p_global_after:.2g}, {r.p_local_after:.2g} | {'yes' if r.explained else 'no'} |")
        lines.append("")
    lines += [f"The gap: **{before} spans unexplained without these effects, {after} with them**.", ""]
    return lines


def write_line_diagnosis(line: LineDiagnosis, paths: DiagnosisPaths,
                         recommendations: pd.DataFrame | None = None, workers: int = 1) -> None:
    """Write a span type's diagnosis with its per-span check (:func:`write_diagnosis`, then
    ``spans.csv``, ``sections.csv``, ``spans.png`` and the check's part of ``summary.md``), the
    figures and the tables in ``workers`` processes side by side (the same files for any number)."""
    tasks = _diagnosis_writers(line.run, paths, recommendations, line.with_unexplained,
                               0 if line.with_unexplained is None else int(line.check.departing.sum()),
                               spans_markdown(line))
    tasks.insert(0, partial(spans_figure, line.check.spans, line.check.sections, paths.spans_figure,
                            line.run.span_type, line.run.settings.fdr))
    tasks.append(partial(_write_check_tables, line, paths))
    call_each(tasks, workers)


def _write_check_tables(line: LineDiagnosis, paths: DiagnosisPaths) -> None:
    """spans.csv, span_effects.csv and sections.csv of the per-span check."""
    line.check.spans.to_csv(paths.spans, index=False, float_format="%.6g")
    if paths.span_effects is not None:
        (line.span_effects if line.span_effects is not None else pd.DataFrame(columns=list(SPAN_EFFECT_COLUMNS))
         ).to_csv(paths.span_effects, index=False, float_format="%.6g")
    line.check.sections.to_csv(paths.sections, index=False, float_format="%.6g")
