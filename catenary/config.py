"""Physical data of the catenary: wires, droppers and span types, read from config.

The values live in ``config/catenary.yaml``; nothing physical is hard-coded here. Loading
checks physical consistency (positive masses and tensions, droppers strictly inside their
span and sorted) and raises :class:`~catenary.errors.ConfigError` naming the offending key.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import yaml

from .errors import ConfigError


@dataclass(frozen=True)
class Wire:
    """A pre-tensioned wire modelled as an Euler–Bernoulli beam.

    Attributes
    ----------
    mass_per_length_kg_m : float
        Linear mass [kg/m].
    bending_stiffness_n_m2 : float
        Bending stiffness EI [N·m²].
    """

    mass_per_length_kg_m: float
    bending_stiffness_n_m2: float


@dataclass(frozen=True)
class Droppers:
    """Dropper wires and their clamps.

    Attributes
    ----------
    mass_per_length_kg_m : float
        Linear mass of the dropper wire [kg/m].
    axial_stiffness_n : float
        EA [N]; a dropper of unstretched length L has stiffness EA/L [N/m] in tension and
        none in compression.
    clamp_mass_contact_kg, clamp_mass_messenger_kg : float
        Clamp masses on the contact wire and on the messenger wire [kg].
    """

    mass_per_length_kg_m: float
    axial_stiffness_n: float
    clamp_mass_contact_kg: float
    clamp_mass_messenger_kg: float


@dataclass(frozen=True)
class SteadyArm:
    """Steady arm holding the contact wire at a mast.

    Attributes
    ----------
    stiffness_n_m : float or None
        Vertical stiffness [N/m] about the static position (0: a hinged arm that only
        supplies the static holding force); ``None`` holds the contact wire fixed. Static
        and identification models always hold it fixed.
    mass_kg : float
        Mass moving with the contact wire at the support [kg] (dynamics only).
    """

    stiffness_n_m: float | None
    mass_kg: float


@dataclass(frozen=True)
class DynamicSettings:
    """Settings of the dynamic model (SPEC §4.4).

    Attributes
    ----------
    time_step_s : float
        Fixed time step of the Newmark integration [s].
    damping_ratio : float
        Rayleigh damping ratio reached at both ``damping_frequencies_hz`` [-].
    damping_frequencies_hz : tuple of float
        The two anchor frequencies of the Rayleigh damping [Hz].
    contact_stiffness_n_m : float
        Penalty stiffness of the pantograph–CW contact [N/m].
    """

    time_step_s: float
    damping_ratio: float
    damping_frequencies_hz: tuple[float, float]
    contact_stiffness_n_m: float


@dataclass(frozen=True)
class SpanType:
    """Design of a span type (N2, N3...).

    Attributes
    ----------
    name : str
        Span type name.
    length_m : float
        Span length between masts [m].
    dropper_positions_m : numpy.ndarray
        Dropper abscissae from the left mast [m], strictly increasing, inside the span.
    presag_m : float
        Designed mid-span presag of the contact wire [m] (positive = downwards), parabolic
        between the first and the last dropper.
    contact_tension_n, messenger_tension_n : float
        Design tensions T_CW and T_MW [N].
    system_height_m : float
        Design system height ΔH, messenger above contact wire at the masts [m].
    cw_height_m : float
        Design contact-wire height at the steady arms [m].
    """

    name: str
    length_m: float
    dropper_positions_m: np.ndarray
    presag_m: float
    contact_tension_n: float
    messenger_tension_n: float
    system_height_m: float
    cw_height_m: float

    @property
    def n_droppers(self) -> int:
        return int(self.dropper_positions_m.size)


@dataclass(frozen=True)
class Catenary:
    """Everything physical the models need besides the geometry of one section.

    Attributes
    ----------
    contact, messenger : Wire
        Contact wire (CW) and messenger wire (MW).
    droppers : Droppers
    steady_arm : SteadyArm
    span_types : dict of str to SpanType
    gravity_m_s2 : float
        Gravitational acceleration [m/s²].
    max_element_length_m : float
        Largest finite-element length [m].
    dynamics : DynamicSettings
    """

    contact: Wire
    messenger: Wire
    droppers: Droppers
    steady_arm: SteadyArm
    span_types: dict[str, SpanType]
    gravity_m_s2: float
    max_element_length_m: float
    dynamics: DynamicSettings

    def span_type(self, name: str) -> SpanType:
        """Return the span type ``name`` or raise a ConfigError listing the known ones."""
        try:
            return self.span_types[name]
        except KeyError:
            known = ", ".join(sorted(self.span_types))
            raise ConfigError(f"unknown span type {name!r}; config defines: {known}") from None


def _get(mapping: Mapping[str, Any], key: str, where: str) -> Any:
    if not isinstance(mapping, Mapping):
        raise ConfigError(f"{where}: expected a mapping, got {type(mapping).__name__}")
    if key not in mapping:
        raise ConfigError(f"{where}.{key}: missing key")
    return mapping[key]


def _number(mapping: Mapping[str, Any], key: str, where: str, *, positive: bool = True,
            allow_zero: bool = False) -> float:
    value = _get(mapping, key, where)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(f"{where}.{key}: expected a number, got {value!r}")
    value = float(value)
    if not np.isfinite(value):
        raise ConfigError(f"{where}.{key}: expected a finite number, got {value!r}")
    if positive and (value < 0 or (value == 0 and not allow_zero)):
        bound = "≥ 0" if allow_zero else "> 0"
        raise ConfigError(f"{where}.{key}: expected a value {bound}, got {value!r}")
    return value


def _span_type(name: str, raw: Mapping[str, Any], where: str) -> SpanType:
    length = _number(raw, "length_m", where)
    positions = _get(raw, "dropper_positions_m", where)
    if not isinstance(positions, (list, tuple)) or len(positions) < 1:
        raise ConfigError(f"{where}.dropper_positions_m: expected a non-empty list of [m]")
    try:
        x = np.asarray(positions, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(f"{where}.dropper_positions_m: expected numbers, got {positions!r}") from None
    if np.any(np.diff(x) <= 0):
        raise ConfigError(f"{where}.dropper_positions_m: positions must be strictly increasing, got {positions}")
    if x[0] <= 0 or x[-1] >= length:
        raise ConfigError(
            f"{where}.dropper_positions_m: every dropper must lie strictly inside the span "
            f"(0, {length}) m, got {positions}")
    return SpanType(
        name=name,
        length_m=length,
        dropper_positions_m=x,
        presag_m=_number(raw, "presag_m", where, allow_zero=True),
        contact_tension_n=_number(raw, "contact_tension_n", where),
        messenger_tension_n=_number(raw, "messenger_tension_n", where),
        system_height_m=_number(raw, "system_height_m", where),
        cw_height_m=_number(raw, "cw_height_m", where),
    )


def catenary_from_dict(raw: Mapping[str, Any], where: str = "catenary") -> Catenary:
    """Build a :class:`Catenary` from a parsed YAML mapping, checking physical consistency.

    Raises
    ------
    ConfigError
        Naming the key (dotted path from ``where``) and what was expected.
    """
    wires = _get(raw, "wires", where)
    wires_where = f"{where}.wires"

    def wire(key: str) -> Wire:
        w = _get(wires, key, wires_where)
        return Wire(
            mass_per_length_kg_m=_number(w, "mass_per_length_kg_m", f"{wires_where}.{key}"),
            bending_stiffness_n_m2=_number(w, "bending_stiffness_n_m2", f"{wires_where}.{key}", allow_zero=True),
        )

    d = _get(raw, "droppers", where)
    dw = f"{where}.droppers"
    droppers = Droppers(
        mass_per_length_kg_m=_number(d, "mass_per_length_kg_m", dw, allow_zero=True),
        axial_stiffness_n=_number(d, "axial_stiffness_n", dw),
        clamp_mass_contact_kg=_number(d, "clamp_mass_contact_kg", dw, allow_zero=True),
        clamp_mass_messenger_kg=_number(d, "clamp_mass_messenger_kg", dw, allow_zero=True),
    )
    sa = _get(raw, "steady_arm", where)
    sw = f"{where}.steady_arm"
    stiffness = _get(sa, "stiffness_n_m", sw)
    steady_arm = SteadyArm(
        stiffness_n_m=None if stiffness is None else _number(sa, "stiffness_n_m", sw, allow_zero=True),
        mass_kg=_number(sa, "mass_kg", sw, allow_zero=True),
    )
    types_raw = _get(raw, "span_types", where)
    if not isinstance(types_raw, Mapping) or not types_raw:
        raise ConfigError(f"{where}.span_types: expected a non-empty mapping of span types")
    span_types = {str(name): _span_type(str(name), spec, f"{where}.span_types.{name}")
                  for name, spec in types_raw.items()}
    mesh = _get(raw, "mesh", where)
    dyn = _get(raw, "dynamics", where)
    dyw = f"{where}.dynamics"
    freqs = _get(dyn, "damping_frequencies_hz", dyw)
    if (not isinstance(freqs, (list, tuple)) or len(freqs) != 2
            or not all(isinstance(f, (int, float)) and f > 0 for f in freqs) or freqs[0] >= freqs[1]):
        raise ConfigError(f"{dyw}.damping_frequencies_hz: expected two increasing positive frequencies [Hz], got {freqs!r}")
    dynamics = DynamicSettings(
        time_step_s=_number(dyn, "time_step_s", dyw),
        damping_ratio=_number(dyn, "damping_ratio", dyw, allow_zero=True),
        damping_frequencies_hz=(float(freqs[0]), float(freqs[1])),
        contact_stiffness_n_m=_number(dyn, "contact_stiffness_n_m", dyw),
    )
    return Catenary(
        contact=wire("contact"),
        messenger=wire("messenger"),
        droppers=droppers,
        steady_arm=steady_arm,
        span_types=span_types,
        gravity_m_s2=_number(raw, "gravity_m_s2", where),
        max_element_length_m=_number(mesh, "max_element_length_m", f"{where}.mesh"),
        dynamics=dynamics,
    )


def load_catenary(path: str | Path) -> Catenary:
    """Read and check ``path`` (YAML), e.g. ``config/catenary.yaml``."""
    path = Path(path)
    try:
        raw = yaml.safe_load(path.read_text())
    except FileNotFoundError:
        raise ConfigError(f"{path}: catenary file not found") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML ({exc})") from None
    if raw is None:
        raise ConfigError(f"{path}: empty file, expected the catenary mapping")
    return catenary_from_dict(raw, where=str(path))
