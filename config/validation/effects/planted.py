"""Effects the validation campaigns plant that no catalogue lists.

This is the validation's own code: the campaign's truth files list it (``effects_modules``), and
nothing that inverts the recording — the correction, the identification, the diagnosis — ever
imports it. A user who writes an effect of the same physics for the diagnosis writes it anew
(docs/diagnosis.md, "An effect of your own").
"""

import numpy as np
from scipy import special

from catenary.physics.effects import Effect


def in_span_equipment(p, z, *, fraction: float, min_kg: float, max_kg: float, clearance_m: float = 1.0) -> None:
    """A ``fraction`` of the spans carry one piece of equipment clamped on the CW between two
    droppers (a current connector, a splice, a section insulator's fitting): a concentrated mass
    uniform in ``min_kg``–``max_kg``, at a position uniform over the span's length that lies at
    least ``clearance_m`` from its masts and droppers (it is not clamped on a dropper's clamp).
    Three standard normal scores per span: whether, how heavy, where."""
    u = special.ndtr(np.asarray(z, dtype=float).reshape(p.n_spans, 3))
    carried = u[:, 0] < fraction
    mass = np.where(carried, min_kg + (max_kg - min_kg) * u[:, 1], 0.0)
    x = np.zeros(p.n_spans)
    for k in range(p.n_spans):
        knots = np.r_[0.0, p.dropper_x_m[k][np.isfinite(p.dropper_x_m[k])], p.span_length_m[k]]
        lo, hi = knots[:-1] + clearance_m, knots[1:] - clearance_m
        room = np.clip(hi - lo, 0.0, None)
        at = u[k, 2] * room.sum()
        bay = min(int(np.searchsorted(np.cumsum(room), at, side="right")), room.size - 1)
        x[k] = lo[bay] + at - np.r_[0.0, np.cumsum(room)][bay]
    p.add_cw_point_masses(x, mass)


def section_tension_offset(p, z, *, section: float, relative: float) -> None:
    """One section's tensioning device misadjusted: every span of section ``section`` (its index
    in the line) has its MW tension scaled by ``1 + relative`` (its weights set wrong)."""
    inside = p.section_index == int(section)
    p.messenger_tension_n = np.where(inside, p.messenger_tension_n * (1.0 + relative), p.messenger_tension_n)


EFFECTS = [
    Effect("in_span_equipment", in_span_equipment, "span", n_draws=3),
    Effect("section_tension_offset", section_tension_offset, None),
]
