"""Files of the contact-force gather rule for one span type, and their figures.

``replicates.parquet`` (one row per replicate, case and speed), ``summary.csv``
(:func:`.summary.criteria_summary` of the identified laws' replicates), ``nominal.csv`` (the same
criteria on the nominal geometry), ``tolerance.csv`` (:func:`.summary.tolerance_table`),
``sensitivity.csv`` (Sobol indices; its header only when the sensitivity is skipped),
``histograms.png``, ``sobol.png`` (saying so when skipped), ``tolerance.png`` and ``report.md``.
The figures load Matplotlib when drawn: the batch jobs read only :func:`replicates_schema`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa

from catenary.physics.names import CRITERION_LABELS
from catenary.plumbing.parquet import write_table
from .runs import CRITERIA, VIOLATIONS
from .sensitivity import SOBOL_COLUMNS, SobolResult
from .settings import ContactForceSettings
from .summary import violation_labels

__all__ = ["ContactForcePaths", "SENSITIVITY_SKIPPED", "replicates_schema", "write_contact_force"]

#: What the report and ``sobol.png`` say when ``contact_force.sensitivity.n_samples`` is 0.
SENSITIVITY_SKIPPED = ("Sensitivity not computed (contact_force.sensitivity.n_samples: 0): at the N a short run "
                       "affords the Sobol indices' errors are as large as the indices (±0.5 at N = 8); N = 64 "
                       "(768 dynamic runs per span type) gives total indices within about ±0.2.")

_LIMIT_OF = {"mean_force_n": "mean_force_above_target", "statistical_min_n": "statistical_min_below_limit",
             "max_support_uplift_m": "uplift_above_limit", "std_force_n": "std_above_limit"}


@dataclass(frozen=True)
class ContactForcePaths:
    replicates: Path
    summary: Path
    nominal: Path
    tolerance: Path
    sensitivity: Path
    histograms: Path
    sobol: Path
    tolerance_figure: Path
    report: Path

    @classmethod
    def in_folder(cls, folder) -> "ContactForcePaths":
        f = Path(folder)
        return cls(f / "replicates.parquet", f / "summary.csv", f / "nominal.csv", f / "tolerance.csv",
                   f / "sensitivity.csv", f / "histograms.png", f / "sobol.png", f / "tolerance.png", f / "report.md")


def replicates_schema(columns) -> pa.Schema:
    """Arrow schema of ``replicates.parquet``: ``case`` text, violations boolean, the rest numbers."""
    fields = []
    for c in columns:
        if c == "case":
            fields.append(pa.field(c, pa.string(), nullable=False))
        elif c in VIOLATIONS:
            fields.append(pa.field(c, pa.bool_(), nullable=False))
        elif c in ("replicate", "static_slack_droppers"):
            fields.append(pa.field(c, pa.int64(), nullable=False))
        else:
            fields.append(pa.field(c, pa.float64(), nullable=False))
    return pa.schema(fields)


def _limit_value(criterion: str, speed: float, settings: ContactForceSettings, mean_force: float) -> float | None:
    lim = settings.limits
    return {"mean_force_n": lim.mean_force_target_n(speed), "statistical_min_n": lim.min_statistical_n,
            "max_support_uplift_m": lim.max_uplift_m, "std_force_n": lim.max_std_fraction * mean_force}.get(criterion)


def histogram_figure(replicates: pd.DataFrame, nominal: pd.DataFrame, settings: ContactForceSettings, path, title):
    from catenary.plumbing.plots import save_figure, subplots
    data = replicates[replicates["case"] == "identified"]
    shown = [c for c in CRITERIA if c != "contact_loss_percent"]
    fig, axes = subplots(2, 4, figsize=(16, 7))
    for ax, c in zip(axes.ravel(), shown):
        for k, (speed, group) in enumerate(data.groupby("speed_kmh")):
            scale = 1e3 if c.endswith("_m") else 1.0
            ax.hist(scale * group[c], bins=12, alpha=0.5, color=f"C{k}", label=f"{speed:g} km/h: replicates")
            nom = nominal[nominal["speed_kmh"] == speed][c]
            if len(nom):
                ax.axvline(scale * float(nom.iloc[0]), color=f"C{k}", lw=2, ls="-", label=f"{speed:g} km/h: nominal")
            limit = _limit_value(c, speed, settings, float(nom.iloc[0]) if len(nom) else np.nan)
            if limit is not None and np.isfinite(limit):
                ax.axvline(scale * limit, color=f"C{k}", lw=1.5, ls="--", label=f"{speed:g} km/h: limit")
        unit = "mm" if c.endswith("_m") else ("%" if c.endswith("percent") else "N")
        ax.set_xlabel(f"{c} [{unit}]")
        ax.set_ylabel("replicate sections")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6)
    axes.ravel()[-1].axis("off")
    fig.suptitle(title)
    return save_figure(fig, path)


def sobol_figure(results: list[SobolResult], path, title):
    from catenary.plumbing.plots import save_figure, subplots
    fig, axes = subplots(1, max(1, len(results)), figsize=(6 * max(1, len(results)), 4), squeeze=False)
    for ax, r in zip(axes[0], results):
        x = np.arange(len(r.groups))
        ax.bar(x - 0.2, r.first, 0.4, yerr=np.abs(r.first_interval.T - r.first), capsize=3,
               label="first order (95 % bootstrap interval)")
        ax.bar(x + 0.2, r.total, 0.4, yerr=np.abs(r.total_interval.T - r.total), capsize=3,
               label="total order (95 % bootstrap interval)")
        ax.set_xticks(x, [g.replace("effect:", "") for g in r.groups], rotation=20, fontsize=8)
        ax.set_ylabel("Sobol index (share of variance) [-]")
        ax.set_title(f"{r.criterion}: first + second order = {r.sum_first_second:.2f} "
                     f"[{r.sum_interval[0]:.2f}, {r.sum_interval[1]:.2f}]", fontsize=9)
        ax.grid(alpha=0.3, axis="y")
        ax.legend(fontsize=8)
    fig.suptitle(title)
    return save_figure(fig, path)


def tolerance_figure(table: pd.DataFrame, path, title):
    from catenary.plumbing.plots import save_figure, subplots
    fig, ax = subplots(figsize=(7, 4.5))
    for k, (sigma, group) in enumerate(table.groupby("messenger_tension_sigma_n")):
        for j, (name, style) in enumerate((("std_above_limit", "-o"), ("statistical_min_below_limit", "--s"))):
            p = 100 * group[f"p_{name}"]
            err = 100 * np.vstack([group[f"p_{name}"] - group[f"p_{name}_low"],
                                   group[f"p_{name}_high"] - group[f"p_{name}"]])
            ax.errorbar(group["dropper_tolerance_mm"] + 0.05 * (2 * k + j), p, yerr=err, fmt=style, color=f"C{k}",
                        capsize=3, label=f"T_MW σ {sigma:g} N: P({name}) and 95 % interval")
    ax.set_xlabel("dropper-length tolerance ± [mm]")
    ax.set_ylabel("probability that a section violates [%]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title(title, fontsize=9)
    return save_figure(fig, path)


def _pct(p, low, high) -> str:
    return f"{100 * p:.0f} % [{100 * low:.0f}, {100 * high:.0f}]"


def report_markdown(span_type: str, settings: ContactForceSettings, summary: pd.DataFrame, nominal: pd.DataFrame,
                    tolerance: pd.DataFrame, sobol: list[SobolResult],
                    laws_summary: dict, figures: tuple[str, ...]) -> str:
    lines = [f"# Contact force over random {span_type} sections", "",
             f"{settings.replicates} sections of {settings.n_spans} spans drawn from the identified laws "
             f"(dropper σ {', '.join(f'{1e3 * s:.1f}' for s in laws_summary['dropper_sigma_m'])} mm; T_MW "
             f"{laws_summary['messenger_tension_n'][0]:.0f} ± {laws_summary['messenger_tension_n'][1]:.0f} N per span; "
             f"ΔH {1e3 * laws_summary['system_height_m'][0]:.1f} ± {1e3 * laws_summary['system_height_m'][1]:.1f} mm "
             f"per mast; steady-arm heights {1e3 * laws_summary['cw_height_m'][0]:.0f} ± "
             f"{1e3 * laws_summary['cw_height_m'][1]:.0f} mm"
             + (f"; named effects {laws_summary['effects']}" if laws_summary["effects"] else "")
             + f"), run over by the `{settings.pantograph}` pantograph; statistics between masts "
             f"{settings.analysis_masts[0]} and {settings.analysis_masts[1]}, force filtered at "
             f"{settings.filter_cutoff_hz:g} Hz.", ""]
    for speed, group in summary.groupby("speed_kmh"):
        g = group.set_index("quantity")
        nom = nominal[nominal["speed_kmh"] == speed].iloc[0]
        lines += [f"## {speed:g} km/h", "",
                  "| criterion | nominal | mean | σ | 5 % | 50 % | 95 % |", "|---|---:|---:|---:|---:|---:|---:|"]
        for c in CRITERIA:
            r = g.loc[c]
            label, factor, unit = CRITERION_LABELS[c]
            lines.append(f"| {label} [{unit}] | {factor * nom[c]:.4g} | {factor * r['mean']:.4g} | "
                         f"{factor * r['std']:.3g} | {factor * r['q05']:.4g} | {factor * r['q50']:.4g} | "
                         f"{factor * r['q95']:.4g} |")
        lines += ["", f"Probability that a section violates a limit (95 % binomial interval), over "
                  f"{int(g.loc['std_above_limit', 'n_replicates'])} sections:", ""]
        texts = violation_labels(settings.limits, speed)
        for name in VIOLATIONS:
            r = g.loc[name]
            lines.append(f"- {texts[name]}: {_pct(r['probability'], r['probability_low'], r['probability_high'])}")
        lines.append("")
    if len(tolerance):
        lines += ["## Maintenance tolerances", "",
                  f"Dropper lengths held to ±t means a law of σ = t / {settings.tolerance.sigma_per_tolerance:g} "
                  f"(config `contact_force.tolerance_study.sigma_per_tolerance`); {settings.tolerance.replicates} "
                  f"sections per line at {settings.tolerance.speed_kmh:g} km/h, the other laws as identified.", "",
                  "| dropper tolerance | T_MW σ | mean σ_F | P(σ > limit) | P(Fm − 3σ ≤ limit) |",
                  "|---:|---:|---:|---|---|"]
        for _, r in tolerance.iterrows():
            lines.append(f"| ±{r['dropper_tolerance_mm']:g} mm | {r['messenger_tension_sigma_n']:g} N | "
                         f"{r['std_force_mean_n']:.1f} N | "
                         f"{_pct(r['p_std_above_limit'], r['p_std_above_limit_low'], r['p_std_above_limit_high'])} | "
                         f"{_pct(r['p_statistical_min_below_limit'], r['p_statistical_min_below_limit_low'], r['p_statistical_min_below_limit_high'])} |")
        lines.append("")
    lines += ["## Which spread drives the contact-force spread", ""]
    if not sobol:
        lines += [SENSITIVITY_SKIPPED, ""]
    else:
        for r in sobol:
            lines.append(f"{r.criterion}: Sobol indices by OpenTURNS' Mauntz–Kucherenko pick-freeze on the dynamic "
                         f"model (N = {r.n_base}: {r.n_base * (2 * len(r.groups) + 2)} sections; 95 % bootstrap "
                         "intervals):")
            lines += [f"- {g}: first order {f:.2f} [{fl:.2f}, {fh:.2f}], total {t:.2f} [{tl:.2f}, {th:.2f}]"
                      for g, f, (fl, fh), t, (tl, th) in zip(r.groups, r.first, r.first_interval, r.total,
                                                             r.total_interval)]
            lines += [f"- first + second order: {r.sum_first_second:.2f} [{r.sum_interval[0]:.2f}, "
                      f"{r.sum_interval[1]:.2f}] (≈ 1 when third-order interactions are negligible; the "
                      f"interval is the estimator's error at N = {r.n_base})", ""]
    lines += ["## Figures", ""] + [f"![{f}]({f})" for f in figures] + [""]
    return "\n".join(lines)


def write_contact_force(paths: ContactForcePaths, span_type: str, settings: ContactForceSettings,
                        replicates: pd.DataFrame, nominal: pd.DataFrame, summary: pd.DataFrame,
                        tolerance: pd.DataFrame, sobol: list[SobolResult],
                        laws_summary: dict, *, config_hash: str) -> None:
    from catenary.plumbing.plots import save_figure, subplots
    for p in paths.__dict__.values():
        Path(p).parent.mkdir(parents=True, exist_ok=True)
    write_table(replicates, paths.replicates, replicates_schema(replicates.columns), config_hash=config_hash,
                kind="contact_force_replicates")
    summary.to_csv(paths.summary, index=False, float_format="%.6g")
    nominal.to_csv(paths.nominal, index=False, float_format="%.6g")
    tolerance.to_csv(paths.tolerance, index=False, float_format="%.6g")
    sensitivity = (pd.concat([r.table() for r in sobol], ignore_index=True) if sobol
                   else pd.DataFrame(columns=list(SOBOL_COLUMNS)))
    sensitivity.to_csv(paths.sensitivity, index=False, float_format="%.6g")
    histogram_figure(replicates, nominal, settings, paths.histograms, f"{span_type}: criteria over random sections")
    if sobol:
        sobol_figure(sobol, paths.sobol, f"{span_type}: variance shares of the contact-force criteria")
    else:
        fig, ax = subplots(figsize=(6, 1.5))
        ax.text(0.5, 0.5, SENSITIVITY_SKIPPED, ha="center", va="center", wrap=True)
        ax.axis("off")
        save_figure(fig, paths.sobol)
    if len(tolerance):
        tolerance_figure(tolerance, paths.tolerance_figure, f"{span_type}: maintenance tolerances at "
                         f"{settings.tolerance.speed_kmh:g} km/h")
    else:
        fig, ax = subplots()
        ax.text(0.5, 0.5, "no tolerance study configured", ha="center")
        ax.axis("off")
        save_figure(fig, paths.tolerance_figure)
    Path(paths.report).write_text(report_markdown(
        span_type, settings, summary, nominal, tolerance, sobol, laws_summary,
        tuple(Path(p).name for p in (paths.histograms, paths.sobol, paths.tolerance_figure))))
