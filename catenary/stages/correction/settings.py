"""Settings of the dynamic correction (config key ``correction``)."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Mapping

from catenary.plumbing.schema import check

__all__ = ["CorrectionSettings"]


@dataclass(frozen=True)
class CorrectionSettings:
    """Settings of the correction loop (config key ``correction``).

    Attributes
    ----------
    mode : {"dynamic", "quasi_static"}
        Simulated measuring pass.
    time_step_s : float
        Integration step of the dynamic pass [s].
    tolerance_m : float
        A span has converged when its gap norm is below this [m] (paper: 1 mm).
    max_iterations : int
        Largest number of simulated passes per run.
    pantograph : str
        Name of the measuring pantograph in the pantographs file.
    speed_kmh, force_n : float
        Measuring speed [km/h] and static force [N] where the recording has no ``speed_kmh`` /
        ``force_n`` (otherwise each span's speed and the median force over the run of spans).
    quasi_static_start : bool
        In dynamic mode, first iterate with quasi-static passes to a tenth of the tolerance, or
        until a pass no longer halves the largest gap (:data:`.runner.QUASI_STATIC_STALL`):
        they cost far less (the default campaign corrects in 5.2 s quasi-statically against
        63 s dynamically, on 2 processes) and take the gap norm from ≈ 12 mm to ≈ 3–4 mm of dynamic gap.
    """

    mode: str = "dynamic"
    time_step_s: float = 0.002
    tolerance_m: float = 1e-3
    max_iterations: int = 5
    pantograph: str = "measuring"
    speed_kmh: float = 40.0
    force_n: float = 36.0
    quasi_static_start: bool = True

    def __post_init__(self) -> None:
        check(asdict(self), "config", "correction")

    @classmethod
    def from_mapping(cls, mapping: Mapping[str, Any] | None) -> "CorrectionSettings":
        """Settings from the config block (missing keys take their defaults).

        Raises
        ------
        ConfigError
            On an unknown key or a bad value (checked against the config schema).
        """
        mapping = {} if mapping is None else mapping
        check({**asdict(cls()), **mapping} if isinstance(mapping, Mapping) else mapping, "config", "correction")
        return cls(**mapping)
