"""Figures of a diagnosis run: one panel per step, the model before (and after) the step.

Plotting only; every number comes from :mod:`.runner` and :mod:`.locate`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy import stats

from catenary.plumbing.plots import save_figure, subplots

__all__ = ["eigenvalue_figure", "qq_figure", "residual_figure", "score_figure", "spans_figure"]


def _panels(run, height: float = 3.6):
    n = max(1, len(run.steps))
    fig, axes = subplots(1, n, figsize=(5.2 * n, height), squeeze=False)
    return fig, axes[0]


def _states(step):
    """(label, Locate, style) of the model before the step and, when named, after it."""
    out = [(f"before ({', '.join(step.model_effects) or 'start'})", step.before, dict(color="C3", marker="o"))]
    if step.after is not None:
        out.append((f"after (+ {step.effect})", step.after, dict(color="C0", marker="s")))
    return out


def residual_figure(run, path: str | Path, title: str) -> Path:
    """Per-dropper mean residual of the data against the model with its 95 % interval."""
    fig, axes = _panels(run)
    for ax, step in zip(axes, run.steps):
        for k, (label, loc, style) in enumerate(_states(step)):
            x = np.arange(1, loc.residual_mean_m.size + 1) + 0.12 * (k - 0.5)
            ax.errorbar(x, 1e3 * loc.residual_mean_m,
                        yerr=1e3 * np.vstack([loc.residual_mean_m - loc.residual_low_m,
                                              loc.residual_high_m - loc.residual_mean_m]),
                        ls="none", capsize=3, label=f"{label}: mean ± 95 % interval", **style)
        ax.axhline(0.0, color="k", lw=0.8, label="model mean")
        ax.set_xlabel("dropper")
        ax.set_ylabel("mean of W(data) − W(model) [mm]")
        ax.set_title(f"{title} step {step.step}: {step.verdict} {step.effect or ''}", fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    return save_figure(fig, path)


def eigenvalue_figure(run, path: str | Path, title: str) -> Path:
    """Eigenvalues of the model-whitened data covariance against their bootstrap 95 % range."""
    fig, axes = _panels(run)
    for ax, step in zip(axes, run.steps):
        for k, (label, loc, style) in enumerate(_states(step)):
            r = np.arange(1, loc.eigenvalues.size + 1) + 0.15 * (k - 0.5)
            ax.fill_between(r, loc.eigen_low, loc.eigen_high, color=style["color"], alpha=0.15,
                            label=f"{label}: bootstrap 95 % range")
            ax.plot(r, loc.eigenvalues, ls="none", label=f"{label}: data", **style)
        ax.axhline(1.0, color="k", lw=0.8, label="model = data")
        ax.set_yscale("log")
        ax.set_xlabel("rank of the eigenvalue")
        ax.set_ylabel("whitened eigenvalue of Σ_data [-]")
        ax.set_title(f"{title} step {step.step}: whitened covariance", fontsize=9)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
    return save_figure(fig, path)


def qq_figure(run, path: str | Path, title: str) -> Path:
    """Sorted Mahalanobis distances against the χ²ₙ quantiles."""
    fig, axes = _panels(run)
    for ax, step in zip(axes, run.steps):
        top = 0.0
        for label, loc, style in _states(step):
            d2 = np.sort(loc.mahalanobis_sq)
            n = loc.residual_mean_m.size
            q = stats.chi2(n).ppf((np.arange(1, d2.size + 1) - 0.5) / d2.size)
            ax.plot(q, d2, ls="none", ms=3, label=f"{label} (CvM p = {loc.cvm_p_value:.2g})", **style)
            top = max(top, q[-1], d2[-1])
        ax.plot([0, top], [0, top], "k-", lw=0.8, label="χ² law of the model")
        ax.set_xlabel(f"χ²{loc.residual_mean_m.size} quantile [-]")
        ax.set_ylabel("Mahalanobis distance d² of a span [-]")
        ax.set_title(f"{title} step {step.step}: QQ plot", fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    return save_figure(fig, path)


def score_figure(run, path: str | Path, title: str) -> Path:
    """Score screen: U/√I of every candidate parameter at its null, before any refit."""
    fig, axes = _panels(run, height=4.2)
    for ax, step in zip(axes, run.steps):
        labels, values = [], []
        for c in step.candidates:
            for name, z in c.score_z.items():
                labels.append(f"{c.effect}.{name}")
                values.append(z if np.isfinite(z) else 0.0)
        y = np.arange(len(labels))
        ax.barh(y, values, color="C0", label="score U/√I at the null")
        crit = stats.norm.isf(run.settings.level / (2 * max(1, len(step.candidates))))
        for s in (-crit, crit):
            ax.axvline(s, color="k", ls="--", lw=0.8)
        ax.plot([], [], "k--", lw=0.8, label=f"±{crit:.2f}: Bonferroni {100 * run.settings.level:g} %, two-sided")
        ax.set_yticks(y, labels, fontsize=7)
        ax.set_xlabel("score z [-]")
        ax.set_title(f"{title} step {step.step}: score screen", fontsize=9)
        ax.grid(alpha=0.3, axis="x")
        ax.legend(fontsize=7)
    return save_figure(fig, path)


def spans_figure(spans, sections, path: str | Path, title: str, fdr: float) -> Path:
    """Along the chainage: each span's −log₁₀ p (its W and profile together) against the
    false-discovery line, unexplained spans and the sections flagged as one group marked; below,
    where each unexplained span's profile departs most from the model and by how much [mm]."""
    fig, (top, bottom) = subplots(2, 1, figsize=(11, 5.6), sharex=True, height_ratios=[2, 1])
    mid = 0.5 * (spans["start_chainage_m"] + spans["end_chainage_m"]).to_numpy(dtype=float)
    p = np.clip(spans["p_value"].to_numpy(dtype=float), 1e-300, 1.0)
    bad = spans["unexplained"].to_numpy(dtype=bool)
    for section in sections.loc[sections["unexplained"].astype(bool), "section_id"]:
        rows = spans[spans["section_id"] == section]
        for ax in (top, bottom):
            ax.axvspan(rows["start_chainage_m"].min(), rows["end_chainage_m"].max(), color="C1", alpha=0.15)
    top.plot(mid[~bad], -np.log10(p[~bad]), "o", color="C0", ms=3, label="explained")
    top.plot(mid[bad], -np.log10(p[bad]), "o", color="C3", ms=5, label="unexplained")
    ranked = np.sort(p)
    passing = ranked[ranked <= fdr * np.arange(1, ranked.size + 1) / ranked.size]
    threshold = passing.max() if passing.size else fdr / max(ranked.size, 1)
    top.axhline(-np.log10(threshold), color="k", lw=0.8, ls="--",
                label=f"false-discovery rate {100 * fdr:g} % (Benjamini–Hochberg)")
    top.set_ylabel("−log₁₀ p of the span")
    top.set_title(f"{title}: spans the final model does not explain"
                  + (" (shaded: a section whose spans depart together)" if sections["unexplained"].any() else ""),
                  fontsize=9)
    top.legend(fontsize=7)
    top.grid(alpha=0.3)
    peak = spans["peak_chainage_m"].to_numpy(dtype=float)
    size = spans["peak_size_mm"].to_numpy(dtype=float)
    bottom.axhline(0.0, color="k", lw=0.6)
    bottom.plot(peak[~bad], size[~bad], ".", color="C0", ms=2, label="largest departure of each span")
    bottom.plot(peak[bad], size[bad], "v", color="C3", ms=6, label="unexplained span: where and how much")
    bottom.set_xlabel("chainage [m]")
    bottom.set_ylabel("profile departure [mm]")
    bottom.legend(fontsize=7)
    bottom.grid(alpha=0.3)
    return save_figure(fig, path)
