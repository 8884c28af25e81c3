"""The supports of a stretch of height trace without a mast table: the best chain of spans.

Without a table and without the stagger, no single support shows itself clearly in the height:
a span's droppers leave small kinks, the wire is highest at its supports, and both are faint
against the dynamic pass. Followed span by span from the start, one wrong step (a comb that
slips by a dropper spacing, a span type mistaken for another) loses the rest of the stretch
(measured on the r_table campaign's height: 3 of 42 masts found). So the whole stretch is
decided at once, as the most likely segmentation of a signal (the Viterbi algorithm): a chain of
supports ``x₀ < x₁ < … < x_K`` whose spans each have a span type's length, scored by

    Σ_k [ mean of the height's kink at the type's droppers in (x_k, x_k+1)
          + w · (the sag's kink at x_k and at x_k+1) ]  −  c · (number of changes of type)

with the droppers placed at the type's design positions scaled to the span, shifted by the
dynamic pass's lag; ``w`` (:data:`SAG_WEIGHT`) brings in the wire's sag (highest at the
supports), which keeps the chain from sliding half a span where the dropper combs of two
neighbours half overlap. Two passes:

1. span lengths free within ``± max_scale_error`` of each type's: the chain gives the
   odometer's scale (:func:`odometer_scale`), its median span score the price ``c`` of a change
   of type;
2. span lengths within ``± LENGTH_TOLERANCE_M`` of the scaled types' lengths, a change of type
   costing ``c`` (a section keeps its span type unless the trace insists): the end spans, where
   the pass starts and stops and the trace is least like the model, can no longer be fitted by
   another type to gain a little score.

The first support lies within one span length of the stretch's start, the last within one span
length of its end. Measured on the r_table campaign's height trace (two stretches of 21 masts,
odometer 0.3 % long): 21 and 21 supports, every span of the right type, each support within
0.50 m and 0.73 m of the truth (RMS 0.28 m and 0.36 m); the registration then places them.
"""

from __future__ import annotations

import numpy as np

from catenary.physics.config import Catenary

__all__ = ["LENGTH_TOLERANCE_M", "SAG_WEIGHT", "chain_supports", "odometer_scale"]

#: Weight of the sag's kink at the supports against the droppers' comb (module docs). Measured
#: on r_table's height with a draft of this search: 0.1 and 1 both found all 42 supports (within
#: 0.75 m; on the N2 stretch 0.58 m at 0.1, 0.46 m at 1); without it the N2 stretch's chain slid
#: by half a span (the shipped search then finds 41 of 42: tests/test_registration_pipeline.py).
SAG_WEIGHT = 1.0
#: Second pass: a span's length within this of its type's length times the odometer scale [m].
LENGTH_TOLERANCE_M = 0.25


def chain_supports(grid_m: np.ndarray, comb: np.ndarray, sag: np.ndarray, start_m: float, end_m: float,
                   catenary: Catenary, types: list[str], lags_m: dict[str, float],
                   max_scale_error: float) -> tuple[list[float], list[str]]:
    """Supports and span types of one stretch of height trace (module docs).

    Parameters
    ----------
    grid_m : numpy.ndarray
        Regular grid of the run's chainage [m].
    comb, sag : numpy.ndarray
        The height's kink at the droppers' scale and at the sag's scale on ``grid_m`` [m/m]
        (:func:`catenary.measurement.registration.runner.support_kinks`); NaN where unknown.
    start_m, end_m : float
        The stretch of recording [m].
    catenary : Catenary
    types : list of str
        The span types that may occur.
    lags_m : dict
        Lag of each type's dropper kinks in the trace, signed along the chainage [m].
    max_scale_error : float
        Largest odometer scale error (first pass).

    Returns
    -------
    list of float, list of str
        The supports (recorded chainage, increasing) and the type of each span between two of
        them; empty when the stretch holds no span.
    """
    lo, hi = np.searchsorted(grid_m, [start_m, end_m])
    g = np.asarray(grid_m[lo:hi], dtype=float)
    if g.size < 2:
        return [], []
    comb = np.nan_to_num(np.asarray(comb[lo:hi], dtype=float))
    sag = np.nan_to_num(np.asarray(sag[lo:hi], dtype=float))
    step = float(g[1] - g[0])
    first = _viterbi(g, comb, sag, step, catenary, types, lags_m, 1.0,
                     {n: max_scale_error * catenary.span_types[n].length_m for n in types}, 0.0)
    if len(first[0]) < 2:
        return first[0], first[1]
    supports, kinds, scores = first
    scale = odometer_scale([(supports, kinds)], catenary)
    price = max(float(np.median(scores)), 0.0)
    second = _viterbi(g, comb, sag, step, catenary, types, lags_m, scale, {n: LENGTH_TOLERANCE_M for n in types},
                      price)
    return second[0], second[1]


