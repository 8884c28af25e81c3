"""Settings of the registration (config block ``registration``; every key in docs/configuration.md).

The block is checked against the shipped config schema (:mod:`catenary.plumbing.schema`), the same file
the workflow validates its config with.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Mapping

from catenary.plumbing.schema import check

__all__ = ["RegistrationSettings"]


@dataclass(frozen=True)
class RegistrationSettings:
    """How the mast table is registered onto each run's trace.

    Attributes
    ----------
    enabled : bool
        False: the mast table's chainages are taken as the recording's, unchecked by the
        registration (the projection still checks every cut against the trace).
    max_offset_m : float
        Largest distance between a run's chainage and the mast table where the run enters a
        section, before any section of the run is registered [m]; below half the shortest span,
        so that the span pattern cannot be matched one span off.
    max_scale_error : float
        Largest odometer scale error (0.01: 1 %).
    drift_degree : int
        Degree of the polynomial map from table to recorded chainage per section: 1, an offset
        and a scale; 2 or 3, a smooth drift as well (used where a section has enough masts).
    search_m : float
        Each mast's support is looked for within ± this of where the coarse map puts it [m].
    mast_table_std_m : float
        Prior of the mast table's accuracy, the standard error of a chainage in it [m]. Each run
        measures the accuracy per section from where the trace places the masts against the map,
        less the trace's own error (:mod:`catenary.measurement.registration.section_fit`); this value counts
        as two masts' worth of that evidence. The measured accuracy weighs the table against
        the trace in each mast's registered position.
    max_residual_m : float
        A mast whose trace position lies within this of the fitted map is never an outlier [m];
        a mast whose own fit lies within this of where the section's fit places it is confirmed
        by the trace (height alone), and a mast agrees with the coarse line within this (or
        within the table's own spread of span lengths, if wider).
    min_matched_fraction : float
        A section whose trace confirms fewer than this fraction of its table masts is refused.
    min_matched_masts : int
        ... or fewer than this many.
    length_tolerance_m : float
        A registered span whose length differs from every span type's by more than this is not
        a span: an extra mast in the table, or a missing one, is looked for there [m].
    section_gap_m : float
        Without a mast table, a stretch of this length without samples ends a section [m].
    height_lag_std_m : float
        Uncertainty of the height's lag as the correction's model gives it, at each end of a
        section [m] (the measured droppers' kinks lag by ≈ 0.1–0.3 m more or less than the
        nominal model's, and the lag changes along a line): the height cannot place a section's
        offset and scale better (:func:`catenary.measurement.registration.runner._agrees_with_identity`).
    """

    enabled: bool = True
    max_offset_m: float = 15.0
    max_scale_error: float = 0.01
    drift_degree: int = 1
    search_m: float = 1.5
    mast_table_std_m: float = 0.2
    max_residual_m: float = 0.5
    min_matched_fraction: float = 0.5
    min_matched_masts: int = 3
    length_tolerance_m: float = 1.0
    section_gap_m: float = 20.0
    height_lag_std_m: float = 0.2

    def __post_init__(self) -> None:
        check(asdict(self), "config", "registration")

    @classmethod
    def from_mapping(cls, mapping: Mapping[str, Any] | None) -> "RegistrationSettings":
        """Settings from the config block (missing keys take their defaults).

        Raises
        ------
        ConfigError
            On an unknown key or a bad value (checked against the config schema).
        """
        mapping = {} if mapping is None else mapping
        check({**asdict(cls()), **mapping} if isinstance(mapping, Mapping) else mapping, "config", "registration")
        return cls(**mapping)
