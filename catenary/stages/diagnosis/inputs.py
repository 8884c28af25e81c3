"""What the diagnosis needs besides the corrected W: the measuring pass the correction assumed.

The ``measuring_force_offset`` candidate needs the declared force and the sensitivity of the
measured W to it (:func:`catenary.physics.measuring.force_influence`), computed for the span type with
the correction's own pantograph, speed and mode, so that the candidate is the bias that this
correction would leave. The per-span check reads the whole profile against the same pass's
response to the static CW at the droppers (:func:`profile_check_of`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from catenary.physics.config import Catenary, SpanType
from catenary.physics.measuring import force_influence, profile_influence
from catenary.physics.pantograph import Pantograph
from catenary.plumbing.parquet import read_table
from catenary.stages.correction import CorrectionSettings, measuring_conditions
from .profile_check import PROFILE_COLUMNS, Influence, ProfileNoise, ProfileSettings, profile_tests

__all__ = ["MeasuringPass", "ProfileCheck", "measuring_pass_of", "profile_check_of"]

#: Spacing of the tabulated response of the measuring pass along a span [m] (linear interpolation
#: between: the response is piecewise smooth between the droppers at the 0.1 m scale of a sample).
INFLUENCE_STEP_M = 0.05


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
                      settings: CorrectionSettings, workers: int = 1) -> MeasuringPass:
    """Median speed and force of the corrected spans' measuring passes, and the influence (its
    two passes in ``workers`` processes)."""
    spans = read_table(corrected_path).sort_values("start_chainage_m")
    speed, force, _, _ = measuring_conditions(pd.DataFrame(spans), settings)
    influence = force_influence(span_type, catenary, pantograph.with_static_force(force), speed_m_s=speed,
                                mode=settings.mode, time_step_s=settings.time_step_s, workers=workers)
    return MeasuringPass(speed_m_s=speed, force_n=force, influence_m_n=influence)


@dataclass(frozen=True)
class ProfileCheck:
    """The profile test of a span type's spans and what it read: the table
    (:func:`.profile_check.profile_tests`), the line's noise, the profiles, the measuring pass's
    responses per direction and each run's direction."""

    table: pd.DataFrame
    noise: ProfileNoise
    profiles: pd.DataFrame
    influences: dict
    directions: dict


def profile_check_of(corrected_path, profiles_path, span_type: SpanType, catenary: Catenary, pantograph: Pantograph,
                     correction: CorrectionSettings, settings: ProfileSettings, speed_m_s: float,
                     force_n: float, workers: int = 1) -> ProfileCheck:
    """The profile test of every corrected span of ``span_type``
    (:func:`.profile_check.profile_tests`): the measuring pass's response to the static CW at the
    knots for each direction the runs took (:func:`catenary.physics.measuring.profile_influence`, at the
    median speed and force, with the correction's pantograph and mode), each run's direction, and
    the final model's dropper forces (the smallest over the span's runs); the spans' tests in
    ``workers`` processes (the same table for any number)."""
    corrected = read_table(corrected_path)
    profiles = read_table(profiles_path, columns=list(PROFILE_COLUMNS), categorical=["span_id", "run_id"])
    directions = {(str(r.span_id), str(r.run_id)): int(r.direction) for r in corrected.itertuples()}
    x = np.linspace(0.0, span_type.length_m, int(round(span_type.length_m / INFLUENCE_STEP_M)) + 1)
    influences = {d: Influence.from_measuring(x, profile_influence(
        span_type, catenary, pantograph.with_static_force(force_n), speed_m_s=speed_m_s, x_m=x, mode=correction.mode,
        time_step_s=correction.time_step_s, direction=d, workers=workers), span_type.n_droppers)
        for d in sorted(set(directions.values()))}
    force_columns = [f"dropper_{i + 1}_force_n" for i in range(span_type.n_droppers)]
    forces = {}
    if all(c in corrected.columns for c in force_columns):
        code, spans = pd.factorize(corrected["span_id"], sort=True)
        order = np.argsort(code, kind="stable")
        starts = np.flatnonzero(np.r_[True, np.diff(code[order]) != 0])
        # the smallest over each span's rows (NaN if one is NaN, as numpy's min)
        smallest = np.minimum.reduceat(corrected[force_columns].to_numpy(dtype=float)[order], starts, axis=0)
        forces = {str(span): row for span, row in zip(spans[code[order][starts]], smallest)}
    table, noise = profile_tests(profiles, span_type.length_m, span_type.dropper_positions_m,
                                 span_type.contact_tension_n, settings, influences=influences, directions=directions,
                                 dropper_forces_n=forces, workers=workers)
    return ProfileCheck(table, noise, profiles, influences, directions)
