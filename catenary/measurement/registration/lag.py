"""The lag of the height signature of a dynamic measuring pass.

Under a moving pantograph the reported heights show each dropper's kink a little after the
dropper in the direction of travel (the wire and the pantograph respond with inertia and
damping). :func:`height_lag_m` measures that lag on the correction's own model of the measuring
pass — the nominal section of the span type, run over at the run's speed — with the very fit
the registration and the projection's check read the trace with
(:func:`catenary.measurement.registration.supports.align_pattern`), so that the fit's bias is removed
whatever its cause. A quasi-static pass has no lag (zero, tested).
"""

from __future__ import annotations

import numpy as np

from catenary.physics.config import Catenary, SpanType
from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.physics.measuring import measuring_pass
from catenary.physics.pantograph import Pantograph
from catenary.physics.section import uniform_section
from .supports import Trace, align_pattern

__all__ = ["height_lag_m", "lag_function"]

#: Spans of the nominal section the lag is measured on (the central ones are evaluated).
_N_SPANS = 5
#: Sampling of the simulated trace [m].
_STEP_M = 0.05


def height_lag_m(span_type: SpanType, catenary: Catenary, pantograph: Pantograph, speed_m_s: float, *,
                 mode: str = "dynamic", time_step_s: float | None = None) -> float:
    """Shift of the droppers' kinks in the heights of a measuring pass towards increasing
    chainage [m], for a run in that direction (a run the other way sees the opposite shift).

    Parameters
    ----------
    span_type : SpanType
    catenary : Catenary
    pantograph : Pantograph
        The measuring pantograph, at its measuring force.
    speed_m_s : float
        Measuring speed [m/s].
    mode : {"dynamic", "quasi_static"}
        The correction's model of the pass; quasi-static: 0.
    time_step_s : float, optional
        Integration step of the dynamic pass [s].
    """
    if mode == "quasi_static":
        return 0.0
    lengths = nominal_dropper_lengths(span_type, catenary).dropper_lengths_m
    section = uniform_section(span_type, _N_SPANS, lengths)
    masts = section.mast_chainage_m
    x = np.arange(masts[0], masts[-1] + 1e-9, _STEP_M)
    h = measuring_pass(section, catenary, pantograph, speed_m_s=speed_m_s, mode="dynamic",
                       time_step_s=time_step_s, chainage_m=x).height_m
    trace = Trace(x, h, None)
    shifts = []
    for a, b in zip(masts[1:-2], masts[2:-1]):
        pattern = np.r_[a, a + span_type.dropper_positions_m, b]
        fit = align_pattern(trace, pattern, a - 1.0, b + 1.0, search_m=1.0, step_m=0.01)
        shifts.append(fit.position_m)
    return float(np.median(shifts))


def lag_function(catenary: Catenary, pantograph: Pantograph, *, mode: str, time_step_s: float | None,
                 default_speed_kmh: float):
    """``lag(span_type, speed_kmh)`` for the registration and the projection: :func:`height_lag_m`
    of the correction's model of the measuring pass, at the speed rounded to 1 km/h (the lag
    moves by ≈ 0.025 m per km/h: measured 0.09, 0.32, 0.60 m at 30, 40, 50 km/h on N2), cached;
    a missing speed (NaN) takes ``default_speed_kmh``."""
    cache: dict[tuple[str, int], float] = {}

    def lag(span_type: str, speed_kmh: float) -> float:
        speed = default_speed_kmh if not np.isfinite(speed_kmh) else speed_kmh
        key = (span_type, int(round(speed)))
        if key not in cache:
            cache[key] = height_lag_m(catenary.span_type(span_type), catenary, pantograph, key[1] / 3.6, mode=mode,
                                      time_step_s=time_step_s)
        return cache[key]

    return lag

