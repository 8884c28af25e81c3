"""Contact-wire wear as a measuring car records it: residual thickness ↔ fraction of the section lost.

A grooved contact wire (EN 50149 profiles) is a circle of nominal diameter ``d`` with two grooves
near its top for the clamps; the pantograph strips wear a flat on its underside. Worn to depth
``w`` (the residual thickness is ``d − w``), the wire has lost the circular segment of height
``w``:

    A(w) = r² acos(1 − w/r) − (r − w) √(2 r w − w²),    r = d/2,

of its section ``S`` (the grooves are far above any wear within the 20–30 % limits), so the
fraction lost is ``ε = A(w) / S``. ``A`` grows as ``(4/3) √(2r) w^(3/2)`` for a shallow flat: the
first tenth of a millimetre takes little section, so a thickness channel resolves a spread of wear
fractions best on a worn wire.

The model's wear fraction is Gaussian about its mean (:func:`catenary.physics.effects.contact_wire_wear`)
and may fall below 0 for some samples; the thickness is then continued as an odd function of ε
(``w(−ε) = −w(ε)``, a thickness above the nominal), which keeps the map smooth and monotone for the
likelihood. Measured thicknesses above ``d`` read as negative fractions the same way.
"""

from __future__ import annotations

import numpy as np

from catenary.physics.config import Wire
from catenary.plumbing.errors import ConfigError

__all__ = ["residual_thickness_m", "segment_area_m2", "wear_depth_m", "wear_fraction"]


def _geometry(wire: Wire) -> tuple[float, float]:
    if wire.diameter_m is None or wire.section_area_m2 is None:
        raise ConfigError("catenary: wires.contact needs diameter_m and section_area_m2 to relate a residual "
                          "thickness to the fraction of the section lost by wear")
    return 0.5 * wire.diameter_m, wire.section_area_m2


def segment_area_m2(depth_m: np.ndarray, radius_m: float) -> np.ndarray:
    """Area of the circular segment of height ``depth_m`` cut from a circle of ``radius_m`` [m²]
    (odd in the depth; depths beyond the diameter are clipped to it)."""
    w = np.clip(np.abs(np.asarray(depth_m, dtype=float)), 0.0, 2.0 * radius_m)
    r = radius_m
    area = r * r * np.arccos(1.0 - w / r) - (r - w) * np.sqrt(np.maximum(2.0 * r * w - w * w, 0.0))
    return np.sign(depth_m) * area


def wear_fraction(thickness_m: np.ndarray, wire: Wire) -> np.ndarray:
    """Fraction of the section lost for a residual thickness [m] (module docstring)."""
    r, section = _geometry(wire)
    return segment_area_m2(2.0 * r - np.asarray(thickness_m, dtype=float), r) / section


def wear_depth_m(fraction: np.ndarray, wire: Wire) -> np.ndarray:
    """Depth of the worn flat [m] for a fraction of the section lost (the inverse of
    :func:`wear_fraction`'s map; odd in the fraction), by Newton's method on ``A(w) = ε S`` from
    the shallow-flat approximation, to 1e-12 of the diameter."""
    r, section = _geometry(wire)
    eps = np.asarray(fraction, dtype=float)
    target = np.minimum(np.abs(eps) * section, np.pi * r * r)
    w = np.minimum((3.0 * target / (4.0 * np.sqrt(2.0 * r))) ** (2.0 / 3.0), 2.0 * r)
    for _ in range(60):
        chord = 2.0 * np.sqrt(np.maximum(2.0 * r * w - w * w, 0.0))           # dA/dw
        step = np.where(chord > 0, (segment_area_m2(w, r) - target) / np.where(chord > 0, chord, 1.0), 0.0)
        w = np.clip(w - step, 0.0, 2.0 * r)
        if np.all(np.abs(step) <= 1e-12 * r):
            break
    return np.sign(eps) * w


def residual_thickness_m(fraction: np.ndarray, wire: Wire) -> np.ndarray:
    """Residual thickness [m] of a wire that lost ``fraction`` of its section by wear."""
    r, _ = _geometry(wire)
    return 2.0 * r - wear_depth_m(fraction, wire)
