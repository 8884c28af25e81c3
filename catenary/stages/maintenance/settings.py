"""Settings of the per-span answers (config block ``maintenance``; schema: ``catenary/schemas``)."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Mapping

import numpy as np

from catenary.plumbing.schema import check

__all__ = ["MaintenanceSettings", "tolerance_limits"]


@dataclass(frozen=True)
class MaintenanceSettings:
    """What the maintenance stage computes and lists.

    Attributes
    ----------
    enabled : bool
    measurement_noise_m : float
        σ of a span's corrected W error per dropper [m] where the identification carries no noise
        of its own (a single run: no repeatability). Default 0.6 mm: the corrected W's RMS error
        against the truth's static W measured on the default campaign (0.58 mm N2, 0.62 mm N3).
    n_samples : int
        Importance draws per span (:func:`~.posterior.span_posteriors`).
    seed : int
    dropper_tolerance_m : float
        A dropper lies out of tolerance beyond its nominal length ± this [m]. Default 1 cm: the
        accuracy droppers are made to (paper §4.2); a dropper further off was not made or fitted to
        the drawing.
    messenger_tension_tolerance_n : float or None
        T_MW out of tolerance beyond the design tension ± this [N] (default 2 kN, 10 % of
        20 kN: a tensioning device out of its range). None: no limit.
    system_height_tolerance_m : float or None
        ΔH out of tolerance beyond the design ± this [m] (default 2 cm). None: no limit.
    threshold : float
        A span's input enters the maintenance list when its probability of lying outside
        tolerance exceeds this (default 0.5: more likely out than in).
    min_dropper_force_n : float or None
        A dropper whose static force is below this [N] is out of service (default 10 N, against
        53–136 N at N2's nominal geometry): a dropper too long in mid-span goes slack, and W then
        tells that it carries nothing better than how much too long it is. None: no limit.
    fault_probability : float
        Prior probability that a dropper was made or fitted outside its identified law (default
        1 %); 0 keeps the identified law alone, which shrinks a faulty dropper back to nominal.
    fault_std_m : float
        Standard deviation of such a dropper's length error [m] (default 3 cm).
    band_draws_per_span : int
        Posterior draws kept per span for the population's posterior band and its
        leave-one-out coverage (:mod:`.population`; default 200, resampled from the
        ``n_samples`` weighted ones); 0: no band.
    law_uncertainty : bool
        The prior carries the identified laws' own uncertainty (each μ and σ by its standard
        error and systematic, :func:`~.runner.prior_from_s_opt`; default True); False: the laws
        as point values, which narrows the intervals of the inputs W tells little about.
    """

    enabled: bool = True
    measurement_noise_m: float = 6e-4
    n_samples: int = 4000
    seed: int = 14
    dropper_tolerance_m: float = 0.01
    messenger_tension_tolerance_n: float | None = 2000.0
    system_height_tolerance_m: float | None = 0.02
    threshold: float = 0.5
    min_dropper_force_n: float | None = 10.0
    fault_probability: float = 0.01
    fault_std_m: float = 0.03
    band_draws_per_span: int = 200
    law_uncertainty: bool = True

    @classmethod
    def from_mapping(cls, mapping: Mapping[str, Any] | None) -> "MaintenanceSettings":
        """Settings from the config block, checked against the schema (missing keys: defaults).

        Raises
        ------
        ConfigError
            A block the schema refuses.
        """
        if mapping is None:
            return cls()
        check(dict(mapping), "config", "maintenance")
        return cls(**dict(mapping))

    def as_dict(self) -> dict:
        return asdict(self)


def tolerance_limits(names: tuple[str, ...], nominal: np.ndarray, settings: MaintenanceSettings
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper tolerance limits per input and dropper force (NaN where none is given).

    ``names`` as :func:`~.prior.output_names`, ``nominal`` the design value of each.
    """
    half = np.full(len(names), np.nan)
    lower_only = np.full(len(names), np.nan)
    for j, name in enumerate(names):
        if name.endswith("_force_n"):
            if settings.min_dropper_force_n is not None:
                lower_only[j] = settings.min_dropper_force_n
        elif name.startswith("dropper_"):
            half[j] = settings.dropper_tolerance_m
        elif name == "messenger_tension_n" and settings.messenger_tension_tolerance_n is not None:
            half[j] = settings.messenger_tension_tolerance_n
        elif name.startswith("system_height") and settings.system_height_tolerance_m is not None:
            half[j] = settings.system_height_tolerance_m
    nominal = np.asarray(nominal, dtype=float)
    forces = np.array([n.endswith("_force_n") for n in names])
    return np.where(forces, lower_only, nominal - half), np.where(forces, np.nan, nominal + half)
