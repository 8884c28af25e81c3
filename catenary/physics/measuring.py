"""The measuring pass: what a recording car reports over a section.

The measuring pantograph runs along the section (at constant speed, or along a speed profile,
in either direction) and pushes the contact wire up; the car records the height of the contact
point, which the paper calls the *dynamic sag*. Two modes:

``dynamic``
    the time-domain pantograph run of :mod:`catenary.physics.dynamics`;
``quasi_static``
    one static solve per recorded position with the mean uplift force as a point load on the
    same catenary (steady arms and dropper slackening included): the speed → 0 limit.

Heights are reported at a fixed chainage step, as a recording car samples by distance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from catenary.plumbing.workers import map_each

from .config import Catenary, SpanType
from .dropper_table import dropper_lengths_for_cw_heights, nominal_dropper_lengths
from .dynamics import CatenaryDynamics, quasi_static_heights, run_pantograph
from .pantograph import Pantograph
from .section import Section, uniform_section
from .static import StaticModel

MODES = ("dynamic", "quasi_static")


@dataclass(frozen=True)
class MeasuredHeights:
    """Contact-point height along a section.

    Attributes
    ----------
    chainage_m : numpy.ndarray
        Chainage from the section start [m].
    height_m : numpy.ndarray
        CW height at the contact point [m].
    contact_force_n : numpy.ndarray
        Contact force at those points [N] (the mean force in quasi-static mode).
    """

    chainage_m: np.ndarray
    height_m: np.ndarray
    contact_force_n: np.ndarray


def measuring_pass(section: Section, catenary: Catenary, pantograph: Pantograph, *, speed_m_s: float,
                   sampling_step_m: float | None = None, mode: str = "dynamic", time_step_s: float | None = None,
                   ops: CatenaryDynamics | None = None, chainage_m: np.ndarray | None = None,
                   direction: int = 1, speed_profile: tuple[np.ndarray, np.ndarray] | None = None,
                   force_profile: tuple[np.ndarray, np.ndarray] | None = None) -> MeasuredHeights:
    """Contact-point heights of ``pantograph`` over ``section`` every ``sampling_step_m``.

    Parameters
    ----------
    section, catenary : the line and its data
    pantograph : Pantograph
        The measuring pantograph; its mean force at ``speed_m_s`` is the measuring force.
    speed_m_s : float
        Train speed [m/s].
    sampling_step_m : float, optional
        Recording step along the line [m] (a grid from the first to the last mast).
    chainage_m : array_like, optional
        Explicit chainages to report instead of the grid [m].
    mode : {"dynamic", "quasi_static"}
    time_step_s : float, optional
        Integration step of the dynamic mode (default: the catenary's setting).
    ops : CatenaryDynamics, optional
        Pre-assembled operators of ``section`` (re-used across calls; with ``direction=-1``,
        of the mirrored section, :meth:`Section.mirrored`).
    direction : {1, -1}
        Direction of travel: 1 towards increasing chainage, -1 towards decreasing chainage
        (the run over the mirrored section, reported at the original chainages).
    speed_profile : (numpy.ndarray, numpy.ndarray), optional
        ``(chainage_m, speed_m_s)``: the speed along the section (dynamic mode; the
        quasi-static pass has no speed other than through the mean force).
    force_profile : (numpy.ndarray, numpy.ndarray), optional
        ``(chainage_m, delta_force_n)``: a fluctuation of the uplift force along the section [N].
    """
    if mode not in MODES:
        raise ValueError(f"mode: expected one of {MODES}, got {mode!r}")
    masts = section.mast_chainage_m
    if chainage_m is not None:
        chainage = np.asarray(chainage_m, dtype=float)
    elif sampling_step_m is not None and sampling_step_m > 0:
        chainage = np.arange(masts[0], masts[-1] + 1e-9, sampling_step_m)
    else:
        raise ValueError(f"sampling_step_m: expected > 0 (or explicit chainage_m), got {sampling_step_m}")
    if direction not in (1, -1):
        raise ValueError(f"direction: expected 1 or -1, got {direction!r}")
    length = masts[-1]
    if direction == -1:
        # run over the mirrored section: chainage x here is length − x there
        section = section.mirrored()
        chainage = length - chainage
        speed_profile = _mirror_profile(speed_profile, length)
        force_profile = _mirror_profile(force_profile, length)
    ops = ops or CatenaryDynamics(section, catenary)
    force = pantograph.mean_force_n(speed_m_s)
    if mode == "quasi_static":
        # the static limit: the local force (the profile's fluctuation) at each point
        if force_profile is not None:
            force = force + np.interp(chainage, *force_profile)
        heights = quasi_static_heights(ops, chainage, force)
        return MeasuredHeights(_back(chainage, length, direction), heights,
                               np.broadcast_to(force, chainage.shape).astype(float))
    run = run_pantograph(ops, pantograph, speed_m_s, time_step_s=time_step_s, speed_profile=speed_profile,
                         force_profile=force_profile)
    return MeasuredHeights(_back(chainage, length, direction), np.interp(chainage, run.chainage_m, run.cw_height_m),
                           np.interp(chainage, run.chainage_m, run.contact_force_n))


def _mirror_profile(profile, length_m: float):
    if profile is None:
        return None
    knots, values = (np.asarray(a, dtype=float) for a in profile)
    return (length_m - knots)[::-1], values[::-1]


def _back(chainage_m: np.ndarray, length_m: float, direction: int) -> np.ndarray:
    return chainage_m if direction == 1 else length_m - chainage_m


def force_influence(span_type: SpanType, catenary: Catenary, pantograph: Pantograph, *, speed_m_s: float,
                    mode: str = "dynamic", time_step_s: float | None = None, neighbours: int = 2,
                    step_n: float = 1.0, workers: int = 1) -> np.ndarray:
    """Sensitivity of the W a measuring pass reports to the pantograph's static force [m/N].

    The central span of ``2 neighbours + 1`` spans of ``span_type`` at the nominal table is run
    over at the static forces ``F ± step_n`` (``F`` the pantograph's own); W is the height at
    the droppers measured from the chord through the heights measured at the two masts, as the
    projection takes it. The correction removes the uplift of the declared force, so a true
    force higher by ΔF leaves ``ΔF ×`` this vector in the corrected W (the
    ``measuring_force_offset`` effect). Central difference: exact for the linear response of
    taut droppers (the measuring force slackens none of them).

    Parameters
    ----------
    workers : int
        Processes over the two passes (:func:`catenary.plumbing.workers.map_each`): each is its
        own, so the influence is the same for any number.

    Returns
    -------
    numpy.ndarray, shape (n_droppers,)
    """
    lengths = nominal_dropper_lengths(span_type, catenary).dropper_lengths_m
    section = uniform_section(span_type, 2 * neighbours + 1, lengths)
    masts = section.mast_chainage_m[[neighbours, neighbours + 1]]
    at = np.concatenate([masts[0] + span_type.dropper_positions_m, masts])
    ops = CatenaryDynamics(section, catenary)
    n = span_type.n_droppers
    frac = span_type.dropper_positions_m / span_type.length_m

    def w(force: float) -> np.ndarray:
        h = measuring_pass(section, catenary, pantograph.with_static_force(force), speed_m_s=speed_m_s, mode=mode,
                           time_step_s=time_step_s, ops=ops, chainage_m=at).height_m
        return h[:n] - (h[n] + frac * (h[n + 1] - h[n]))

    f0 = pantograph.static_force_n
    up, down = map_each(lambda k: w(f0 + (step_n, -step_n)[k]), 2, workers, 1)
    return (up - down) / (2.0 * step_n)


def profile_influence(span_type: SpanType, catenary: Catenary, pantograph: Pantograph, *, speed_m_s: float,
                      x_m: np.ndarray, mode: str = "dynamic", time_step_s: float | None = None,
                      direction: int = 1, neighbours: int = 2, step_m: float = 1e-3, workers: int = 1) -> np.ndarray:
    """Sensitivity of a span's measured profile to its static CW at its droppers and masts [m/m].

    The central span of ``2 neighbours + 1`` spans of ``span_type`` at the nominal table is run
    over once as it is and once per support point with the static CW raised there by
    ``step_m``: at a dropper, the dropper lengths are solved again (the correction's own move),
    at a mast, its steady arm is raised with the droppers' CW held. Statically the columns are
    the hats of a tensioned wire held at those points; the pass adds the pantograph's dynamic
    response to each change (≈ 0.15–0.3 of it between the droppers on N2 at 40 km/h). They are
    the freedoms a correction stopped within its tolerance leaves in the measured profile
    (:mod:`catenary.stages.diagnosis.profile_check`). Forward differences: the pass is linear in the
    static CW while every dropper stays taut and the pantograph in contact.

    Parameters
    ----------
    x_m : array_like
        Abscissae from the central span's left mast [m], within the span.
    direction : {1, -1}
        Direction of travel of the measuring car.
    workers : int
        Processes over the raised support points (:func:`catenary.plumbing.workers.map_each`):
        each column's pass is its own, so the columns are the same for any number.

    Returns
    -------
    numpy.ndarray, shape (len(x_m), n_droppers + 2)
        Columns: the droppers in order, then the left and the right mast.
    """
    x = np.asarray(x_m, dtype=float)
    if x.ndim != 1 or np.any(x < 0) or np.any(x > span_type.length_m):
        raise ValueError(f"x_m: expected abscissae within the span [0, {span_type.length_m}] m")
    return _raised_supports(span_type, catenary, pantograph, x, (0, 1), speed_m_s=speed_m_s, mode=mode,
                            time_step_s=time_step_s, direction=direction, neighbours=neighbours, step_m=step_m,
                            workers=workers)


def support_response(span_type: SpanType, catenary: Catenary, pantograph: Pantograph, *, speed_m_s: float,
                     mode: str = "dynamic", time_step_s: float | None = None, direction: int = 1,
                     neighbours: int = 2, step_m: float = 1e-3, workers: int = 1) -> np.ndarray:
    """How the heights a measuring pass reports at every support point of ``2 neighbours + 1``
    nominal spans move when the central span's static CW is raised at one of its droppers or at
    its left mast [m/m] (the moves of :func:`profile_influence`, read at the support points of the
    whole section instead of along the central span).

    The correction's step (:mod:`catenary.stages.correction.step`) assembles a run of spans'
    response from these columns, shifted span by span: the pass is linear in the static CW while
    the droppers stay taut and the pantograph in contact, and a span far enough from the
    section's ends answers as the central one.

    Returns
    -------
    numpy.ndarray, shape ((2 neighbours + 1) n + 2 neighbours + 2, n + 1)
        Rows: the droppers span by span, then the masts, in chainage order; columns: the central
        span's droppers, then its left mast (n = ``span_type.n_droppers``).
    """
    spans = 2 * neighbours + 1
    x = np.concatenate([np.add.outer(np.arange(spans) * span_type.length_m, span_type.dropper_positions_m).ravel(),
                        np.arange(spans + 1) * span_type.length_m]) - neighbours * span_type.length_m
    return _raised_supports(span_type, catenary, pantograph, x, (0,), speed_m_s=speed_m_s, mode=mode,
                            time_step_s=time_step_s, direction=direction, neighbours=neighbours, step_m=step_m,
                            workers=workers)


def _raised_supports(span_type: SpanType, catenary: Catenary, pantograph: Pantograph, x_m: np.ndarray,
                     masts: tuple[int, ...], *, speed_m_s: float, mode: str, time_step_s: float | None,
                     direction: int, neighbours: int, step_m: float, workers: int) -> np.ndarray:
    """Columns of :func:`profile_influence` and :func:`support_response`: the measured heights at
    ``x_m`` (from the central span's left mast [m]) per unit raise of each of the central span's
    droppers, then of its masts ``masts`` (0 left, 1 right)."""
    lengths = nominal_dropper_lengths(span_type, catenary).dropper_lengths_m
    section = uniform_section(span_type, 2 * neighbours + 1, lengths)
    at = section.mast_chainage_m[neighbours] + x_m
    ops = CatenaryDynamics(section, catenary) if direction == 1 else CatenaryDynamics(section.mirrored(), catenary)

    def run(s: Section) -> np.ndarray:
        return measuring_pass(s, catenary, pantograph, speed_m_s=speed_m_s, mode=mode, time_step_s=time_step_s,
                              chainage_m=at, direction=direction,
                              ops=None if s is not section else ops).height_m

    base = run(section)
    heights = StaticModel(section, catenary).solve().cw_height_at(section.dropper_chainage_m)
    n = span_type.n_droppers

    def raised(k: int) -> np.ndarray:
        """Column k: a dropper of the central span (k < n), else the mast masts[k - n]."""
        if k < n:
            target = heights.copy()
            target[neighbours * n + k] += step_m
            return (run(dropper_lengths_for_cw_heights(section, catenary, target).section) - base) / step_m
        support = section.cw_support_heights_m.copy()
        support[neighbours + masts[k - n]] += step_m
        moved = section.with_cw_support_heights(support)
        return (run(dropper_lengths_for_cw_heights(moved, catenary, heights).section) - base) / step_m

    columns = map_each(raised, n + len(masts), workers, 1)
    return np.column_stack(columns)

