"""The identification report of one span type in Markdown (``identification.md``)."""

from __future__ import annotations

import numpy as np

from catenary.physics.names import engineer_input
from catenary.stages.model_error.report import model_error_lines
from .runner import IdentificationRun
from .tables import s_opt_table

__all__ = ["markdown_report"]


def _label(name: str) -> tuple[str, str, float, str, float]:
    """Display name, unit and scale of μ, unit and scale of σ for an input name: an engineer's
    name, lengths and heights in mm, tensions in N (:func:`.design.engineer_input`)."""
    label, factor, unit = engineer_input(name)
    return label, unit, factor, unit, factor


def _fmt(value: float, unit: str) -> str:
    if value is None or not np.isfinite(value):
        return "–"
    if unit == "N":
        return f"{value:.0f}"
    if unit == "m":
        return f"{value:.5f}"
    return f"{value:.2f}"


def _p(value) -> str:
    return "–" if value is None else f"{value:.3g}"


def markdown_report(run: IdentificationRun, *, source: str = "corrected.parquet",
                    figures: tuple[str, str] = ("estimators.png", "band.png")) -> str:
    """The identification report of one span type (Markdown).

    A Table-2-style table of s_opt (μ, σ, standard errors, what was identified), the run's
    figures (data, settings, evaluation counts, wall time, J at s0 and s_opt, how the standard
    errors were computed), the normality tests, the estimator comparison and the band.
    """
    r, s, st = run.result, run.settings, run.span_type
    n = st.n_droppers
    random = set(s.random_names(n))
    lines = [f"# Stochastic identification — span type {st.name}", ""]
    if r.status != "ok":
        why = (f"the {r.method} optimiser did NOT converge ({r.message}); s_opt below is only the best point "
               "evaluated" if not r.converged else
               "the observed information is not positive definite at s_opt: no standard errors")
        lines += [f"> **Status: {r.status}** — {why}. Do not use these laws as identified.", ""]
    lines += [f"Maximum likelihood of the measured static deflections W under independent Gamma inputs "
              f"(paper §3). Data: {run.data_w_m.shape[0]} spans from `{source}` (converged "
              f"correction); {len(run.left_out)} left out.", ""]
    runs = run.n_runs if run.n_runs is not None else np.ones(run.data_w_m.shape[0], dtype=int)
    if runs.max() > 1:
        counts = ", ".join(f"{int((runs == k).sum())} spans × {k} run(s)" for k in np.unique(runs))
        lines += [f"Several runs: each span's W is the mean of its converged runs ({counts}).", ""]
    if run.noise_covariance_m2 is not None:
        lines += [f"Measurement noise in the likelihood (`measurement_noise: {s.measurement_noise}`): "
                  f"{1e3 * float(np.sqrt(np.mean(np.diag(run.noise_covariance_m2)))):.3f} mm RMS per dropper and run, "
                  "divided by each span's number of runs; the dropper σ are the geometry's alone.", ""]
    else:
        lines += ["No measurement noise in the likelihood (one run, or `measurement_noise: none`): the "
                  "measured W's own error (≈ 0.4–0.6 mm) is in the dropper σ.", ""]
    for span_id, why in run.left_out:
        lines.append(f"- left out {span_id}: {why}")
    if run.left_out:
        lines.append("")
    lines += ["## s_opt (paper Table 2)", "",
              "| parameter | μ | se(μ) | σ | se(σ) | μ unit | σ unit | s0: μ | s0: σ | identified |",
              "|---|---:|---:|---:|---:|---|---|---:|---:|---|"]
    for e, s0 in zip(r.estimates, run.start):
        label, mu_unit, mu_scale, sd_unit, sd_scale = _label(e.parameter)
        what = ["μ fixed at s0" if e.mu_fixed else "μ",
                "σ" if e.parameter in random else "deterministic (σ ≈ 0)"]
        lines.append(
            f"| {label} | {_fmt(e.mu * mu_scale, mu_unit)} | "
            f"{'–' if e.mu_fixed else _fmt(e.mu_se * mu_scale, mu_unit)} | "
            f"{_fmt(e.sigma * sd_scale, sd_unit) if e.parameter in random else '0'} | "
            f"{_fmt(e.sigma_se * sd_scale, sd_unit) if e.parameter in random else '–'} | {mu_unit} | {sd_unit} | "
            f"{_fmt(s0.mean * mu_scale, mu_unit)} | "
            f"{_fmt(s0.sigma * sd_scale, sd_unit) if e.parameter in random else '0'} | {', '.join(what)} |")
    mode = ("one ΔH per span, used at both masts (ΔH_left = ΔH_right)" if s.system_height_mode == "shared" else
            "ΔH_left and ΔH_right independent draws of the same ΔH law (one law per mast)")
    span = ("the span as it hangs in the line: the central one of "
            f"{2 * s.neighbours + 1} identical spans, both wires continuous over its masts, neighbours at the "
            "nominal table" if s.neighbours else "one span pinned at its masts (the paper's model)")
    lines += ["", f"ΔH law: {mode}. Span model: {span}. se: standard error. The machine-readable table is "
              "`s_opt.csv` (SI).", ""]
    if run.profiles:
        wald = {(w["parameter"], k): (w[f"{k}_low"], w[f"{k}_high"]) for w in r.intervals(s.profile_level)
                for k in ("mu", "sigma")}
        lines += [f"## {100 * s.profile_level:.0f} % intervals", "",
                  "Profile likelihood (the other parameters re-optimised at each value, same design) beside the "
                  "Wald interval of the standard errors (log scale for σ, which can never reach 0). A σ whose "
                  "profile interval reaches 0 is consistent with no spread of that input.", "",
                  "| parameter | statistic | estimate | profile interval | Wald interval | unit | verdict |",
                  "|---|---|---:|---|---|---|---|"]
        for p in run.profiles:
            label, mu_unit, mu_scale, sd_unit, sd_scale = _label(p.parameter)
            unit, scale = (mu_unit, mu_scale) if p.statistic == "mu" else (sd_unit, sd_scale)
            lo, hi = wald[(p.parameter, p.statistic)]
            verdict = ("consistent with no spread" if p.no_spread_detected else
                       "spread detected" if p.statistic == "sigma" else "")
            if p.high_at_boundary or (p.low_at_boundary and p.statistic == "mu"):
                verdict += " (interval reaches the edge of the admissible box)"
            lines.append(f"| {label} | {'μ' if p.statistic == 'mu' else 'σ'} | {_fmt(p.estimate * scale, unit)} | "
                         f"[{_fmt(p.low * scale, unit)}, {_fmt(p.high * scale, unit)}] | "
                         f"[{_fmt(lo * scale, unit)}, {_fmt(hi * scale, unit)}] | {unit} | {verdict} |")
        lines += ["", f"{sum(p.n_evaluations for p in run.profiles)} J evaluations, {run.profile_time_s:.1f} s with "
                  "the normality tests, the estimators figure and the band beside them.", ""]
    lines += model_error_lines(run.model_error, s_opt_table(r, run.profiles, run.model_error, s.profile_level),
                               run.model_error_shifts, run.data_w_m.shape[0], _label)
    lines += ["## Run", "",
              "| item | value |", "|---|---|",
              f"| spans used | {run.data_w_m.shape[0]} |",
              f"| estimator of p_W | {s.estimator}" + (f" (bandwidth rule {s.bandwidth})" if s.estimator == "kernel" else "") + " |",
              f"| design | {s.design}, N = {s.n_samples}, seed {s.seed} (common random numbers: J(s) deterministic) |",
              f"| optimiser | {r.method} (initial step {s.initial_step} in θ, budget {s.max_evaluations}); "
              f"{'converged' if r.converged else 'NOT converged'}: {r.message} |",
              f"| free parameters | {len(r.free_parameters)}: {', '.join(r.free_parameters)} |",
              f"| J evaluations | {r.n_evaluations} by the optimiser (all in `trace.parquet`) + "
              f"{r.n_hessian_evaluations} for the standard errors = {r.n_evaluations + r.n_hessian_evaluations} |",
              f"| wall time | {run.identification_time_s:.1f} s optimisation and standard errors; "
              f"{run.total_time_s:.1f} s with fast model, normality tests, estimators and band |",
              f"| J(s0) | {run.j_start:.3f} |",
              f"| J(s_opt) | {r.j_opt:.3f} |",
              f"| slack fraction at s_opt | {r.slack_fraction:.4f} (model samples with a slack dropper, "
              f"tapered out of p_W) |", ""]
    lines += ["Standard errors: observed information — the Hessian H of J in the optimiser's coordinates θ "
              f"(μ = μ0 + σ0 θ_μ, σ = σ0 exp θ_σ) by central finite differences at s_opt (step {s.hessian_step}), "
              "covariance (−H)⁻¹, delta method back to μ and σ (the profile-likelihood intervals are above). "
              "They are conditional on the design (the Monte Carlo error of a finite N is not included) and are "
              "blank (–) where −H is not positive definite.", ""]
    if r.at_lower_bound:
        names = ", ".join(f"{_label(p.rsplit('.', 1)[0])[0]} σ" for p in r.at_lower_bound)
        lines += [f"{names}: at the lower edge of the admissible box (σ0/50, a spread W cannot resolve), on the "
                  "boundary of the parameter space where J is flat: no standard error (–); the profile interval "
                  "is the one to read. The other standard errors come from the information of the other "
                  "parameters.", ""]
    if r.covariance == "sandwich" and r.sandwich_available:
        widening = dict(zip(r.free_parameters, r.variance_widening))
        widened = [f"{_label(p.rsplit('.', 1)[0])[0]} {'μ' if p.endswith('.mu') else 'σ'} ×{w:.2f}"
                   for p, w in widening.items() if w > 1.0]
        lines += ["Spans that share a mast are not independent: every variance above is the observed "
                  "information's widened by the sandwich H⁻¹KH⁻¹ (K from the per-span scores, with the cross "
                  "terms of the " + f"{r.n_mast_pairs} pairs of spans sharing a mast) where that is wider; the "
                  "profile intervals' critical drop is widened by the same factor. Variance factors: "
                  + (", ".join(widened) if widened else "none above 1") + " (`*_variance_widening` in `s_opt.csv`).", ""]
    else:
        lines += ["The spans are treated as independent (observed information alone"
                  + (": the data do not say which spans share a mast)." if s.standard_errors == "sandwich" else
                     ", `identification.standard_errors: observed_information`).") , ""]
    lines += ["## Normality of W (Henze–Zirkler)", "",
              f"Model samples: i.i.d. Monte Carlo draws of taut spans (seed {s.seed + 3}), not the design of J "
              "(a Sobol design is too even for the test's null law and would always pass).", "",
              "| sample | n | HZ | p-value | normal at α |", "|---|---:|---:|---:|---|"]
    for key, label in (("model_s0", "model at s0"), ("model_s_opt", "model at s_opt"), ("data", "measured")):
        v = run.normality[key]
        verdict = "–" if v["normal"] is None else ("not rejected" if v["normal"] else "rejected")
        lines.append(f"| {label} | {v['n_samples']} | {_p(v['statistic'])} | {_p(v['p_value'])} | "
                     f"{verdict} (α = {v['alpha']}) |")
    lines += ["", "## Gaussian against kernel estimate (paper Fig. 7)", "",
              f"Marginals of W at the droppers at s_opt, one design per N ({s.design}, seed {s.seed + 2}). "
              "L1 distance ∫|p_kernel − p_Gauss| dW (0: identical, 2: disjoint).", "",
              "| N | effective N | mean L1 over droppers | max L1 |", "|---:|---:|---:|---:|"]
    for m in run.marginals:
        lines.append(f"| {m.n_samples} | {m.n_effective:.0f} | {m.l1_distance.mean():.4f} | {m.l1_distance.max():.4f} |")
    b = run.band
    width = 1e3 * (b.upper_m - b.lower_m)
    widest = int(np.argmax(width))
    lines += ["", f"![Gaussian and kernel marginals]({figures[0]})", "",
              f"## {100 * b.level:.0f} % band of the CW deflection (paper Fig. 10)", "",
              f"Pointwise quantiles {50 * (1 - b.level):.0f} % and {50 * (1 + b.level):.0f} % of the CW deflection "
              f"from the chord at {b.x_m.size} points along the span, from {b.n_samples} samples of the inputs "
              f"at s_opt ({s.design}, seed {s.seed + 1}; {b.n_slack} with a slack dropper dropped), each solved "
              f"by the static model of one span. Largest width {width[widest]:.1f} mm, at x = {b.x_m[widest]:.2f} m.", "",
              "| dropper | x [m] | lower [mm] | upper [mm] | measured W inside |", "|---:|---:|---:|---:|---:|"]
    at = np.searchsorted(b.x_m, st.dropper_positions_m)
    for i, (x, k) in enumerate(zip(st.dropper_positions_m, at)):
        lines.append(f"| {i + 1} | {x:.2f} | {1e3 * b.lower_m[k]:.1f} | {1e3 * b.upper_m[k]:.1f} | "
                     f"{100 * run.data_in_band[i]:.1f} % |")
    lines += ["", f"![{100 * b.level:.0f} % band]({figures[1]})", ""]
    return "\n".join(lines)
