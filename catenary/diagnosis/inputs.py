"""What the diagnosis needs besides the corrected W: the measuring pass the correction assumed.

The ``measuring_force_offset`` candidate needs the declared force and the sensitivity of the
measured W to it (:func:`catenary.measuring.force_influence`), computed for the span type with
the correction's own pantograph, speed and mode, so that the candidate is the bias that this
correction would leave.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..config import Catenary, SpanType
from ..correction import CorrectionSettings, measuring_conditions
from ..measuring import force_influence
from ..pantograph import Pantograph
from ..parquet import read_table

__all__ = ["MeasuringPass", "measuring_pass_of"]


@dataclass(frozen=True)
class MeasuringPass:
    """The measuring pass of a recording as the correction modelled it.

    Attributes
    ----------
    speed_m_s : float
        Median measuring speed [m/s].
    force_n : float
        Median declared static force [N].
    influence_m_n : numpy.ndarray, shape (n,)
        ∂W/∂F at the droppers [m/N].
    """

    speed_m_s: float
    force_n: float
    influence_m_n: np.ndarray


def measuring_pass_of(corrected_path, span_type: SpanType, catenary: Catenary, pantograph: Pantograph,
                      settings: CorrectionSettings) -> MeasuringPass:
    """Median speed and force of the corrected spans' measuring passes, and the influence."""
    spans = read_table(corrected_path).sort_values("start_chainage_m")
    speed, force, _, _ = measuring_conditions(pd.DataFrame(spans), settings)
    influence = force_influence(span_type, catenary, pantograph.with_static_force(force), speed_m_s=speed,
                                mode=settings.mode, time_step_s=settings.time_step_s)
    return MeasuringPass(speed_m_s=speed, force_n=force, influence_m_n=influence)
