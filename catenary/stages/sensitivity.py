"""Sensitivity of the span's static deflection to its parameters (paper §2.1, Figs 2–4).

Each variation changes one group of parameters of a single span built with the nominal
dropper table and compares the CW deflection from the chord (W) with the nominal one:

* ``contact_tension_±20%`` and ``messenger_tension_±20%`` (Fig. 2);
* ``steady_arms_+5/-5cm``: left steady arm raised and right one lowered by 5 cm, system
  heights kept (Fig. 3) — W after projection onto the chord should not move;
* ``system_height_+5/-5cm``: ΔH_left + 5 cm, ΔH_right − 5 cm (Fig. 4) — asymmetric.

Dropper lengths are kept in every variation, so droppers may go slack; the FE model
handles that and the result records it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from catenary.physics.config import Catenary, SpanType
from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.physics.section import Section, single_span
from catenary.physics.static import StaticSolution, solve_static
from catenary.plumbing.plots import save_figure, subplots

STEADY_ARM_SHIFT_M = 0.05
SYSTEM_HEIGHT_SHIFT_M = 0.05
TENSION_FACTOR = 0.20


@dataclass(frozen=True)
class VariationResult:
    """One varied span compared with the nominal one.

    Attributes
    ----------
    name : str
        Variation name (see module docstring).
    figure : str
        Which paper figure it belongs to (``fig2``, ``fig3``, ``fig4``).
    solution : StaticSolution
        Static solution of the varied span.
    dw_droppers_m : numpy.ndarray
        W(varied) − W(nominal) at the droppers [m].
    dw_span_m : numpy.ndarray
        The same along the span at ``SensitivityResult.x_m`` [m].
    """

    name: str
    figure: str
    solution: StaticSolution
    dw_droppers_m: np.ndarray
    dw_span_m: np.ndarray

    @property
    def max_abs_dw_m(self) -> float:
        """Largest |ΔW| at the droppers [m]."""
        return float(np.max(np.abs(self.dw_droppers_m)))


@dataclass(frozen=True)
class SensitivityResult:
    """Nominal span and all variations of :func:`run_sensitivity`."""

    span_type: SpanType
    x_m: np.ndarray
    nominal: StaticSolution
    variations: list[VariationResult] = field(default_factory=list)

    def variation(self, name: str) -> VariationResult:
        for v in self.variations:
            if v.name == name:
                return v
        raise KeyError(f"no variation {name!r}; have {[v.name for v in self.variations]}")

    def summary_rows(self) -> list[dict]:
        """One row per variation: name, figure, max |ΔW| at droppers and along the span [mm],
        mean ΔW over the left and right halves of the droppers [mm], slack droppers."""
        x = self.span_type.dropper_positions_m
        left = x < 0.5 * self.span_type.length_m
        right = x > 0.5 * self.span_type.length_m
        return [{
            "variation": v.name,
            "figure": v.figure,
            "max_abs_dw_mm": 1e3 * v.max_abs_dw_m,
            "max_abs_dw_span_mm": 1e3 * float(np.max(np.abs(v.dw_span_m))),
            "mean_dw_left_half_mm": 1e3 * float(np.mean(v.dw_droppers_m[left])),
            "mean_dw_right_half_mm": 1e3 * float(np.mean(v.dw_droppers_m[right])),
            "slack_droppers": int(np.sum(v.solution.dropper_slack)),
        } for v in self.variations]


def sensitivity_sections(span_type: SpanType, lengths_m: np.ndarray) -> list[tuple[str, str, Section]]:
    """The varied spans of the paper's sensitivity study: (name, figure, section)."""
    t_cw, t_mw = span_type.contact_tension_n, span_type.messenger_tension_n
    h, dh = span_type.cw_height_m, span_type.system_height_m
    pct = int(round(100 * TENSION_FACTOR))
    cases = []
    for sign, tag in ((1, "+"), (-1, "-")):
        factor = 1 + sign * TENSION_FACTOR
        cases.append((f"contact_tension_{tag}{pct}%", "fig2",
                      single_span(span_type, lengths_m, contact_tension_n=factor * t_cw)))
    for sign, tag in ((1, "+"), (-1, "-")):
        factor = 1 + sign * TENSION_FACTOR
        cases.append((f"messenger_tension_{tag}{pct}%", "fig2",
                      single_span(span_type, lengths_m, messenger_tension_n=factor * t_mw)))
    cm = int(round(100 * STEADY_ARM_SHIFT_M))
    cases.append((f"steady_arms_+{cm}/-{cm}cm", "fig3",
                  single_span(span_type, lengths_m, cw_height_left_m=h + STEADY_ARM_SHIFT_M,
                              cw_height_right_m=h - STEADY_ARM_SHIFT_M)))
    cm = int(round(100 * SYSTEM_HEIGHT_SHIFT_M))
    cases.append((f"system_height_+{cm}/-{cm}cm", "fig4",
                  single_span(span_type, lengths_m, system_height_left_m=dh + SYSTEM_HEIGHT_SHIFT_M,
                              system_height_right_m=dh - SYSTEM_HEIGHT_SHIFT_M)))
    return cases


def run_sensitivity(span_type: SpanType, catenary: Catenary, n_points: int = 401) -> SensitivityResult:
    """Solve the nominal span and every variation; W compared at droppers and along the span."""
    lengths = nominal_dropper_lengths(span_type, catenary).dropper_lengths_m
    x = np.linspace(0.0, span_type.length_m, n_points)
    nominal = solve_static(single_span(span_type, lengths), catenary)
    w_nom = nominal.cw_deflection_at(x)
    out = SensitivityResult(span_type=span_type, x_m=x, nominal=nominal)
    for name, figure, section in sensitivity_sections(span_type, lengths):
        sol = solve_static(section, catenary)
        out.variations.append(VariationResult(
            name=name, figure=figure, solution=sol,
            dw_droppers_m=sol.dropper_deflection_m() - nominal.dropper_deflection_m(),
            dw_span_m=sol.cw_deflection_at(x) - w_nom))
    return out


def _span_axes(ax, result: SensitivityResult, title: str) -> None:
    for x in result.span_type.dropper_positions_m:
        ax.axvline(x, color="0.85", lw=0.6, zorder=0)
    ax.set_xlabel("x along the span [m]")
    ax.set_ylabel("CW deflection from the chord W [mm]")
    ax.set_title(title)
    ax.grid(alpha=0.3)


def _plot_w(ax, result: SensitivityResult, names: list[str], dashed: bool = False) -> None:
    x = result.x_m
    ax.plot(x, 1e3 * result.nominal.cw_deflection_at(x), "k-", lw=1.6, label="nominal")
    for name in names:
        v = result.variation(name)
        ax.plot(x, 1e3 * v.solution.cw_deflection_at(x), "--" if dashed else "-", lw=1.2, label=name)
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
    axes[1].text(0.02, 0.04, f"the two curves coincide: largest difference {1e3 * gap:.3f} mm", fontsize=8,
                 transform=axes[1].transAxes)
    paths.append(save_figure(fig, out_dir / "fig3_steady_arms.png"))

    (dh,) = by_fig["fig4"]
    fig, ax = subplots(figsize=(7, 4.5))
    _span_axes(ax, result, f"{name}: ΔH_left +5 cm, ΔH_right −5 cm")
    _plot_w(ax, result, [dh])
    paths.append(save_figure(fig, out_dir / "fig4_system_height.png"))
    return paths
