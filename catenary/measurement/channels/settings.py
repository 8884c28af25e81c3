"""Settings of what cars and crews measure besides the height: config block ``measurements``.

``accuracy`` gives each quantity's standard uncertainty where its file does not (``std``, of one
span's, mast's or section's value; ``contact_force_n``: of a run's mean from the car's
contact-force channel, its calibration) and that of an error every value shares (``common_std``: a
channel's calibration, the new wire's diameter for a residual thickness). ``options`` is the menu
of measurements the diagnosis may recommend, each with the hours one unit of it costs (a car run
over every span, one span, section or mast, or once for the line).

The defaults and their sources are in docs/input_formats.md ("Measurements besides the height");
the block is checked against the config schema, the contract.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from catenary.plumbing.errors import ConfigError
from catenary.plumbing.schema import check
from .quantities import QUANTITIES

__all__ = ["Accuracy", "MeasurementOption", "MeasurementSettings", "UNITS"]

#: What one unit of an option is.
UNITS = ("run", "span", "section", "mast", "line")


@dataclass(frozen=True)
class Accuracy:
    """Standard uncertainties of a quantity [SI]: of each value, and of an error all share."""

    std: float
    common_std: float = 0.0


@dataclass(frozen=True)
class MeasurementOption:
    """One measurement the diagnosis may recommend.

    Attributes
    ----------
    name : str
    quantity : str
        What it measures (:data:`catenary.measurement.channels.quantities.QUANTITIES`).
    per : str
        Its unit (:data:`UNITS`): ``run`` — a car run measures every span; ``span``, ``section``,
        ``mast`` — one each; ``line`` — once.
    cost_h : float
        Hours of work of one unit.
    """

    name: str
    quantity: str
    per: str
    cost_h: float

    def __post_init__(self):
        place = QUANTITIES[self.quantity].place
        fits = {"span": ("run", "span"), "section": ("section",), "mast": ("mast",), "line": ("line",)}[place]
        if self.per not in fits:
            raise ConfigError(f"measurements.options {self.name!r}: {self.quantity} is measured per {place}; "
                              f"per must be one of {fits}, got {self.per!r}")


#: Defaults (docs/input_formats.md gives each figure's source or the assumption behind it).
DEFAULT_ACCURACY = {
    "cw_residual_thickness_m": Accuracy(3.0e-5, 9.0e-5),
    "messenger_tension_n": Accuracy(820.0),
    "contact_tension_n": Accuracy(640.0),
    "system_height_m": Accuracy(0.005),
    "measuring_force_n": Accuracy(0.5),
    "contact_force_n": Accuracy(1.0),
}
DEFAULT_OPTIONS = (
    MeasurementOption("wear_channel", "cw_residual_thickness_m", "run", 3.0),
    MeasurementOption("tension_in_spans", "messenger_tension_n", "span", 0.5),
    MeasurementOption("tension_at_anchors", "contact_tension_n", "section", 0.5),
    MeasurementOption("system_height_survey", "system_height_m", "mast", 0.15),
    MeasurementOption("force_calibration", "measuring_force_n", "line", 1.0),
)


@dataclass(frozen=True)
class MeasurementSettings:
    """The ``measurements`` block: ``accuracy`` (quantity → :class:`Accuracy`) and ``options``."""

    accuracy: Mapping[str, Accuracy] = None
    options: tuple[MeasurementOption, ...] = DEFAULT_OPTIONS

    def __post_init__(self):
        object.__setattr__(self, "accuracy", {**DEFAULT_ACCURACY, **(self.accuracy or {})})
        names = [o.name for o in self.options]
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise ConfigError(f"measurements.options: names must be unique, {repeated} repeated")

    @classmethod
    def from_mapping(cls, mapping: Mapping[str, Any] | None) -> "MeasurementSettings":
        """Settings from the config block (missing keys take the defaults), checked against the schema."""
        if mapping is None:
            return cls()
        check(mapping, "config", "measurements")
        accuracy = {k: Accuracy(float(v["std"]), float(v.get("common_std", 0.0)))
                    for k, v in (mapping.get("accuracy") or {}).items()}
        options = mapping.get("options")
        return cls(accuracy, DEFAULT_OPTIONS if options is None else tuple(
            MeasurementOption(o["name"], o["quantity"], o["per"], float(o["cost_h"])) for o in options))
