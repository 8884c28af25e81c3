"""Candidate effects: physical extensions of the identification model the diagnosis can add.

Each candidate is one of the effects of :mod:`catenary.physics.effects` (the same function the
campaign plants it with) or a model-form extension (``wire_continuity``), with named
parameters, a null value at which it vanishes, an allowed range and the physics and the
signature on W it is expected to have. The signatures below were measured on the N2 span in
the line at realistic sizes (``benchmarks/signatures.py``; ``docs/diagnosis.md``).

Parameter kinds
---------------
``spread``
    A standard deviation ≥ 0: the null 0 lies on the boundary of the allowed range. Its
    likelihood-ratio statistic is a mixture of χ² laws at the null (Self & Liang, JASA 1987),
    and its score and Fisher information are taken in the variance σ² (J depends on σ through
    σ² near 0).
``shift``
    A signed magnitude (a mean offset, a gain, a force): the null 0 is interior.

Candidates
----------
``messenger_tension_variability``
    Per-span T_MW deviation ``std_n`` [N]. Signature: mid-span-heavy, nearly the shape of the
    MW's sag (paper Fig. 2).
``contact_tension_variability``
    Per-section T_CW deviation ``std_n`` [N] (each model span is a section of its own). Weak
    on W: the CW is nearly straight between droppers (paper Fig. 2).
``dropper_creep``
    Common dropper-length offset ``mean_m`` and its per-span spread ``std_m`` [m]. The mean
    moves W as a ΔH mean of opposite sign does (both shift the CW against the MW), so with a
    free ΔH mean it is not identifiable; the spread is the part of a ΔH spread common to both
    masts of a span.
``system_height_dropper_correlation``
    ``gain``: end droppers lengthened by gain × (ΔH − mean) at their mast (paper §4.2).
``measuring_force_offset``
    ``force_n`` [N] more than the declared measuring force: a deterministic mean shift of W
    equal to ``force_n`` times the measured heights' sensitivity to the force (the measuring
    pass's influence, :func:`catenary.physics.measuring.force_influence`).
``cw_longitudinal_offset``
    CW clamps ``mean_m`` ± ``std_m`` [m] along the line from the MW clamps (inclined droppers):
    a lift of W, second order in δ (δ = 0.1 m: ≈ 2 mm mid-span).
``steady_arm_height_difference``
    Per-mast steady-arm raise ``std_m`` [m], MW with it: removed by the projection onto the
    chord (paper Fig. 3). The negative control: its signature on W is nil for a pinned span
    and 1.3e-3 of its size in the line (0.06 mm for 5 cm), so it must never be named.
``contact_wire_wear``
    CW section lost by wear, ``mean_fraction`` and ``std_fraction`` per span: the droppers
    carry less weight and the MW sags less, much as under a higher T_MW.
``wire_continuity``
    ``fraction`` of the change from a span pinned at its masts to the span in the line, both
    wires continuous over the masts (issue [6]): a near-uniform lift of W by ≈ 1.1 mm. Only a
    candidate when the starting model is the pinned span (``neighbours: 0``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from catenary.physics.effects import EFFECTS, EffectParameter

__all__ = ["CANDIDATES", "KINDS", "Candidate", "CandidateParameter", "MODEL_FORM", "format_magnitude", "known",
           "register_plugins"]

KINDS = ("spread", "shift")
#: Candidates that are a change of the span model rather than an effect of catenary.physics.effects.
MODEL_FORM = ("wire_continuity",)


#: One parameter of a candidate effect (:class:`catenary.physics.effects.EffectParameter`: name, kind,
#: bounds, scale, realistic size, unit, label).
CandidateParameter = EffectParameter


@dataclass(frozen=True)
class Candidate:
    """A candidate extension of the identification model.

    Attributes
    ----------
    name : str
        Effect name (:data:`catenary.physics.effects.EFFECTS`) or a model-form name (:data:`MODEL_FORM`).
    parameters : tuple of CandidateParameter
    needs : frozenset of str
        What the fast model must carry: ``contact_tension`` (a per-sample T_CW), ``offset`` (a
        per-sample CW clamp offset), ``extended`` (worn-CW and steady-arm loads),
        ``force_influence`` (the measuring pass's sensitivity to the force), ``continuity``
        (a pinned and an in-line span model).
    summary : str
        One line of physics for reports.
    """

    name: str
    parameters: tuple[CandidateParameter, ...]
    needs: frozenset[str]
    summary: str

    @property
    def draw(self) -> str | None:
        """Kind of standard normal draw the effect takes (:data:`catenary.physics.effects.DRAW_KINDS`)."""
        return EFFECTS[self.name].draw if self.name in EFFECTS else None

    @property
    def design_columns(self) -> int:
        """Design columns one model span needs: the effect's draws per span or section, twice
        that for a mast draw (the span's two masts), 0 without randomness."""
        per = EFFECTS[self.name].n_draws if self.name in EFFECTS else 1
        return per * {"span": 1, "section": 1, "mast": 2, None: 0}[self.draw]

    @property
    def n_spread(self) -> int:
        return sum(p.kind == "spread" for p in self.parameters)

    @property
    def n_shift(self) -> int:
        return sum(p.kind == "shift" for p in self.parameters)

    def null(self) -> dict[str, float]:
        """The magnitudes at which the effect vanishes (all 0)."""
        return {p.name: 0.0 for p in self.parameters}


def format_magnitude(value: float, unit: str, se: float | None = None, *, name: str = "") -> str:
    """A candidate's magnitude in the unit people read: N; mm for metres; per cent for a
    fraction (a magnitude whose ``name`` ends with ``fraction``); else as it is."""
    scale, suffix, digits = {"N": (1.0, " N", 0), "m": (1e3, " mm", 1)}.get(unit, (1.0, "", 3))
    if unit == "-" and name.endswith("fraction"):
        scale, suffix, digits = 100.0, " %", 1
    if not math.isfinite(value):
        return "∞"
    text = f"{scale * value:.{digits}f}"
    if se is not None and math.isfinite(se):
        text += f" ± {scale * se:.{digits}f}"
    return text + suffix


def _p(name, kind, bounds, scale, realistic, unit, label):
    return CandidateParameter(name, kind, (float(bounds[0]), float(bounds[1])), float(scale), float(realistic), unit,
                              label)


CANDIDATES: dict[str, Candidate] = {c.name: c for c in (
    Candidate("messenger_tension_variability",
              (_p("std_n", "spread", (0, 2500), 400, 600, "N", "per-span messenger tension σ"),),
              frozenset(), "per-span deviation of the MW tension from its section's regulated one"),
    Candidate("contact_tension_variability",
              (_p("std_n", "spread", (0, 2000), 400, 400, "N", "per-section contact tension σ"),),
              frozenset({"contact_tension"}), "per-section deviation of the CW tension from the design one"),
    Candidate("dropper_creep",
              (_p("mean_m", "shift", (-0.03, 0.03), 0.004, 0.005, "m", "mean dropper creep"),
               _p("std_m", "spread", (0, 0.02), 0.003, 0.004, "m", "per-span dropper creep σ")),
              frozenset(), "common offset of a span's dropper lengths (creep, a batch's cutting error)"),
    Candidate("system_height_dropper_correlation",
              (_p("gain", "shift", (-3, 3), 0.5, 1.0, "-", "end-dropper gain on ΔH"),),
              frozenset(), "end droppers lengthened with the system height at their mast"),
    Candidate("measuring_force_offset",
              (_p("force_n", "shift", (-15, 15), 2, 4, "N", "measuring force excess"),),
              frozenset({"force_influence"}), "measuring force above the declared one, left in W by the correction"),
    Candidate("cw_longitudinal_offset",
              (_p("mean_m", "shift", (-0.2, 0.2), 0.05, 0.15, "m", "mean CW shift along the line"),
               _p("std_m", "spread", (0, 0.1), 0.03, 0.05, "m", "per-span CW shift σ")),
              frozenset({"offset"}), "CW shifted along the line against the MW: inclined droppers"),
    Candidate("steady_arm_height_difference",
              (_p("std_m", "spread", (0, 0.15), 0.02, 0.03, "m", "per-mast steady-arm height σ"),),
              frozenset({"extended"}), "steady arms raised per mast, MW with them (removed by the projection)"),
    Candidate("contact_wire_wear",
              (_p("mean_fraction", "shift", (-0.05, 0.25), 0.03, 0.08, "-", "mean CW wear (fraction of section)"),
               _p("std_fraction", "spread", (0, 0.04), 0.01, 0.02, "-", "per-span CW wear σ (fraction of section)")),
              frozenset({"extended"}), "CW section lost by wear: less weight on the droppers"),
    Candidate("wire_continuity",
              (_p("fraction", "shift", (-0.5, 1.5), 0.5, 1.0, "-", "fraction of the wires' continuity over the masts"),),
              frozenset({"continuity"}), "wires continuous over the masts instead of a span pinned at them"),
)}


def register_plugins() -> tuple[str, ...]:
    """Make every user's effect of ``scope="population"`` with declared parameters a candidate
    (:func:`catenary.physics.effects.load_modules` registers them as effects first); return their names."""
    out = []
    for name, effect in EFFECTS.items():
        if name in CANDIDATES or effect.scope != "population" or not effect.parameters:
            continue
        CANDIDATES[name] = Candidate(name, tuple(effect.parameters), frozenset(),
                                     effect.summary or f"{name} (an effect of one's own)")
        out.append(name)
    return tuple(out)


def known(name: str) -> bool:
    """Whether ``name`` is a candidate: a built-in, a registered user's effect of population
    scope, or a user's effect of span scope (fitted span by span, :mod:`.span_effects`)."""
    return name in CANDIDATES or (name in EFFECTS and EFFECTS[name].scope == "span" and bool(EFFECTS[name].parameters))
