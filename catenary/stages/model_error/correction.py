"""How far one standard uncertainty of each source moves the corrected W.

At convergence the correction's model ``S`` (static CW heights) satisfies
``M = S − U(S, θ)``: the measured heights ``M`` are the static ones less the uplift ``U`` that the
simulated pass with the model's inputs ``θ`` predicts. With another ``θ'`` the fixed point moves to
``S' ≈ S + U(S, θ') − U(S, θ)`` — to first order — when the uplift did not itself depend on the
geometry. Quasi-statically it hardly does (the correction's passes contract the gap by ≈ 1e-2),
dynamically it does (the pantograph's inertia answers the profile: the passes contract by only
0.3–0.5), so the shift is found by the correction's own fixed-point step, with the perturbed
inputs, from the converged model: move the model's static heights by the difference between the
base pass and the perturbed pass over the moved model, until that pass reports the base pass's
heights within ``tolerance_m`` (the residual falls by the contraction per pass: 2–3 passes
quasi-statically, 4–6 dynamically on a smooth profile).

What the budget needs is the part of the shift that every span shares — a systematic of the
car's model — so convergence is judged on the span-common gap (per dropper rank, the mean over the
run's measured spans). On a profile roughened by the sensor's noise the pointwise gap stalls
after one move at 0.03–0.05 mm (measured on the small campaign's sections, where further passes
drift a mid-span W by ≈ 0.04 mm each: a rough direction the pass hardly sees, in which the
measurement does not fix W — nor did it fix the correction's own W); that part differs from span
to span, averages out over a span type's spans and is left to the noise. The iteration stops when
the span-common residual is below ``tolerance_m`` or no longer falls (:data:`STAGNATION`), keeps
the model with the smallest residual and writes the residual beside the shift. Each move mixes the
last passes (Anderson mixing, :func:`_anderson_step`): on those sections the plain step drifts
the rough part of W by ≈ 0.04 mm per pass without end, the mixed one holds it. The static W of the moved model (exact inverse static solver, as
the correction moves its model) less the converged static W is the shift of the corrected W.
Working on the difference of two simulated passes, it does not see the base correction's own
residual gap (up to its tolerance). Its accuracy against a full correction at ``θ'`` is measured in
``tests/test_model_error.py``; in quasi-static passes the uplift is proportional to the force, so
the force's shift is also checked against ``(corrected W − measured W) · δF / F``.

Only measured spans move: an unmeasured span kept in the model keeps its design, as in the
correction.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
import pandas as pd

from catenary.physics.config import Catenary
from catenary.physics.dropper_table import dropper_lengths_for_cw_heights
from catenary.physics.measuring import measuring_pass
from catenary.physics.pantograph import Pantograph
from catenary.physics.section import Section
from catenary.physics.static import StaticModel
from catenary.plumbing.errors import ConvergenceError
from .sources import Source, perturbed

__all__ = ["RESOLUTION_FLOOR_M", "STAGNATION", "UNSETTLED", "SectionBudget", "Shift", "run_shifts", "shift_columns", "shifts_table",
           "w_shifts"]

#: A pass that leaves more than this fraction of the previous pass's span-common residual has
#: stopped settling: the iteration stops there and keeps its best model. Measured on the small
#: campaign's 20-span sections: the residual falls by 0.7–0.8 per pass (Anderson mixing) down to
#: a floor of ≈ 0.01 mm, the rough part of the gap (0.03–0.05 mm pointwise, different in every
#: span) averaged over the spans.
STAGNATION = 0.9

#: A shift whose residual stays above this fraction of its source's direct effect, and above
#: :data:`RESOLUTION_FLOOR_M`, is not given (its status says so): the moved model does not solve
#: the correction's equation for it. Measured on the small campaign: force 0.004 of 0.36 mm,
#: head mass and catenary damping 0.005–0.013 of 0.011–0.024 mm (the floor), speed +1 % 0.062
#: of 0.062 mm on N2 — a pattern alternating from dropper to dropper that the pantograph's
#: response to a static change of height cannot reproduce.
UNSETTLED = 0.5

#: Residual below which a shift is given whatever its direct effect [m]: a systematic of
#: 0.02 mm per dropper moves T_MW's mean by ≈ 4 N, 2 % of its standard error on 20 spans.
RESOLUTION_FLOOR_M = 2e-5


def _static_w(section: Section, catenary: Catenary) -> np.ndarray:
    return StaticModel(section, catenary).solve().dropper_deflection_m()


@dataclass(frozen=True)
class Shift:
    """The shift of one run's corrected W for one source.

    Attributes
    ----------
    w_m : numpy.ndarray
        Shift of the static W per dropper of the run, in the section's dropper order [m].
    residual_m : float
        Largest span-common height gap left between the perturbed pass over the moved model and
        the base pass (at each dropper rank, the mean over the run's measured spans; and the
        masts') [m]: the accuracy to which the moved model solves the correction's equation in
        what is shared by every span (the correction itself stops at a gap norm of 1 mm).
    direct_m : float
        The same before any move: the source's direct effect on the span-common heights [m].
    passes : int
        Simulated passes with the perturbed inputs.
    """

    w_m: np.ndarray
    residual_m: float
    direct_m: float
    passes: int


def w_shifts(section: Section, measured: np.ndarray, catenary: Catenary, pantograph: Pantograph,
             speed_m_s: float, sources: Sequence[Source], *, mode: str, time_step_s: float, direction: int = 1,
             speed_profile: tuple[np.ndarray, np.ndarray] | None = None, k: float = 1.0,
             tolerance_m: float = 5e-6, max_passes: int = 8, memory: int = 3,
             base_height_m: np.ndarray | None = None) -> dict[str, Shift]:
    """Shift of the corrected static W of every dropper when each source moves by ``k`` standard
    uncertainties (module docstring).

    Parameters
    ----------
    section : Section
        The correction's converged model of one run of consecutive spans.
    measured : numpy.ndarray of bool
        Per span of the run: measured (moves) or kept unmeasured in the model (does not).
    catenary, pantograph, speed_m_s
        The correction's inputs for this run (the pantograph at the run's force) [m/s].
    sources : sequence of Source
    mode, time_step_s, direction, speed_profile
        The correction's simulated pass for this run.
    k : float
        Multiple of each source's standard uncertainty.
    tolerance_m : float
        The iteration stops when the perturbed pass over the moved model reports the base pass's
        span-common heights (:attr:`Shift.residual_m`) within this [m] (5 µm: a few per cent of a
        typical shift).
    max_passes : int
        Largest number of moves of the model per source.
    memory : int
        Past passes mixed into each move (:func:`_anderson_step`; 0: the correction's plain step).
    base_height_m : numpy.ndarray, optional
        The base pass over ``section`` with the correction's inputs, at its droppers then its
        masts [m], if the caller has it (the correction's last pass:
        :attr:`catenary.stages.correction.RunCorrection.simulated_height_m`); simulated otherwise.

    Returns
    -------
    dict
        Source name → :class:`Shift`. The moved model kept is the one with the smallest residual:
        the iteration also stops when a pass no longer reduces the residual by
        :data:`STAGNATION` (module docstring); the residual is written beside the shift and
        judged by :func:`run_shifts`.

    Raises
    ------
    ConvergenceError
        A static or dynamic solve that did not converge (the caller reports it per run).
    ConfigError
        A source the pantograph cannot take (:func:`~catenary.stages.model_error.sources.perturbed`).
    """
    points = np.concatenate([section.dropper_chainage_m, section.mast_chainage_m])
    n_d = section.dropper_chainage_m.size
    on_d = np.asarray(measured, dtype=bool)[section.dropper_span]
    on_m = np.r_[measured, False] | np.r_[False, measured]
    first = np.searchsorted(section.dropper_span, section.dropper_span)
    place = np.r_[np.arange(n_d) - first, np.full(points.size - n_d, n_d)]   # dropper rank in its span; masts
    on = np.r_[on_d, on_m]

    def common(gap: np.ndarray) -> float:
        # the largest span-common gap: the mean over the measured spans at each dropper rank
        # (and over the masts), what a systematic of the car's model leaves in every span
        sums = np.bincount(place[on], weights=gap[on], minlength=n_d + 1)
        counts = np.bincount(place[on], minlength=n_d + 1)
        return float(np.max(np.abs(sums[counts > 0] / counts[counts > 0]), initial=0.0))

    def simulate_over(model: Section, panto: Pantograph, cat: Catenary, speed: float) -> np.ndarray:
        kwargs = {"direction": direction} if direction != 1 else {}
        if speed_profile is not None:
            kwargs["speed_profile"] = (speed_profile[0], speed_profile[1] * speed / speed_m_s)
        return measuring_pass(model, cat, panto, speed_m_s=speed, mode=mode, time_step_s=time_step_s,
                              chainage_m=points, **kwargs).height_m

    base = (simulate_over(section, pantograph, catenary, speed_m_s) if base_height_m is None
            else np.asarray(base_height_m, dtype=float))
    if base.shape != points.shape:
        raise ValueError(f"base_height_m: expected {points.size} heights (droppers, then masts), got {base.shape}")
    base_w = _static_w(section, catenary)
    targets = StaticModel(section, catenary).solve().cw_height_at(section.cw_clamp_chainage_m)
    out = {}
    for source in sources:
        inputs = perturbed(source, k, pantograph, catenary, speed_m_s)
        model, x = section, np.zeros(points.size)
        shift = np.zeros_like(base_w)
        best, direct, previous = None, None, np.inf
        xs, fs = [], []
        for done in range(max_passes + 1):
            # the correction's own step, with the perturbed inputs: move the static heights until
            # the perturbed pass over the moved model reports what the base pass reported
            gap = base - simulate_over(model, *inputs)
            residual = common(gap)
            direct = residual if direct is None else direct
            if best is None or residual < best.residual_m:
                best = Shift(w_m=shift, residual_m=residual, direct_m=direct, passes=done + 1)
            if residual < tolerance_m or residual > STAGNATION * previous or done == max_passes:
                break
            previous = residual
            x = _anderson_step(xs, fs, x, np.where(on, gap, 0.0), memory)
            shifted = section.with_cw_support_heights(section.cw_support_heights_m + x[n_d:])
            model = dropper_lengths_for_cw_heights(shifted, catenary, targets + x[:n_d], allow_slack=True).section
            shift = _static_w(model, catenary) - base_w
        out[source.name] = Shift(w_m=best.w_m, residual_m=best.residual_m, direct_m=direct, passes=done + 1)
    return out


def shift_columns(n_max: int) -> list[str]:
    """Columns of :func:`run_shifts`' table for spans of at most ``n_max`` droppers."""
    return (["run_id", "section_id", "span_type", "span_id", "source"] + [f"w{i + 1}_m" for i in range(n_max)]
            + ["residual_m", "direct_m", "passes", "status"])



@dataclass
class SectionBudget:
    """The model-error budget measured on one section's corrected runs.

    Called by the correction after each run (its ``after_run`` hook, with the run's rows, its
    :class:`~catenary.stages.correction.RunCorrection`, the run's pantograph, speed [m/s],
    direction and speed profile), it measures :func:`run_shifts` on that run and keeps the rows;
    :meth:`table` is what the rule writes.

    Attributes
    ----------
    catenary : Catenary
    sources : sequence of Source
        The budget's sources (:class:`~catenary.stages.model_error.sources.ModelErrorSettings`).
    mode : str
        The correction's pass, ``"dynamic"`` or ``"quasi_static"``.
    time_step_s : float
        Its time step [s].
    n_max : int
        Most droppers in a span of the section's types (the table's W columns).
    log : logging.Logger or None
        Where each measured run is said.
    """

    catenary: Catenary
    sources: Sequence[Source]
    mode: str
    time_step_s: float
    n_max: int = 9
    log: object = None
    shifts: list = field(default_factory=list)

    def __call__(self, rows: pd.DataFrame, result, pantograph: Pantograph, speed_m_s: float, direction: int,
                 speed_profile) -> None:
        self.shifts.append(run_shifts(rows, result, self.catenary, pantograph, speed_m_s, self.sources,
                                      mode=self.mode, time_step_s=self.time_step_s, direction=direction,
                                      speed_profile=speed_profile, n_max=self.n_max))
        if self.log is not None:
            self.log.info("section %s, run %s: model-error budget measured for %d sources",
                          rows["section_id"].iloc[0], rows["run_id"].iloc[0], len(self.sources))

    def table(self) -> pd.DataFrame:
        """Every measured run's rows (:func:`shift_columns`); empty when no run was measured."""
        return (pd.concat(self.shifts, ignore_index=True) if self.shifts
                else pd.DataFrame(columns=shift_columns(self.n_max)))

def _anderson_step(xs: list, fs: list, x: np.ndarray, f: np.ndarray, memory: int) -> np.ndarray:
    """Next move of the model by Anderson mixing of the last ``memory`` passes: the plain step
    ``x + f`` corrected by the combination of past steps that best cancels the gap ``f``, as if
    the pass were linear in the move (it is, for moves of a few hundredths of a millimetre); a
    multisecant method, which settles the directions the plain step contracts slowly or not at
    all. ``memory`` 0 is the plain step."""
    xs.append(x.copy())
    fs.append(f.copy())
    del xs[:-(memory + 1)], fs[:-(memory + 1)]
    if len(xs) < 2:
        return x + f
    d_x = np.diff(np.array(xs), axis=0).T
    d_f = np.diff(np.array(fs), axis=0).T
    gamma = np.linalg.lstsq(d_f, f, rcond=None)[0]
    return x + f - (d_x + d_f) @ gamma


def shifts_table(span_ids: Sequence[str], dropper_span: np.ndarray, shifts: dict[str, np.ndarray],
                 n_max: int, measured: np.ndarray | None = None) -> pd.DataFrame:
    """One row per measured span and source: ``span_id``, ``source``, ``w1_m``… (NaN beyond a
    span's droppers) [m]."""
    n_d = np.bincount(dropper_span, minlength=len(span_ids))
    keep = np.ones(len(span_ids), dtype=bool) if measured is None else np.asarray(measured, dtype=bool)
    rows = []
    for name, shift in shifts.items():
        for k in np.flatnonzero(keep):
            w = np.full(n_max, np.nan)
            w[:n_d[k]] = shift[dropper_span == k]
            rows.append({"span_id": span_ids[k], "source": name, **{f"w{i + 1}_m": w[i] for i in range(n_max)}})
    return pd.DataFrame(rows, columns=["span_id", "source"] + [f"w{i + 1}_m" for i in range(n_max)])


def run_shifts(rows: pd.DataFrame, result, catenary: Catenary, pantograph: Pantograph, speed_m_s: float,
               sources: Sequence[Source], *, mode: str, time_step_s: float, direction: int = 1,
               speed_profile: tuple[np.ndarray, np.ndarray] | None = None, n_max: int = 9) -> pd.DataFrame:
    """:func:`w_shifts` of one corrected run of spans as a table: one row per measured span and
    source, ``run_id``, ``section_id``, ``span_type``, ``span_id``, ``source``, ``w1_m``… [m per
    standard uncertainty], ``residual_m``, ``direct_m`` and ``passes`` (:class:`Shift`, the
    run's: the residual is the shift's resolution in height) and ``status`` ("" or why the shift
    is not given: the correction failed on the run, a perturbed pass did not converge, or the
    residual stayed above :data:`UNSETTLED` of the direct effect and above
    :data:`RESOLUTION_FLOOR_M`)."""
    if not sources:
        return pd.DataFrame(columns=shift_columns(n_max))
    measured = rows["measured"].to_numpy(dtype=bool) if "measured" in rows else np.ones(len(rows), dtype=bool)
    span_ids = rows["span_id"].astype(str).tolist()
    failed = ""
    shifts: dict[str, Shift] = {}
    if result.section is None or result.failure:
        failed = f"not measured: the correction failed on this run ({result.failure})"
    else:
        # the correction's last pass is the base pass when it ran in this mode (same model, inputs
        # and points): one dynamic pass saved per run, the same heights bit for bit
        last_mode = result.history[-1][0] if result.history else None
        try:
            shifts = w_shifts(result.section, measured, catenary, pantograph, speed_m_s, sources, mode=mode,
                              time_step_s=time_step_s, direction=direction, speed_profile=speed_profile,
                              base_height_m=result.simulated_height_m if last_mode == mode else None)
        except ConvergenceError as exc:
            failed = f"not measured: a perturbed pass did not converge ({exc})"
    dropper_span = result.section.dropper_span if shifts else np.repeat(np.arange(len(rows)), n_max)
    tables = []
    for source in sources:
        got = shifts.get(source.name)
        status = failed
        if got is not None and got.residual_m > max(UNSETTLED * got.direct_m, RESOLUTION_FLOOR_M):
            status = (f"not settled: the moved model reproduces the base pass's span-common heights within "
                      f"{1e3 * got.residual_m:.3f} mm of the {1e3 * got.direct_m:.3f} mm the source moved them")
        w = got.w_m if got is not None and not status else np.full(dropper_span.size, np.nan)
        tables.append(shifts_table(span_ids, dropper_span, {source.name: w}, n_max, measured).assign(
            residual_m=got.residual_m if got is not None else np.nan,
            direct_m=got.direct_m if got is not None else np.nan,
            passes=got.passes if got is not None else 0, status=status))
    table = pd.concat(tables, ignore_index=True)
    keys = rows.set_index(rows["span_id"].astype(str))
    table.insert(0, "span_type", keys.loc[table["span_id"], "span_type"].to_numpy())
    table.insert(0, "section_id", keys.loc[table["span_id"], "section_id"].to_numpy())
    table.insert(0, "run_id", str(rows["run_id"].iloc[0]) if "run_id" in rows else "run")
    return table
