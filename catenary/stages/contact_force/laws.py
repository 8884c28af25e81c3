"""Random sections from the identified laws: the campaign's own sampling code, other laws.

A replicate is a section of consecutive spans of one type drawn exactly as the virtual campaign
draws its truth (:func:`catenary.measurement.truth.draw_line`): dropper lengths per span and dropper from
their Gamma laws, ΔH per mast from its Gamma law, steady-arm heights per mast, then the hidden
effects (:mod:`catenary.physics.effects`). Only the laws differ: they are the identified ones
(``s_opt.csv``) and the effects the diagnosis named with their identified magnitudes
(``findings.csv``). The identified T_MW law is per span; the campaign's truth draws T_MW per
section, and a per-span spread is its ``messenger_tension_variability`` effect (a normal
deviation), so a replicate's T_MW is its mean plus that effect with the identified σ — a normal
law where the identification has a Gamma one of the same mean and σ (at σ/μ ≈ 4 % their
skewness differs by 0.08: nothing the contact force can feel).

A named ``messenger_tension_variability`` is not added again when the identification already
has a random T_MW (it is the same spread).
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from catenary.measurement.truth import Law, Measurement, SectionSpec, TruthSpec
from catenary.physics.config import Catenary, SpanType
from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.plumbing.errors import InputError

__all__ = ["SectionLaws", "design_laws", "read_laws", "section_spec"]

#: Effects the diagnosis names that are already a random input of the identification.
_IN_BASE = {"messenger_tension_variability": "messenger_tension_n"}


@dataclass(frozen=True)
class SectionLaws:
    """Laws of one span type's random section.

    Attributes
    ----------
    span_type : str
    dropper_mean_m, dropper_sigma_m : numpy.ndarray, shape (n,)
        Dropper-length laws (Gamma) [m].
    messenger_tension_mean_n, messenger_tension_sigma_n : float
        T_MW per span [N].
    system_height_mean_m, system_height_sigma_m : float
        ΔH per mast (Gamma) [m].
    cw_height : Law
        Steady-arm heights per mast [m].
    effects : tuple of (str, dict)
        Further named effects and their magnitudes (SI).
    """

    span_type: str
    dropper_mean_m: np.ndarray
    dropper_sigma_m: np.ndarray
    messenger_tension_mean_n: float
    messenger_tension_sigma_n: float
    system_height_mean_m: float
    system_height_sigma_m: float
    cw_height: Law
    effects: tuple = ()

    def with_spreads(self, *, dropper_sigma_m=None, messenger_tension_sigma_n=None) -> "SectionLaws":
        """The same laws with other dropper-length or T_MW spreads (the tolerance study)."""
        changes = {}
        if dropper_sigma_m is not None:
            changes["dropper_sigma_m"] = np.broadcast_to(np.asarray(dropper_sigma_m, dtype=float),
                                                         self.dropper_mean_m.shape).copy()
        if messenger_tension_sigma_n is not None:
            changes["messenger_tension_sigma_n"] = float(messenger_tension_sigma_n)
        return dataclasses.replace(self, **changes)

    def summary(self) -> dict:
        return {"dropper_sigma_m": self.dropper_sigma_m.tolist(), "messenger_tension_n": [
            self.messenger_tension_mean_n, self.messenger_tension_sigma_n],
            "system_height_m": [self.system_height_mean_m, self.system_height_sigma_m],
            "cw_height_m": [self.cw_height.mean, self.cw_height.std], "effects": [list(e) for e in self.effects]}


def read_laws(s_opt_path, findings_path, span_type: SpanType, cw_height: Law) -> SectionLaws:
    """Laws of ``span_type`` from the identification's ``s_opt.csv`` and the diagnosis's
    ``findings.csv`` (its named effects; None or a missing file: none).

    Raises
    ------
    InputError
        If ``s_opt.csv`` lacks a parameter or column, or says the identification did not converge.
    """
    table = pd.read_csv(s_opt_path)
    needed = {"parameter", "mu", "sigma", "status"}
    if not needed <= set(table.columns):
        raise InputError(f"{s_opt_path}: expected columns {sorted(needed)}, got {list(table.columns)}")
    if (table["status"] != "ok").any():
        raise InputError(f"{s_opt_path}: identification status {sorted(set(table['status']))}: the laws are not "
                         "an optimum; random sections from them would mislead")
    rows = table.set_index("parameter")
    names = [f"dropper_{i + 1}_length_m" for i in range(span_type.n_droppers)] + ["messenger_tension_n",
                                                                                  "system_height_m"]
    missing = [n for n in names if n not in rows.index]
    if missing:
        raise InputError(f"{s_opt_path}: missing parameter row(s) {missing}")
    droppers = rows.loc[names[:-2]]
    effects = []
    if findings_path is not None and Path(findings_path).exists():
        findings = pd.read_csv(findings_path)
        for _, step in findings[findings["verdict"] == "named"].iterrows():
            if step["effect"] in _IN_BASE:
                continue
            params = {k: float(v[0]) for k, v in json.loads(step["parameters"]).items()}
            effects.append((str(step["effect"]), params))
    return SectionLaws(span_type=span_type.name, dropper_mean_m=droppers["mu"].to_numpy(float),
                       dropper_sigma_m=droppers["sigma"].to_numpy(float),
                       messenger_tension_mean_n=float(rows.loc["messenger_tension_n", "mu"]),
                       messenger_tension_sigma_n=float(rows.loc["messenger_tension_n", "sigma"]),
                       system_height_mean_m=float(rows.loc["system_height_m", "mu"]),
                       system_height_sigma_m=float(rows.loc["system_height_m", "sigma"]),
                       cw_height=cw_height, effects=tuple(effects))


def design_laws(span_type: SpanType, catenary: Catenary) -> SectionLaws:
    """The design geometry as laws without spread: the nominal section of the dynamics rule."""
    n = span_type.n_droppers
    return SectionLaws(span_type=span_type.name,
                       dropper_mean_m=nominal_dropper_lengths(span_type, catenary).dropper_lengths_m,
                       dropper_sigma_m=np.zeros(n), messenger_tension_mean_n=span_type.messenger_tension_n,
                       messenger_tension_sigma_n=0.0, system_height_mean_m=span_type.system_height_m,
                       system_height_sigma_m=0.0, cw_height=Law("fixed", span_type.cw_height_m))


def section_spec(laws: SectionLaws, span_type: SpanType, n_spans: int, seed: int) -> TruthSpec:
    """A truth specification of one section of ``n_spans`` spans under ``laws`` (module docstring)."""
    gamma_or_fixed = lambda mean, std: Law("gamma", mean, std) if std > 0 else Law("fixed", mean)  # noqa: E731
    effects = []
    if laws.messenger_tension_sigma_n > 0:
        effects.append(("messenger_tension_variability", {"std_n": laws.messenger_tension_sigma_n}))
    effects.extend((name, dict(m)) for name, m in laws.effects)
    measurement = Measurement(pantograph="", speed_kmh=0.0, force_n=0.0, sampling_step_m=1.0, noise_std_m=0.0,
                              quantisation_m=0.0, dropout_rate_per_km=0.0, dropout_length_m=0.0,
                              spike_rate_per_km=0.0, spike_height_m=0.0, mode="dynamic", time_step_s=0.001)
    return TruthSpec(
        seed=int(seed), sections=[SectionSpec("R", span_type.name, int(n_spans))], section_gap_m=0.0,
        span_length_jitter_m=0.0, cw_height=laws.cw_height,
        dropper_laws={span_type.name: (laws.dropper_mean_m, laws.dropper_sigma_m, "gamma")},
        system_height={span_type.name: gamma_or_fixed(laws.system_height_mean_m, laws.system_height_sigma_m)},
        contact_tension=Law("fixed", span_type.contact_tension_n),
        messenger_tension={span_type.name: Law("fixed", laws.messenger_tension_mean_n)},
        hidden_effects=effects, measurement=measurement)
