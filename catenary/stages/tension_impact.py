"""Impact of the messenger-wire tension on the measured sag (paper §2.2, Fig. 6).

The dynamic correction changes dropper lengths only. The paper checks that this is
legitimate: two catenaries with the *same static CW sag*, one at T_MW = 16 kN and one at
20 kN (dropper lengths adjusted), give measured (dynamic) sags within 2 mm of each other under
the measuring pass. If so, a correction that explains a sag difference by droppers alone
gives the static geometry right even when the real cause was T_MW.

Here both models are sections of ``n_spans`` identical spans (wires continuous over the masts)
and the central span is evaluated, so that the run-in of the pantograph and the section ends
do not matter. The common static sag is either

``"presag"``
    the span type's design profile (presag parabola at the droppers): both models get their
    dropper lengths from :func:`~catenary.physics.dropper_table.dropper_lengths_for_cw_heights`. This
    is the sag the correction meets on real spans.
``"nominal_table"``
    the paper's literal construction: the first model keeps the nominal dropper table at its
    tension (at 16 kN the CW then sags ≈ 3 × the presag), the second gets the dropper lengths
    reproducing that sag.

With the same CW heights at every dropper the two static CW profiles coincide along the whole
span, not only at the droppers: the CW equilibrium between droppers involves T_CW and the CW
loads only. The measured sags differ because the lower T_MW makes the catenary softer under
the pantograph (more uplift).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from catenary.physics.config import Catenary, SpanType
from catenary.physics.dropper_table import dropper_lengths_for_cw_heights, nominal_dropper_lengths, presag_deflection_m
from catenary.physics.measuring import MODES, measuring_pass
from catenary.physics.pantograph import Pantograph
from catenary.physics.section import Section, uniform_section
from catenary.physics.static import solve_static

COMMON_SAGS = ("presag", "nominal_table")
MM = 1e3


@dataclass(frozen=True)
class TensionImpactResult:
    """Static and measured sags of two catenaries with the same static sag.

    All profiles are CW deflections from the chord between the design steady-arm heights of
    the central span [m] (negative below); index 0 is the first tension, 1 the second.

    Attributes
    ----------
    span_type : SpanType
    messenger_tensions_n : numpy.ndarray
        The two T_MW [N].
    dropper_lengths_m : numpy.ndarray
        Unstretched dropper lengths of the central span of each model [m], shape (2, n_droppers).
    x_m : numpy.ndarray
        Positions along the central span from its left mast [m].
    dropper_x_m : numpy.ndarray
        Dropper positions in the span [m].
    static_m, measured_m : numpy.ndarray
        Static and measured deflection at ``x_m``, shape (2, n_points) [m].
    static_droppers_m, measured_droppers_m : numpy.ndarray
        The same at the droppers, shape (2, n_droppers) [m].
    settings : dict
        n_spans, speed_m_s, force_n, time_step_s, mode, common_sag.
    """

    span_type: SpanType
    messenger_tensions_n: np.ndarray
    dropper_lengths_m: np.ndarray
    x_m: np.ndarray
    dropper_x_m: np.ndarray
    static_m: np.ndarray
    measured_m: np.ndarray
    static_droppers_m: np.ndarray
    measured_droppers_m: np.ndarray
    settings: dict

    @property
    def difference_m(self) -> np.ndarray:
        """Measured deflection of the first model minus the second, along the span [m]."""
        return self.measured_m[0] - self.measured_m[1]

    @property
    def difference_droppers_m(self) -> np.ndarray:
        """Measured deflection of the first model minus the second, at the droppers [m]."""
        return self.measured_droppers_m[0] - self.measured_droppers_m[1]

    def summary(self) -> pd.DataFrame:
        """One row at the droppers and one along the span.

        Columns: ``span_type``, ``where`` (``droppers`` or ``span``), ``max_difference_mm``
        (max |measured₁ − measured₂|), ``max_static_difference_mm`` (max |static₁ − static₂|),
        ``max_correction_mm`` (max |measured − static| of either model: the size of the
        dynamic correction), and the two tensions.
        """
        rows = []
        for where, static, measured in (("droppers", self.static_droppers_m, self.measured_droppers_m),
                                        ("span", self.static_m, self.measured_m)):
            rows.append({
                "span_type": self.span_type.name,
                "where": where,
                "max_difference_mm": MM * float(np.max(np.abs(measured[0] - measured[1]))),
                "max_static_difference_mm": MM * float(np.max(np.abs(static[0] - static[1]))),
                "max_correction_mm": MM * float(np.max(np.abs(measured - static))),
                "messenger_tension_1_n": float(self.messenger_tensions_n[0]),
                "messenger_tension_2_n": float(self.messenger_tensions_n[1]),
            })
        return pd.DataFrame(rows)


def same_sag_sections(span_type: SpanType, catenary: Catenary, messenger_tensions_n, n_spans: int, *,
                      common_sag: str = "presag") -> tuple[Section, Section]:
    """Two uniform sections at the two tensions with the same static CW heights at every dropper.

    Parameters
    ----------
    span_type, catenary
    messenger_tensions_n : (float, float)
        T_MW of the two models [N].
    n_spans : int
        Spans per section.
    common_sag : {"presag", "nominal_table"}
        The common sag (module docstring).
    """
    if common_sag not in COMMON_SAGS:
        raise ValueError(f"common_sag: expected one of {COMMON_SAGS}, got {common_sag!r}")
    t1, t2 = (float(t) for t in messenger_tensions_n)
    nominal = nominal_dropper_lengths(span_type, catenary).dropper_lengths_m
    base = uniform_section(span_type, n_spans, nominal)
    if common_sag == "presag":
        target = span_type.cw_height_m + presag_deflection_m(span_type, base.dropper_x_m)
        first = dropper_lengths_for_cw_heights(base.with_tensions(messenger_tension_n=t1), catenary, target).section
    else:
        first = base.with_tensions(messenger_tension_n=t1)
        sol = solve_static(first, catenary)
        if sol.any_slack:
            raise ValueError(f"nominal dropper table at T_MW = {t1} N leaves droppers slack; "
                             "no common taut sag to start from")
        target = sol.cw_height_m[sol.mesh.dropper_nodes]
    second = dropper_lengths_for_cw_heights(base.with_tensions(messenger_tension_n=t2), catenary, target).section
    return first, second


def tension_impact(span_type: SpanType, catenary: Catenary, pantograph: Pantograph, *,
                   messenger_tensions_n=(16000.0, 20000.0), n_spans: int = 5, speed_m_s: float = 40 / 3.6,
                   force_n: float | None = None, time_step_s: float | None = None,
                   sampling_step_m: float = 0.1, common_sag: str = "presag",
                   mode: str = "dynamic") -> TensionImpactResult:
    """Paper Fig. 6 analogue: measuring passes over two catenaries with the same static sag.

    Parameters
    ----------
    span_type, catenary
    pantograph : Pantograph
        Measuring pantograph.
    messenger_tensions_n : (float, float)
        T_MW of the two models [N] (paper: 16 and 20 kN).
    n_spans : int
        Spans of each simulated section (≥ 3); the central one (index ``n_spans // 2``) is
        evaluated.
    speed_m_s : float
        Train speed [m/s].
    force_n : float, optional
        Static uplift of the measuring pantograph [N] (default: the pantograph's own).
    time_step_s : float, optional
        Integration step of the dynamic pass [s] (default: the catenary's).
    sampling_step_m : float
        Spacing of the evaluation points along the central span [m].
    common_sag : {"presag", "nominal_table"}
    mode : {"dynamic", "quasi_static"}
        Measuring-pass mode (:func:`catenary.physics.measuring.measuring_pass`).
    """
    if n_spans < 3:
        raise ValueError(f"n_spans: expected ≥ 3 so that the central span has neighbours, got {n_spans}")
    if mode not in MODES:
        raise ValueError(f"mode: expected one of {MODES}, got {mode!r}")
    if not sampling_step_m > 0:
        raise ValueError(f"sampling_step_m: expected > 0, got {sampling_step_m}")
    if force_n is not None:
        pantograph = pantograph.with_static_force(force_n)
    sections = same_sag_sections(span_type, catenary, messenger_tensions_n, n_spans, common_sag=common_sag)
    centre = n_spans // 2
    left = sections[0].mast_chainage_m[centre]
    n_points = int(np.ceil(span_type.length_m / sampling_step_m - 1e-9)) + 1
    x = np.linspace(0.0, span_type.length_m, n_points)
    xd = span_type.dropper_positions_m
    chainage = np.concatenate([left + x, left + xd])
    chord = span_type.cw_height_m  # both steady arms of the central span at the design height
    static, measured, lengths = [], [], []
    for section in sections:
        sol = solve_static(section, catenary)
        if sol.any_slack:
            raise ValueError(f"static model at T_MW = {section.messenger_tension_n} N has slack droppers")
        static.append(sol.cw_height_at(chainage) - chord)
        run = measuring_pass(section, catenary, pantograph, speed_m_s=speed_m_s, mode=mode,
                             time_step_s=time_step_s, chainage_m=chainage)
        measured.append(run.height_m - chord)
        lengths.append(section.dropper_lengths_m[section.dropper_span == centre])
    static, measured = np.array(static), np.array(measured)
    return TensionImpactResult(
        span_type=span_type, messenger_tensions_n=np.asarray(messenger_tensions_n, dtype=float),
        dropper_lengths_m=np.array(lengths), x_m=x, dropper_x_m=xd,
        static_m=static[:, :n_points], measured_m=measured[:, :n_points],
        static_droppers_m=static[:, n_points:], measured_droppers_m=measured[:, n_points:],
        settings={"n_spans": n_spans, "speed_m_s": speed_m_s, "force_n": pantograph.mean_force_n(speed_m_s),
                  "time_step_s": time_step_s or catenary.dynamics.time_step_s, "mode": mode,
                  "common_sag": common_sag})


def tension_impact_figure(result: TensionImpactResult, path: str | Path) -> Path:
    """Write the Fig. 6 analogue: static and measured sags of both models, and their
    difference [mm], along the central span (PNG)."""
    from catenary.plumbing.plots import save_figure, subplots

    t = result.messenger_tensions_n / 1e3
    s = result.settings
    fig, (top, bottom) = subplots(2, 1, figsize=(9, 7), sharex=True, height_ratios=[2, 1])
    for x in result.dropper_x_m:
        for ax in (top, bottom):
            ax.axvline(x, color="0.85", lw=0.6, zorder=0)
    styles = (("C0", "-"), ("C3", "--"))
    for i, (color, ls) in enumerate(styles):
        top.plot(result.x_m, MM * result.static_m[i], color=color, ls=ls, lw=1.0, alpha=0.7,
                 label=f"static, T_MW = {t[i]:g} kN")
        top.plot(result.x_m, MM * result.measured_m[i], color=color, ls=ls, lw=1.8,
                 label=f"measured ({s['mode']}), T_MW = {t[i]:g} kN")
    top.set_ylabel("CW deflection from the chord [mm]")
    top.set_title(f"{result.span_type.name}: same static sag at T_MW = {t[0]:g} and {t[1]:g} kN "
                  f"({s['common_sag']}); {s['force_n']:g} N at {3.6 * s['speed_m_s']:g} km/h, "
                  f"central span of {s['n_spans']}", fontsize=9)
    top.legend(fontsize=8)
    top.grid(alpha=0.3)
    d = MM * result.difference_m
    bottom.plot(result.x_m, d, "k-", lw=1.2, label="measured difference")
    bottom.plot(result.dropper_x_m, MM * result.difference_droppers_m, "ko", ms=4, label="at the droppers")
    for level in (-2.0, 2.0):
        bottom.axhline(level, color="C1", ls=":", lw=1.0, label="±2 mm (the paper's bound)" if level > 0 else None)
    bottom.set_xlabel("x along the central span [m]")
    bottom.set_ylabel(f"{t[0]:g} kN − {t[1]:g} kN [mm]")
    bottom.legend(fontsize=8)
    bottom.grid(alpha=0.3)
    return save_figure(fig, path, dpi=120)
