"""Physical data of the catenary: wires, droppers and span types, read from config.

The values live in ``config/catenary.yaml``; nothing physical is hard-coded here. Loading
checks physical consistency (positive masses and tensions, droppers strictly inside their
span and sorted) and raises :class:`~catenary.plumbing.errors.ConfigError` naming the offending key.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import yaml

from catenary.plumbing.errors import ConfigError
from catenary.plumbing.schema import check


@dataclass(frozen=True)
class Wire:
    """A pre-tensioned wire modelled as an Euler–Bernoulli beam.

    Attributes
    ----------
    mass_per_length_kg_m : float
        Linear mass [kg/m].
    bending_stiffness_n_m2 : float
        Bending stiffness EI [N·m²].
    diameter_m : float or None
        Nominal diameter of the unworn wire [m] (EN 50149 gives it for each grooved profile);
        with ``section_area_m2``, what turns a measured residual thickness into the fraction of
        the section lost by wear (:mod:`catenary.measurement.channels.wear`). None: not given.
    section_area_m2 : float or None
        Cross-section of the unworn wire [m²] (its nominal section, e.g. 150 mm²).
    """

    mass_per_length_kg_m: float
    bending_stiffness_n_m2: float
    diameter_m: float | None = None
    section_area_m2: float | None = None


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
    """Settings of the dynamic model.

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


def _span_type(name: str, raw: Mapping[str, Any], where: str) -> SpanType:
    length = float(raw["length_m"])
    positions = raw["dropper_positions_m"]
    x = np.asarray(positions, dtype=float)
    if np.any(np.diff(x) <= 0):
        raise ConfigError(f"{where}.dropper_positions_m: positions must be strictly increasing, got {positions}")
    if x[0] <= 0 or x[-1] >= length:
        raise ConfigError(
            f"{where}.dropper_positions_m: every dropper must lie strictly inside the span "
            f"(0, {length}) m, got {positions}")
    return SpanType(
        name=name, length_m=length, dropper_positions_m=x, presag_m=float(raw["presag_m"]),
        contact_tension_n=float(raw["contact_tension_n"]), messenger_tension_n=float(raw["messenger_tension_n"]),
        system_height_m=float(raw["system_height_m"]), cw_height_m=float(raw["cw_height_m"]),
    )


def catenary_from_dict(raw: Mapping[str, Any], where: str = "catenary") -> Catenary:
    """Build a :class:`Catenary` from a parsed YAML mapping, checking physical consistency.

    Every key and value is checked against the shipped catenary schema (:mod:`catenary.plumbing.schema`);
    this function adds what a schema cannot say: dropper positions strictly increasing and
    inside their span, damping frequencies increasing.

    Raises
    ------
    ConfigError
        Naming the key (dotted path from ``where``) and what was expected.
    """
    check(raw, "catenary", where=where)
    wires = raw["wires"]

    def wire(key: str) -> Wire:
        w = wires[key]
        diameter, area = w.get("diameter_m"), w.get("section_area_m2")
        if diameter is not None and area is not None and not area < np.pi * diameter ** 2 / 4:
            raise ConfigError(f"{where}.wires.{key}: section_area_m2 {area:g} m² must be smaller than the circle of "
                              f"diameter_m {diameter:g} m ({np.pi * diameter ** 2 / 4:g} m²): the grooves are not worn")
        return Wire(mass_per_length_kg_m=float(w["mass_per_length_kg_m"]),
                    bending_stiffness_n_m2=float(w["bending_stiffness_n_m2"]),
                    diameter_m=None if diameter is None else float(diameter),
                    section_area_m2=None if area is None else float(area))

    d = raw["droppers"]
    droppers = Droppers(
        mass_per_length_kg_m=float(d["mass_per_length_kg_m"]), axial_stiffness_n=float(d["axial_stiffness_n"]),
        clamp_mass_contact_kg=float(d["clamp_mass_contact_kg"]),
        clamp_mass_messenger_kg=float(d["clamp_mass_messenger_kg"]),
    )
    sa = raw["steady_arm"]
    steady_arm = SteadyArm(stiffness_n_m=None if sa["stiffness_n_m"] is None else float(sa["stiffness_n_m"]),
                           mass_kg=float(sa["mass_kg"]))
    span_types = {str(name): _span_type(str(name), spec, f"{where}.span_types.{name}")
                  for name, spec in raw["span_types"].items()}
    dyn = raw["dynamics"]
    freqs = dyn["damping_frequencies_hz"]
    if freqs[0] >= freqs[1]:
        raise ConfigError(f"{where}.dynamics.damping_frequencies_hz: expected two increasing positive frequencies "
                          f"[Hz], got {freqs!r}")
    dynamics = DynamicSettings(
        time_step_s=float(dyn["time_step_s"]), damping_ratio=float(dyn["damping_ratio"]),
        damping_frequencies_hz=(float(freqs[0]), float(freqs[1])),
        contact_stiffness_n_m=float(dyn["contact_stiffness_n_m"]),
    )
    return Catenary(
        contact=wire("contact"), messenger=wire("messenger"), droppers=droppers, steady_arm=steady_arm,
        span_types=span_types, gravity_m_s2=float(raw["gravity_m_s2"]),
        max_element_length_m=float(raw["mesh"]["max_element_length_m"]), dynamics=dynamics,
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
