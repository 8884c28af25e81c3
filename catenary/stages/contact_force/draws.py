"""Random sections drawn group by group, each group from its own seeded stream.

A section of ``n_spans`` spans is built as the campaign builds its line (a
:class:`~catenary.measurement.truth.Line`, masts at the type's span length, then
:func:`catenary.measurement.campaign.section_model`), with the campaign's laws (:class:`~catenary.measurement.truth.Law`)
and effect functions (:data:`catenary.physics.effects.EFFECTS`). Its random inputs fall into groups —
``dropper_lengths`` (per span and dropper), ``messenger_tension`` (per span), ``system_height``
(per mast), ``steady_arm_heights`` (per mast) and each named effect — and each group draws from
a generator of its own seed. A replicate is one seed per group; the variance-based sensitivity
(:mod:`.sensitivity`) mixes the seeds of two replicates group by group (pick-freeze).

Effects are applied in their order after the groups, all with normal scores from one more
stream (``named_effects``) (an effect that reads another group's values, such as ``system_height_dropper_correlation``,
reads them as drawn for that section).
"""

from __future__ import annotations

import numpy as np

from catenary.measurement.campaign import section_model
from catenary.measurement.truth import Law, Line, SectionSpec
from catenary.physics.config import Catenary, SpanType
from catenary.physics.effects import EFFECTS, SpanParameters, draws_for
from catenary.physics.section import Section
from .laws import SectionLaws

__all__ = ["BASE_GROUPS", "GROUPS", "build_section", "draw_inputs", "draw_section", "groups", "replicate_seeds"]

BASE_GROUPS = ("dropper_lengths", "messenger_tension", "system_height", "steady_arm_heights")


#: Every group of random inputs: the base ones and the named effects' draws (one stream for all).
GROUPS = (*BASE_GROUPS, "named_effects")


def groups(laws: SectionLaws) -> tuple[str, ...]:
    """The groups of random inputs of a section (the same for every law, so that the jobs are
    known before the diagnosis has named anything; ``named_effects`` drives nothing without one)."""
    return GROUPS


def replicate_seeds(seed: int, replicate: int, laws: SectionLaws) -> dict[str, np.random.SeedSequence]:
    """The seeds of replicate ``replicate``: one stream per group, reproducible from ``seed``."""
    return {g: np.random.SeedSequence([int(seed), int(replicate), i]) for i, g in enumerate(groups(laws))}


def draw_inputs(laws: SectionLaws, span_type: SpanType, n_spans: int,
                seeds: dict[str, np.random.SeedSequence] | None) -> SpanParameters:
    """The drawn parameters of one section (``seeds`` None: every input at its mean, no effect)."""
    n_d = span_type.n_droppers
    n_masts = n_spans + 1
    if seeds is None:
        lengths = np.tile(laws.dropper_mean_m, (n_spans, 1))
        dh = np.full(n_masts, laws.system_height_mean_m)
        cw_height = np.full(n_masts, laws.cw_height.mean)
    else:
        rng = {g: np.random.default_rng(s) for g, s in seeds.items()}
        lengths = np.column_stack([Law("gamma", m, s).sample(rng["dropper_lengths"], n_spans)
                                   for m, s in zip(laws.dropper_mean_m, laws.dropper_sigma_m)]).reshape(n_spans, n_d)
        dh = Law("gamma", laws.system_height_mean_m, laws.system_height_sigma_m).sample(rng["system_height"], n_masts)
        cw_height = laws.cw_height.sample(rng["steady_arm_heights"], n_masts)
    left = np.arange(n_spans)
    p = SpanParameters(
        dropper_lengths_m=lengths, system_height_left_m=dh[:-1].copy(), system_height_right_m=dh[1:].copy(),
        system_height_mean_m=np.full(n_spans, laws.system_height_mean_m),
        messenger_tension_n=np.full(n_spans, laws.messenger_tension_mean_n),
        contact_tension_n=np.full(n_spans, span_type.contact_tension_n), section_index=np.zeros(n_spans, dtype=int),
        measuring_force_n=0.0, creep_offset_m=np.zeros(n_spans), cw_offset_m=np.zeros(n_spans), left_mast=left,
        mast_cw_height_offset_m=cw_height.copy(), cw_wear_fraction=np.zeros(n_spans))
    if seeds is None:
        return p
    # The per-span T_MW spread is the campaign's messenger_tension_variability, on its own stream.
    EFFECTS["messenger_tension_variability"].apply(
        p, rng["messenger_tension"].standard_normal(n_spans), std_n=laws.messenger_tension_sigma_n)
    for name, magnitudes in laws.effects:
        effect = EFFECTS[name]
        z = rng["named_effects"].standard_normal(draws_for(effect.draw, p)) if effect.draw else None
        effect.apply(p, z, **magnitudes)
    return p


def build_section(p: SpanParameters, span_type: SpanType, catenary: Catenary) -> Section:
    """The section of drawn parameters ``p`` (``mast_cw_height_offset_m`` holds the steady-arm
    heights themselves here), assembled as the campaign assembles its line's sections."""
    n_spans = p.n_spans
    n_masts = n_spans + 1
    left = np.arange(n_spans)
    dh = np.r_[p.system_height_left_m, p.system_height_right_m[-1]]
    x = span_type.length_m * np.arange(n_masts, dtype=float)
    mast_ids = np.array([f"R{j:03d}" for j in range(n_masts)])
    line = Line(masts={"mast_id": mast_ids, "section_id": np.full(n_masts, "R"), "chainage_m": x,
                       "cw_height_m": p.mast_cw_height_offset_m, "system_height_m": dh},
                spans={"span_id": np.array([f"{mast_ids[j]}-{mast_ids[j + 1]}" for j in left]),
                       "section_id": np.full(n_spans, "R"), "span_type": np.full(n_spans, span_type.name),
                       "left_mast": left},
                params=p, sections=[SectionSpec("R", span_type.name, n_spans)])
    section, _ = section_model(line, 0, catenary)
    return section


def draw_section(laws: SectionLaws, span_type: SpanType, catenary: Catenary, n_spans: int,
                 seeds: dict[str, np.random.SeedSequence]) -> tuple[Section, SpanParameters]:
    """The section of one replicate and its drawn parameters (module docstring)."""
    p = draw_inputs(laws, span_type, n_spans, seeds)
    return build_section(p, span_type, catenary), p

