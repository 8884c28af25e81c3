"""Settings of the identification rule, read from the ``identification`` block of the config.

Every key is documented in ``config/README.md``; :meth:`IdentificationSettings.from_mapping`
refuses unknown keys and bad values with a :class:`~catenary.errors.ConfigError` naming the key.

Input names
-----------
The random inputs are ``dropper_1_length_m`` … ``dropper_n_length_m``, ``messenger_tension_n``
and ``system_height_m`` (design order, :mod:`.design`). In ``random_inputs`` and ``free_means``
the group name ``dropper_lengths_m`` stands for every dropper of the span type.

* An input listed in ``random_inputs`` is random: a Gamma law whose σ is identified.
* An input not listed is deterministic: its σ is held at 1e-9 of its mean (the Gamma law needs
  σ > 0; such a law moves W by less than a nanometre) and not identified.
* A mean listed in ``free_means`` is identified; every other mean stays at its start value
  (the paper fixes the dropper means at the nominal table).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from ..config import Catenary, SpanType
from ..dropper_table import nominal_dropper_lengths
from ..errors import ConfigError
from .design import (DESIGN_METHODS, MESSENGER_TENSION, SYSTEM_HEIGHT, SYSTEM_HEIGHT_MODES, RandomInput,
                     dropper_names)
from .fit import METHODS
from .likelihood import BANDWIDTH_RULES, ESTIMATORS

__all__ = ["DETERMINISTIC_CV", "DROPPER_GROUP", "IdentificationSettings"]

#: Group name standing for every dropper length in ``random_inputs`` and ``free_means``.
DROPPER_GROUP = "dropper_lengths_m"
#: σ/μ given to a deterministic (non-random) input.
DETERMINISTIC_CV = 1e-9


def _number(value: Any) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool) \
        and bool(np.isfinite(value))


def _positive(where: str, value: Any) -> float:
    if not (_number(value) and value > 0):
        raise ConfigError(f"{where}: expected a positive number, got {value!r}")
    return float(value)


def _integer(where: str, value: Any, low: int) -> int:
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise ConfigError(f"{where}: expected an integer ≥ {low}, got {value!r}")
    return int(value)


def _choice(where: str, value: Any, options: tuple[str, ...]) -> str:
    if value not in options:
        raise ConfigError(f"{where}: expected one of {', '.join(options)}, got {value!r}")
    return str(value)


def _known_keys(where: str, mapping: Mapping, known: set[str]) -> dict:
    if mapping is None:
        return {}
    if not isinstance(mapping, Mapping):
        raise ConfigError(f"{where}: expected a mapping, got {mapping!r}")
    unknown = sorted(set(mapping) - known)
    if unknown:
        raise ConfigError(f"{where}: unknown key(s) {', '.join(map(str, unknown))}; known: {', '.join(sorted(known))}")
    return dict(mapping)


@dataclass(frozen=True)
class IdentificationSettings:
    """What the identification rule does for each span type (config block ``identification``).

    Attributes
    ----------
    random_inputs : tuple of str
        Inputs with a random law whose σ is identified (names or ``dropper_lengths_m``).
    free_means : tuple of str
        Inputs whose mean is identified; the other means stay at their start value.
    dropper_mean_m : str or tuple of float
        Start means of the dropper lengths: ``"nominal"`` (the type's dropper table) or n values [m].
    dropper_sigma_m : float or tuple of float
        Start σ of the dropper lengths [m], one value or n values.
    messenger_tension_mean_n : str or float
        Start mean of T_MW: ``"design"`` (the type's design tension) or a value [N].
    messenger_tension_sigma_n : float or None
        Start σ of T_MW [N]; ``None``: 3 % of the start mean.
    system_height_mean_m : str or float
        Start mean of ΔH: ``"design"`` or a value [m].
    system_height_sigma_m : float
        Start σ of ΔH [m].
    system_height_mode : {"shared", "independent"}
        How ΔH_left and ΔH_right follow the ΔH law (:mod:`.design`).
    n_samples : int
        Design size N of J.
    design : {"sobol", "lhs"}
    estimator : {"gaussian", "kernel"}
    bandwidth : {"scott", "silverman"}
        Kernel bandwidth rule (kernel estimator and the estimators figure).
    seed : int
        Seed of the identification design; the other draws use ``seed + 1`` (band),
        ``seed + 2`` (estimators figure) and ``seed + 3`` (normality samples).
    method : {"nelder-mead", "bobyqa"}
    max_evaluations : int
    initial_step : float
    xtol, ftol : float or None
        Optimiser tolerances (``None``: the optimiser's default, see :func:`.fit.identify`).
    hessian_step : float
        Finite-difference step of the observed information, in the scaled coordinates θ.
    estimators_n_samples : tuple of int
        Sample sizes of the estimators figure (paper Fig. 7).
    band_level : float
        Probability content of the band (0.98: the 1 %–99 % quantiles, paper Fig. 10).
    band_n_samples : int
        Model samples drawn for the band.
    band_n_points : int
        Points along the span at which the band is computed (the dropper abscissae are added).
    normality_alpha : float
        Level of the Henze–Zirkler decisions.
    normality_n_samples : int
        Size of the i.i.d. model samples tested for normality at s0 and s_opt (the test costs
        O(n²); see :func:`.report.normality_report` for why not the design itself).
    """

    random_inputs: tuple[str, ...] = (DROPPER_GROUP, MESSENGER_TENSION, SYSTEM_HEIGHT)
    free_means: tuple[str, ...] = (MESSENGER_TENSION, SYSTEM_HEIGHT)
    dropper_mean_m: str | tuple[float, ...] = "nominal"
    dropper_sigma_m: float | tuple[float, ...] = 0.005
    messenger_tension_mean_n: str | float = "design"
    messenger_tension_sigma_n: float | None = None
    system_height_mean_m: str | float = "design"
    system_height_sigma_m: float = 0.005
    system_height_mode: str = "independent"
    n_samples: int = 10_000
    design: str = "sobol"
    estimator: str = "gaussian"
    bandwidth: str = "scott"
    seed: int = 1
    method: str = "nelder-mead"
    max_evaluations: int = 6000
    initial_step: float = 0.5
    xtol: float | None = None
    ftol: float | None = None
    hessian_step: float = 0.01
    estimators_n_samples: tuple[int, ...] = (1_000, 10_000, 100_000)
    band_level: float = 0.98
    band_n_samples: int = 4000
    band_n_points: int = 235
    normality_alpha: float = 0.05
    normality_n_samples: int = 10_000

    @classmethod
    def from_mapping(cls, mapping: Mapping[str, Any] | None, where: str = "identification") -> "IdentificationSettings":
        """Settings from the config block (missing keys take their defaults).

        Raises
        ------
        ConfigError
            On an unknown key or a bad value; the message names the key.
        """
        top = _known_keys(where, mapping, {"random_inputs", "free_means", "start", "system_height_mode",
                                           "n_samples", "design", "estimator", "bandwidth", "seed",
                                           "optimiser", "estimators_n_samples", "band", "normality"})
        kw: dict[str, Any] = {}
        for key in ("random_inputs", "free_means"):
            if key in top:
                value = top[key]
                if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
                    raise ConfigError(f"{where}.{key}: expected a list of input names, got {value!r}")
                kw[key] = tuple(value)
        start = _known_keys(f"{where}.start", top.get("start"),
                            {"dropper_length_m", MESSENGER_TENSION, SYSTEM_HEIGHT})
        for key, mean_kw, sigma_kw in (("dropper_length_m", "dropper_mean_m", "dropper_sigma_m"),
                                       (MESSENGER_TENSION, "messenger_tension_mean_n", "messenger_tension_sigma_n"),
                                       (SYSTEM_HEIGHT, "system_height_mean_m", "system_height_sigma_m")):
            law = _known_keys(f"{where}.start.{key}", start.get(key), {"mean", "sigma"})
            for sub, name in (("mean", mean_kw), ("sigma", sigma_kw)):
                if sub in law:
                    value = law[sub]
                    kw[name] = tuple(value) if isinstance(value, list) else value
        if "system_height_mode" in top:
            kw["system_height_mode"] = top["system_height_mode"]
        for key in ("n_samples", "design", "estimator", "bandwidth", "seed"):
            if key in top:
                kw[key] = top[key]
        optimiser = _known_keys(f"{where}.optimiser", top.get("optimiser"),
                                {"method", "max_evaluations", "initial_step", "xtol", "ftol", "hessian_step"})
        kw.update(optimiser)
        if "estimators_n_samples" in top:
            value = top["estimators_n_samples"]
            if not isinstance(value, (list, tuple)):
                raise ConfigError(f"{where}.estimators_n_samples: expected a list of sample sizes, got {value!r}")
            kw["estimators_n_samples"] = tuple(value)
        band = _known_keys(f"{where}.band", top.get("band"), {"level", "n_samples", "n_points"})
        kw.update({f"band_{k}": v for k, v in band.items()})
        normality = _known_keys(f"{where}.normality", top.get("normality"), {"alpha", "n_samples"})
        kw.update({f"normality_{k}": v for k, v in normality.items()})
        return cls(**kw)._checked(where)

    def _checked(self, where: str) -> "IdentificationSettings":
        """Validate every value (raises ConfigError naming the key); returns ``self``."""
        names = {DROPPER_GROUP, MESSENGER_TENSION, SYSTEM_HEIGHT}
        for key in ("random_inputs", "free_means"):
            for name in getattr(self, key):
                if name not in names and not _is_dropper_name(name):
                    raise ConfigError(f"{where}.{key}: unknown input {name!r}; expected {DROPPER_GROUP}, "
                                      f"dropper_<i>_length_m, {MESSENGER_TENSION} or {SYSTEM_HEIGHT}")
        if not self.random_inputs:
            raise ConfigError(f"{where}.random_inputs: expected at least one random input")
        if isinstance(self.dropper_mean_m, str):
            if self.dropper_mean_m != "nominal":
                raise ConfigError(f"{where}.start.dropper_length_m.mean: expected 'nominal' or a list of "
                                  f"lengths [m], got {self.dropper_mean_m!r}")
        else:
            for v in self.dropper_mean_m:
                _positive(f"{where}.start.dropper_length_m.mean", v)
        for v in (self.dropper_sigma_m if isinstance(self.dropper_sigma_m, tuple) else (self.dropper_sigma_m,)):
            _positive(f"{where}.start.dropper_length_m.sigma", v)
        for key, value in ((MESSENGER_TENSION, self.messenger_tension_mean_n), (SYSTEM_HEIGHT, self.system_height_mean_m)):
            if value != "design":
                _positive(f"{where}.start.{key}.mean ('design' or a value)", value)
        if self.messenger_tension_sigma_n is not None:
            _positive(f"{where}.start.{MESSENGER_TENSION}.sigma", self.messenger_tension_sigma_n)
        _positive(f"{where}.start.{SYSTEM_HEIGHT}.sigma", self.system_height_sigma_m)
        _choice(f"{where}.system_height_mode", self.system_height_mode, SYSTEM_HEIGHT_MODES)
        _integer(f"{where}.n_samples", self.n_samples, 16)
        _choice(f"{where}.design", self.design, DESIGN_METHODS)
        _choice(f"{where}.estimator", self.estimator, ESTIMATORS)
        _choice(f"{where}.bandwidth", self.bandwidth, BANDWIDTH_RULES)
        _integer(f"{where}.seed", self.seed, 0)
        _choice(f"{where}.optimiser.method", self.method, METHODS)
        _integer(f"{where}.optimiser.max_evaluations", self.max_evaluations, 1)
        _positive(f"{where}.optimiser.initial_step", self.initial_step)
        for key in ("xtol", "ftol"):
            if getattr(self, key) is not None:
                _positive(f"{where}.optimiser.{key}", getattr(self, key))
        _positive(f"{where}.optimiser.hessian_step", self.hessian_step)
        if not self.estimators_n_samples:
            raise ConfigError(f"{where}.estimators_n_samples: expected at least one sample size")
        for n in self.estimators_n_samples:
            _integer(f"{where}.estimators_n_samples", n, 16)
        if not (_number(self.band_level) and 0 < self.band_level < 1):
            raise ConfigError(f"{where}.band.level: expected a probability in (0, 1), got {self.band_level!r}")
        _integer(f"{where}.band.n_samples", self.band_n_samples, 100)
        _integer(f"{where}.band.n_points", self.band_n_points, 11)
        if not (_number(self.normality_alpha) and 0 < self.normality_alpha < 1):
            raise ConfigError(f"{where}.normality.alpha: expected a level in (0, 1), got {self.normality_alpha!r}")
        _integer(f"{where}.normality.n_samples", self.normality_n_samples, 16)
        # Integers given as 1e4 in YAML arrive as floats: store them as int.
        for key, values in (("n_samples", self.n_samples), ("max_evaluations", self.max_evaluations),
                            ("band_n_samples", self.band_n_samples), ("band_n_points", self.band_n_points),
                            ("normality_n_samples", self.normality_n_samples), ("seed", self.seed)):
            object.__setattr__(self, key, int(values))
        object.__setattr__(self, "estimators_n_samples", tuple(int(n) for n in self.estimators_n_samples))
        return self

    def as_dict(self) -> dict[str, Any]:
        """Flat view of the settings (for logs and the report)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def _expand(self, names: tuple[str, ...], n_droppers: int, where: str) -> tuple[str, ...]:
        out: list[str] = []
        droppers = dropper_names(n_droppers)
        for name in names:
            if name == DROPPER_GROUP:
                out.extend(droppers)
            elif _is_dropper_name(name) and name not in droppers:
                raise ConfigError(f"identification.{where}: {name!r} does not exist for a span type with "
                                  f"{n_droppers} droppers")
            else:
                out.append(name)
        order = (*droppers, MESSENGER_TENSION, SYSTEM_HEIGHT)
        return tuple(n for n in order if n in set(out))

    def random_names(self, n_droppers: int) -> tuple[str, ...]:
        """Names of the random inputs (design order) for a span type with ``n_droppers``."""
        return self._expand(self.random_inputs, n_droppers, "random_inputs")

    def free_mean_names(self, n_droppers: int) -> tuple[str, ...]:
        """Names of the inputs whose mean is identified (design order)."""
        return self._expand(self.free_means, n_droppers, "free_means")

    def start_inputs(self, span_type: SpanType, catenary: Catenary) -> tuple[RandomInput, ...]:
        """Start laws s0 of ``span_type`` in design order (droppers, T_MW, ΔH).

        A deterministic input (not in ``random_inputs``) gets σ = 1e-9 × its mean.

        Raises
        ------
        ConfigError
            If a list of dropper means or σ does not have one value per dropper, or if fewer
            random scalars than droppers would make the law of W singular.
        """
        n = span_type.n_droppers
        if isinstance(self.dropper_mean_m, str):
            means = nominal_dropper_lengths(span_type, catenary).dropper_lengths_m
        else:
            means = np.asarray(self.dropper_mean_m, dtype=float)
        sigmas = np.broadcast_to(np.asarray(self.dropper_sigma_m, dtype=float), means.shape) \
            if np.ndim(self.dropper_sigma_m) == 0 else np.asarray(self.dropper_sigma_m, dtype=float)
        for key, values in (("mean", means), ("sigma", sigmas)):
            if values.shape != (n,):
                raise ConfigError(f"identification.start.dropper_length_m.{key}: expected one value per dropper "
                                  f"({n} for span type {span_type.name}), got {values.size}")
        t_mean = span_type.messenger_tension_n if self.messenger_tension_mean_n == "design" \
            else float(self.messenger_tension_mean_n)
        t_sigma = 0.03 * t_mean if self.messenger_tension_sigma_n is None else float(self.messenger_tension_sigma_n)
        h_mean = span_type.system_height_m if self.system_height_mean_m == "design" else float(self.system_height_mean_m)
        random = set(self.random_names(n))
        n_random = len(random) + (SYSTEM_HEIGHT in random and self.system_height_mode == "independent")
        if n_random < n:
            raise ConfigError(f"identification.random_inputs: {n_random} random scalar(s) for span type "
                              f"{span_type.name} cannot spread W over its {n} droppers (the law of W would be "
                              f"singular); make at least {n} random (ΔH counts twice with "
                              "system_height_mode: independent)")
        laws = [(name, float(m), float(s)) for name, m, s in zip(dropper_names(n), means, sigmas)]
        laws += [(MESSENGER_TENSION, t_mean, t_sigma), (SYSTEM_HEIGHT, h_mean, float(self.system_height_sigma_m))]
        return tuple(RandomInput(name, m, s if name in random else DETERMINISTIC_CV * m) for name, m, s in laws)


def _is_dropper_name(name: str) -> bool:
    parts = name.split("_")
    return (len(parts) == 4 and parts[0] == "dropper" and parts[1].isdigit() and int(parts[1]) >= 1
            and parts[2:] == ["length", "m"])
