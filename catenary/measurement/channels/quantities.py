"""What a measuring car or a crew can measure besides the height, and what each is in the model.

Each quantity is a function of the per-span parameters (:class:`catenary.physics.effects.SpanParameters`):
the same function gives the virtual campaign's true value (before its measurement error) and the
model's value for each sample of the identification's and the diagnosis' designs, so that the
physics that records a quantity and the model that reads it are one code.

``cw_residual_thickness_m`` (per span; the car's wear channel, or a crew's calliper)
    Residual thickness of the CW [m], the mean over the span: the diameter less the depth worn
    flat for the span's fraction of section lost (:mod:`.wear`).
``messenger_tension_n`` (per span; a crew with a tension meter in the span)
    The MW tension of the span [N], per-span deviations included.
``contact_tension_n`` (per section; a crew at the tensioning device)
    The CW tension of the section [N].
``system_height_m`` (per mast; a crew's survey)
    ΔH at the mast [m]. A model span carries its two masts: a mast's value is read as the
    left mast of the span it starts (the right mast of a section's last span for its last mast).
``measuring_force_n`` (the line; the car's force calibrated at standstill, or the mean of its
    contact-force channel over a run)
    The static force the measuring pantograph really applies [N].

Where (:data:`PLACES`): ``span``, ``section``, ``mast`` or ``line``. A span, section or mast
quantity is read jointly with the W of the span it belongs to (its law and W's are one Gaussian);
a line quantity is one observation of the whole line.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from catenary.physics.config import Catenary
from catenary.physics.effects import SpanParameters
from .wear import residual_thickness_m

__all__ = ["PLACES", "QUANTITIES", "Quantity", "model_columns", "observe"]

PLACES = ("span", "section", "mast", "line")


@dataclass(frozen=True)
class Quantity:
    """One measurable quantity.

    Attributes
    ----------
    name : str
        Its name, with its SI unit (a recording column, a survey ``quantity``).
    place : str
        One of :data:`PLACES`.
    unit : str
        SI unit, for reports.
    label : str
        What it is, in words.
    observe : callable
        ``observe(p, catenary) -> ndarray``: its value for each span of ``p`` (for a mast
        quantity, the left and the right masts' values are columns ``_left`` and ``_right``).
    """

    name: str
    place: str
    unit: str
    label: str
    observe: Callable[[SpanParameters, Catenary], np.ndarray]


def _thickness(p: SpanParameters, catenary: Catenary) -> np.ndarray:
    return residual_thickness_m(p.cw_wear_fraction, catenary.contact)


def _system_height(p: SpanParameters, catenary: Catenary) -> np.ndarray:
    return np.column_stack([p.system_height_left_m, p.system_height_right_m])


QUANTITIES: dict[str, Quantity] = {q.name: q for q in (
    Quantity("cw_residual_thickness_m", "span", "m", "CW residual thickness", _thickness),
    Quantity("messenger_tension_n", "span", "N", "MW tension in the span", lambda p, c: p.messenger_tension_n),
    Quantity("contact_tension_n", "section", "N", "CW tension at the tensioning device",
             lambda p, c: p.contact_tension_n),
    Quantity("system_height_m", "mast", "m", "system height ΔH at the mast", _system_height),
    Quantity("measuring_force_n", "line", "N", "static force of the measuring pantograph",
             lambda p, c: np.full(p.n_spans, p.measuring_force_n)),
)}


def model_columns(names) -> list[str]:
    """The model's columns of the quantities ``names``: a mast quantity's left and right mast."""
    out = []
    for name in names:
        q = QUANTITIES[name]
        out += [f"{name}_left", f"{name}_right"] if q.place == "mast" else [name]
    return out


def observe(p: SpanParameters, catenary: Catenary, names) -> np.ndarray:
    """Values of the quantities ``names`` for each span of ``p``, shape (n_spans, columns) in
    the order of :func:`model_columns` [SI]."""
    if not names:
        return np.zeros((p.n_spans, 0))
    return np.column_stack([np.asarray(QUANTITIES[n].observe(p, catenary), dtype=float).reshape(p.n_spans, -1)
                            for n in names])
