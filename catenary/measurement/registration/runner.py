"""Register the mast table onto each run's trace (or find the masts from the trace alone).

For each run, the sections of the mast table are taken in the run's order of travel, each
starting from the map of the section before (the odometer's error grows with the distance
travelled):

1. **Coarse.** Each table mast is looked for within ``± max_offset_m`` of where the map so far
   puts it: the stagger's reversal (``|kink|`` of the stagger), or, in the height alone, the
   comb of the two adjacent spans' droppers (the mean of the height's ±1 m kink signal at the
   droppers' design places) plus the sag's broad peak at the mast (the wire is highest at its
   supports: the height's kink over ±8 m windows), added with two weights, 0.1 and 1
   (``_SAG_WEIGHTS``): a little breaks the ties of a comb that slips by one dropper spacing,
   as much carries the search on a trace whose droppers' kinks are fainter than the model's.
   The masts are searched together: the line (offset and scale within ``max_scale_error``)
   along which their standardised scores add up best, so that a mast whose own best offset
   slips by a dropper spacing does not pull the map; a mast agrees with the line when its score
   near the line is among its top 1 %, within ``max_residual_m`` of the line — or, for a table
   whose own span lengths stray from their types' lengths, within 2.5 times that spread
   (:func:`_length_spread`: a table kept to the metre is not refused for being one). Of the two
   weightings, the one more masts agree with is kept.

With the stagger, each mast is then placed on its own (``_place_one_by_one``):

2. **Fine.** Around that line each mast's support is fitted within ``± search_m``
   (:mod:`.supports`), with its standard error.
3. **Map.** The map from table to recorded chainage is fitted robustly to the supports found
   (:mod:`.mapping`); a mast whose support lies too far from it is left to the table. The
   table's accuracy is measured by the matched masts' residuals against the map less the fits'
   own variances (:func:`.section_fit.table_std_from_residuals`; ``mast_table_std_m`` is its
   prior) and the map fitted again with it. Where the supports agree with the recording's
   chainage as it is (offset and scale not significantly off, the height's lag uncertain by
   ``height_lag_std_m`` at each end of the section), the map is the identity.
4. **Masts.** Each mast's registered chainage (in the table's frame) weighs the trace's
   position against the table's by their standard errors.

With the height alone, no single support shows itself well enough (0.2–0.3 m, tails to a
metre): the section's supports are found jointly (``_place_by_height``, :mod:`.section_fit`) —
every support's dropper pattern, every span's length and the table, with the map and the
table's accuracy that best explain them all; a mast is confirmed (``matched``) when its own
pattern fits within ``max_residual_m`` of where the section places it. The dynamic lag's error
(``height_lag_std_m`` at each end) is added to the masts' standard errors and their neighbours'
correlation (``corr_next``), unless the map is the identity.

Before either, the table is made consistent with the span types' lengths: a mast whose removal
leaves a span of a known length is **extra in the table** and is dropped; a span as long as two
spans hides a mast **missing from the table**, inserted where the trace (or else the span types'
length) puts it, with the id ``<left mast>+1``.

5. **Refusal.** A section whose trace confirms fewer than ``min_matched_fraction`` of its masts
   (and at least ``min_matched_masts``) — at the coarse line, or where the fine fits or the
   section's fit place them — is refused with that reason: a trace that does not show the
   supports, or a table of another line. A table's accuracy is no reason: it is measured and
   weighed. A section the run does not cover is reported as such. The projection then rejects
   every span of such a section for that run.

Without a mast table (:func:`masts_from_trace`), the supports are found along the first run's
trace, sections end at gaps in the recording, and the span types are read from the supports'
spacing; every run is then registered onto that table (a start only: the trace's own evidence,
not an independent one, so its accuracy is not measured).

One module, one concern: the map from one mast table onto one run's trace. The coarse line,
the fine fits, the map and the placement of each mast (missing, extra, refused) are the steps of
one decision per section that share its state; the support detectors they call
(:mod:`.supports`), the map's fit (:mod:`.mapping`), the lag (:mod:`.lag`), the settings and
the files are apart.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np
import pandas as pd

from catenary.physics.config import Catenary
from catenary.plumbing.workers import map_each
from .chain import chain_supports, odometer_scale
from .mapping import ChainageMap, fit_map
from .section_fit import fit_section, height_evidence, table_std_from_residuals
from .settings import RegistrationSettings
from .supports import LocalFit, Trace, align_pattern, kink_signal, locate_stagger_support, trace_of

__all__ = ["MAST_COLUMNS", "REGISTRATION_COLUMNS", "SECTION_COLUMNS", "RunRegistration", "masts_from_trace",
           "register_run", "support_kinks", "support_line", "unregistered_run"]

MATCHED, TABLE_ONLY, MISSING, EXTRA = "matched", "table_only", "missing_from_table", "extra_in_table"
REGISTERED, REFUSED, NOT_COVERED, UNREGISTERED = "registered", "refused", "not_covered", "unregistered"

MAST_COLUMNS = ["run_id", "section_id", "mast_id", "span_type", "status", "method", "table_chainage_m",
                "recorded_chainage_m", "chainage_m", "std_m", "residual_m", "corr_next"]
"""Columns of the registered masts: one row per run and mast of the table (and per mast the
registration inserted). ``span_type``: of the span starting at the mast (empty at a section's last
mast); ``status``: ``matched`` (the trace confirms it), ``table_only`` (position from the table),
``missing_from_table`` (inserted), ``extra_in_table`` (dropped); ``method``: what placed it
(``stagger``: the mast's own reversal; ``height``: the whole section's height, its spans and the
table (:mod:`.section_fit`); ``table``; ``span_length``: inserted where the span types put it);
without stagger a ``table_only`` mast is one whose own kinks do not confirm where the section's
fit places it; ``table_chainage_m`` (NaN when inserted), ``recorded_chainage_m`` (in the run's own
chainage), ``chainage_m`` (registered, in the table's frame; NaN when dropped), ``std_m`` (its
standard error), ``residual_m`` (the trace's position minus the map, in table metres; NaN unless
matched), ``corr_next`` (correlation of its position's error with the next mast's of the section:
the height's fit ties neighbours through their span; NaN where independent)."""

SECTION_COLUMNS = ["run_id", "section_id", "status", "reason", "n_table_masts", "n_matched",
                   "n_missing_from_table", "n_extra_in_table", "offset_m", "scale", "degree", "residual_rms_m",
                   "recorded_low_m", "recorded_high_m", "reference_m", "coefficients", "table_std_m",
                   "span_length_std_m", "support_std_m"]
"""Columns of the registered sections: one row per run and section. ``status``: ``registered``,
``refused`` (``reason`` says why), ``not_covered`` (the run has no samples there),
``unregistered`` (registration switched off); ``offset_m`` and ``scale`` of the map at the
section's middle, its ``degree``, the RMS of the matched masts' residuals, the recorded chainages
the section spans, and the map's polynomial (``coefficients``, space-separated, in powers of
the table chainage minus ``reference_m``); ``table_std_m``, the table's accuracy measured by the
run (standard deviation of a listed chainage's error, in table metres; ``mast_table_std_m`` is
its prior), ``span_length_std_m`` (without stagger: the spans' lengths' standard deviation about
their types' lengths, in table metres; NaN with the stagger) and ``support_std_m`` (RMS of the
masts' standard errors)."""

#: Step of the coarse search of each mast [m].
_COARSE_STEP_M = 0.05
#: Cells (slopes × masts × offsets) of the coarse line's scores gathered at once: 8 MB of floats.
_COARSE_BLOCK_CELLS = 2**20
#: The recording's columns the registration reads (:func:`register_run`, :func:`masts_from_trace`,
#: :func:`unregistered_run`).
REGISTRATION_COLUMNS = ["chainage_m", "height_m", "stagger_m", "speed_kmh", "run_id", "direction"]
#: Beyond a section's expected masts ± the search's reach and two span lengths, the stretch of
#: kink signals its search reads reaches this much further [m] (more than a kink window).
_KINK_MARGIN_M = 50.0
#: Half-widths of the kink signals [m]: height (droppers), height (the span's sag) and stagger
#: (supports).
_HEIGHT_KINK_HALF_M, _SAG_KINK_HALF_M, _STAGGER_KINK_HALF_M = 1.0, 8.0, 3.0
#: Weights of the sag's kink added to the droppers' comb (support_line). Measured: 0.1 finds the
#: right offset at 31 of 42 masts of the small campaign (26 with the comb alone, 18 at weight 1);
#: the hand-made example (data/example, no dropper kinks in its trace) registers only at 1.
_SAG_WEIGHTS = (0.1, 1.0)
#: A mast agrees with a section's coarse line when its best score near the line is among the top
#: 1 % of its scores over the offsets searched (_coarse_line). Measured at the registration's
#: tolerance (0.5 m), height alone: 14 and 19 of 21 masts on the r_table campaign's two sections
#: (11 needed); 9 of 17 on the hand-made example's sag-only trace, 7 of 18 for another line's
#: table and 2 of 17 on a flat trace (9 needed). At 0.995 the same cases give 13, 17, 8, 5 and 1.
_AGREE_QUANTILE = 0.99
#: A mast agrees with a section's coarse line within this many times the table's own spread
#: (:func:`_length_spread`) when that is wider than ``max_residual_m`` (at most ``search_m``), and
#: a span's length matches its type within this many of its spread when wider than
#: ``length_tolerance_m``: a uniform error of ±a has a spread a/√3, and 2.5 spreads (1.44 a)
#: hold all of it; 98.8 % of a Gaussian's.
_SPREAD_TOLERANCE = 2.5
#: Weight of a mast table found from the height trace itself (:func:`masts_from_trace`) in the
#: section's fit [m]: the chain of spans places each support to within a metre (0.50 / 0.73 m
#: at worst, 0.28 / 0.36 m RMS on r_height_no_table's two sections), from the same trace.
_FOUND_TABLE_STD_M = 0.5
#: A section's height fit is done again on a grid centred where it put the supports when one of
#: them lies within this of its grid's edge [m], at most this many times in all: measured on the
#: default line with ±1 m tables, the coarse line put a section's grid 1–2 m off the true supports
#: (the fit then 0.65 m off at worst, its own fits at the edge: 10 of 21 confirmed); centred
#: again, 0.3 m.
_RECENTRE_MARGIN_M, _RECENTRE_PASSES = 0.5, 3
#: Half-width of the slopes a loose table's coarse line may take about the odometer scale of its
#: section's chain of spans (:func:`_chain_slopes`): measured 0.01–0.03 % off the truth on
#: r_table's two sections (1.2 km each); 0.05 % moves a section's far end by 0.6 m.
_CHAIN_SCALE_TOLERANCE = 5e-4
#: Margin of recorded samples kept around a registered section [m].
MARGIN_M = 5.0


@dataclass
class RunRegistration:
    """The registration of one run.

    Attributes
    ----------
    run_id : str
    direction : int
    masts : pandas.DataFrame
        :data:`MAST_COLUMNS`.
    sections : pandas.DataFrame
        :data:`SECTION_COLUMNS`.
    maps : dict of str to ChainageMap
        The map of every registered section.
    """

    run_id: str
    direction: int
    masts: pd.DataFrame
    sections: pd.DataFrame
    maps: dict = field(default_factory=dict)


@dataclass
class _TableSection:
    section_id: str
    mast_id: list
    table_m: np.ndarray           # table chainage; for a mast missing from the table, where the span types put it
    span_type: list               # type of the span starting at each mast (None at the last)
    table_std_m: np.ndarray       # standard error of table_m
    missing: np.ndarray           # inserted: missing from the table
    extra: list = field(default_factory=list)     # (mast_id, table chainage) of masts dropped as extra
    spread_m: float = 0.0         # the table's own spread of a mast's chainage (_length_spread / √2)


def _span_types_of(masts: pd.DataFrame, catenary: Catenary) -> list:
    """Span type of the span starting at each mast: the table's, or the type nearest in length."""
    types = []
    x = masts["chainage_m"].to_numpy(dtype=float)
    sec = masts["section_id"].to_numpy(dtype=object)
    declared = masts["span_type"].to_numpy(dtype=object)
    for i in range(len(masts)):
        if i + 1 >= len(masts) or sec[i + 1] != sec[i]:
            types.append(None)
            continue
        name = declared[i]
        types.append(name if isinstance(name, str) and name in catenary.span_types
                     else _nearest_type(x[i + 1] - x[i], catenary))
    return types


def _chain_slopes(kinks: tuple, predicted: np.ndarray, reach_m: float, sec: _TableSection, catenary: Catenary,
                  type_lag: dict, scale: float, settings: RegistrationSettings) -> tuple[float, float]:
    """Slopes the coarse line of a loose table's section may take, from the odometer scale that
    the section's own chain of spans gives (:func:`.chain.chain_supports`, the table's span types
    at their lengths): within :data:`_CHAIN_SCALE_TOLERANCE` of it. A table kept to the metre
    puts its masts' comb scores where its errors put them; their best line can then take another
    scale (measured on r_table's trace with a ±1 m table: 0.08 % for 0.3 %, the far masts 3 m
    off), which the span lengths, read over the whole section, do not allow."""
    grid, comb, sag = kinks
    names = sorted({k for k in sec.span_type if k is not None}, key=lambda n: catenary.span_types[n].length_m)
    supports, kinds = chain_supports(grid, comb, sag, float(predicted.min()) - reach_m, float(predicted.max()) + reach_m,
                                     catenary, names, type_lag, settings.max_scale_error)
    if len(supports) < 3:
        return -settings.max_scale_error, settings.max_scale_error
    centre = odometer_scale([(supports, kinds)], catenary) - scale
    return (max(centre - _CHAIN_SCALE_TOLERANCE, -settings.max_scale_error),
            min(centre + _CHAIN_SCALE_TOLERANCE, settings.max_scale_error))


def _table_sections(masts: pd.DataFrame, catenary: Catenary, settings: RegistrationSettings) -> list[_TableSection]:
    """The table's sections, made consistent with the span types' lengths (module docs, step 4):
    a mast whose two spans match no span type while the two together match one, or two, is extra
    (two: it sits in the gap of a missing mast); a span as long as two spans gets the mast
    missing between them, where the span types put it."""
    types = _span_types_of(masts, catenary)
    lengths = np.array([st.length_m for st in catenary.span_types.values()])
    out = []
    for section_id, rows in masts.groupby("section_id", sort=False):
        idx = rows.index.to_numpy()
        ids = rows["mast_id"].astype(str).tolist()
        x = rows["chainage_m"].to_numpy(dtype=float).tolist()
        kinds = [types[i] for i in idx]
        spread = _length_spread(np.asarray(x), kinds, catenary, settings.length_tolerance_m)
        tol = max(settings.length_tolerance_m, _SPREAD_TOLERANCE * spread)
        std = [settings.mast_table_std_m] * len(ids)
        missing = [False] * len(ids)
        extra = []
        changed = True
        while changed:
            changed = False
            for j in range(1, len(ids) - 1):
                left, right = x[j] - x[j - 1], x[j + 1] - x[j]
                if _matches(left, lengths, tol) or _matches(right, lengths, tol):
                    continue
                one = _matches(left + right, lengths, tol)
                # Two spans around a mast metres from where any span type would put it (beyond
                # four tolerances: not a table's positioning error): a mast listed where none is,
                # or moved out of recognition, in the gap of a missing one. Dropped here, the
                # missing one inserted by the pass below where the span types put it.
                two = (not _matches(left, lengths, 4 * tol) and not _matches(right, lengths, 4 * tol)
                       and _two_spans(left + right, kinds[j - 1], catenary, 2 * tol) is not None)
                if one or two:
                    extra.append((ids[j], x[j]))
                    if one:
                        kinds[j - 1] = _nearest_type(left + right, catenary)
                    for seq in (ids, x, kinds, std, missing):
                        del seq[j]
                    changed = True
                    break
            if changed:
                continue
            for j in range(len(ids) - 1):
                pair = None if _matches(x[j + 1] - x[j], lengths, tol) else _two_spans(
                    x[j + 1] - x[j], kinds[j], catenary, 2 * tol)
                if pair is not None:
                    kinds[j] = pair[0]
                    for seq, value in ((ids, f"{ids[j]}+1"), (x, x[j] + catenary.span_type(pair[0]).length_m),
                                       (kinds, pair[1]), (std, tol), (missing, True)):
                        seq.insert(j + 1, value)
                    changed = True
                    break
        out.append(_TableSection(str(section_id), ids, np.array(x), kinds, np.array(std), np.array(missing), extra,
                                 spread / np.sqrt(2.0)))
    return out


def _length_spread(x: np.ndarray, kinds: list, catenary: Catenary, tolerance_m: float) -> float:
    """Robust standard deviation of a table's span lengths about their types' lengths [m]: 1.4826
    × the median of ``|Δt − L|`` over the spans within four ``length_tolerance_m`` of their type
    (a span beside a missing or an extra mast is off by metres, not by the table's positioning).
    Each span's error is the difference of two masts' errors: a mast's spread is this / √2 — the
    table's accuracy if its spans have their types' lengths, more if they do not. A table kept to
    the metre gets a length tolerance of 2.5 spreads (2 m for ±1 m) instead of failing to find its
    extra and missing masts (an extra mast midway between two others listed ±1 m off leaves two
    half-spans that add up to a span only within ±2 m)."""
    d = np.array([x[k + 1] - x[k] - catenary.span_type(kinds[k]).length_m for k in range(x.size - 1)
                  if kinds[k] is not None])
    d = d[np.abs(d) <= 4.0 * tolerance_m]
    return float(1.4826 * np.median(np.abs(d))) if d.size >= 3 else 0.0


def _middle_gap(positions_m: np.ndarray, length_m: float) -> float:
    """The midpoint between two neighbouring droppers nearest to mid-span [m from the span's start]."""
    gaps = 0.5 * (positions_m[1:] + positions_m[:-1])
    return float(gaps[np.argmin(np.abs(gaps - 0.5 * length_m))]) if gaps.size else 0.5 * length_m


def _pattern(table_m: np.ndarray, types: list, j: int, catenary: Catenary) -> tuple[np.ndarray, float, float]:
    """Kinks around mast ``j`` relative to it in table metres (the mast and the droppers of its two
    spans), and how far the fitted trace reaches into the spans before and after (0 at a section
    end): to the midpoint between the two droppers nearest to mid-span. Not to mid-span itself:
    both span types have a dropper there, whose kink would cross the window's edge as the pattern
    shifts, changing the fit's number of parameters between neighbouring trials (measured on
    ``r_table``'s N3 height: 0.43 m RMS from the truth with the edge at mid-span, 0.30 m here)."""
    offsets = [0.0]
    left = right = 0.0
    if j + 1 < table_m.size and types[j] is not None:
        st = catenary.span_type(types[j])
        offsets += list(st.dropper_positions_m)
        right = _middle_gap(st.dropper_positions_m, table_m[j + 1] - table_m[j])
    if j > 0 and types[j - 1] is not None:
        st = catenary.span_type(types[j - 1])
        length = table_m[j] - table_m[j - 1]
        offsets += list(st.dropper_positions_m - length)
        left = length - _middle_gap(st.dropper_positions_m, length)
    return np.array(offsets), left, right


def _local_fit(trace: Trace, where_m: float, offsets_m: np.ndarray, left_m: float, right_m: float, scale: float,
               lag_m: float, search_m: float) -> tuple[LocalFit, str]:
    """A mast's support near ``where_m`` (recording frame) and the signature that placed it: the
    stagger's reversal when recorded (not at the end of a recorded stretch), else the height's
    dropper pattern; ``position_m`` in the recording frame."""
    if trace.has_stagger:
        fit = locate_stagger_support(trace, where_m, search_m)
        if fit.found:
            return fit, "stagger"
    if left_m == 0 or right_m == 0:
        # a section's end: the droppers of one span alone place it too loosely (measured: errors of
        # half a metre with standard errors of a decimetre); the table places it
        return LocalFit(float("nan"), float("nan"), float("nan"), 0), "height"
    low = where_m - scale * left_m
    high = where_m + scale * right_m
    fit = align_pattern(trace, where_m + scale * offsets_m, low, high, search_m, lag_m=lag_m)
    return LocalFit(where_m + fit.position_m, fit.std_m, fit.statistic, fit.n_samples, fit.at_edge), "height"


def _coarse_line(t: np.ndarray, predicted: np.ndarray, scores: np.ndarray, offsets: np.ndarray,
                 slopes: tuple[float, float], tolerance_m: float) -> tuple[np.ndarray, np.ndarray, float] | None:
    """(offset, scale) line along which the masts' scores add up best, and the masts that agree.

    ``scores[j, k]`` is mast j's score at offset ``offsets[k]`` from ``predicted[j]``. Each mast's
    scores are standardised over its offsets (a faint and a strong signature count alike); every
    line of slope within ``slopes`` (low, high; steps that move the section's far end by one grid
    step) and offset on the grid is scored by the mean over the masts of their standardised
    score on it (a mast the line takes out of its search counts 0, its average). A mast
    **agrees** with the best line when its best score within ``± tolerance_m`` of the line is
    among the top 1 % of its own scores: a support seen there, not just noise. Returns the
    positions on the line (predicted + line), which masts agree and the line's score, or None
    when no mast has a score.

    A line, not the masts one by one: a height trace's dropper comb often peaks one dropper
    spacing off at a single mast, while the section's masts together peak only at the right
    line (measured on the r_table campaign's first section: 6 of 21 masts have their own best
    offset within 0.5 m of the truth, the joint line puts all 21 within 0.52 m).
    """
    z = np.where(np.isfinite(scores), scores, np.nan)
    has = np.isfinite(z).sum(axis=1) > 1
    if not has.any():
        return None
    with np.errstate(invalid="ignore"):
        z[has] = (z[has] - np.nanmean(z[has], axis=1, keepdims=True)) / np.nanstd(z[has], axis=1, keepdims=True)
    z[~np.isfinite(z)] = np.nan
    step = float(offsets[1] - offsets[0])
    centre = float(np.mean(t))
    reach = max(float(t.max() - t.min()), step)
    slopes = np.arange(slopes[0], slopes[1] + 0.5 * step / reach, step / reach)
    filled = np.nan_to_num(z, nan=0.0)
    best = (-np.inf, 0.0, 0.0)
    rows = np.arange(t.size)[None, :, None]
    per_block = max(1, _COARSE_BLOCK_CELLS // max(filled.size, 1))
    for first in range(0, slopes.size, per_block):      # the slopes in blocks, each block at once
        block = slopes[first:first + per_block]
        k = np.rint((offsets[None, None, :] + block[:, None, None] * (t - centre)[None, :, None] - offsets[0])
                    / step).astype(int)
        inside = (k >= 0) & (k < offsets.size)
        values = np.where(inside, filled[rows, np.clip(k, 0, offsets.size - 1)], 0.0)
        total = values.sum(axis=1) / t.size
        s_best, i = np.unravel_index(int(np.argmax(total)), total.shape)     # the first of equal maxima
        if total[s_best, i] > best[0]:
            best = (float(total[s_best, i]), float(offsets[i]), float(block[s_best]))
    score, offset, slope = best
    line = offset + slope * (t - centre)
    agree = np.zeros(t.size, dtype=bool)
    for j in np.flatnonzero(has):
        near = (np.abs(offsets - line[j]) <= tolerance_m) & np.isfinite(z[j])
        if near.any():
            own = z[j][np.isfinite(z[j])]
            agree[j] = np.mean(own <= np.max(z[j][near])) >= _AGREE_QUANTILE
    return predicted + line, agree, score


def _coarse_scores(trace: Trace, kinks: tuple[np.ndarray, np.ndarray], predicted: np.ndarray, table_m: np.ndarray,
                   span_types: list, catenary: Catenary, scale: float, lag_m: float,
                   reach_m: float, sag: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Score of every mast at every coarse offset (the sag's kink at the mast with ``sag``, else
    the stagger's or the dropper comb; module docs)."""
    kink_grid, kink = kinks
    offsets = np.arange(-reach_m, reach_m + 0.5 * _COARSE_STEP_M, _COARSE_STEP_M)
    scores = np.full((predicted.size, offsets.size), np.nan)
    for j in range(predicted.size):
        if sag:
            features = np.array([lag_m])
        elif trace.has_stagger:
            features = np.zeros(1)
        else:
            pattern, _, _ = _pattern(table_m, span_types, j, catenary)
            features = scale * pattern[1:] + lag_m
        if features.size == 0:
            continue
        values = np.interp(predicted[j] + offsets[:, None] + features[None, :], kink_grid, kink, left=np.nan,
                           right=np.nan)
        if trace.has_stagger:
            values = np.abs(values)
        counts = np.isfinite(values).sum(axis=1)
        scores[j] = np.where(counts > 0, np.nansum(values, axis=1) / np.maximum(counts, 1), np.nan)
    return scores, offsets


def support_kinks(trace: Trace, low_m: float | None = None,
                  high_m: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """The kink signals the coarse search reads (:func:`catenary.measurement.registration.supports.kink_signal`)
    on a grid of the run's chainage: (grid, the stagger's, None) when the stagger is recorded,
    else (grid, the height's at the droppers' scale, the height's at the sag's scale).

    With ``low_m`` and ``high_m`` the grid is the part of the run's grid between them (the same
    points): a section's search reads its own stretch, so the memory does not grow with the
    run. The signals are local (a window of :data:`_SAG_KINK_HALF_M` at most), so inside the
    stretch, away from its ends by more than that window, they are the whole grid's.
    """
    grid = _run_grid(trace.chainage_m[0], trace.chainage_m[-1], low_m, high_m)
    if trace.has_stagger:
        return grid, kink_signal(trace, grid, _STAGGER_KINK_HALF_M, "stagger"), None
    return (grid, kink_signal(trace, grid, _HEIGHT_KINK_HALF_M, "height"),
            kink_signal(trace, grid, _SAG_KINK_HALF_M, "height"))


def _run_grid(start_m: float, stop_m: float, low_m: float | None, high_m: float | None) -> np.ndarray:
    """``np.arange(start_m, stop_m, _COARSE_STEP_M)``, or its points between ``low_m`` and
    ``high_m``, computed as NumPy computes them (``start + i × δ``, δ its first difference) so
    that a stretch's points are the whole grid's, bit for bit."""
    n = max(int(np.ceil((stop_m - start_m) / _COARSE_STEP_M)), 0)
    lo = 0 if low_m is None else min(max(int(np.floor((low_m - start_m) / _COARSE_STEP_M)), 0), n)
    hi = n if high_m is None else min(max(int(np.ceil((high_m - start_m) / _COARSE_STEP_M)) + 1, lo), n)
    delta = (start_m + _COARSE_STEP_M) - start_m
    return start_m + np.arange(lo, hi) * delta


def support_line(trace: Trace, kinks: tuple[np.ndarray, np.ndarray], table_m: np.ndarray, span_types: list,
                 predicted_m: np.ndarray, catenary: Catenary, *, scale: float, lag_m: float, reach_m: float,
                 max_scale_error: float, tolerance_m: float,
                 slopes: tuple[float, float] | None = None) -> tuple[np.ndarray, np.ndarray] | None:
    """Where a section's supports are, from the coarse search (module docs, step 1).

    Parameters
    ----------
    trace, kinks : the run's trace and its :func:`support_kinks`
    table_m : numpy.ndarray
        The masts' chainages in the frame their span lengths are in [m].
    span_types : list
        Type of the span starting at each mast (None at the last).
    predicted_m : numpy.ndarray
        Where the masts are believed to be in the trace's frame [m].
    scale, lag_m : float
        Trace metres per table metre; the height's lag [m].
    reach_m, max_scale_error, tolerance_m : float
        Offsets tried [m]; largest scale error; how close to the line a mast must be to agree [m].
    slopes : (float, float), optional
        The line's slopes tried relative to ``predicted_m`` (default ``± max_scale_error``).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray of bool, numpy.ndarray) or None
        The supports' positions on the best line (:func:`_coarse_line`), which masts agree
        with it, and each mast's own best offset from ``predicted_m`` [m] (NaN without a
        score); None when no mast has a score.
    """
    grid, fine, sag = kinks
    comb, offsets = _coarse_scores(trace, (grid, fine), predicted_m, table_m, span_types, catenary, scale, lag_m,
                                   reach_m)
    weighted = [comb]
    if sag is not None:
        # The sag's broad peak at each mast added to the comb with two weights: a little (it
        # breaks the ties of a comb that slips by one dropper spacing) and as much (it carries
        # the search where the droppers' kinks are fainter than the model's). The weighting on
        # whose line more masts agree is kept.
        broad, _ = _coarse_scores(trace, (grid, sag), predicted_m, table_m, span_types, catenary, scale, lag_m,
                                  reach_m, sag=True)
        weighted = [comb + w * broad for w in _SAG_WEIGHTS]
    line, scores = None, weighted[0]
    for candidate in weighted:
        found = _coarse_line(table_m, predicted_m, candidate, offsets,
                             slopes if slopes is not None else (-max_scale_error, max_scale_error), tolerance_m)
        if found is not None and (line is None or (found[1].sum(), found[2]) > (line[1].sum(), line[2])):
            line, scores = found, candidate
    if line is None:
        return None
    has = np.isfinite(scores).any(axis=1)
    own = np.where(has, offsets[np.argmax(np.where(np.isfinite(scores), scores, -np.inf), axis=1)], np.nan)
    return line[0], line[1], own


def _matches(length: float, lengths: np.ndarray, tolerance: float) -> bool:
    return bool(np.any(np.abs(lengths - length) <= tolerance))


@dataclass
class _Placement:
    """Where one section's masts are placed on a run, or why they cannot be (``why``)."""

    rows: list = field(default_factory=list)
    fitted: ChainageMap | None = None
    n_matched: int = 0
    identity: bool = False
    residual_rms_m: float = float("nan")
    table_std_m: float = float("nan")
    length_std_m: float = float("nan")
    why: str = ""


def _place_one_by_one(trace: Trace, sec: _TableSection, guess: np.ndarray, scale: float, type_lag: dict,
                      lag_m: float, settings: RegistrationSettings, catenary: Catenary, run_id: str,
                      table_from_trace: bool) -> _Placement:
    """Each mast's support fitted on its own (the stagger's reversal; the height's pattern where the
    stagger is not recorded), the map fitted robustly to them, each mast placed by the trace and
    the table weighed by their errors (module docs, steps 2–4). The table's accuracy is measured by
    the matched masts' residuals against the map less the fits' own variances
    (:func:`.section_fit.table_std_from_residuals`, the reversals' alone where at least 3), and
    the map fitted again with it; reported NaN for a table found from the same trace."""
    t = sec.table_m
    fits, methods = [], []
    for j in range(t.size):
        pattern, left, right = _pattern(t, sec.span_type, j, catenary)
        lag_j = type_lag.get(sec.span_type[j] or sec.span_type[j - 1], lag_m)
        fit, how = _local_fit(trace, float(guess[j]), pattern, left, right, scale, lag_j, settings.search_m)
        fits.append(fit)
        methods.append(how)
    methods = np.array(methods)
    found = np.array([f.found and np.isfinite(f.std_m) for f in fits])
    position = np.array([f.position_m if ok else np.nan for f, ok in zip(fits, found)])
    std = np.array([f.std_m if ok else np.nan for f, ok in zip(fits, found)])
    table_std, accuracy = sec.table_std_m, settings.mast_table_std_m
    for _ in range(2):
        try:
            fitted, inlier = fit_map(t, position, std, degree=settings.drift_degree, reference_m=float(t[0]),
                                     table_std_m=table_std, bound_m=settings.max_residual_m)
        except ValueError:
            return _Placement(why=f"the trace confirms {int(found.sum())} of the {t.size} masts")
        listed = inlier & ~sec.missing
        slope = fitted.slope(t)
        residual = np.full(t.size, np.nan)
        residual[listed] = (position[listed] - fitted.to_recorded(t[listed])) / slope[listed]
        by = listed & (methods == "stagger")
        by = by if by.sum() >= 3 else listed
        accuracy = table_std_from_residuals(residual[by], std[by] / slope[by], fitted.degree + 1,
                                            settings.mast_table_std_m)
        table_std = np.where(sec.missing, sec.table_std_m, accuracy)
    n_matched = int(listed.sum())
    rms = float(np.sqrt(np.nanmean(residual ** 2))) if n_matched else float("nan")
    identity = _agrees_with_identity(t, position, listed, methods, settings)
    if identity:
        fitted = ChainageMap.identity(float(t[0]))
        residual[listed] = position[listed] - t[listed]
    sec = _TableSection(sec.section_id, sec.mast_id, t, sec.span_type, table_std, sec.missing, sec.extra)
    rows = _place_masts(sec, fitted, inlier, position, std, residual, run_id, methods)
    return _Placement(rows, fitted, n_matched, identity, rms, float("nan") if table_from_trace else accuracy)


def _place_by_height(trace: Trace, sec: _TableSection, guess: np.ndarray, scale: float, type_lag: dict,
                     settings: RegistrationSettings, catenary: Catenary, run_id: str,
                     table_from_trace: bool) -> _Placement:
    """The section's supports found jointly from the height, its spans and the table
    (:mod:`.section_fit`), the table's accuracy measured on the way. A mast is confirmed
    (``matched``) when its own pattern's best fit lies within ``max_residual_m`` of where the
    whole section places it. Where the supports' own fits agree with the recording's chainage as
    it is, the map is the identity and each mast sits where the table puts it plus its residual
    about the fitted map: the fitted offset and scale are then the height's lag error, which must
    not move the masts (on the hand-made example's sag-only trace, fitting with the identity map
    held put its last mast 1 m off its exact table). A table found from the same
    trace (``table_from_trace``) is no independent evidence: it only starts the fit, weighted as
    :data:`_FOUND_TABLE_STD_M`, and its accuracy is not measured (NaN)."""
    t = sec.table_m
    listed = ~sec.missing
    lengths = np.array([catenary.span_type(name).length_m for name in sec.span_type[:-1]])
    if listed.sum() < 2:
        return _Placement(why=f"the table lists {int(listed.sum())} of the section's masts")
    line = np.linalg.lstsq(np.vander(t[listed] - t[0], 2, increasing=True), guess[listed], rcond=None)[0]
    options = {"initial": ChainageMap(line, float(t[0])), "degree": settings.drift_degree,
               "prior_std_m": settings.mast_table_std_m,
               "fixed_table_std_m": _FOUND_TABLE_STD_M if table_from_trace else None}
    for _ in range(_RECENTRE_PASSES):
        evidence = height_evidence(trace, guess, sec.span_type, catenary, scale, type_lag, settings.search_m)
        own = evidence.own_m
        seen = listed & np.isfinite(own)
        fit = fit_section(evidence, t, listed, lengths, **options)
        # a support the fit puts near its grid's edge may lie beyond it (a loose table's coarse
        # line off by a metre): the grid is centred again on where the section's fit puts them
        if np.all(np.abs(fit.position_m - guess) <= settings.search_m - _RECENTRE_MARGIN_M):
            break
        guess = fit.position_m
        options["initial"] = fit.chainage_map
    fitted = fit.chainage_map
    confirmed = seen & (np.abs(own - fit.position_m) <= settings.max_residual_m)
    slope = fitted.slope(t)
    offset = (fit.position_m - fitted.to_recorded(t)) / slope          # about the map, in table metres
    std, corr = fit.std_m, fit.corr_next
    # the supports' own fits agree with the recording's chainage as it is: the map is the identity
    identity = _agrees_with_identity(t, own, seen, np.full(t.size, "height"), settings)
    if identity:
        fitted, slope = ChainageMap.identity(float(t[0])), np.ones(t.size)
        std = std / fit.chainage_map.slope(t)
        chain = recorded = t + offset
    else:
        chain, recorded = fitted.to_table(fit.position_m), fit.position_m
        # A map fitted to the height carries the dynamic lag's error, height_lag_std_m at each end
        # of the section independently (_agrees_with_identity): it moves the section's supports
        # together, so it adds to each position's variance and to neighbours' covariance.
        f = (t - t[0]) / max(float(t[-1] - t[0]), 1.0)
        lag2 = settings.height_lag_std_m ** 2
        variance = std ** 2 + lag2 * ((1.0 - f) ** 2 + f ** 2)
        covariance = corr[:-1] * std[:-1] * std[1:] + lag2 * ((1.0 - f[:-1]) * (1.0 - f[1:]) + f[:-1] * f[1:])
        std = np.sqrt(variance)
        corr = np.r_[covariance / (std[:-1] * std[1:]), np.nan]
    residual = np.where(confirmed, offset, np.nan)
    n_matched = int(confirmed.sum())
    rms = float(np.sqrt(np.nanmean(residual ** 2))) if n_matched else float("nan")
    rows = []
    for j in range(t.size):
        status = MISSING if sec.missing[j] else (MATCHED if confirmed[j] else TABLE_ONLY)
        rows.append({"run_id": run_id, "section_id": sec.section_id, "mast_id": sec.mast_id[j],
                     "span_type": sec.span_type[j] or "", "status": status, "method": "height",
                     "table_chainage_m": float("nan") if sec.missing[j] else float(t[j]),
                     "recorded_chainage_m": float(recorded[j]), "chainage_m": float(chain[j]),
                     "std_m": float(std[j] / slope[j]), "residual_m": float(residual[j]),
                     "corr_next": float(corr[j])})
    return _Placement(rows + _extra_rows(run_id, sec), fitted, n_matched, identity, rms,
                      float("nan") if table_from_trace else fit.table_std_m, fit.length_std_m)


def register_run(samples: pd.DataFrame, masts: pd.DataFrame, catenary: Catenary, settings: RegistrationSettings,
                 lag: Callable[[str, float], float], log=None, table_from_trace: bool = False) -> RunRegistration:
    """Register the mast table onto one run (module docs).

    Parameters
    ----------
    samples : pandas.DataFrame
        The run's rows of a validated recording (``chainage_m``, ``height_m``, ``stagger_m``,
        ``speed_kmh``, ``run_id``, ``direction``).
    masts : pandas.DataFrame
        Validated masts (:func:`catenary.measurement.recording.validate_masts`).
    catenary : Catenary
    settings : RegistrationSettings
    lag : callable
        ``lag(span_type, speed_kmh)``: lag of the height's dropper kinks for a run towards
        increasing chainage [m] (:func:`catenary.measurement.registration.lag.height_lag_m`).
    log : logging.Logger, optional
    table_from_trace : bool
        ``masts`` were found from a run's trace (:func:`masts_from_trace`): no independent
        evidence on the supports, and no table whose accuracy to measure.

    Returns
    -------
    RunRegistration
    """
    run_id = str(samples["run_id"].iloc[0])
    direction = int(samples["direction"].iloc[0])
    trace = trace_of(samples["chainage_m"].to_numpy(), samples["height_m"].to_numpy(),
                     samples["stagger_m"].to_numpy() if samples["stagger_m"].notna().any() else None)
    speed = float(samples["speed_kmh"].median()) if samples["speed_kmh"].notna().any() else float("nan")
    masts = masts.reset_index(drop=True)
    sections = _table_sections(masts, catenary, settings)
    if direction < 0:
        sections = sections[::-1]
    longest = max(st.length_m for st in catenary.span_types.values())
    current = ChainageMap.identity(sections[0].table_m[0] if sections else 0.0)
    first = True
    mast_rows, section_rows, maps = [], [], {}
    method = "stagger" if trace.has_stagger else "height"       # the signature the coarse search reads
    for sec in sections:
        t = sec.table_m
        predicted = current.to_recorded(t)
        covered = (trace.chainage_m[0] <= predicted.max() + settings.max_offset_m) and (
            trace.chainage_m[-1] >= predicted.min() - settings.max_offset_m)
        inside = np.mean((predicted >= trace.chainage_m[0]) & (predicted <= trace.chainage_m[-1]))
        base = {"run_id": run_id, "section_id": sec.section_id, "n_table_masts": t.size}
        if not covered or inside < 0.5:
            section_rows.append({**base, "status": NOT_COVERED, "reason": (
                f"run {run_id} does not cover section {sec.section_id}: its samples span "
                f"{trace.chainage_m[0]:.1f}–{trace.chainage_m[-1]:.1f} m, the section's masts are expected at "
                f"{predicted.min():.1f}–{predicted.max():.1f} m"), "n_matched": 0})
            mast_rows += _unplaced(run_id, sec, TABLE_ONLY, "table")
            continue
        scale = current.scale
        type_lag = {name: direction * (lag(name, speed) if not trace.has_stagger else 0.0)
                    for name in {x for x in sec.span_type if x is not None}}
        lag_m = float(np.mean(list(type_lag.values()))) if type_lag else 0.0
        reach = settings.max_offset_m if first else min(settings.max_offset_m, max(3.0, 2 * settings.search_m))
        tolerance = max(settings.max_residual_m, 0.2, min(_SPREAD_TOLERANCE * sec.spread_m, settings.search_m))
        # The kink signals of this section's stretch, with room for a span's pattern past each end.
        margin = reach + 2 * longest + _KINK_MARGIN_M
        kinks = support_kinks(trace, float(predicted.min()) - margin, float(predicted.max()) + margin)
        slopes = None
        if method == "height" and tolerance > settings.max_residual_m:
            slopes = _chain_slopes(kinks, predicted, reach, sec, catenary, type_lag, scale, settings)
        coarse = support_line(trace, kinks, t, sec.span_type, predicted, catenary, scale=scale, lag_m=lag_m,
                              reach_m=reach, max_scale_error=settings.max_scale_error, tolerance_m=tolerance,
                              slopes=slopes)
        required = max(settings.min_matched_masts, int(np.ceil(settings.min_matched_fraction * t.size)))
        if coarse is None or coarse[1].sum() < required:
            agree = 0 if coarse is None else int(coarse[1].sum())
            section_rows.append({**base, "status": REFUSED, "n_matched": agree, "reason": (
                f"section {sec.section_id}, run {run_id}: registration failed: the trace's {method} shows the "
                f"supports of only {agree} of the {t.size} table masts at a common offset and scale (need {required}: "
                f"min_matched_fraction {settings.min_matched_fraction:g}, min_matched_masts "
                f"{settings.min_matched_masts}) within ±{reach:g} m of where the table puts them; a mast table of "
                "another line, a recording of another line, or a trace without usable supports")})
            mast_rows += _unplaced(run_id, sec, TABLE_ONLY, "table")
            continue
        guess = coarse[0]
        placed = (_place_by_height(trace, sec, guess, scale, type_lag, settings, catenary, run_id, table_from_trace)
                  if method == "height"
                  else _place_one_by_one(trace, sec, guess, scale, type_lag, lag_m, settings, catenary, run_id,
                                         table_from_trace))
        n_matched = placed.n_matched
        if placed.why or n_matched < required:
            why = placed.why or (f"the trace's {method} confirms {n_matched} of the {t.size} masts "
                                 f"(need {required}: min_matched_fraction {settings.min_matched_fraction:g}, "
                                 f"min_matched_masts {settings.min_matched_masts}) where "
                                 + ("the whole section's fit places them (within max_residual_m "
                                    f"{settings.max_residual_m:g} m); a trace whose droppers' kinks the height "
                                    "does not show" if method == "height" else "the map puts them"))
            section_rows.append({**base, "status": REFUSED, "n_matched": n_matched, "reason": (
                f"section {sec.section_id}, run {run_id}: registration failed: {why}")})
            mast_rows += _unplaced(run_id, sec, TABLE_ONLY, "table")
            continue
        rows, fitted, identity, rms = placed.rows, placed.fitted, placed.identity, placed.residual_rms_m
        n_missing, n_extra = int(sec.missing.sum()), len(sec.extra)
        mast_rows += rows
        maps[sec.section_id] = fitted
        middle = float(np.mean(t))
        recorded = [r["recorded_chainage_m"] for r in rows if np.isfinite(r["recorded_chainage_m"])]
        section_rows.append({**base, "status": REGISTERED, "n_matched": n_matched,
                             "reason": "" if not identity else (
                                 "the trace agrees with the table's chainage within what it can tell: identity map"),
                             "n_missing_from_table": n_missing, "n_extra_in_table": n_extra,
                             "offset_m": float(fitted.to_recorded(middle) - middle),
                             "scale": float(fitted.slope(middle)), "degree": fitted.degree, "residual_rms_m": rms,
                             "recorded_low_m": float(min(recorded)), "recorded_high_m": float(max(recorded)),
                             "reference_m": fitted.reference_m,
                             "coefficients": " ".join(f"{c:.12g}" for c in fitted.coefficients),
                             "table_std_m": placed.table_std_m, "span_length_std_m": placed.length_std_m,
                             "support_std_m": float(np.sqrt(np.nanmean(np.square(
                                 [r["std_m"] for r in rows if r["status"] != EXTRA]))))})
        current = fitted
        first = False
        if log is not None:
            log.info("run %s, section %s: %d of %d masts confirmed by the %s, offset %+.3f m, scale %.5f, "
                     "residual RMS %.3f m, the table accurate to %.3f m (mast_table_std_m %g m: the prior), masts "
                     "placed to %.3f m (RMS), %d missing from the table, %d extra", run_id, sec.section_id, n_matched,
                     t.size, method, section_rows[-1]["offset_m"], section_rows[-1]["scale"], rms, placed.table_std_m,
                     settings.mast_table_std_m, section_rows[-1]["support_std_m"], n_missing, n_extra)
    masts_out = pd.DataFrame(mast_rows, columns=MAST_COLUMNS)
    sections_out = pd.DataFrame(section_rows, columns=SECTION_COLUMNS)
    for name in ("n_missing_from_table", "n_extra_in_table", "degree", "n_matched"):
        sections_out[name] = sections_out[name].fillna(0).astype(int)
    sections_out["reason"] = sections_out["reason"].fillna("")
    sections_out["coefficients"] = sections_out["coefficients"].fillna("")
    if direction < 0:                               # report in the table's order
        order = {s.section_id: i for i, s in enumerate(sections[::-1])}
        sections_out = sections_out.iloc[np.argsort(sections_out["section_id"].map(order).to_numpy(),
                                                     kind="stable")].reset_index(drop=True)
        masts_out = masts_out.iloc[np.argsort(masts_out["section_id"].map(order).to_numpy(),
                                              kind="stable")].reset_index(drop=True)
    return RunRegistration(run_id, direction, masts_out, sections_out, maps)


def _agrees_with_identity(t: np.ndarray, position: np.ndarray, listed: np.ndarray, methods: np.ndarray,
                          settings: RegistrationSettings) -> bool:
    """Whether the section's supports are consistent with the recording's chainage as it is
    (offset 0 and scale 1): the offset (at the section's middle) and the scale of a line through
    the confirmed masts, with their standard errors from the residuals' scatter, against the
    95 % quantile of χ² with 2 degrees of freedom. Then the map is the identity: a trace cannot
    improve on a chainage it agrees with, and a height trace would only move it by its lag's
    error.

    Where the height placed masts, the line also carries the bias of the height's dynamic lag,
    ``height_lag_std_m`` independently at each end of the section (the lag follows the tension,
    the speed and the wear, which change along a line): the offset's variance grows by σ²/2 and
    the scale's by 2σ²/L². On the default campaign's line (exact odometer and table), measured
    by three runs (the default run; forward and backward in ``r_two_runs_default``), the
    height-placed supports' line lies at the 54 section ends 0.12 m RMS from the truth, between
    −0.45 and +0.26 m, its scatter about the line 0.09–0.22 m RMS. With the lag as one offset
    error of 0.1 m the default run's S08 (−0.28 m to −0.07 m over 1 026 m, scatter 0.12 m) was
    mapped off by 0.34 m and its first span's W by 3 mm; with 0.15 m at each end the forward
    run's S08 (−0.04 to −0.45 m, 12 masts) was still mapped off; the default 0.2 m keeps all 27
    at the identity, while a 0.1 % scale or a 0.6 m offset over a section is still mapped."""
    if listed.sum() < 3:
        return False
    x = t[listed] - np.mean(t[listed])
    y = position[listed] - t[listed]
    a = np.column_stack([np.ones_like(x), x])
    coef, *_ = np.linalg.lstsq(a, y, rcond=None)
    residual = y - a @ coef
    s2 = float(residual @ residual) / max(listed.sum() - 2, 1)
    cov = s2 * np.linalg.inv(a.T @ a)
    if np.any(methods[listed] == "height"):
        length = float(np.ptp(t[listed]))
        cov[0, 0] += settings.height_lag_std_m ** 2 / 2
        cov[1, 1] += 2 * settings.height_lag_std_m ** 2 / max(length, 1.0) ** 2
    statistic = float(coef @ np.linalg.solve(cov, coef))
    return statistic <= 5.991


def _unplaced(run_id: str, sec: _TableSection, status: str, method: str) -> list[dict]:
    """Rows of a section the run could not register: the table's positions, unconfirmed."""
    rows = [{"run_id": run_id, "section_id": sec.section_id, "mast_id": m, "span_type": st or "",
             "status": MISSING if miss else status, "method": "span_length" if miss else method,
             "table_chainage_m": float("nan") if miss else float(x), "recorded_chainage_m": float("nan"),
             "chainage_m": float(x), "std_m": float("nan"), "residual_m": float("nan"), "corr_next": float("nan")}
            for m, x, st, miss in zip(sec.mast_id, sec.table_m, sec.span_type, sec.missing)]
    return rows + _extra_rows(run_id, sec)


def _extra_rows(run_id: str, sec: _TableSection) -> list[dict]:
    return [{"run_id": run_id, "section_id": sec.section_id, "mast_id": m, "span_type": "", "status": EXTRA,
             "method": "span_length", "table_chainage_m": float(x), "recorded_chainage_m": float("nan"),
             "chainage_m": float("nan"), "std_m": float("nan"), "residual_m": float("nan"), "corr_next": float("nan")}
            for m, x in sec.extra]


def _place_masts(sec: _TableSection, fitted: ChainageMap, inlier: np.ndarray, position: np.ndarray, std: np.ndarray,
                 residual: np.ndarray, run_id: str, methods: np.ndarray) -> list[dict]:
    """Registered position of every mast: the trace's and the table's weighed by their errors.

    A trace position's error is its fit's standard error, or, when larger, what the section's
    residuals of that signature (stagger or height) show beyond the table's own error: their mean
    square less the table's variance (the height's fits understate theirs: the droppers' random
    kinks bias each fit a little, and a few fits lie far off). The mean square, not a robust
    spread: the weights are those of the least-squares combination, which needs the errors'
    variance, heavy tails included (on ``r_table``'s N3, where a few height fits lie 0.5–0.8 m
    off, the robust spread gave them weights that left the masts 0.19 m RMS from the truth
    against the table's own 0.16 m). With fewer than 5 masts of a signature to tell, at least the
    table's error."""
    t = sec.table_m
    scale = fitted.slope(t)
    z = fitted.to_table(np.where(inlier, position, fitted.to_recorded(t)))
    listed = inlier & ~sec.missing
    z_var = (std / scale) ** 2
    for how in np.unique(methods):
        these = listed & (methods == how)
        if these.sum() >= 5:
            r = residual[these]
            floor = float(np.mean(r ** 2)) - float(np.median(sec.table_std_m[these])) ** 2
        else:
            floor = float(np.median(sec.table_std_m)) ** 2
        z_var = np.where(methods == how, np.maximum(z_var, floor), z_var)
    w_trace = np.where(inlier, 1.0 / z_var, 0.0)
    w_table = 1.0 / sec.table_std_m ** 2
    chain = (w_trace * np.nan_to_num(z) + w_table * t) / (w_trace + w_table)
    chain_std = 1.0 / np.sqrt(w_trace + w_table)
    rows = []
    for j in range(t.size):
        status = MISSING if sec.missing[j] else (MATCHED if inlier[j] else TABLE_ONLY)
        rows.append({"run_id": run_id, "section_id": sec.section_id, "mast_id": sec.mast_id[j],
                     "span_type": sec.span_type[j] or "", "status": status,
                     "method": methods[j] if inlier[j] else ("span_length" if sec.missing[j] else "table"),
                     "table_chainage_m": float("nan") if sec.missing[j] else float(t[j]),
                     "recorded_chainage_m": float(fitted.to_recorded(chain[j])), "chainage_m": float(chain[j]),
                     "std_m": float(chain_std[j]), "residual_m": float(residual[j]), "corr_next": float("nan")})
    return rows + _extra_rows(run_id, sec)


def _nearest_type(length: float, catenary: Catenary) -> str:
    return min(catenary.span_types, key=lambda t: abs(catenary.span_types[t].length_m - length))


def _two_spans(length: float, declared: str | None, catenary: Catenary, tolerance: float) -> tuple[str, str] | None:
    """Two span types whose lengths add up to ``length`` within ``tolerance`` (the declared type first)."""
    names = sorted(catenary.span_types, key=lambda n: (n != declared, n))
    best = None
    for a in names:
        for b in names:
            error = abs(catenary.span_types[a].length_m + catenary.span_types[b].length_m - length)
            if error <= tolerance and (best is None or error < best[0] - 1e-9):
                best = (error, a, b)
    return None if best is None else (best[1], best[2])


def register_runs(samples_of: Callable[[str], pd.DataFrame], run_ids: Sequence[str], masts: pd.DataFrame,
                  catenary: Catenary, settings: RegistrationSettings, lag: Callable[[str, float], float], *,
                  log=None, table_from_trace: bool = False, workers: int = 1) -> list[RunRegistration]:
    """Every run of a recording registered (:func:`register_run`; :func:`unregistered_run` where
    ``settings.enabled`` is false), in the order of ``run_ids``.

    The runs are independent: each is registered from its own trace and the same mast table, so
    they go to ``workers`` forked processes, one run at a time each, and the registrations are
    the same, bit for bit, for any number of workers. A run's sections follow each other (each
    search starts from the previous section's map): a recording of one run uses one process.

    Parameters
    ----------
    samples_of : callable
        ``samples_of(run_id)``: the run's validated samples (each process reads only the runs it
        registers).
    run_ids : sequence of str
    masts, catenary, settings, lag, log, table_from_trace
        As :func:`register_run`.
    workers : int
        Processes (1: every run in this one, in turn).
    """
    def one(k: int) -> RunRegistration:
        samples = samples_of(run_ids[k])
        if not settings.enabled:
            return unregistered_run(samples, masts, catenary)
        return register_run(samples, masts, catenary, settings, lag, log=log, table_from_trace=table_from_trace)

    return map_each(one, len(run_ids), workers, 1)


def unregistered_run(samples: pd.DataFrame, masts: pd.DataFrame, catenary: Catenary) -> RunRegistration:
    """The mast table taken as it is for one run (registration switched off): every mast at its
    table chainage with an unknown error, every map the identity."""
    run_id = str(samples["run_id"].iloc[0])
    direction = int(samples["direction"].iloc[0])
    masts = masts.reset_index(drop=True)
    rows, section_rows, maps = [], [], {}
    for section_id, part in masts.groupby("section_id", sort=False):
        x = part["chainage_m"].to_numpy(dtype=float)
        for i, (mast, x_m) in enumerate(zip(part["mast_id"].astype(str), x)):
            declared = part["span_type"].iloc[i]
            rows.append({"run_id": run_id, "section_id": str(section_id), "mast_id": mast,
                         "span_type": declared if isinstance(declared, str) else "", "status": TABLE_ONLY,
                         "method": "table", "table_chainage_m": float(x_m), "recorded_chainage_m": float(x_m),
                         "chainage_m": float(x_m), "std_m": float("nan"), "residual_m": float("nan"),
                         "corr_next": float("nan")})
        maps[str(section_id)] = ChainageMap.identity(float(x[0]))
        section_rows.append({"run_id": run_id, "section_id": str(section_id), "status": UNREGISTERED, "reason": "",
                             "n_table_masts": x.size, "n_matched": 0, "n_missing_from_table": 0,
                             "n_extra_in_table": 0, "offset_m": 0.0, "scale": 1.0, "degree": 1,
                             "residual_rms_m": float("nan"), "recorded_low_m": float(x[0]),
                             "recorded_high_m": float(x[-1]), "reference_m": float(x[0]),
                             "coefficients": f"{x[0]:.12g} 1", "table_std_m": float("nan"),
                             "span_length_std_m": float("nan"), "support_std_m": float("nan")})
    return RunRegistration(run_id, direction, pd.DataFrame(rows, columns=MAST_COLUMNS),
                           pd.DataFrame(section_rows, columns=SECTION_COLUMNS), maps)


def masts_from_trace(samples: pd.DataFrame, catenary: Catenary, settings: RegistrationSettings,
                     lag: Callable[[str, float], float]) -> pd.DataFrame:
    """A mast table found from one run's trace alone (no mast table given).

    A stretch of recording ends where ``section_gap_m`` passes without samples. With the stagger,
    its supports are followed span by span: the first is where the stagger's reversal is
    strongest within one span length of the stretch's start, placed by its own fit; each next
    one is looked for one span length further (each span type tried, the best fit kept), within
    ``± search_m``, until the trace ends — a reversal marks each support on its own. With the
    height alone, whose supports do not, the stretch's whole chain of spans is found at once
    (:mod:`.chain`). Each stretch is a section (``T01``, ``T02``…), its masts
    ``T01.000``, ``T01.001``…; chainages are the run's own, rescaled by the odometer scale that
    the supports against the span types' lengths give (:func:`.chain.odometer_scale`). Masts and
    span types come out as a masts table (:func:`catenary.measurement.recording.validate_masts`' columns).
    """
    direction = int(samples["direction"].iloc[0])
    trace = trace_of(samples["chainage_m"].to_numpy(), samples["height_m"].to_numpy(),
                     samples["stagger_m"].to_numpy() if samples["stagger_m"].notna().any() else None)
    speed = float(samples["speed_kmh"].median()) if samples["speed_kmh"].notna().any() else float("nan")
    types = sorted(catenary.span_types, key=lambda n: catenary.span_types[n].length_m)
    lags = {n: direction * (lag(n, speed) if not trace.has_stagger else 0.0) for n in types}
    longest = max(catenary.span_types[t].length_m for t in types)
    x = trace.chainage_m[np.isfinite(trace.height_m)]
    breaks = np.flatnonzero(np.diff(x) > settings.section_gap_m)
    stretches = np.split(x, breaks + 1)
    rows = []
    for n, stretch in enumerate(s for s in stretches if s.size and s[-1] - s[0] > min(
            catenary.span_types[t].length_m for t in types)):
        margin = 2 * longest + _KINK_MARGIN_M          # this stretch's kink signals (support_kinks)
        kink_grid, kink, sag = support_kinks(trace, stretch[0] - margin, stretch[-1] + margin)
        if trace.has_stagger:
            supports, kinds = _follow(trace, kink_grid, kink, stretch[0], stretch[-1], catenary, types, lags, settings)
        else:
            supports, kinds = chain_supports(kink_grid, kink, sag, stretch[0], stretch[-1], catenary, types, lags,
                                             settings.max_scale_error)
        if len(supports) < 2:
            continue
        rows.append({"section": n, "supports": supports, "types": kinds})
    scale = odometer_scale([(r["supports"], r["types"]) for r in rows], catenary)
    out = []
    origin = rows[0]["supports"][0] if rows else 0.0
    for k, r in enumerate(rows):
        section_id = f"T{k + 1:02d}"
        for i, x_m in enumerate(r["supports"]):
            out.append({"mast_id": f"{section_id}.{i:03d}", "chainage_m": origin + (x_m - origin) / scale,
                        "section_id": section_id, "span_type": r["types"][i] if i < len(r["types"]) else None})
    return pd.DataFrame(out, columns=["mast_id", "chainage_m", "section_id", "span_type"])


def _follow(trace, kink_grid, kink, start, end, catenary, types, lags, settings):
    """Supports along one stretch of a trace with the stagger (see :func:`masts_from_trace`)."""
    longest = max(catenary.span_types[t].length_m for t in types)
    # first support: the strongest reversal of the stagger within one span length of the start
    offsets = np.arange(start, start + longest, _COARSE_STEP_M)
    best = (-np.inf, None, None)
    values = np.abs(np.interp(offsets, kink_grid, kink, left=np.nan, right=np.nan))
    if np.isfinite(values).any():
        k = int(np.nanargmax(values))
        best = (values[k], offsets[k], types[0])
    if best[1] is None:
        return [], []
    # the kink signal's grid and windows place it to a few decimetres (0.18 m on r_no_table's
    # first support): the reversal's own fit, as for every next support, to about a centimetre
    first = locate_stagger_support(trace, float(best[1]), settings.search_m)
    if first.found:
        best = (best[0], first.position_m, best[2])
    supports, kinds = [float(best[1])], []
    while True:
        here = supports[-1]
        options = []
        for name in types:
            st = catenary.span_type(name)
            guess = here + st.length_m
            if guess > end + 1.0:
                continue
            half = 0.5 * st.length_m
            offsets_m = np.r_[0.0, st.dropper_positions_m - st.length_m]
            fit, _ = _local_fit(trace, guess, offsets_m, half, 1.0 if guess + 1.0 > end else half, 1.0,
                                lags[name], settings.search_m)
            # a support that would make the span off its type's length by more than the tolerance
            # is not this type's (the search reaches further than the tolerance)
            if fit.found and np.isfinite(fit.std_m) and abs(fit.position_m - guess) <= settings.length_tolerance_m:
                options.append((-fit.std_m, fit.position_m, name))
        if not options:
            break
        _, position, name = max(options)
        supports.append(float(position))
        kinds.append(name)
    return supports, kinds
