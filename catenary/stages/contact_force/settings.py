"""Settings of the contact-force rules, read from the ``contact_force`` block of the config.

Every key is documented in ``docs/configuration.md`` and checked against the ``contact_force`` block
of the shipped config schema (:mod:`catenary.plumbing.schema`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from catenary.measurement.truth import Law
from catenary.plumbing.schema import check, merged_mapping

__all__ = ["ContactForceSettings", "Limits", "ToleranceStudy", "batch_replicates", "n_batches", "sobol_size",
           "tolerance_replicates"]


@dataclass(frozen=True)
class Limits:
    """EN 50367-style acceptance limits of one run.

    Attributes
    ----------
    mean_force_coefficients : (float, float)
        Target mean force Fm(v) = a v² + b [N], v in km/h (EN 50367 for AC lines: 0.00097, 70);
        a mean force above it is a violation.
    max_std_fraction : float
        σ above this fraction of Fm is a violation (EN 50367: 0.3).
    min_statistical_n : float
        Fm − 3σ at or below this is a violation (EN 50367: > 0) [N].
    max_uplift_m : float
        Steady-arm uplift above this is a violation [m].
    """

    mean_force_coefficients: tuple[float, float] = (0.00097, 70.0)
    max_std_fraction: float = 0.3
    min_statistical_n: float = 0.0
    max_uplift_m: float = 0.12

    def mean_force_target_n(self, speed_kmh: float) -> float:
        a, b = self.mean_force_coefficients
        return a * speed_kmh**2 + b


@dataclass(frozen=True)
class ToleranceStudy:
    """Maintenance tolerances tried (``contact_force.tolerance_study``).

    Attributes
    ----------
    dropper_tolerances_m : tuple of float
        Dropper-length tolerances ±t [m]; the law's σ is ``t / sigma_per_tolerance``.
    sigma_per_tolerance : float
        How a tolerance maps to the law: a tolerance is this many σ (2: ±t holds 95 % of the
        droppers).
    messenger_tension_sigmas_n : tuple of float
        T_MW spreads tried with each dropper tolerance [N].
    replicates : int
        Sections per combination.
    speed_kmh : float
    """

    dropper_tolerances_m: tuple[float, ...] = (0.002, 0.004, 0.006, 0.008)
    sigma_per_tolerance: float = 2.0
    messenger_tension_sigmas_n: tuple[float, ...] = (200.0, 800.0)
    replicates: int = 8
    speed_kmh: float = 300.0


@dataclass(frozen=True)
class ContactForceSettings:
    """What the contact-force rules do for each span type (config block ``contact_force``).

    Attributes
    ----------
    speeds_kmh : tuple of float
    pantograph : str
        Name in the pantographs file.
    n_spans : int
        Spans of a replicate section (run-in and run-out included).
    analysis_masts : (int, int)
        Statistics between these masts (the central spans).
    filter_cutoff_hz : float
    cw_height : Law
        Steady-arm heights per mast [m], as the campaign draws them.
    replicates : int
        Random sections under the identified laws.
    batch_size : int
        Replicates per job.
    seed : int
    limits : Limits
    tolerance : ToleranceStudy
    sensitivity_samples : int
        Base size N of the pick-freeze design (N (2k + 2) dynamic runs for k = 5 groups); 0
        skips the sensitivity (no ``sobol`` batches, :attr:`sensitivity_enabled`).
    """

    speeds_kmh: tuple[float, ...] = (300.0, 320.0)
    pantograph: str = "reference_2mass"
    n_spans: int = 10
    analysis_masts: tuple[int, int] = (3, 7)
    filter_cutoff_hz: float = 20.0
    cw_height: Law = Law("normal", 5.08, 0.02)
    replicates: int = 32
    batch_size: int = 8
    seed: int = 11
    limits: Limits = field(default_factory=Limits)
    tolerance: ToleranceStudy = field(default_factory=ToleranceStudy)
    sensitivity_samples: int = 8

    @classmethod
    def from_mapping(cls, mapping: Mapping[str, Any] | None, where: str = "contact_force") -> "ContactForceSettings":
        raw = merged_mapping(cls().as_mapping(), mapping)
        check(raw, "config", "contact_force", where=where)
        lim, tol, h = raw["limits"], raw["tolerance_study"], raw["cw_height_m"]
        return cls(speeds_kmh=tuple(float(v) for v in raw["speeds_kmh"]), pantograph=raw["pantograph"],
                   n_spans=int(raw["n_spans"]), analysis_masts=tuple(int(m) for m in raw["analysis_masts"]),
                   filter_cutoff_hz=float(raw["filter_cutoff_hz"]),
                   cw_height=Law(h["law"], float(h["mean"]), float(h.get("std", 0.0))),
                   replicates=int(raw["replicates"]), batch_size=int(raw["batch_size"]), seed=int(raw["seed"]),
                   limits=Limits(mean_force_coefficients=tuple(float(c) for c in lim["mean_force_coefficients"]),
                                 max_std_fraction=float(lim["max_std_fraction"]),
                                 min_statistical_n=float(lim["min_statistical_n"]),
                                 max_uplift_m=float(lim["max_uplift_m"])),
                   tolerance=ToleranceStudy(dropper_tolerances_m=tuple(float(t) for t in tol["dropper_tolerances_m"]),
                                            sigma_per_tolerance=float(tol["sigma_per_tolerance"]),
                                            messenger_tension_sigmas_n=tuple(float(s) for s in
                                                                             tol["messenger_tension_sigmas_n"]),
                                            replicates=int(tol["replicates"]), speed_kmh=float(tol["speed_kmh"])),
                   sensitivity_samples=int(raw["sensitivity"]["n_samples"]))

    def as_mapping(self) -> dict[str, Any]:
        lim, tol = self.limits, self.tolerance
        return {"speeds_kmh": list(self.speeds_kmh), "pantograph": self.pantograph, "n_spans": self.n_spans,
                "analysis_masts": list(self.analysis_masts), "filter_cutoff_hz": self.filter_cutoff_hz,
                "cw_height_m": {"law": self.cw_height.kind, "mean": self.cw_height.mean, "std": self.cw_height.std},
                "replicates": self.replicates, "batch_size": self.batch_size, "seed": self.seed,
                "limits": {"mean_force_coefficients": list(lim.mean_force_coefficients),
                           "max_std_fraction": lim.max_std_fraction, "min_statistical_n": lim.min_statistical_n,
                           "max_uplift_m": lim.max_uplift_m},
                "tolerance_study": {"dropper_tolerances_m": list(tol.dropper_tolerances_m),
                                    "sigma_per_tolerance": tol.sigma_per_tolerance,
                                    "messenger_tension_sigmas_n": list(tol.messenger_tension_sigmas_n),
                                    "replicates": tol.replicates, "speed_kmh": tol.speed_kmh},
                "sensitivity": {"n_samples": self.sensitivity_samples}}

    @property
    def sensitivity_enabled(self) -> bool:
        """Whether the Sobol indices are computed (``sensitivity.n_samples`` > 0)."""
        return self.sensitivity_samples > 0

    def cases(self) -> list[str]:
        """Cases of the batch jobs: ``identified``, ``sobol`` (the sensitivity's design) and
        ``tolerance`` (every combination of the tolerance study, :meth:`tolerance_cases`, in one
        run of batches: each combination's few sections would otherwise pay a job's start-up,
        ≈ 3 s, for ≈ 4 s of runs); no ``sobol`` when the sensitivity is skipped."""
        return ["identified", *(["sobol"] if self.sensitivity_enabled else []), "tolerance"]

    def tolerance_cases(self) -> list[tuple[str, float, float]]:
        """The tolerance study's combinations: ``(name, dropper σ [m], T_MW σ [N])``, named
        ``tol_<dropper tolerance mm>mm_<T_MW σ>N`` (the ``case`` of their rows)."""
        tol = self.tolerance
        return [(f"tol_{1e3 * t:g}mm_{s:g}N", t / tol.sigma_per_tolerance, s) for t in tol.dropper_tolerances_m
                for s in tol.messenger_tension_sigmas_n]


def sobol_size(settings: ContactForceSettings) -> int:
    """Sections of the pick-freeze design: N (2k + 2) for the k = 5 input groups of
    :mod:`.draws` (second order included)."""
    return settings.sensitivity_samples * (2 * 5 + 2)


def _case_size(settings: ContactForceSettings, case: str, n_droppers: int) -> int:
    if case == "identified":
        return settings.replicates
    if case == "sobol":
        return sobol_size(settings)
    if case == "tolerance":
        return len(settings.tolerance_cases()) * settings.tolerance.replicates
    raise ValueError(f"case: expected one of {settings.cases()}, got {case!r}")


def batch_replicates(settings: ContactForceSettings, case: str, batch: int,
                     n_droppers: int) -> tuple[list[int], tuple[float, ...]]:
    """Replicate (or design row) indices and speeds of batch ``batch`` of ``case`` (``tolerance``:
    indices over its combinations in turn, :func:`tolerance_replicates`)."""
    total = _case_size(settings, case, n_droppers)
    speeds = (settings.speeds_kmh if case == "identified" else
              (settings.speeds_kmh[0],) if case == "sobol" else (settings.tolerance.speed_kmh,))
    start = batch * settings.batch_size
    return list(range(start, min(start + settings.batch_size, total))), speeds


def tolerance_replicates(settings: ContactForceSettings, indices: list[int]) -> list[tuple[tuple[str, float, float],
                                                                                            list[int]]]:
    """The ``tolerance`` case's indices as ``(combination, its replicates)``: index k is
    replicate ``k mod R`` of combination ``k div R`` (R sections per combination)."""
    per = settings.tolerance.replicates
    combinations = settings.tolerance_cases()
    out: dict[int, list[int]] = {}
    for k in indices:
        out.setdefault(k // per, []).append(k % per)
    return [(combinations[c], replicates) for c, replicates in out.items()]


def n_batches(settings: ContactForceSettings, case: str, n_droppers: int) -> int:
    return -(-_case_size(settings, case, n_droppers) // settings.batch_size)
