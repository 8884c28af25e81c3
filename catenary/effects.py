"""Hidden physical effects: the one place where each effect's physics lives.

The virtual campaign plants these effects in its truth; the discrepancy workflow will offer the
same functions as candidate extensions of the fast static model. Each effect acts on the
per-span parameters of a line (a :class:`SpanParameters` table) and is parameterised by a
magnitude read from the truth specification:

``messenger_tension_variability`` (``std_n``)
    Each span's MW tension deviates from its section's regulated tension by a zero-mean
    normal amount (friction at the cantilevers, temperature differences).
``contact_tension_variability`` (``std_n``)
    Each section's CW tension deviates from the design one (tensioning weights, friction).
``dropper_creep`` (``mean_m``, ``std_m``)
    A common offset of all dropper lengths of a span (creep of the dropper wires, or a
    systematic cutting error of that span's dropper batch).
``system_height_dropper_correlation`` (``gain``)
    The end droppers follow the system height at their mast: the dropper next to a mast is
    lengthened by ``gain`` × (ΔH at that mast − its mean), as fitters adjust the first
    dropper to the measured system height.
``measuring_force_offset`` (``force_n``)
    The measuring pantograph pushes ``force_n`` more than the declared force.
``cw_longitudinal_offset`` (``mean_m``, ``std_m``)
    The CW is shifted along the line relative to the MW (thermal expansion of wires regulated
    from different anchors, or droppers fitted off the design position): every dropper of a
    span is inclined, its CW clamp ``δ`` from its MW clamp, with ``δ`` drawn per span. The
    droppers' geometry is :func:`catenary.section.inclined_dropper`; the fast model takes the
    same offset (``FastSpanModel(cw_clamp_offset_m=...)``).

All magnitudes are SI. Effects are applied in the order listed in the truth file.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np


@dataclass
class SpanParameters:
    """Mutable per-span and per-section parameters of a line during the truth draw.

    Attributes
    ----------
    dropper_lengths_m : numpy.ndarray
        (n_spans, n_droppers) unstretched dropper lengths [m].
    system_height_left_m, system_height_right_m : numpy.ndarray
        ΔH at each span's left and right mast [m].
    system_height_mean_m : numpy.ndarray
        Mean of the ΔH law of each span's type [m].
    messenger_tension_n, contact_tension_n : numpy.ndarray
        Per-span tensions [N] (equal within a section unless an effect changes them).
    section_index : numpy.ndarray
        Section of each span.
    measuring_force_n : float
        Force the measuring pantograph really applies [N].
    creep_offset_m : numpy.ndarray
        Common dropper-length offset planted in each span [m] (0 without creep).
    cw_offset_m : numpy.ndarray
        Longitudinal offset of each span's CW clamps from its MW clamps [m] (0: vertical droppers).
    """

    dropper_lengths_m: np.ndarray
    system_height_left_m: np.ndarray
    system_height_right_m: np.ndarray
    system_height_mean_m: np.ndarray
    messenger_tension_n: np.ndarray
    contact_tension_n: np.ndarray
    section_index: np.ndarray
    measuring_force_n: float
    creep_offset_m: np.ndarray
    cw_offset_m: np.ndarray


def messenger_tension_variability(p: SpanParameters, rng: np.random.Generator, *, std_n: float) -> None:
    p.messenger_tension_n = p.messenger_tension_n + std_n * rng.standard_normal(p.messenger_tension_n.size)


def contact_tension_variability(p: SpanParameters, rng: np.random.Generator, *, std_n: float) -> None:
    n_sections = int(p.section_index.max()) + 1
    p.contact_tension_n = p.contact_tension_n + (std_n * rng.standard_normal(n_sections))[p.section_index]


def dropper_creep(p: SpanParameters, rng: np.random.Generator, *, mean_m: float, std_m: float = 0.0) -> None:
    offset = mean_m + std_m * rng.standard_normal(p.dropper_lengths_m.shape[0])
    p.creep_offset_m = p.creep_offset_m + offset
    p.dropper_lengths_m = p.dropper_lengths_m + offset[:, None]


def system_height_dropper_correlation(p: SpanParameters, rng: np.random.Generator, *, gain: float) -> None:
    lengths = p.dropper_lengths_m.copy()
    lengths[:, 0] += gain * (p.system_height_left_m - p.system_height_mean_m)
    lengths[:, -1] += gain * (p.system_height_right_m - p.system_height_mean_m)
    p.dropper_lengths_m = lengths


def measuring_force_offset(p: SpanParameters, rng: np.random.Generator, *, force_n: float) -> None:
    p.measuring_force_n = p.measuring_force_n + force_n


def cw_longitudinal_offset(p: SpanParameters, rng: np.random.Generator, *, mean_m: float, std_m: float = 0.0) -> None:
    p.cw_offset_m = p.cw_offset_m + mean_m + std_m * rng.standard_normal(p.cw_offset_m.size)


EFFECTS: dict[str, Callable[..., None]] = {
    "messenger_tension_variability": messenger_tension_variability,
    "contact_tension_variability": contact_tension_variability,
    "dropper_creep": dropper_creep,
    "system_height_dropper_correlation": system_height_dropper_correlation,
    "measuring_force_offset": measuring_force_offset,
    "cw_longitudinal_offset": cw_longitudinal_offset,
}
