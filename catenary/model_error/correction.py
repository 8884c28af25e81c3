"""How far one standard uncertainty of each source moves the corrected W.

At convergence the correction's model ``S`` (static CW heights) satisfies
``M = S − U(S, θ)``: the measured heights ``M`` are the static ones less the uplift ``U`` that the
simulated pass with the model's inputs ``θ`` predicts. With another ``θ'`` the fixed point moves to
``S' ≈ S + U(S, θ') − U(S, θ)`` — to first order — when the uplift did not itself depend on the
geometry. Quasi-statically it hardly does (the correction's passes contract the gap by ≈ 1e-2),
dynamically it does (the pantograph's inertia answers the profile: the passes contract by only
0.3–0.5), so the shift is found by the correction's own fixed-point step, with the perturbed
inputs, from the converged model: move the model's static heights by the difference between the
base pass and the perturbed pass over the moved model, until a pass moves W by less than
``tolerance_m`` (the error falls by the contraction per pass: 2–3 passes quasi-statically, 4–6
dynamically). The static W of the moved model (exact inverse static solver, as
the correction moves its model) less the converged static W is the shift of the corrected W.
Working on the difference of two simulated passes, it does not see the base correction's own
residual gap (up to its tolerance). Its accuracy against a full correction at ``θ'`` is measured in
``tests/test_model_error.py``; in quasi-static passes the uplift is proportional to the force, so
the force's shift is also checked against ``(corrected W − measured W) · δF / F``.

Only measured spans move: an unmeasured span kept in the model keeps its design, as in the
correction.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import pandas as pd

from ..config import Catenary
from ..dropper_table import dropper_lengths_for_cw_heights
from ..errors import ConvergenceError
from ..measuring import measuring_pass
from ..pantograph import Pantograph
from ..section import Section
from ..static import StaticModel
from .sources import Source, perturbed

__all__ = ["run_shifts", "shifts_table", "w_shifts"]


def _static_w(section: Section, catenary: Catenary) -> np.ndarray:
    return StaticModel(section, catenary).solve().dropper_deflection_m()


def w_shifts(section: Section, measured: np.ndarray, catenary: Catenary, pantograph: Pantograph,
             speed_m_s: float, sources: Sequence[Source], *, mode: str, time_step_s: float, direction: int = 1,
             speed_profile: tuple[np.ndarray, np.ndarray] | None = None, k: float = 1.0,
             tolerance_m: float = 5e-6, max_passes: int = 8) -> dict[str, np.ndarray]:
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
        The iteration stops when a pass moves no dropper's W shift by more than this [m] (5 µm:
        a few per cent of a typical shift; the error left is about the last move times
        contraction / (1 − contraction), ≈ 3 µm dynamically).
    max_passes : int
        Largest number of moves of the model per source.

    Returns
    -------
    dict
        Source name → shift of W per dropper of the run, in the section's dropper order [m].

    Raises
    ------
    ConvergenceError
        A static or dynamic solve that did not converge (the caller reports it per run).
    ConfigError
        A source the pantograph cannot take (:func:`~catenary.model_error.sources.perturbed`).
    """
    points = np.concatenate([section.dropper_chainage_m, section.mast_chainage_m])
    n_d = section.dropper_chainage_m.size
    on_d = np.asarray(measured, dtype=bool)[section.dropper_span]
    on_m = np.r_[measured, False] | np.r_[False, measured]

    def simulate_over(model: Section, panto: Pantograph, cat: Catenary, speed: float) -> np.ndarray:
        kwargs = {"direction": direction} if direction != 1 else {}
        if speed_profile is not None:
            kwargs["speed_profile"] = (speed_profile[0], speed_profile[1] * speed / speed_m_s)
        return measuring_pass(model, cat, panto, speed_m_s=speed, mode=mode, time_step_s=time_step_s,
                              chainage_m=points, **kwargs).height_m

    base = simulate_over(section, pantograph, catenary, speed_m_s)
    base_w = _static_w(section, catenary)
    targets = StaticModel(section, catenary).solve().cw_height_at(section.cw_clamp_chainage_m)
    out = {}
    for source in sources:
        inputs = perturbed(source, k, pantograph, catenary, speed_m_s)
        model, d_d, d_m = section, np.zeros(n_d), np.zeros(points.size - n_d)
        shift = np.zeros_like(base_w)
        for done in range(1, max_passes + 1):
            # the correction's own step, with the perturbed inputs: move the static heights until
            # the perturbed pass over the moved model reports what the base pass reported
            gap = base - simulate_over(model, *inputs)
            d_d += np.where(on_d, gap[:n_d], 0.0)
            d_m += np.where(on_m, gap[n_d:], 0.0)
            shifted = section.with_cw_support_heights(section.cw_support_heights_m + d_m)
            model = dropper_lengths_for_cw_heights(shifted, catenary, targets + d_d, allow_slack=True).section
            previous, shift = shift, _static_w(model, catenary) - base_w
            # settled when a pass moves no W by more than the tolerance (a slack dropper's point,
            # which the model cannot reach, stops moving W rather than closing its gap)
            if done > 1 and np.max(np.abs(shift - previous)) < tolerance_m:
                break
        else:
            raise ConvergenceError(f"source {source.name}: the shift of W still moved by "
                                   f"{1e3 * np.max(np.abs(shift - previous)):.4f} mm at pass {max_passes}")
        out[source.name] = shift
    return out


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
    standard uncertainty] and ``status`` ("" or why the shift could not be measured: the
    correction failed on the run, or a perturbed pass did not converge)."""
    measured = rows["measured"].to_numpy(dtype=bool) if "measured" in rows else np.ones(len(rows), dtype=bool)
    span_ids = rows["span_id"].astype(str).tolist()
    status = ""
    shifts = {}
    if result.section is None or result.failure:
        status = f"not measured: the correction failed on this run ({result.failure})"
    else:
        try:
            shifts = w_shifts(result.section, measured, catenary, pantograph, speed_m_s, sources, mode=mode,
                              time_step_s=time_step_s, direction=direction, speed_profile=speed_profile)
        except ConvergenceError as exc:
            status = f"not measured: a perturbed pass did not converge ({exc})"
    if not shifts:
        dropper_span = np.repeat(np.arange(len(rows)), n_max)      # every value NaN: no shape to keep
        shifts = {s.name: np.full(dropper_span.size, np.nan) for s in sources}
    else:
        dropper_span = result.section.dropper_span
    table = shifts_table(span_ids, dropper_span, shifts, n_max, measured)
    keys = rows.set_index(rows["span_id"].astype(str))
    table.insert(0, "span_type", keys.loc[table["span_id"], "span_type"].to_numpy())
    table.insert(0, "section_id", keys.loc[table["span_id"], "section_id"].to_numpy())
    table.insert(0, "run_id", str(rows["run_id"].iloc[0]) if "run_id" in rows else "run")
    return table.assign(status=status)
