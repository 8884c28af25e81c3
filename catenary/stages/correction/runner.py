"""Iterative dynamic correction of measured spans (paper §2.2, Fig. 5).

The recording car reports the contact-wire height under a pantograph pushing ≈36 N, not the
static geometry. For each run of consecutive measured spans (a section, or the part of it
between rejected spans) a model is built with the exact span lengths and the measured support
heights, and iterated:

1. simulate the measuring pass over the model (dynamic or quasi-static,
   :func:`catenary.physics.measuring.measuring_pass`);
2. gap = measured − simulated CW height, at the droppers and at the steady arms;
3. if every span's gap norm ``√Σ_i (gap W_i)²`` is below the tolerance, stop;
4. else move the model's static CW: the steady-arm heights at the masts, the dropper lengths by
   the exact inverse static solver (:func:`catenary.physics.dropper_table.dropper_lengths_for_cw_heights`)
   so that the static CW at the droppers moves as asked: by the gap itself, except after the
   first dynamic pass, by the step that closes the gap under the measuring pass's response to
   the static CW (:mod:`.step`), where the run has one; go to 1.

The corrected static W of a span is that of the model whose simulated pass last matched the
measurement. (Applying the last gap on top, the step a next pass would take, was tried: it
took the corrected W's RMS error on two runs of 20 N2 and 20 N3 spans from 0.601 / 0.672 mm to
0.592 / 0.644 mm, but made the small profile's N3 diagnosis ambiguous between a T_MW spread and
contact-wire wear, BIC margin 0.86, and the same-direction repeatability noisier: not kept.)
The gap in W is the gap in height minus its chord between the span's two steady arms, so an
error common to a whole span's heights does not count. Tensions and system heights stay at
their design values: they are what the identification later treats as random.

A span the projection rejected between measured ones (a drop-out, a cut it could not trust)
still hangs in the line: it stays in the model, at the span type's design (its dropper table,
the steady-arm heights its neighbours measured or the design height), is run over by the
simulated pass and never corrected — so that its neighbours are not modelled as a section's end,
with anchored wires and the pantograph starting there (that alone moved their corrected W by
≈ 3 mm on the small campaign). Only the measured spans' gaps drive and stop the iteration.

Each run of the recording is corrected on its own, with its own measuring pass: in its
direction of travel (the pantograph's lag makes a run towards decreasing chainage report other
heights than one towards increasing chainage) and at the local speed of each span (the median of
the recording's ``speed_kmh`` over the span, as the projection gives it; a speed profile through
the spans' middles, held beyond the first and last), not one speed per file.

*Several runs.* Where several runs corrected a span to convergence, each run of spans is then
passed over once more with the static W of those spans set to the runs' mean corrected W
(:func:`measured_residuals`): its measured W minus that pass's W is written per span and dropper
(``residual_w*_m``; NaN for a span one run measured). Their scatter between runs is the
measurement's own repeatability (:mod:`catenary.measurement.repeatability`): unlike the corrected W's, it
holds nothing of where each run's correction stopped, which differs between directions of travel
where a dropper hangs slack.

One module, one concern (hence over 500 lines): the iterative correction of a section's runs (its
loop, the several runs' residual pass, the convergence record); its settings, the tables it writes
and the measuring pass's lag are apart (:mod:`.settings`, :mod:`.outputs`, :mod:`.lag`), and so are
the measuring pass and the inverse static solver it calls (:mod:`catenary.physics.measuring`,
:mod:`catenary.physics.dropper_table`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from catenary.physics.config import Catenary
from catenary.physics.dropper_table import dropper_lengths_for_cw_heights, presag_deflection_m
from catenary.physics.measuring import measuring_pass
from catenary.physics.pantograph import Pantograph
from catenary.physics.section import Section
from catenary.physics.static import StaticModel
from catenary.plumbing.errors import ConvergenceError, InputError
from catenary.plumbing.progress import Progress

from .settings import CorrectionSettings
from .step import SupportResponse, run_response, step_move

#: Largest mismatch [m] between the end of a span and the start of the next for them to be
#: modelled as one run of consecutive spans (the projection copies the masts' chainages).
CONTIGUITY_TOLERANCE_M = 1e-6
#: The quasi-static start stops once a pass no longer halves the largest gap (it stays above this
#: fraction of the previous pass's): it is there to bring the model near the measurement cheaply,
#: and a span whose gap stalls (a dropper at the edge of slack: 0.127, 0.128, 0.129 mm in passes
#: 2–5 of a typical section) would otherwise hold every section to its 5 passes — 40 % of the
#: 10 000-span line's sections made 4 or 5 of them, and the dynamic passes after them were as
#: many (1 246 against 1 249). Where the dynamic passes end moves within their tolerance: on the
#: 1 000-span line half of N3's corrected spans by up to 1.03 mm, as close to the truth (RMS).
QUASI_STATIC_STALL = 0.5
#: A pass in the settings' mode ends the loop when it took less than 3 % off the gap of every
#: span still above the tolerance (each stays above this fraction of its gap after the pass
#: before, in the same mode): what is left is held by what a further pass does not move — a
#: dropper at the edge of slack, whose span's gap sits at 1.1–1.5 mm pass after pass (1.43,
#: 1.43, 1.43 mm; 1.10, 1.10 mm on the 1 000-span line) — and 40 of the 10 000-span line's 500
#: sections made their 5 dynamic passes for it. Such a span ends unconverged either way; a gap
#: still shrinking (the dynamic passes contract by 0.25–0.9) is left to the tolerance.
DYNAMIC_STALL = 0.97
#: Columns of the corrected profiles (:func:`correct_spans`; ``results/{span_type}/corrected_profiles.parquet``):
#: per measured sample, its height, the final model's simulated pass and its static CW height [m].
PROFILE_COLUMNS = ("span_id", "run_id", "x_m", "height_m", "simulated_height_m", "static_height_m")


@dataclass
class RunCorrection:
    """Outcome of the correction of one run of consecutive spans.

    Attributes
    ----------
    span_id : numpy.ndarray
        The run's spans, in chainage order.
    static_w_m : numpy.ndarray
        Corrected static W, (n_spans, n_droppers) [m] (NaN beyond a span's droppers).
    gap_norm_m : numpy.ndarray
        Final gap norm of each span [m].
    iterations : int
        Simulated passes made in the settings' mode (the quasi-static start not counted).
    history : list of (str, numpy.ndarray)
        Mode and gap norm of each span after each pass [m].
    dropper_lengths_m : numpy.ndarray
        Dropper lengths of the final model [m] (all droppers of the run).
    failure : str
        Empty, or why the run could not be corrected.
    slack_droppers : numpy.ndarray
        Droppers per span that the final model needs slack (the measured CW there lies higher
        than the neighbours let a taut dropper hold it).
    section : Section or None
        The final model (None when the run failed): what the model-error budget perturbs.
    simulated_height_m : numpy.ndarray or None
        The last simulated pass, over the final model: CW heights at the run's droppers, then
        at its masts [m] (None when the run failed); the model-error budget's base pass.
    dropper_force_n : numpy.ndarray or None
        Static tension of every dropper of the final model, (n_spans, n_droppers) [N] (NaN beyond
        a span's droppers; None when the run failed): a dropper that carries less than the
        measuring pass unloads it by may go slack under the pantograph.
    profile_simulated_m, profile_static_m : numpy.ndarray or None
        At the run's profile chainages (``correct_run``'s ``profile_chainage_m``): the final
        model's simulated measuring pass and its static CW height [m] (None without profile
        chainages or when the run failed).
    """

    span_id: np.ndarray
    static_w_m: np.ndarray
    gap_norm_m: np.ndarray
    iterations: int
    history: list = field(default_factory=list)
    dropper_lengths_m: np.ndarray | None = None
    failure: str = ""
    slack_droppers: np.ndarray | None = None
    section: Section | None = None
    simulated_height_m: np.ndarray | None = None
    dropper_force_n: np.ndarray | None = None
    profile_simulated_m: np.ndarray | None = None
    profile_static_m: np.ndarray | None = None


def fill_unmeasured(rows: pd.DataFrame, report: pd.DataFrame, catenary: Catenary) -> pd.DataFrame:
    """The spans of one run and section, measured ones (``rows``) and, between and around them,
    the spans the projection rejected (``report`` rows of that run and section with a known span
    type), in chainage order, with ``measured`` true or false (module docs).

    A rejected span gets the design W (:func:`catenary.physics.dropper_table.presag_deflection_m`) and the
    steady-arm heights of its measured neighbours (the design height where none is measured)."""
    rows = rows.assign(measured=True)
    run_id, section_id = rows["run_id"].iloc[0], rows["section_id"].iloc[0]
    extra = report[(report["run_id"] == run_id) & (report["section_id"] == section_id)
                   & (report["status"] != "used") & (report["span_type"].fillna("") != "")
                   & ~report["span_id"].isin(rows["span_id"])]
    if extra.empty:
        return rows
    chain = pd.concat([rows, extra[["span_id", "run_id", "section_id", "span_type", "start_chainage_m",
                                    "end_chainage_m", "length_m"]].assign(measured=False)], ignore_index=True)
    chain = chain.sort_values("start_chainage_m", kind="stable").reset_index(drop=True)
    contiguous = np.abs(chain["start_chainage_m"].to_numpy()[1:] - chain["end_chainage_m"].to_numpy()[:-1]) <= 1e-6
    if not contiguous.all():
        return rows                               # the report does not give an unbroken chain: as measured
    for column in ("direction", "speed_kmh", "force_n"):
        if column in rows:
            chain[column] = chain[column].fillna(rows[column].iloc[0] if column == "direction" else np.nan)
    left = chain["cw_height_left_m"].to_numpy(dtype=float).copy()
    right = chain["cw_height_right_m"].to_numpy(dtype=float).copy()
    for k in range(len(chain)):                  # a mast's height from the measured span that shares it
        if not np.isfinite(left[k]) and k > 0 and np.isfinite(right[k - 1]):
            left[k] = right[k - 1]
        if not np.isfinite(right[k]) and k + 1 < len(chain) and np.isfinite(left[k + 1]):
            right[k] = left[k + 1]
    for k in range(len(chain) - 1, -1, -1):
        if not np.isfinite(right[k]) and k + 1 < len(chain) and np.isfinite(left[k + 1]):
            right[k] = left[k + 1]
        if not np.isfinite(left[k]) and k > 0 and np.isfinite(right[k - 1]):
            left[k] = right[k - 1]
    design = np.array([catenary.span_type(t).cw_height_m for t in chain["span_type"]])
    chain["cw_height_left_m"] = np.where(np.isfinite(left), left, design)
    chain["cw_height_right_m"] = np.where(np.isfinite(right), right, design)
    for k in np.flatnonzero(~chain["measured"].to_numpy(dtype=bool)):
        st = catenary.span_type(chain.loc[k, "span_type"])
        for i, w in enumerate(presag_deflection_m(st, st.dropper_positions_m)):
            chain.loc[k, f"w{i + 1}_m"] = w
    return chain


def consecutive_runs(spans: pd.DataFrame) -> list[pd.DataFrame]:
    """Split projected spans into runs of consecutive spans of one section and one measuring run.

    Parameters
    ----------
    spans : pandas.DataFrame
        Rows of the projection's ``spans.parquet`` (any span types), with ``span_type``.

    Returns
    -------
    list of pandas.DataFrame
        Each sorted by chainage; a run ends at a section change or where a span is missing
        (rejected by the projection); the recording's runs apart (in order of appearance).
    """
    runs = []
    keys = ["run_id", "section_id"] if "run_id" in spans.columns else ["section_id"]
    for _, rows in spans.sort_values("start_chainage_m").groupby(keys, sort=False):
        rows = rows.reset_index(drop=True)
        breaks = np.flatnonzero(np.abs(rows["start_chainage_m"].to_numpy()[1:]
                                       - rows["end_chainage_m"].to_numpy()[:-1]) > CONTIGUITY_TOLERANCE_M) + 1
        for part in np.split(np.arange(len(rows)), breaks):
            runs.append(rows.iloc[part].reset_index(drop=True))
    return runs


def measured_heights(rows: pd.DataFrame, section: Section) -> tuple[np.ndarray, np.ndarray]:
    """Measured CW heights of a run at its droppers (chord + W) and at its steady arms [m]."""
    masts = _mast_heights(rows)
    w = np.concatenate([rows.loc[k, [f"w{i + 1}_m" for i in range(int(n))]].to_numpy(dtype=float)
                        for k, n in enumerate(np.bincount(section.dropper_span, minlength=len(rows)))])
    return section.chord_at_droppers(masts) + w, masts


def _mast_heights(rows: pd.DataFrame) -> np.ndarray:
    """Measured CW height at each steady arm of a run [m], shape (n_spans + 1,)."""
    return np.append(rows["cw_height_left_m"].to_numpy(dtype=float), rows["cw_height_right_m"].iloc[-1])


def run_section(rows: pd.DataFrame, catenary: Catenary, dropper_lengths_m: np.ndarray | None = None) -> Section:
    """Model of a run: exact span lengths, the span types' dropper positions, design tensions and
    system heights, measured steady-arm heights; droppers at ``dropper_lengths_m`` (default: the
    system height, a starting guess for the inverse solver)."""
    types = [catenary.span_type(t) for t in rows["span_type"]]
    lengths = (rows["end_chainage_m"] - rows["start_chainage_m"]).to_numpy(dtype=float)
    x = np.concatenate([t.dropper_positions_m for t in types])
    span = np.repeat(np.arange(len(types)), [t.n_droppers for t in types])
    system = np.array([t.system_height_m for t in types])
    masts = _mast_heights(rows)
    return Section(
        span_lengths_m=lengths, dropper_span=span, dropper_x_m=x,
        dropper_lengths_m=system[span] if dropper_lengths_m is None else dropper_lengths_m,
        cw_support_heights_m=masts, system_heights_m=np.append(system, system[-1]),
        contact_tension_n=np.array([t.contact_tension_n for t in types]),
        messenger_tension_n=np.array([t.messenger_tension_n for t in types]))


def correct_run(rows: pd.DataFrame, catenary: Catenary, pantograph: Pantograph, speed_m_s: float,
                settings: CorrectionSettings, log=None, *, direction: int = 1,
                speed_profile: tuple[np.ndarray, np.ndarray] | None = None,
                profile_chainage_m: np.ndarray | None = None, responses: list[SupportResponse] = ()) -> RunCorrection:
    """Correct one run of consecutive spans (module docstring).

    Parameters
    ----------
    rows : pandas.DataFrame
        The run's projected spans in chainage order (``span_type``, chainages, ``cw_height_left_m``,
        ``cw_height_right_m``, ``w1_m``…).
    catenary : Catenary
    pantograph : Pantograph
        The measuring pantograph, at the recording's static force.
    speed_m_s : float
        Measuring speed [m/s] (where no profile is given).
    settings : CorrectionSettings
    log : logging.Logger, optional
        Where each pass's progress goes (gap, spans within tolerance, elapsed time, estimate of
        the time left against the maximum number of passes).
    direction : int
        +1: the car ran towards increasing chainage; -1: towards decreasing.
    speed_profile : (numpy.ndarray, numpy.ndarray), optional
        Speed [m/s] along the run of spans, at chainages from its first mast [m].
    profile_chainage_m : numpy.ndarray, optional
        Chainages from the run's first mast [m] (the recorded samples between the droppers)
        at which the final model's simulated pass and static CW height are returned too: a
        dynamic pass reports them at no extra cost (they are read off the same run); after a
        quasi-static last pass they cost one static solve each.
    responses : list of SupportResponse
        The measuring pass's responses per span type in the run's direction (:mod:`.step`): the
        first dynamic pass's gap moves the static CW by the step they give (the later ones, and
        a span type without a response, by the gap itself).

    Returns
    -------
    RunCorrection
        ``failure`` says why when a static or dynamic solve did not converge (a
        :class:`~catenary.plumbing.errors.ConvergenceError`); any other error propagates.
    """
    span_ids = rows["span_id"].to_numpy()
    section = run_section(rows, catenary)
    n_d = np.bincount(section.dropper_span, minlength=len(rows))
    measured_d, measured_m = measured_heights(rows, section)
    measured = _measured(rows)
    # only measured spans have gaps: an unmeasured span keeps its design; a mast only unmeasured
    # spans hold keeps its height
    on_measured_d = measured[section.dropper_span]
    on_measured_m = np.r_[measured, False] | np.r_[False, measured]
    points = np.concatenate([section.dropper_chainage_m, section.mast_chainage_m])
    n_points = points.size
    profile_x = np.zeros(0) if profile_chainage_m is None else np.asarray(profile_chainage_m, dtype=float)
    static_d = measured_d.copy()       # first guess: the measurement is static
    history: list[tuple[str, np.ndarray]] = []
    empty = np.full((len(rows), n_d.max()), np.nan)
    run_kwargs = {}
    if direction != 1:
        run_kwargs["direction"] = direction
    if speed_profile is not None:
        run_kwargs["speed_profile"] = speed_profile
    response = (run_response(list(rows["span_type"].astype(str)), list(n_d), list(responses), direction)
                if settings.mode == "dynamic" and len(responses) else None)
    stages = [(settings.mode, settings.tolerance_m)]
    if settings.mode == "dynamic" and settings.quasi_static_start:
        # Cheap quasi-static passes remove most of the gap before the dynamic ones.
        stages.insert(0, ("quasi_static", 0.1 * settings.tolerance_m))
    try:
        for mode, tolerance in stages:
            # one estimate per stage: a dynamic pass costs ≈ 20 quasi-static ones
            progress = Progress(log, f"section {rows['section_id'].iloc[0]} correction", settings.max_iterations,
                                f"{mode} passes", bound=True, every_s=0.0)
            for done in range(1, settings.max_iterations + 1):
                if history:          # move the static CW: by the response's step after the first dynamic pass (.step)
                    first_dynamic = last_mode == "dynamic" and sum(m == "dynamic" for m, _ in history) == 1
                    move_d, move_m = step_move(response if first_dynamic else None, gap_d, gap_m,
                                               on_measured_d, on_measured_m)
                    section = section.with_cw_support_heights(section.cw_support_heights_m + move_m)
                    static_d = static_d + move_d
                inverse = dropper_lengths_for_cw_heights(section, catenary, static_d, allow_slack=True)
                section = inverse.section
                # a dynamic pass reports the profile's chainages too (read off the same run)
                at = np.concatenate([points, profile_x]) if mode == "dynamic" else points
                simulated = measuring_pass(section, catenary, pantograph, speed_m_s=speed_m_s, mode=mode,
                                           time_step_s=settings.time_step_s, chainage_m=at, **run_kwargs).height_m
                last_mode = mode
                gap_d = np.where(on_measured_d, measured_d - simulated[:measured_d.size], 0.0)
                gap_m = np.where(on_measured_m, measured_m - simulated[measured_d.size:n_points], 0.0)
                gap_w = gap_d - section.chord_at_droppers(gap_m)
                norms = np.sqrt(np.bincount(section.dropper_span, gap_w ** 2, minlength=len(rows)))
                norms[~measured] = 0.0
                history.append((mode, norms))
                progress.update(done, f"largest gap {1e3 * largest_finite(norms):.3f} mm, "
                                f"{int(np.sum(norms[measured] < tolerance))} of {int(measured.sum())} spans within "
                                f"{1e3 * tolerance:.2f} mm")
                if np.all(norms[measured] < tolerance):
                    break
                if mode == settings.mode and _stalled(history, tolerance):
                    break        # no further pass moves what is left (DYNAMIC_STALL)
                if mode != settings.mode and len(history) > 1 and (
                        largest_finite(norms) > QUASI_STATIC_STALL * largest_finite(history[-2][1])):
                    break        # the quasi-static start has done what it can (QUASI_STATIC_STALL)
        profile_simulated = None
        if profile_chainage_m is not None:
            profile_simulated = (simulated[n_points:] if last_mode == "dynamic" else measuring_pass(
                section, catenary, pantograph, speed_m_s=speed_m_s, mode=last_mode,
                time_step_s=settings.time_step_s, chainage_m=profile_x, **run_kwargs).height_m)
        # Static W of the last simulated model (at slack droppers the CW hangs below its target).
        solution = StaticModel(section, catenary).solve()
    except ConvergenceError as exc:
        # Only a solver that did not settle is a property of this run; a ConfigError, an
        # InputError or a programming error propagates and stops the rule.
        return RunCorrection(span_ids, empty, np.full(len(rows), np.nan), _passes(history, settings.mode),
                             history, failure=f"a solver did not converge on this run ({exc})")
    w = solution.dropper_deflection_m()
    static_w, forces = empty.copy(), empty.copy()
    for k in range(len(rows)):
        static_w[k, :n_d[k]] = w[section.dropper_span == k]
        forces[k, :n_d[k]] = solution.dropper_force_n[section.dropper_span == k]
    slack = np.bincount(section.dropper_span, inverse.slack, minlength=len(rows)).astype(int)
    return RunCorrection(span_ids, static_w, history[-1][1], _passes(history, settings.mode), history,
                         section.dropper_lengths_m, slack_droppers=slack, section=section,
                         simulated_height_m=simulated[:n_points], dropper_force_n=forces,
                         profile_simulated_m=profile_simulated,
                         profile_static_m=None if profile_chainage_m is None else solution.cw_height_at(profile_x))


def measured_residuals(rows: pd.DataFrame, result: RunCorrection, common_w_m: np.ndarray, catenary: Catenary,
                       pantograph: Pantograph, speed_m_s: float, settings: CorrectionSettings, *, direction: int = 1,
                       speed_profile: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """What a run measured minus what its own measuring pass gives over a static W common to
    several runs, per span and dropper [m] (module docs, *Several runs*).

    Parameters
    ----------
    rows : pandas.DataFrame
        The run's spans, as corrected (:func:`correct_run`).
    result : RunCorrection
        The run's correction; its final model gives the steady arms and the spans without a
        common W.
    common_w_m : numpy.ndarray
        Static W per span (n_spans, n_droppers) [m]; NaN rows keep the run's own model.
    catenary, pantograph, speed_m_s, settings, direction, speed_profile
        As for :func:`correct_run`.

    Returns
    -------
    numpy.ndarray
        Measured minus simulated W (n_spans, n_droppers) [m]; NaN on spans without a common W,
        unmeasured spans, and everywhere when the run failed.
    """
    out = np.full(result.static_w_m.shape, np.nan)
    if result.section is None:
        return out
    section = result.section
    n_d = np.bincount(section.dropper_span, minlength=len(rows))
    measured = _measured(rows)
    common = np.concatenate([common_w_m[k, :n_d[k]] for k in range(len(rows))])
    use = np.isfinite(common) & measured[section.dropper_span]
    own = StaticModel(section, catenary).solve().dropper_deflection_m()
    target = section.chord_at_droppers(section.cw_support_heights_m) + np.where(use, common, own)
    section = dropper_lengths_for_cw_heights(section, catenary, target, allow_slack=True).section
    measured_d, measured_m = measured_heights(rows, section)
    points = np.concatenate([section.dropper_chainage_m, section.mast_chainage_m])
    run_kwargs = {} if direction == 1 else {"direction": direction}
    if speed_profile is not None:
        run_kwargs["speed_profile"] = speed_profile
    simulated = measuring_pass(section, catenary, pantograph, speed_m_s=speed_m_s, mode=settings.mode,
                               time_step_s=settings.time_step_s, chainage_m=points, **run_kwargs).height_m
    gap_w = (measured_d - simulated[:measured_d.size]) - section.chord_at_droppers(
        measured_m - simulated[measured_d.size:])
    gap_w = np.where(use, gap_w, np.nan)
    for k in range(len(rows)):
        out[k, :n_d[k]] = gap_w[section.dropper_span == k]
    return out


def _measured(rows: pd.DataFrame) -> np.ndarray:
    """Which spans of a run were measured (False: a rejected span kept in the model)."""
    return rows["measured"].to_numpy(dtype=bool) if "measured" in rows else np.ones(len(rows), dtype=bool)


def _converged(result: RunCorrection, settings: CorrectionSettings) -> np.ndarray:
    """Per span of a run: its final gap norm is below the tolerance."""
    return np.isfinite(result.gap_norm_m) & (result.gap_norm_m < settings.tolerance_m)


def _passes_to_converge(history: list[tuple[str, np.ndarray]], settings: CorrectionSettings,
                        n_spans: int) -> np.ndarray:
    """Per span: passes in the settings' mode until its gap first fell below the tolerance (all
    passes made when it never did; 0 when the run failed before its first such pass). The run
    goes on while any of its spans is above."""
    norms = np.array([n for m, n in history if m == settings.mode])
    if norms.size == 0:
        return np.zeros(n_spans, dtype=int)
    below = norms < settings.tolerance_m
    return np.where(below.any(axis=0), below.argmax(axis=0) + 1, norms.shape[0])


def _stalled(history: list[tuple[str, np.ndarray]], tolerance_m: float) -> bool:
    """Whether the last pass took less than 1 − :data:`DYNAMIC_STALL` off the gap of every span
    still at or above ``tolerance_m`` [m], against the pass before in the same mode (False after
    one pass of the mode, or when every span is within the tolerance)."""
    if len(history) < 2 or history[-1][0] != history[-2][0]:
        return False
    (_, now), (_, before) = history[-1], history[-2]
    out = now >= tolerance_m
    return bool(out.any() and np.all(now[out] > DYNAMIC_STALL * before[out]))


def _passes(history: list[tuple[str, np.ndarray]], mode: str) -> int:
    return sum(m == mode for m, _ in history)


def measuring_conditions(rows: pd.DataFrame, settings: CorrectionSettings
                         ) -> tuple[float, float, int, tuple[np.ndarray, np.ndarray] | None]:
    """How the car measured a run of consecutive spans: speed [m/s] (the median of the spans'),
    static force [N] (the median of the spans' ``force_n``), direction of travel (±1) and, when the
    spans' speeds differ, the speed profile through their middles (chainage from the run's first
    mast [m], speed [m/s]). A span without a recorded speed or force takes the settings' value.

    Raises
    ------
    InputError
        A recorded speed or force that is not positive.
    """
    values = []
    for column, default in (("speed_kmh", settings.speed_kmh), ("force_n", settings.force_n)):
        data = rows[column].to_numpy(dtype=float) if column in rows else np.full(len(rows), np.nan)
        data = np.where(np.isfinite(data), data, default)
        bad = np.flatnonzero(data <= 0)
        if bad.size:
            raise InputError(f"recording: column {column} must be > 0; span {rows['span_id'].iloc[bad[0]]} has "
                             f"a median of {data[bad[0]]}")
        values.append(data)
    speed_kmh, force = values
    direction = int(rows["direction"].iloc[0]) if "direction" in rows else 1
    profile = None
    if np.ptp(speed_kmh) > 0:
        start = rows["start_chainage_m"].to_numpy(dtype=float)
        middle = 0.5 * (start + rows["end_chainage_m"].to_numpy(dtype=float)) - start[0]
        profile = (middle, speed_kmh / 3.6)
    return float(np.median(speed_kmh)) / 3.6, float(np.median(force)), direction, profile


CORRECTED_BASE_COLUMNS = ["span_id", "run_id", "direction", "speed_kmh", "force_n", "section_id", "span_type",
                          "start_chainage_m", "end_chainage_m", "length_m"]


def correct_spans(spans: pd.DataFrame, catenary: Catenary, pantograph: Pantograph,
                  settings: CorrectionSettings, log=None, report: pd.DataFrame | None = None,
                  after_run=None, profiles: pd.DataFrame | None = None, responses: list[SupportResponse] = ()
                  ) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """Correct every run of consecutive spans in ``spans`` (module docstring).

    Parameters
    ----------
    spans : pandas.DataFrame
        Projected spans (rows of the projection's ``spans.parquet`` with ``span_type``), with their
        run's ``run_id``, ``direction``, ``speed_kmh`` and ``force_n``.
    catenary : Catenary
    pantograph : Pantograph
        The measuring pantograph; its static force is set to the recording's force.
    settings : CorrectionSettings
    log : logging.Logger, optional
    report : pandas.DataFrame, optional
        The projection's span report: the spans it rejected between and around measured ones stay
        in the model, unmeasured (:func:`fill_unmeasured`).
    after_run : callable, optional
        Called after each run of spans as ``after_run(rows, result, pantograph, speed_m_s,
        direction, speed_profile)`` with the run's :class:`RunCorrection` and measuring conditions
        (the model-error budget perturbs its converged model).
    profiles : pandas.DataFrame, optional
        The measured profiles of the spans (the projection's ``profiles.parquet`` rows:
        ``span_id``, ``run_id``, ``x_m``, ``height_m``): each run's final model is read at their
        chainages too.
    responses : list of SupportResponse
        The measuring pass's responses per span type and direction (:mod:`.step`; rule
        ``measuring_response``): the step after each run's first dynamic pass. Default: none,
        the plain step.

    Returns
    -------
    corrected : pandas.DataFrame
        One row per input span: identifiers, the corrected static ``w1_m``…, the measured minus
        simulated ``residual_w1_m``… over the runs' mean W (NaN unless several runs corrected the
        span), ``iterations``, ``gap_norm_m``, ``converged`` and ``reason`` (empty when converged).
    convergence : pandas.DataFrame
        The gap norm of every span after every simulated pass.
    corrected_profiles : pandas.DataFrame
        One row per profile sample of a span whose run was corrected (:data:`PROFILE_COLUMNS`):
        the measured height, the final model's simulated pass and its static CW height there
        (empty without ``profiles``). The corrected static profile is ``height_m −
        (simulated_height_m − static_height_m)``.
    """
    n_max = max(catenary.span_type(t).n_droppers for t in spans["span_type"].unique()) if len(spans) else 0
    rows_out, history_out = [], []
    spans = spans.copy()
    for column, default in (("run_id", "run"), ("direction", 1), ("speed_kmh", np.nan), ("force_n", np.nan)):
        if column not in spans:
            spans[column] = default
    done, profile_parts = [], []
    for rows in consecutive_runs(spans):
        if report is not None:
            rows = fill_unmeasured(rows, report, catenary)
        speed, force, direction, profile = measuring_conditions(rows, settings)
        samples = None if profiles is None else _run_profile(rows, profiles)
        result = correct_run(rows, catenary, pantograph.with_static_force(force), speed, settings, log=log,
                             direction=direction, speed_profile=profile,
                             profile_chainage_m=None if samples is None else samples["chainage_m"].to_numpy(),
                             responses=responses)
        if samples is not None and result.profile_simulated_m is not None:
            profile_parts.append(samples.assign(simulated_height_m=result.profile_simulated_m,
                                                static_height_m=result.profile_static_m)[list(PROFILE_COLUMNS)])
        if after_run is not None:
            after_run(rows, result, pantograph.with_static_force(force), speed, direction, profile)
        done.append((rows, result, (speed, force, direction, profile)))
    residuals = _several_runs_residuals(done, catenary, pantograph, settings, log)
    for (rows, result, (speed, force, direction, profile)), residual in zip(done, residuals):
        converged = _converged(result, settings)
        passes = _passes_to_converge(result.history, settings, len(rows))
        measured = _measured(rows)
        for k in np.flatnonzero(measured):
            reason = result.failure or ("" if converged[k] else
                                        f"gap {result.gap_norm_m[k] * 1e3:.2f} mm after {result.iterations} passes")
            row = {c: rows.loc[k, c] for c in CORRECTED_BASE_COLUMNS}
            row.update({f"w{i + 1}_m": result.static_w_m[k, i] if i < result.static_w_m.shape[1] else np.nan
                        for i in range(n_max)})
            row.update({f"residual_w{i + 1}_m": residual[k, i] if i < residual.shape[1] else np.nan
                        for i in range(n_max)})
            tensions = result.dropper_force_n
            row.update({f"dropper_{i + 1}_force_n": tensions[k, i] if tensions is not None and i < tensions.shape[1]
                        else np.nan for i in range(n_max)})
            row.update(iterations=int(passes[k]), gap_norm_m=result.gap_norm_m[k], converged=bool(converged[k]),
                       slack_droppers=0 if result.slack_droppers is None else int(result.slack_droppers[k]),
                       reason=reason)
            rows_out.append(row)
        for it, (mode, norms) in enumerate(result.history, start=1):
            for k in np.flatnonzero(measured):
                history_out.append({"section_id": rows.loc[k, "section_id"], "span_id": rows.loc[k, "span_id"],
                                    "run_id": rows.loc[k, "run_id"], "iteration": it, "mode": mode,
                                    "gap_norm_m": norms[k]})
        if log is not None:
            log.info("section %s, run %s (%s), spans %s…%s: %d %s passes (%d in all) at %.1f km/h%s and %.1f N, "
                     "gap max %.3f mm%s", rows["section_id"].iloc[0], rows["run_id"].iloc[0],
                     "towards increasing chainage" if direction > 0 else "towards decreasing chainage",
                     rows["span_id"].iloc[0], rows["span_id"].iloc[-1]
                     + (f" ({int((~measured).sum())} unmeasured kept in the model)" if (~measured).any() else ""),
                     result.iterations, settings.mode, len(result.history), speed * 3.6,
                     " (median; a profile through the spans)" if profile is not None else "", force,
                     largest_finite(result.gap_norm_m) * 1e3,
                     f"; FAILED: {result.failure}" if result.failure else "")
    corrected = pd.DataFrame(rows_out, columns=corrected_columns(n_max))
    convergence = pd.DataFrame(history_out, columns=["section_id", "span_id", "run_id", "iteration", "mode",
                                                     "gap_norm_m"])
    corrected_profiles = (pd.concat(profile_parts, ignore_index=True) if profile_parts
                          else pd.DataFrame({c: pd.Series(dtype=str if c in ("span_id", "run_id") else float)
                                             for c in PROFILE_COLUMNS}))
    return corrected, convergence, corrected_profiles



def corrected_columns(n_droppers: int) -> list[str]:
    """The corrected table's columns, in order, for spans of at most ``n_droppers`` droppers
    (:func:`correct_spans`, whose spans may be of several span types: it takes the largest)."""
    return CORRECTED_BASE_COLUMNS + [f"w{i + 1}_m" for i in range(n_droppers)] + [
        f"residual_w{i + 1}_m" for i in range(n_droppers)] + [f"dropper_{i + 1}_force_n" for i in range(n_droppers)] + [
        "iterations", "gap_norm_m", "converged", "slack_droppers", "reason"]


def _run_profile(rows: pd.DataFrame, profiles: pd.DataFrame) -> pd.DataFrame:
    """The measured profile samples of a run of spans' measured spans, with their chainage from
    the run's first mast (``chainage_m``), in the run's span order."""
    run_id = rows["run_id"].iloc[0]
    lengths = (rows["end_chainage_m"] - rows["start_chainage_m"]).to_numpy(dtype=float)
    starts = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
    mine = profiles[profiles["run_id"].astype(str) == str(run_id)]
    parts = []
    for k in np.flatnonzero(_measured(rows)):
        part = mine[mine["span_id"].astype(str) == str(rows.loc[k, "span_id"])]
        parts.append(part.assign(chainage_m=starts[k] + part["x_m"].to_numpy(dtype=float)))
    if not parts:
        return pd.DataFrame(columns=["span_id", "run_id", "x_m", "height_m", "chainage_m"])
    return pd.concat(parts, ignore_index=True)


def _several_runs_residuals(done: list, catenary: Catenary, pantograph: Pantograph, settings: CorrectionSettings,
                            log=None) -> list[np.ndarray]:
    """For every corrected run of spans, :func:`measured_residuals` over the mean corrected W of
    the spans that several runs corrected to convergence (all NaN where no span was)."""
    ws: dict[str, list[np.ndarray]] = {}
    for rows, result, _ in done:
        ok = _converged(result, settings)
        measured = _measured(rows)
        for k in np.flatnonzero(ok & measured):
            ws.setdefault(str(rows.loc[k, "span_id"]), []).append(result.static_w_m[k])
    common = {k: np.mean(v, axis=0) for k, v in ws.items() if len(v) >= 2}
    out = []
    for rows, result, (speed, force, direction, profile) in done:
        ids = rows["span_id"].astype(str).to_numpy()
        if not any(i in common for i in ids):
            out.append(np.full(result.static_w_m.shape, np.nan))
            continue
        w = np.array([common.get(i, np.full(result.static_w_m.shape[1], np.nan)) for i in ids])
        out.append(measured_residuals(rows, result, w, catenary, pantograph.with_static_force(force), speed,
                                      settings, direction=direction, speed_profile=profile))
        if log is not None:
            log.info("section %s, run %s: measured minus simulated W over the runs' mean corrected W, %d spans "
                     "(one more %s pass)", rows["section_id"].iloc[0], rows["run_id"].iloc[0],
                     int(sum(i in common for i in ids)), settings.mode)
    return out


def largest_finite(values: np.ndarray) -> float:
    """The largest finite value of ``values``; NaN where none is finite."""
    finite = np.asarray(values, dtype=float)
    finite = finite[np.isfinite(finite)]
    return float(finite.max()) if finite.size else float("nan")
