"""Settings of the identification rule, read from the ``identification`` block of the config.

Every key is documented in ``docs/configuration.md``. The settings are checked against the
``identification`` block of the shipped config schema (:mod:`catenary.plumbing.schema`), the same file
the workflow validates its config with; an unknown key or a bad value is a
:class:`~catenary.plumbing.errors.ConfigError` naming the key.

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

from catenary.physics.config import Catenary, SpanType
from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.plumbing.errors import ConfigError
from catenary.plumbing.schema import check, merged_mapping
from .design import MESSENGER_TENSION, SYSTEM_HEIGHT, RandomInput, dropper_names

__all__ = ["DETERMINISTIC_CV", "DROPPER_GROUP", "IdentificationSettings"]

#: Group name standing for every dropper length in ``random_inputs`` and ``free_means``.
DROPPER_GROUP = "dropper_lengths_m"
#: σ/μ given to a deterministic (non-random) input.
DETERMINISTIC_CV = 1e-9


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
    neighbours : int
        Model of one span: 0, the paper's single span pinned at its masts; k > 0, the span as the
        central one of 2k + 1 identical spans, both wires continuous over its masts, neighbours
        at the nominal table (:class:`catenary.physics.fast.FastSpanModel`).
    standard_errors : {"sandwich", "observed_information"}
        ``"sandwich"``: the observed information with each variance widened by the sandwich over
        spans that share a mast where that is wider (:mod:`.dependence`; used when the data say
        which spans share a mast, else the observed information alone); ``"observed_information"``:
        spans independent (the paper's).
    on_non_convergence : {"fail", "mark"}
        When the optimiser stops without converging: ``"fail"`` raises
        :class:`~catenary.plumbing.errors.ConvergenceError` (the rule fails, no output); ``"mark"`` writes
        every output with ``status`` ``not_converged``.
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
    profile_parameters : tuple of str
        Inputs whose free μ and σ get profile-likelihood intervals (``dropper_lengths_m`` for
        every dropper); empty: none.
    profile_level : float
        Confidence level of the profile intervals.
    profile_max_evaluations : int
        J evaluations of each inner re-optimisation of the profile.
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
        O(n²); see :func:`.normality.normality_report` for why not the design itself).
    measurement_noise : str or float
        The measured W's own error in the likelihood: ``"repeatability"`` (the covariance the
        runs of a recording measured several times show, :mod:`catenary.measurement.repeatability`, divided
        by each span's number of runs; none when no span was measured twice), ``"none"`` (no
        noise term: the dropper σ absorb it, the paper's), or a standard deviation [m] assumed
        for each dropper of one run.
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
    neighbours: int = 1
    standard_errors: str = "sandwich"
    on_non_convergence: str = "fail"
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
    profile_parameters: tuple[str, ...] = (DROPPER_GROUP, MESSENGER_TENSION, SYSTEM_HEIGHT)
    profile_level: float = 0.95
    profile_max_evaluations: int = 300
    estimators_n_samples: tuple[int, ...] = (1_000, 10_000, 100_000)
    band_level: float = 0.98
    band_n_samples: int = 4000
    band_n_points: int = 235
    normality_alpha: float = 0.05
    normality_n_samples: int = 10_000
    measurement_noise: str | float = "repeatability"

    def __post_init__(self) -> None:
        check(self.as_mapping(), "config", "identification")
        # Integers given as 1e4 in YAML arrive as floats: store them as int.
        for key in ("n_samples", "max_evaluations", "band_n_samples", "band_n_points", "normality_n_samples",
                    "seed", "neighbours", "profile_max_evaluations"):
            object.__setattr__(self, key, int(getattr(self, key)))
        object.__setattr__(self, "estimators_n_samples", tuple(int(n) for n in self.estimators_n_samples))

    @classmethod
    def from_mapping(cls, mapping: Mapping[str, Any] | None, where: str = "identification") -> "IdentificationSettings":
        """Settings from the config block (missing keys take their defaults).

        Raises
        ------
        ConfigError
            On an unknown key or a bad value (checked against the config schema); the message
            names the key.
        """
        raw = merged_mapping(cls().as_mapping(), mapping)
        check(raw, "config", "identification", where=where)
        start, optimiser = raw["start"], raw["optimiser"]

        def value(v):
            return tuple(v) if isinstance(v, list) else v

        return cls(
            random_inputs=tuple(raw["random_inputs"]), free_means=tuple(raw["free_means"]),
            dropper_mean_m=value(start["dropper_length_m"]["mean"]),
            dropper_sigma_m=value(start["dropper_length_m"]["sigma"]),
            messenger_tension_mean_n=start[MESSENGER_TENSION]["mean"],
            messenger_tension_sigma_n=start[MESSENGER_TENSION]["sigma"],
            system_height_mean_m=start[SYSTEM_HEIGHT]["mean"], system_height_sigma_m=start[SYSTEM_HEIGHT]["sigma"],
            system_height_mode=raw["system_height_mode"], neighbours=raw["neighbours"],
            standard_errors=raw["standard_errors"], on_non_convergence=raw["on_non_convergence"],
            n_samples=raw["n_samples"], design=raw["design"], estimator=raw["estimator"],
            bandwidth=raw["bandwidth"], seed=raw["seed"], **optimiser,
            profile_parameters=tuple(raw["profile_intervals"]["parameters"]),
            profile_level=raw["profile_intervals"]["level"],
            profile_max_evaluations=raw["profile_intervals"]["max_evaluations"],
            estimators_n_samples=tuple(raw["estimators_n_samples"]),
            **{f"band_{k}": v for k, v in raw["band"].items()},
            **{f"normality_{k}": v for k, v in raw["normality"].items()},
            measurement_noise=raw["measurement_noise"])

    def as_mapping(self) -> dict[str, Any]:
        """The settings as the config block ``identification`` (the schema's layout)."""
        def listed(v):
            return list(v) if isinstance(v, tuple) else v

        return {
            "random_inputs": list(self.random_inputs), "free_means": list(self.free_means),
            "start": {"dropper_length_m": {"mean": listed(self.dropper_mean_m), "sigma": listed(self.dropper_sigma_m)},
                      MESSENGER_TENSION: {"mean": self.messenger_tension_mean_n,
                                          "sigma": self.messenger_tension_sigma_n},
                      SYSTEM_HEIGHT: {"mean": self.system_height_mean_m, "sigma": self.system_height_sigma_m}},
            "system_height_mode": self.system_height_mode, "neighbours": self.neighbours,
            "standard_errors": self.standard_errors, "on_non_convergence": self.on_non_convergence,
            "n_samples": self.n_samples, "design": self.design, "estimator": self.estimator,
            "bandwidth": self.bandwidth, "seed": self.seed,
            "optimiser": {"method": self.method, "max_evaluations": self.max_evaluations,
                          "initial_step": self.initial_step, "xtol": self.xtol, "ftol": self.ftol,
                          "hessian_step": self.hessian_step},
            "profile_intervals": {"parameters": list(self.profile_parameters), "level": self.profile_level,
                                  "max_evaluations": self.profile_max_evaluations},
            "estimators_n_samples": list(self.estimators_n_samples),
            "band": {"level": self.band_level, "n_samples": self.band_n_samples, "n_points": self.band_n_points},
            "normality": {"alpha": self.normality_alpha, "n_samples": self.normality_n_samples},
            "measurement_noise": self.measurement_noise,
        }

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

    def profile_names(self, n_droppers: int) -> tuple[str, ...]:
        """Names of the inputs whose free μ and σ are profiled (design order)."""
        return self._expand(self.profile_parameters, n_droppers, "profile_intervals.parameters")

    def free_mean_names(self, n_droppers: int) -> tuple[str, ...]:
        """Names of the inputs whose mean is identified (design order)."""
        return self._expand(self.free_means, n_droppers, "free_means")

    def noise_covariance_m2(self, n_droppers: int, repeatability_m2: np.ndarray | None) -> np.ndarray | None:
        """Covariance of one run's W error the likelihood adds (``measurement_noise``) [m²]:
        the repeatability's, an assumed σ² I, or None."""
        if self.measurement_noise == "none":
            return None
        if self.measurement_noise == "repeatability":
            return None if repeatability_m2 is None else np.asarray(repeatability_m2, dtype=float)
        return float(self.measurement_noise) ** 2 * np.eye(n_droppers)

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
