"""Inverse static problem: dropper lengths that give a target contact-wire profile.

With the CW heights prescribed at the droppers, the CW equilibrium alone gives the dropper
tensions (9 equations, 9 unknowns per span); loading the MW with those tensions gives its
heights, and each unstretched length follows from Hooke's law,
``L = l · EA / (EA + F)`` with ``l`` the stretched length. The half dropper weight carried by
each wire depends on ``L``, so the three steps are repeated until the lengths stop changing
(a contraction: two or three passes reach 1e-12 m). The same solver builds the nominal
dropper table and updates dropper lengths in the dynamic correction;
:func:`dropper_lengths_for_many` takes its passes for many targets on one geometry at once (the
inversion of measured spans: each pass's two linear solves factored once for all of them).

A target that would need a dropper in compression has no taut solution. With
``allow_slack=True`` such droppers are made slack instead: their CW height is released (the
wire hangs there from its neighbours) and their length is set ``SLACK_MARGIN_M`` longer than
the distance between the wires, so they stay slack under an uplift; the others are solved
again, until every prescribed dropper pulls.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .config import Catenary, SpanType
from catenary.plumbing.errors import ConvergenceError, NoTautSolutionError
from .section import Section, single_span
from .static import StaticModel


@dataclass(frozen=True)
class InverseResult:
    """Dropper lengths reproducing a target CW profile.

    Attributes
    ----------
    dropper_lengths_m : numpy.ndarray
        Unstretched dropper lengths [m].
    dropper_force_n : numpy.ndarray
        Dropper tensions at equilibrium [N].
    section : Section
        The section with those lengths.
    slack : numpy.ndarray of bool
        Droppers made slack (their target height released); all False unless ``allow_slack``.
    """

    dropper_lengths_m: np.ndarray
    dropper_force_n: np.ndarray
    section: Section
    slack: np.ndarray

#: A dropper made slack by the inverse solver is this much longer than the wire distance [m].
SLACK_MARGIN_M = 0.01


def presag_deflection_m(span_type: SpanType, x_m: np.ndarray) -> np.ndarray:
    """Designed CW deflection from the chord [m]: a parabola of depth ``presag_m`` between the
    first and the last dropper, zero outside (negative = below the chord)."""
    x = np.asarray(x_m, dtype=float)
    a, b = span_type.dropper_positions_m[0], span_type.dropper_positions_m[-1]
    inside = (x >= a) & (x <= b)
    return np.where(inside, -4.0 * span_type.presag_m * (x - a) * (b - x) / (b - a) ** 2, 0.0)


def dropper_lengths_for_cw_heights(section: Section, catenary: Catenary, cw_heights_m: np.ndarray, *,
                                   tolerance_m: float = 1e-12, max_iterations: int = 20,
                                   allow_slack: bool = False) -> InverseResult:
    """Unstretched dropper lengths giving the CW heights ``cw_heights_m`` at every dropper.

    Parameters
    ----------
    section : Section
        Geometry and tensions; its dropper lengths are the starting guess.
    catenary : Catenary
    cw_heights_m : array_like
        Target CW height at each dropper's CW clamp [m] (at the dropper for vertical ones).
    allow_slack : bool
        Make droppers slack where the target needs compression (module docstring), instead of
        raising.

    Raises
    ------
    NoTautSolutionError
        If the target needs a dropper in compression (no taut solution exists) and
        ``allow_slack`` is False.
    ValueError
        If ``cw_heights_m`` has the wrong size (a programming error).
    ConvergenceError
        If the lengths do not settle (should not happen: the weight coupling is weak).
    """
    target = np.asarray(cw_heights_m, dtype=float)
    if target.shape != section.dropper_lengths_m.shape:
        raise ValueError(f"cw_heights_m: expected {section.dropper_lengths_m.size} heights, got {target.size}")
    ea = catenary.droppers.axial_stiffness_n
    lengths = section.dropper_lengths_m.copy()
    no_droppers = np.zeros(lengths.size, dtype=bool)
    slack = np.zeros(lengths.size, dtype=bool)
    for _ in range(max_iterations):
        model = StaticModel(section.with_dropper_lengths(lengths), catenary)
        # CW with its (pulling) dropper points prescribed: the reactions there are the dropper tensions.
        while True:
            held = ~slack
            u, k, f = model.linear_solve(no_droppers, model.f_gravity, model.dropper_cw_dof[held], target[held])
            force = np.where(held, (k @ u - f)[model.dropper_cw_dof], 0.0)
            pushing = held & (force <= 0)
            if not np.any(pushing):
                break
            if not allow_slack:
                raise NoTautSolutionError(_compression(section, pushing, force))
            slack |= pushing
        # MW under its weight and the dropper tensions.
        loads = model.f_gravity.copy()
        np.add.at(loads, model.dropper_mw_dof, -force)
        np.add.at(loads, model.dropper_cw_dof, force)
        u_mw, _, _ = model.linear_solve(no_droppers, loads)
        stretched = u_mw[model.dropper_mw_dof] - np.where(slack, u[model.dropper_cw_dof], target)
        if np.any(section.clamp_offset_m):
            vertical = stretched - force / model.dropper_stiffness_n_m  # fixed point: k_v depends on L
            new = np.sqrt(vertical ** 2 + section.clamp_offset_m ** 2)
        else:
            new = stretched * ea / (ea + force)
        new = np.where(slack, np.sqrt((stretched + SLACK_MARGIN_M) ** 2 + section.clamp_offset_m ** 2), new)
        change = np.max(np.abs(new - lengths))
        lengths = new
        if change < tolerance_m:
            break
    else:
        raise ConvergenceError(f"dropper lengths did not settle in {max_iterations} passes (last change {change:.3g} m)")
    return InverseResult(lengths, force, section.with_dropper_lengths(lengths), slack)


def _compression(section: Section, pushing: np.ndarray, force: np.ndarray) -> str:
    """Why a target has no taut solution: the droppers it needs in compression, and their forces."""
    bad = np.flatnonzero(pushing)
    first = np.searchsorted(section.dropper_span, section.dropper_span[bad])
    where = ", ".join(f"span {s + 1} dropper {i + 1}" for s, i in zip(section.dropper_span[bad], bad - first))
    return (f"target CW profile needs {where} in compression (forces {np.round(force[bad], 3).tolist()} N); "
            "no taut dropper lengths produce it")


def dropper_lengths_for_many(section: Section, catenary: Catenary, cw_heights_m: np.ndarray, *,
                             tolerance_m: float = 1e-12, max_iterations: int = 20
                             ) -> tuple[np.ndarray, list[str]]:
    """:func:`dropper_lengths_for_cw_heights` (taut droppers) for many targets on one geometry.

    The section's wires, tensions and supports are the same for every target: only the
    prescribed CW heights and, through the droppers' half weights, the loads differ, so each of a
    pass's two linear solves is one factorisation for every target at once (a load case each,
    :meth:`~catenary.physics.static.StaticModel.linear_solve`). The passes are those of the
    single-target solver, to the same tolerance.

    Parameters
    ----------
    section : Section
        Geometry and tensions, its droppers vertical; its dropper lengths are the starting guess
        of every target.
    catenary : Catenary
    cw_heights_m : numpy.ndarray, shape (n_targets, n_droppers)
        Target CW heights at the droppers [m].

    Returns
    -------
    lengths : numpy.ndarray, shape (n_targets, n_droppers)
        Unstretched dropper lengths [m]; NaN for a target without a taut solution.
    failures : list of str
        Per target, empty or why it has no taut solution (the droppers it needs in compression).

    Raises
    ------
    ValueError
        If the droppers are inclined or the targets' shape is wrong (programming errors).
    ConvergenceError
        If the lengths do not settle.
    """
    target = np.atleast_2d(np.asarray(cw_heights_m, dtype=float))
    n_d = section.dropper_lengths_m.size
    if target.shape[1:] != (n_d,):
        raise ValueError(f"cw_heights_m: expected shape (n_targets, {n_d}), got {target.shape}")
    if np.any(section.clamp_offset_m):
        raise ValueError("dropper_lengths_for_many: vertical droppers only (inclined ones: dropper_lengths_for_cw_heights)")
    model = StaticModel(section, catenary)
    ea = catenary.droppers.axial_stiffness_n
    half_weight = 0.5 * catenary.gravity_m_s2 * catenary.droppers.mass_per_length_kg_m   # on each wire [N/m]
    cw, mw = model.dropper_cw_dof, model.dropper_mw_dof
    no_droppers = np.zeros(n_d, dtype=bool)
    lengths = np.broadcast_to(section.dropper_lengths_m, target.shape).copy()
    failures = [""] * target.shape[0]
    active = np.arange(target.shape[0])
    for _ in range(max_iterations):
        # the model's gravity loads with each target's half dropper weights (a column each)
        loads = np.repeat(model.f_gravity[:, None], active.size, axis=1)
        extra = -half_weight * (lengths[active] - section.dropper_lengths_m).T
        np.add.at(loads, cw, extra)
        np.add.at(loads, mw, extra)
        # CW with its dropper points prescribed: the reactions there are the dropper tensions
        u, k, f = model.linear_solve(no_droppers, loads, cw, target[active].T)
        force = (k @ u - f)[cw].T
        pushing = force <= 0.0
        bad = pushing.any(axis=1)
        for row in np.flatnonzero(bad):
            failures[active[row]] = _compression(section, pushing[row], force[row])
            lengths[active[row]] = np.nan
        keep = ~bad
        active, force, loads = active[keep], force[keep], loads[:, keep]
        if active.size == 0:
            break
        # MW under its weight and the dropper tensions
        np.add.at(loads, mw, -force.T)
        np.add.at(loads, cw, force.T)
        u_mw, _, _ = model.linear_solve(no_droppers, loads)
        new = (u_mw[mw].T - target[active]) * ea / (ea + force)
        change = np.max(np.abs(new - lengths[active]))
        lengths[active] = new
        if change < tolerance_m:
            break
    else:
        raise ConvergenceError(f"dropper lengths did not settle in {max_iterations} passes (last change {change:.3g} m)")
    return lengths, failures


def nominal_dropper_lengths(span_type: SpanType, catenary: Catenary) -> InverseResult:
    """Nominal dropper table of ``span_type``: the lengths giving its presag profile on one
    span at the design tensions and system height, steady arms at the design height."""
    x = span_type.dropper_positions_m
    guess = np.full(x.size, span_type.system_height_m)
    section = single_span(span_type, guess)
    target = span_type.cw_height_m + presag_deflection_m(span_type, x)
    return dropper_lengths_for_cw_heights(section, catenary, target)
