"""The inputs of the correction's model that the budget questions, and how each is perturbed.

A source names one input the correction takes on trust and its standard uncertainty, either
absolute (``std``, in the input's unit) or relative (``relative_std``, a fraction of its value):

``force_n``
    The measuring pantograph's static force [N] (the recording's ``force_n`` or the correction's
    declared force): an offset of the regulation or of its calibration.
``speed``
    The measuring speed, relative (the recorded or declared speed and the speed profile scaled).
``pantograph.<array>.<i>``
    Entry ``i`` (0: the head) of the measuring pantograph's ``masses_kg``, ``stiffnesses_n_m``
    or ``dampings_n_s_m``.
``catenary.damping_ratio``
    The catenary's Rayleigh damping ratio (``dynamics.damping_ratio`` of the catenary file).

The settings are checked against the config schema (``model_error`` block), the contract.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Mapping


from catenary.physics.config import Catenary
from catenary.physics.pantograph import Pantograph
from catenary.plumbing.errors import ConfigError
from catenary.plumbing.schema import check

__all__ = ["ModelErrorSettings", "Source", "perturbed"]


@dataclass(frozen=True)
class Source:
    """One questioned input of the correction's model.

    Attributes
    ----------
    name : str
        How the budget's tables name it (``measuring_force``, ``head_mass``…).
    input : str
        Which input (module docstring).
    std : float
        Standard uncertainty in the input's unit (0 when relative).
    relative_std : float
        Standard uncertainty as a fraction of the input's value (0 when absolute).
    """

    name: str
    input: str
    std: float = 0.0
    relative_std: float = 0.0


@dataclass(frozen=True)
class ModelErrorSettings:
    """Config block ``model_error``: ``enabled``, the ``sources`` and ``sections_per_span_type``
    (sections of each span type whose runs are measured, the first by section id; 0: all)."""

    enabled: bool = False
    sources: tuple[Source, ...] = ()
    sections_per_span_type: int = 0

    def measured_sections(self, spans) -> set[str]:
        """Ids of the sections whose runs the budget measures, from the projected spans of every
        type (``section_id``, ``span_type``): for each span type, the first
        ``sections_per_span_type`` sections holding it (every section for 0). A source of the car's
        model is shared by every span, so its shift measured on one section of 20 spans stands for
        the others (their own rough part, ≈ 0.03 mm, averages out in the identification)."""
        if not self.enabled:
            return set()
        chosen = set()
        for _, part in spans.groupby("span_type", sort=True):
            ids = sorted(set(part["section_id"].astype(str)))
            chosen.update(ids if self.sections_per_span_type == 0 else ids[:self.sections_per_span_type])
        return chosen

    def force_bound_n(self, declared_force_n: float) -> float | None:
        """How far the budget allows the measuring force off the declared one at 95 %: two standard
        uncertainties of its ``force_n`` source [N]; None without a budget or such a source."""
        force = [src for src in self.sources if src.input == "force_n"]
        if not (self.enabled and force):
            return None
        return 2.0 * (force[0].std or force[0].relative_std * declared_force_n)

    @classmethod
    def from_mapping(cls, mapping: Mapping[str, Any] | None) -> "ModelErrorSettings":
        """Settings from the config block, checked against the schema (a missing block: disabled).

        Raises
        ------
        ConfigError
            A block the schema refuses, or two sources of one name. (A pantograph entry beyond
            the pantograph's is refused by :func:`perturbed`, which knows the pantograph.)
        """
        if mapping is None:
            return cls()
        check(mapping, "config", "model_error")
        sources = tuple(Source(s["name"], s["input"], float(s.get("std", 0.0)), float(s.get("relative_std", 0.0)))
                        for s in mapping.get("sources", []))
        names = [s.name for s in sources]
        duplicated = sorted({n for n in names if names.count(n) > 1})
        if duplicated:
            raise ConfigError(f"config: model_error.sources: names must be unique, {duplicated} repeated")
        return cls(bool(mapping.get("enabled", True)), sources, int(mapping.get("sections_per_span_type", 0)))


def perturbed(source: Source, k: float, pantograph: Pantograph, catenary: Catenary, speed_m_s: float
              ) -> tuple[Pantograph, Catenary, float]:
    """The correction's inputs with ``source`` moved by ``k`` standard uncertainties.

    Returns
    -------
    pantograph, catenary, speed_m_s
        Copies (the inputs are not modified); the speed [m/s] is the run's median speed, which
        the caller scales its speed profile with.

    Raises
    ------
    ConfigError
        A pantograph entry the pantograph does not have, or a perturbed value that is not
        positive (a mass, a stiffness of an internal link, the force, the speed).
    """
    where = f"config: model_error source {source.name!r} ({source.input})"

    def moved(value: float) -> float:
        return value + k * (source.std if source.std else source.relative_std * value)

    if source.input == "force_n":
        force = moved(pantograph.static_force_n)
        if force <= 0:
            raise ConfigError(f"{where}: the perturbed force {force:g} N is not positive")
        return pantograph.with_static_force(force), catenary, speed_m_s
    if source.input == "speed":
        speed = moved(speed_m_s)
        if speed <= 0:
            raise ConfigError(f"{where}: the perturbed speed {speed:g} m/s is not positive")
        return pantograph, catenary, speed
    if source.input == "catenary.damping_ratio":
        ratio = moved(catenary.dynamics.damping_ratio)
        if ratio < 0:
            raise ConfigError(f"{where}: the perturbed damping ratio {ratio:g} is negative")
        return pantograph, replace(catenary, dynamics=replace(catenary.dynamics, damping_ratio=ratio)), speed_m_s
    _, array, index = source.input.split(".")       # the schema's pattern: a pantograph array and an index
    values = getattr(pantograph, array).astype(float).copy()
    i = int(index)
    if i >= values.size:
        raise ConfigError(f"{where}: pantograph {pantograph.name!r} has {values.size} {array}")
    values[i] = moved(values[i])
    if values[i] < 0 or (values[i] == 0 and array == "masses_kg"):
        raise ConfigError(f"{where}: the perturbed value {values[i]:g} is not physical")
    return replace(pantograph, **{array: values}), catenary, speed_m_s
