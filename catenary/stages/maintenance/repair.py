"""What fixing buys: the contact force over the listed spans, as measured and once repaired.

For each section holding listed spans, windows of ``contact_force.n_spans`` consecutive spans
are cut so that every listed span lies between the window's analysis masts
(``contact_force.analysis_masts``: the run-in and run-out spans are not analysed). Each window is
built twice from its spans' posterior means — dropper lengths, T_MW and ΔH at each mast —

* ``as_measured``: the posterior means;
* ``repaired``: every listed dropper (by its length or as unloaded) set back to its nominal
  length, the rest unchanged;

and run over by the operating pantograph at the operating speeds (``contact_force.speeds_kmh``,
:func:`~catenary.stages.contact_force.runs.run_section`, the contact-force study's own runs). The
EN 50367 criteria and their margins to the limits (``contact_force.limits``: target mean force,
σ ≤ 0.3 Fm, Fm − 3σ > 0, steady-arm uplift) are written per window, speed and state, and the
change repair brings to σ_F and to each margin. The steady arms are at the design CW height: the
measured span's chord removes its ends' heights from W (paper Fig. 3), so the posterior does not
know them.

The posterior means stand for the span, not its uncertainty: the change is what repairing the
most likely geometry buys. A section shorter than a window is skipped, with its reason.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from catenary.physics.config import Catenary, SpanType
from catenary.physics.effects import SpanParameters
from catenary.physics.pantograph import Pantograph
from catenary.plumbing.workers import map_blocks
from catenary.stages.contact_force.draws import build_section
from catenary.stages.contact_force.runs import CRITERIA, run_section
from catenary.stages.contact_force.settings import ContactForceSettings

__all__ = ["REPAIR_COLUMNS", "PosteriorMeans", "RepairWindow", "fixing_buys", "posterior_means", "repair_windows",
           "window_parameters"]

#: Repair windows per block of the worker processes of :func:`fixing_buys`.
WINDOWS_PER_BLOCK = 4

#: Columns of ``repair.csv``: one row per window, speed and state (``as_measured``, ``repaired``).
REPAIR_COLUMNS = ("section_id", "first_span_id", "last_span_id", "listed", "speed_kmh", "state", *CRITERIA,
                  "mean_force_margin_n", "std_margin_n", "statistical_min_margin_n", "uplift_margin_m")


@dataclass(frozen=True)
class RepairWindow:
    """``n_spans`` consecutive spans of a section (``span_ids`` in line order) and the listed
    droppers inside its analysis window: ``(span_id, dropper index from 0)``."""

    section_id: str
    span_ids: tuple[str, ...]
    droppers: tuple[tuple[str, int], ...]


def _listed_droppers(listed: pd.DataFrame) -> list[tuple[str, int]]:
    rows = listed[listed["input"].str.startswith("dropper_")]
    return sorted({(str(r.span_id), int(r.input.split("_")[1]) - 1) for r in rows.itertuples()})


def repair_windows(posterior: pd.DataFrame, listed: pd.DataFrame, n_spans: int, analysis_masts: tuple[int, int]
                   ) -> tuple[list[RepairWindow], list[tuple[str, str]]]:
    """Windows covering every listed dropper's span in their analysis part, and what no window
    analyses (sections shorter than a window; spans among a section's first or last ones, which
    are some window's run-in or run-out), with the reason."""
    spans = posterior.drop_duplicates("span_id").sort_values(["section_id", "start_chainage_m"], kind="stable")
    droppers = _listed_droppers(listed)
    first, last = analysis_masts                        # analysed spans: window indices first … last − 1
    windows, skipped = [], []
    for section, part in spans.groupby("section_id", sort=True):
        ids = list(part["span_id"].astype(str))
        mine = [d for d in droppers if d[0] in ids]
        if not mine:
            continue
        if len(ids) < n_spans:
            skipped.append((str(section), f"{len(ids)} measured spans, fewer than a window's "
                                          f"{n_spans} (contact_force.n_spans)"))
            continue
        lo, hi = first, len(ids) - n_spans + last - 1       # spans some window analyses
        ends = sorted({s for s, _ in mine if not lo <= ids.index(s) <= hi})
        if ends:
            skipped.append((str(section), f"span(s) {', '.join(ends)} among the first {lo} or last "
                                          f"{n_spans - last} of the section: run-in or run-out of every window"))
        todo = sorted({ids.index(s) for s, _ in mine} & set(range(lo, hi + 1)))
        while todo:
            start = min(max(todo[0] - first, 0), len(ids) - n_spans)
            inside = [k for k in todo if start + first <= k < start + last]
            window = ids[start:start + n_spans]
            windows.append(RepairWindow(str(section), tuple(window),
                                        tuple(d for d in mine if ids.index(d[0]) in inside)))
            todo = [k for k in todo if k not in inside]
    return windows, skipped


@dataclass(frozen=True)
class PosteriorMeans:
    """Each span's posterior mean and nominal value of every input: one row per span
    (``span_id``), one column per input (``dropper_1_length_m`` …) [SI]."""

    mean: pd.DataFrame
    nominal: pd.DataFrame


def posterior_means(posterior: pd.DataFrame) -> PosteriorMeans:
    """The posterior table (one row per span and input) read once into :class:`PosteriorMeans`,
    so that a window's values are looked up by span, not searched for in the whole line's rows."""
    return PosteriorMeans(mean=posterior.pivot(index="span_id", columns="input", values="mean"),
                          nominal=posterior.pivot(index="span_id", columns="input", values="nominal"))


def window_parameters(means: PosteriorMeans, window: RepairWindow, span_type: SpanType,
                      repaired: bool = False) -> SpanParameters:
    """The window's spans at their posterior means (``repaired``: listed droppers at nominal)."""
    n = span_type.n_droppers
    spans = list(window.span_ids)
    k = len(spans)
    mean = means.mean.loc[spans]
    lengths = mean[[f"dropper_{i + 1}_length_m" for i in range(n)]].to_numpy(dtype=float, copy=True)
    if repaired:
        for span, i in window.droppers:
            lengths[spans.index(span), i] = float(means.nominal.at[span, f"dropper_{i + 1}_length_m"])
    if "system_height_left_m" in mean.columns:
        left = mean["system_height_left_m"].to_numpy(dtype=float)
        right = mean["system_height_right_m"].to_numpy(dtype=float)
    else:
        left = right = mean["system_height_m"].to_numpy(dtype=float)
    # A mast's ΔH: the mean of what the two spans on it say (one section model, one ΔH per mast).
    masts = np.r_[left[0], 0.5 * (right[:-1] + left[1:]), right[-1]]
    tension = mean["messenger_tension_n"].to_numpy(dtype=float)
    return SpanParameters(
        dropper_lengths_m=lengths, system_height_left_m=masts[:-1].copy(), system_height_right_m=masts[1:].copy(),
        system_height_mean_m=np.full(k, span_type.system_height_m), messenger_tension_n=tension,
        contact_tension_n=np.full(k, span_type.contact_tension_n), section_index=np.zeros(k, dtype=int),
        measuring_force_n=0.0, creep_offset_m=np.zeros(k), cw_offset_m=np.zeros(k), left_mast=np.arange(k),
        mast_cw_height_offset_m=np.full(k + 1, span_type.cw_height_m), cw_wear_fraction=np.zeros(k))


def _margins(row: dict, settings: ContactForceSettings) -> dict:
    lim = settings.limits
    fm, sd = row["mean_force_n"], row["std_force_n"]
    return {"mean_force_margin_n": lim.mean_force_target_n(row["speed_kmh"]) - fm,
            "std_margin_n": lim.max_std_fraction * fm - sd,
            "statistical_min_margin_n": fm - 3.0 * sd - lim.min_statistical_n,
            "uplift_margin_m": lim.max_uplift_m - row["max_support_uplift_m"]}


def fixing_buys(posterior: pd.DataFrame, listed: pd.DataFrame, span_type: SpanType, catenary: Catenary,
                pantograph: Pantograph, settings: ContactForceSettings, workers: int = 1
                ) -> tuple[pd.DataFrame, list[tuple[str, str]]]:
    """The contact force over each repair window as measured and repaired (module docstring).

    Parameters
    ----------
    workers : int
        Processes over the windows (:func:`catenary.plumbing.workers.map_blocks`): each window's
        runs are its own, so the table is the same for any number.

    Returns
    -------
    table : pandas.DataFrame
        :data:`REPAIR_COLUMNS`, one row per window, speed and state.
    skipped : list of (str, str)
        Sections holding listed droppers that no window fits, with the reason.
    """
    windows, skipped = repair_windows(posterior, listed, settings.n_spans, settings.analysis_masts)
    means = posterior_means(posterior)

    def block(start: int, stop: int) -> list[dict]:
        rows = []
        for window in windows[start:stop]:
            label = ";".join(f"{s}:{i + 1}" for s, i in window.droppers)
            for state in ("as_measured", "repaired"):
                section = build_section(window_parameters(means, window, span_type, state == "repaired"),
                                        span_type, catenary)
                _, runs = run_section(section, catenary, pantograph, settings, settings.speeds_kmh)
                for run in runs:
                    rows.append({"section_id": window.section_id, "first_span_id": window.span_ids[0],
                                 "last_span_id": window.span_ids[-1], "listed": label, "state": state,
                                 **{c: run[c] for c in ("speed_kmh", *CRITERIA)}, **_margins(run, settings)})
        return rows

    rows = [row for part in map_blocks(block, len(windows), workers, WINDOWS_PER_BLOCK) for row in part]
    return pd.DataFrame(rows, columns=list(REPAIR_COLUMNS)), skipped


def repair_summary(table: pd.DataFrame) -> pd.DataFrame:
    """Per window and speed, what repair changes: σ_F and each margin, repaired − as measured."""
    if table.empty:
        return pd.DataFrame(columns=["section_id", "first_span_id", "last_span_id", "speed_kmh", "listed",
                                     "std_force_change_n", "statistical_min_margin_change_n",
                                     "std_margin_change_n", "uplift_margin_change_m"])
    keys = ["section_id", "first_span_id", "last_span_id", "speed_kmh", "listed"]
    wide = table.pivot_table(index=keys, columns="state",
                             values=["std_force_n", "statistical_min_margin_n", "std_margin_n", "uplift_margin_m"])
    out = pd.DataFrame({
        "std_force_change_n": wide[("std_force_n", "repaired")] - wide[("std_force_n", "as_measured")],
        "statistical_min_margin_change_n": (wide[("statistical_min_margin_n", "repaired")]
                                            - wide[("statistical_min_margin_n", "as_measured")]),
        "std_margin_change_n": wide[("std_margin_n", "repaired")] - wide[("std_margin_n", "as_measured")],
        "uplift_margin_change_m": wide[("uplift_margin_m", "repaired")] - wide[("uplift_margin_m", "as_measured")],
    })
    return out.reset_index()