def _viterbi(g, comb, sag, step, catenary, types, lags_m, scale, tolerance_m, price):
    """The best chain on the grid ``g`` (module docs): supports, span types, span scores."""
    n, nt = g.size, len(types)
    longest = max(catenary.span_types[t].length_m for t in types) * scale
    moves = []                                           # (grid steps, type, score of a span starting at each point)
    for ti, name in enumerate(types):
        st = catenary.span_types[name]
        centre = int(round(scale * st.length_m / step))
        reach = int(np.ceil(tolerance_m[name] / step))
        for d in range(max(centre - reach, 1), centre + reach + 1):
            length = d * step
            droppers = g[:, None] + st.dropper_positions_m[None, :] * (length / st.length_m) + lags_m[name]
            score = np.interp(droppers, g, comb, left=np.nan, right=np.nan).mean(axis=1)
            at_supports = (np.interp(g + lags_m[name], g, sag, left=np.nan, right=np.nan)
                           + np.interp(g + length + lags_m[name], g, sag, left=np.nan, right=np.nan))
            score = score + SAG_WEIGHT * at_supports
            moves.append((d, ti, np.where(np.isfinite(score), score, -np.inf)))
    shortest = min(d for d, _, _ in moves)
    # best[b, t]: best score of a chain whose last span, of type t, ends at b; column nt: a
    # chain's first support (score 0 within one span length of the start)
    best = np.full((n, nt + 1), -np.inf)
    best[g < g[0] + longest, nt] = 0.0
    came = np.full((n, nt, 2), -1, dtype=int)
    change = np.full((nt + 1, nt), price)
    change[np.arange(nt), np.arange(nt)] = 0.0
    change[nt] = 0.0
    # a span is at least `shortest` steps long: the points of one block depend on earlier blocks only
    for b0 in range(0, n, shortest):
        b = np.arange(b0, min(b0 + shortest, n))
        for d, ti, score in moves:
            a = b - d
            ok = a >= 0
            if not ok.any():
                continue
            a, bb = a[ok], b[ok]
            before = best[a] - change[:, ti]              # (points, previous type)
            previous = np.argmax(before, axis=1)
            total = before[np.arange(a.size), previous] + score[a]
            better = total > best[bb, ti]
            best[bb[better], ti] = total[better]
            came[bb[better], ti, 0] = a[better]
            came[bb[better], ti, 1] = previous[better]
    tail = np.flatnonzero(g > g[-1] - longest)
    end = best[tail, :nt]
    if not np.isfinite(end).any():
        return [], [], []
    i, ti = np.unravel_index(int(np.argmax(end)), end.shape)
    b = int(tail[i])
    supports, kinds, scores = [float(g[b])], [], []
    while ti < nt and came[b, ti, 0] >= 0:
        a, previous = int(came[b, ti, 0]), int(came[b, ti, 1])
        supports.append(float(g[a]))
        kinds.append(types[ti])
        d = next(m for m in moves if m[1] == ti and m[0] == b - a)
        scores.append(float(d[2][a]))
        b, ti = a, previous
    return supports[::-1], kinds[::-1], scores[::-1]


def odometer_scale(chains: list[tuple[list[float], list[str]]], catenary: Catenary) -> float:
    """Recorded metres per metre of the span types' lengths [-]: the least-squares slope of the
    supports' recorded chainages against their cumulative design chainages, pooled over the
    chains (each with its own origin). A slope, not a median of spacings: each spacing is only
    known to the grid and to its supports' errors, a section's length to those of its two ends.

    Parameters
    ----------
    chains : list of (supports, span types)
        Supports (recorded chainage, increasing) and the type of each span between them.
    catenary : Catenary

    Returns
    -------
    float
        1.0 when no chain has two supports.
    """
    sxy = sxx = 0.0
    for supports, kinds in chains:
        if len(supports) < 2:
            continue
        design = np.r_[0.0, np.cumsum([catenary.span_types[k].length_m for k in kinds])]
        recorded = np.asarray(supports, dtype=float)
        design, recorded = design - design.mean(), recorded - recorded.mean()
        sxy += float(design @ recorded)
        sxx += float(design @ design)
    return sxy / sxx if sxx > 0 else 1.0
