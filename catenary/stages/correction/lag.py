"""The lag of the correction's own measuring pass, which the registration and the projection use."""

from __future__ import annotations

from catenary.measurement.registration.lag import lag_function
from catenary.physics.config import Catenary
from catenary.physics.pantograph import Pantograph

from .settings import CorrectionSettings

__all__ = ["measuring_lag"]


def measuring_lag(catenary: Catenary, pantographs: dict[str, Pantograph], correction: CorrectionSettings):
    """:func:`lag_function` of the correction's measuring pass: its pantograph at its declared
    force, its mode, time step and default speed (what the rules register and project with)."""
    pantograph = pantographs[correction.pantograph].with_static_force(correction.force_n)
    return lag_function(catenary, pantograph, mode=correction.mode, time_step_s=correction.time_step_s,
                        default_speed_kmh=correction.speed_kmh)
