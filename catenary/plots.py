"""Figures for people: matplotlib, one function per figure, files written as PNG.

Plotting only; every number drawn here is computed elsewhere in the package. Figures are
:class:`matplotlib.figure.Figure` objects made by :func:`subplots`, never through pyplot: no
backend is chosen and no global figure registry touched, so importing the package (or drawing
with it) leaves a caller's Matplotlib as it was; ``savefig`` writes a PNG through the Agg canvas
whatever the caller's backend.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from .sensitivity import SensitivityResult

MM = 1e3


def _span_axes(ax, result: SensitivityResult, title: str) -> None:
    for x in result.span_type.dropper_positions_m:
        ax.axvline(x, color="0.85", lw=0.6, zorder=0)
    ax.set_xlabel("x along the span [m]")
    ax.set_ylabel("CW deflection from the chord W [mm]")
    ax.set_title(title)
    ax.grid(alpha=0.3)


def _plot_w(ax, result: SensitivityResult, names: list[str], dashed: bool = False) -> None:
    x = result.x_m
    ax.plot(x, MM * result.nominal.cw_deflection_at(x), "k-", lw=1.6, label="nominal")
    for name in names:
        v = result.variation(name)
        ax.plot(x, MM * v.solution.cw_deflection_at(x), "--" if dashed else "-", lw=1.2, label=name)
    ax.legend(fontsize=8)


def sensitivity_figures(result: SensitivityResult, out_dir: str | Path) -> list[Path]:
    """Write the paper's Figs 2–4 analogues for ``result``; return the paths written."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    name = result.span_type.name
    paths = []
    by_fig = {}
    for v in result.variations:
        by_fig.setdefault(v.figure, []).append(v.name)

    fig, axes = subplots(1, 2, figsize=(12, 4.5), sharey=True)
    cw = [n for n in by_fig["fig2"] if n.startswith("contact")]
    mw = [n for n in by_fig["fig2"] if n.startswith("messenger")]
    for ax, names, title in ((axes[0], cw, "T_CW ±20 %"), (axes[1], mw, "T_MW ±20 %")):
        _span_axes(ax, result, f"{name}: {title}")
        _plot_w(ax, result, names)
    paths.append(save_figure(fig, out_dir / "fig2_tensions.png"))

    (sa,) = by_fig["fig3"]
    fig, axes = subplots(1, 2, figsize=(12, 4.5))
    x = result.x_m
    v = result.variation(sa)
    axes[0].plot(x, result.nominal.cw_height_at(x), "k-", label="nominal")
    axes[0].plot(x, v.solution.cw_height_at(x), "--", label=sa)
    axes[0].set_xlabel("x along the span [m]")
    axes[0].set_ylabel("CW height [m]")
    axes[0].set_title(f"{name}: steady arms moved, ΔH kept (heights)")
    axes[0].grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    _span_axes(axes[1], result, f"{name}: after projection on the chord")
    _plot_w(axes[1], result, [sa], dashed=True)
    gap = float(np.max(np.abs(result.variation(sa).solution.cw_deflection_at(x) - result.nominal.cw_deflection_at(x))))
    axes[1].text(0.02, 0.04, f"the two curves coincide: largest difference {MM * gap:.3f} mm", fontsize=8,
                 transform=axes[1].transAxes)
    paths.append(save_figure(fig, out_dir / "fig3_steady_arms.png"))

    (dh,) = by_fig["fig4"]
    fig, ax = subplots(figsize=(7, 4.5))
    _span_axes(ax, result, f"{name}: ΔH_left +5 cm, ΔH_right −5 cm")
    _plot_w(ax, result, [dh])
    paths.append(save_figure(fig, out_dir / "fig4_system_height.png"))
    return paths


def subplots(nrows: int = 1, ncols: int = 1, *, figsize=None, **kwargs):
    """A figure and its axes, as :func:`matplotlib.pyplot.subplots` gives them, without pyplot."""
    fig = Figure(figsize=figsize)
    return fig, fig.subplots(nrows, ncols, **kwargs)


def save_figure(fig, path: str | Path, dpi: int = 110) -> Path:
    """Lay out ``fig`` and write it as PNG at ``path`` (creating its folder)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    return path


def dynamics_figure(runs: dict, mast_chainage_m, window_m: tuple[float, float], title: str,
                    path: str | Path, cutoff_hz: float = 20.0) -> Path:
    """Contact force (raw and low-passed) and steady-arm uplift versus chainage, one colour
    per speed; ``runs`` maps a label (e.g. "300 km/h") to a RunResult."""
    import numpy as np

    from .contact_statistics import lowpass

    fig, (ax_f, ax_u) = subplots(2, 1, figsize=(11, 7), sharex=True)
    for label, run in runs.items():
        dt = float(run.time_s[1] - run.time_s[0])
        line, = ax_f.plot(run.chainage_m, run.contact_force_n, lw=0.5, alpha=0.35, label=f"{label} (raw)")
        ax_f.plot(run.chainage_m, lowpass(run.contact_force_n, dt, cutoff_hz), lw=1.2, color=line.get_color(),
                  label=f"{label} (0–{cutoff_hz:g} Hz)")
        uplift = 1e3 * run.support_uplift_m
        nearest = np.argmin(np.abs(run.chainage_m[:, None] - np.asarray(mast_chainage_m)[None, :]), axis=1)
        ax_u.plot(run.chainage_m, uplift[np.arange(uplift.shape[0]), nearest], color=line.get_color(), label=label)
    for ax in (ax_f, ax_u):
        for k, x in enumerate(mast_chainage_m):
            ax.axvline(x, color="0.85", lw=0.6, zorder=0, label="masts" if k == 0 else None)
        ax.axvspan(*window_m, color="0.95", zorder=-1, label="analysis window")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    ax_f.set_ylabel("contact force [N]")
    ax_u.set_ylabel("uplift of the nearest steady arm [mm]")
    ax_u.set_xlabel("chainage [m] (shaded: analysis window)")
    ax_f.set_title(title)
    return save_figure(fig, Path(path))
