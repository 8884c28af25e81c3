"""Where the trace of one run puts the supports (steady arms) and the droppers.

Two signatures of a support are read from a recording, each by a least-squares fit whose
misfit, as a function of where the support is assumed, gives both the position and its
standard error:

**Stagger** (when the car records it). The steady arms pull the CW alternately to each side, so
the stagger is a straight line between supports that reverses at each one
(:func:`catenary.measurement.recording_car.stagger_at`). Around a support the model is the kinked line
``s = a + b·u + c·|u − u₀|``; its residual sum of squares ``RSS(u₀)`` is smallest at the
support, to about a centimetre (a 13 mm/m slope reversal against a few millimetres of noise).

**Height**. The CW is not held at a fixed height at the steady arm (the measuring pantograph
lifts it there as anywhere) and a steady arm's kink may point either way, so the height trace
does not mark the masts by a local maximum. It marks the **droppers**: each holds the CW up by a
point force, so the CW's slope drops there (by ≈ 0.5–3 mm/m). A span's droppers sit at the
span type's design distances from its mast; the trace between them is smooth. So the trace
around a mast is fitted by a continuous piecewise quadratic whose slope may jump at the mast and
at the droppers of the two spans beside it, all shifted together by ``u₀``; ``RSS(u₀)`` is
smallest where the whole dropper pattern lines up, to about 0.1–0.2 m per mast (the kinks are
small and random).

The dynamic pass lags: the heights a car reports at 40 km/h show the droppers' kinks ≈ 0.25 m
after the droppers in the direction of travel (a quasi-static pass shows none). The height
signature is therefore read with a lag, ``lag_m`` (signed along the chainage), which
:func:`catenary.measurement.registration.lag.height_lag_m` measures on the correction's own model of the
measuring pass.

Both fits are evaluated on a grid of trial positions. The stagger's misfit is smooth: its best
trial is refined by a parabola through the best three, and the standard error is
``√(2 σ² / RSS'')`` with ``σ²`` the residual variance at the optimum (the curvature of a
least-squares misfit in a location parameter). The height's misfit is rough at the scale of the
sampling step (each sample that a moving kink crosses changes the fit's basis), so the curvature
through three neighbouring trials measures that roughness, not the valley: on the validation
campaign ``r_table`` (1 mm of noise every 0.1 m) it gave 0.03–0.12 m where the masts lay
0.24–0.43 m (RMS) from the truth. The height's position and standard error are therefore those
of a least-squares parabola through every trial within ``±VALLEY_M`` of the best (the valley's
own width): measured on the same traces, 0.23 / 0.30 m (RMS, N2 / N3) from the truth with a
median standard error of 0.13 / 0.18 m; on four N3 masts, each re-drawn with 12 noise draws,
the positions spread by 0.12–0.44 m where the three-point curvature said 0.10–0.13 m and the
valley 0.17–0.22 m.
"""

from __future__ import annotations

from dataclasses import dataclass

import warnings

import numpy as np

__all__ = ["LocalFit", "Trace", "align_pattern", "despike", "locate_stagger_support", "pattern_misfit", "trace_of", "valley_fit"]

#: Half-width of the running median that finds spikes [samples].
_DESPIKE_HALF = 10
#: A sample further than this many robust standard deviations from its running median is a spike.
_DESPIKE_THRESHOLD = 4.0
#: Half-width of the misfit's valley through which the height's parabola is fitted [m]
#: (module docs): wide enough to average the misfit's roughness at the sampling step, narrow
#: enough for the valley to be a parabola (measured on ``r_table``: 0.5, 0.75, 1.0 m give the
#: masts 0.26, 0.27, 0.28 m RMS from the truth and standard errors 1.76, 1.59, 1.46 times too small).
VALLEY_M = 0.75


@dataclass(frozen=True)
class Trace:
    """The samples of one run, sorted by increasing chainage of the run's own frame.

    Attributes
    ----------
    chainage_m : numpy.ndarray
        Recorded chainage [m], increasing.
    height_m : numpy.ndarray
        Heights [m] with drop-outs and spikes removed (NaN).
    stagger_m : numpy.ndarray or None
        Stagger [m] with spikes removed, or None when the run has none.
    """

    chainage_m: np.ndarray
    height_m: np.ndarray
    stagger_m: np.ndarray | None

    @property
    def has_stagger(self) -> bool:
        return self.stagger_m is not None

    def window(self, low_m: float, high_m: float, signal: str = "height") -> tuple[np.ndarray, np.ndarray]:
        """Valid samples (chainage, value) of ``signal`` (``"height"`` or ``"stagger"``) in
        ``[low_m, high_m]``."""
        a, b = np.searchsorted(self.chainage_m, [low_m, high_m], side="left")
        b = np.searchsorted(self.chainage_m, high_m, side="right")
        values = (self.height_m if signal == "height" else self.stagger_m)[a:b]
        keep = np.isfinite(values)
        return self.chainage_m[a:b][keep], values[keep]


#: Samples per block of :func:`despike`'s running median (≈ 10 MB of windows a block).
_DESPIKE_BLOCK = 1 << 16


def despike(values: np.ndarray, floor: float) -> np.ndarray:
    """``values`` with isolated spikes set to NaN: samples further than 4 robust standard
    deviations (1.4826 MAD of the deviations, at least ``floor``) from the running median of
    ±10 samples."""
    v = np.asarray(values, dtype=float)
    n = v.size
    if n < 2 * _DESPIKE_HALF + 1:
        return v.copy()
    padded = np.pad(v, _DESPIKE_HALF, mode="edge")
    windows = np.lib.stride_tricks.sliding_window_view(padded, 2 * _DESPIKE_HALF + 1)
    median = np.empty(n)
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        # a window all inside a dropout has no median: its samples are NaN already
        warnings.simplefilter("ignore", RuntimeWarning)
        # by blocks of samples: each window's median is its own, and the sort's copies of the
        # windows (21 values a sample, several times) stay the block's size, not the run's
        for start in range(0, n, _DESPIKE_BLOCK):
            median[start:start + _DESPIKE_BLOCK] = np.nanmedian(windows[start:start + _DESPIKE_BLOCK], axis=1)
    deviation = v - median
    scale = max(1.4826 * float(np.nanmedian(np.abs(deviation))), floor)
    out = v.copy()
    out[np.abs(deviation) > _DESPIKE_THRESHOLD * scale] = np.nan
    return out


def trace_of(chainage_m: np.ndarray, height_m: np.ndarray, stagger_m: np.ndarray | None = None, *,
             height_floor_m: float = 5e-4, stagger_floor_m: float = 1e-3) -> Trace:
    """A :class:`Trace` from one run's samples (any order); spikes removed from both signals."""
    order = np.argsort(chainage_m, kind="stable")
    x = np.asarray(chainage_m, dtype=float)[order]
    h = despike(np.asarray(height_m, dtype=float)[order], height_floor_m)
    s = None
    if stagger_m is not None:
        s_raw = np.asarray(stagger_m, dtype=float)[order]
        if np.isfinite(s_raw).sum() > 2 * _DESPIKE_HALF:
            s = despike(s_raw, stagger_floor_m)
    return Trace(x, h, s)


@dataclass(frozen=True)
class LocalFit:
    """Where a local fit puts a feature.

    Attributes
    ----------
    position_m : float
        Best position (recording frame) [m]; NaN when the window had too few samples.
    std_m : float
        Its standard error [m] (curvature of the misfit).
    statistic : float
        ``(RSS(guess) − RSS(best)) / σ²``: how much better the best position explains the trace
        than the guessed one (≈ χ² with one degree of freedom when the guess is right).
    n_samples : int
        Samples in the fit.
    at_edge : bool
        The best position lies at the edge of the searched interval (the feature may be further).
    """

    position_m: float
    std_m: float
    statistic: float
    n_samples: int
    at_edge: bool = False

    @property
    def found(self) -> bool:
        return bool(np.isfinite(self.position_m)) and not self.at_edge


_NOT_FOUND = LocalFit(float("nan"), float("nan"), float("nan"), 0, False)


def _refine(trials: np.ndarray, rss: np.ndarray, dof: int, guess: float, step: float, n: int) -> LocalFit:
    """Best trial, refined by a parabola through its neighbours; standard error and statistic."""
    finite = np.isfinite(rss)
    if not finite.any() or dof <= 0:
        return _NOT_FOUND
    k = int(np.nanargmin(rss))
    best, curvature = trials[k], np.nan
    if 0 < k < trials.size - 1 and np.all(np.isfinite(rss[k - 1:k + 2])):
        r0, r1, r2 = rss[k - 1], rss[k], rss[k + 1]
        denominator = r0 - 2 * r1 + r2
        if denominator > 0:
            best = trials[k] + 0.5 * step * (r0 - r2) / denominator
            curvature = denominator / step ** 2
    sigma2 = max(float(rss[k]) / dof, 1e-30)
    at_guess = float(np.interp(guess, trials, rss))
    std = float(np.sqrt(2.0 * sigma2 / curvature)) if np.isfinite(curvature) else float("inf")
    edge = k in (0, trials.size - 1)
    return LocalFit(float(best), std, (at_guess - float(rss[k])) / sigma2, n, edge)


def valley_fit(trials: np.ndarray, rss: np.ndarray, dof: int, guess: float, step: float, n: int) -> LocalFit:
    """Best trial's valley fitted by a least-squares parabola over ``±VALLEY_M`` (module docs): its
    vertex and ``√(2 σ² / RSS'')``; the three-point refinement (:func:`_refine`) where the valley
    is not a parabola opening upwards with its vertex inside it."""
    local = _refine(trials, rss, dof, guess, step, n)
    if not np.isfinite(local.position_m) or local.at_edge:
        return local
    best = trials[int(np.nanargmin(rss))]
    sel = np.isfinite(rss) & (np.abs(trials - best) <= VALLEY_M + 1e-9)
    if sel.sum() < 5:
        return local
    c2, c1, _ = np.polyfit(trials[sel] - best, rss[sel], 2)
    if c2 <= 0 or abs(c1 / (2 * c2)) > VALLEY_M:
        return local
    sigma2 = max(float(np.nanmin(rss)) / dof, 1e-30)
    # RSS'' = 2 c2: the standard error √(2 σ² / RSS'') = √(σ² / c2)
    return LocalFit(float(best - c1 / (2 * c2)), float(np.sqrt(sigma2 / c2)), local.statistic, n, False)


def locate_stagger_support(trace: Trace, guess_m: float, search_m: float, half_window_m: float = 15.0,
                           step_m: float = 0.02) -> LocalFit:
    """A support read from the stagger's reversal near ``guess_m`` (module docs); not found (NaN)
    where the stagger is not recorded over half a window on both sides of the guess.

    Parameters
    ----------
    trace : Trace
        With a stagger.
    guess_m : float
        Predicted position (recording frame) [m].
    search_m : float
        The support is looked for within ``guess ± search_m`` [m].
    half_window_m : float
        The kinked line is fitted to the samples within ``guess ± (search_m + half_window_m)`` [m].
    step_m : float
        Grid of trial positions [m].
    """
    if trace.stagger_m is None:
        raise ValueError("locate_stagger_support: the trace has no stagger")
    x, s = trace.window(guess_m - search_m - half_window_m, guess_m + search_m + half_window_m, "stagger")
    if x.size < 8 or x[0] > guess_m - 0.5 * half_window_m or x[-1] < guess_m + 0.5 * half_window_m:
        # the stagger is not recorded on both sides of the guess (a recorded stretch's end): the
        # trials it can see lie on one side, and the best of them would be where the data end
        return _NOT_FOUND
    trials = np.arange(guess_m - search_m, guess_m + search_m + 0.5 * step_m, step_m)
    rss = np.full(trials.size, np.nan)
    for i, u0 in enumerate(trials):
        # a reversal needs the stagger on both sides (not the end of a recorded stretch)
        if x[0] > u0 - 0.5 * half_window_m or x[-1] < u0 + 0.5 * half_window_m:
            continue
        u = x - u0
        a = np.column_stack([np.ones_like(u), u, np.abs(u)])
        coef = np.linalg.lstsq(a, s, rcond=None)[0]
        r = s - a @ coef
        rss[i] = r @ r
    # the same samples at every trial position: the misfits compare like with like
    return _refine(trials, rss, x.size - 3, guess_m, step_m, x.size)


def _spline_rss(u: np.ndarray, h: np.ndarray, knots: np.ndarray) -> tuple[np.ndarray, int]:
    """Residual sum of squares of the continuous piecewise quadratic with free slope and
    curvature jumps at the knots, fitted to the samples ``(u, h)`` (``u`` from the window's start
    [m]), for each row of ``knots`` (one trial, all with the same number of knots inside the
    window), and its degrees of freedom.

    The trials are solved together, segment by segment: on segment j (from knot ``t_j``) the
    spline is ``a_j + b_j v + c_j v²`` in ``v = u − t_j``, continuity gives
    ``a_{j+1} = a_j + b_j d_j + c_j d_j²`` (``d_j`` the segment's length), and the normal
    equations in ``(a_0, b_0, c_0, b_1, c_1, …)`` add up each segment's moments of v and h — the
    same space as the ramps ``(u − k)₊``, ``(u − k)₊²`` over a quadratic, in O(samples) a trial
    instead of a least-squares factorisation of its whole design. The misfit is summed from the
    residuals themselves (no difference of two large sums). A trial with a segment holding fewer
    than three samples has dependent columns: it is solved apart by least squares on the ramps."""
    n_trials, n_knots = knots.shape
    knots = np.sort(knots, axis=1)
    n_seg, unknowns = n_knots + 1, 3 + 2 * n_knots
    seg = np.sum(knots[:, :, None] < u[None, None, :], axis=1)                  # (trials, samples)
    start = np.concatenate([np.zeros((n_trials, 1)), knots], axis=1)
    v = u[None, :] - np.take_along_axis(start, seg, axis=1)
    flat = (seg + n_seg * np.arange(n_trials)[:, None]).ravel()
    vf, hb = v.ravel(), np.broadcast_to(h, v.shape).ravel()

    def moment(weights):
        return np.bincount(flat, weights, minlength=n_trials * n_seg).reshape(n_trials, n_seg)

    count = moment(None)
    v2 = vf * vf
    m = [count, moment(vf), moment(v2), moment(v2 * vf), moment(v2 * v2)]
    moments = np.stack([np.stack([m[i + j] for j in range(3)], axis=-1) for i in range(3)], axis=-2)
    rhs = np.stack([moment(hb), moment(hb * vf), moment(hb * v2)], axis=-1)      # (trials, seg, 3)
    # (a_j, b_j, c_j) = B_j θ: a_j carries the segments before it
    d = np.diff(start, axis=1)                                                   # the segments' lengths but the last
    b = np.zeros((n_trials, n_seg, 3, unknowns))
    b[:, :, 0, 0] = 1.0
    for j in range(n_seg):
        b[:, j, 1, 1 + 2 * j] = 1.0
        b[:, j, 2, 2 + 2 * j] = 1.0
        for i in range(j):
            b[:, j, 0, 1 + 2 * i] = d[:, i]
            b[:, j, 0, 2 + 2 * i] = d[:, i] ** 2
    solvable = np.all(count >= 3, axis=1)
    rss = np.full(n_trials, np.nan)
    if solvable.any():
        bs = b[solvable]
        k = bs.shape[0]
        stacked = bs.reshape(k, 3 * n_seg, unknowns)
        gram = stacked.transpose(0, 2, 1) @ (moments[solvable] @ bs).reshape(k, 3 * n_seg, unknowns)
        theta = np.linalg.solve(gram, stacked.transpose(0, 2, 1) @ rhs[solvable].reshape(k, 3 * n_seg, 1))
        coef = (stacked @ theta).reshape(k, n_seg, 3)                             # (a_j, b_j, c_j)
        c = np.take_along_axis(coef, seg[solvable][:, :, None], axis=1)
        vs = v[solvable]
        rss[solvable] = np.sum((h[None, :] - (c[:, :, 0] + vs * (c[:, :, 1] + vs * c[:, :, 2]))) ** 2, axis=1)
    for t in np.flatnonzero(~solvable):
        ramp = np.clip(u[:, None] - knots[t][None, :], 0.0, None)
        a = np.column_stack([np.ones_like(u), u, u * u, ramp, ramp * ramp])
        fitted = a @ np.linalg.lstsq(a, h, rcond=None)[0]
        rss[t] = float(np.sum((h - fitted) ** 2))
    return rss, u.size - unknowns


def align_pattern(trace: Trace, pattern_m: np.ndarray, low_m: float, high_m: float, search_m: float,
                  step_m: float = 0.05, lag_m: float = 0.0) -> LocalFit:
    """Shift of a support-and-dropper pattern that best explains the height trace (module docs).

    Parameters
    ----------
    trace : Trace
    pattern_m : numpy.ndarray
        Assumed positions (recording frame) of the kinks: masts and droppers [m].
    low_m, high_m : float
        The part of the trace fitted (recording frame) [m], the same for every shift, so that
        the misfits compare like with like.
    search_m : float
        Shifts within ± this are tried [m].
    step_m : float
        Grid of shifts [m].
    lag_m : float
        Where the dynamic pass shows a kink, relative to the kink (signed along the chainage;
        :func:`catenary.measurement.registration.lag.height_lag_m`) [m].

    Returns
    -------
    LocalFit
        ``position_m`` is the best **shift** of the pattern [m] (0: where it was assumed).
    """
    shifts = np.arange(-search_m, search_m + 0.5 * step_m, step_m)
    rss, dof = pattern_misfit(trace, pattern_m + lag_m, low_m, high_m, shifts)
    return valley_fit(shifts, rss, dof, 0.0, step_m, dof)


def pattern_misfit(trace: Trace, kinks_m: np.ndarray, low_m: float, high_m: float,
                   shifts_m: np.ndarray) -> tuple[np.ndarray, int]:
    """Misfit of the height trace by a pattern of kinks at each of its shifts.

    Parameters
    ----------
    trace : Trace
    kinks_m : numpy.ndarray
        Where the trace shows the kinks (masts and droppers, the dynamic pass's lag included) at
        shift 0 (recording frame) [m].
    low_m, high_m : float
        The part of the trace fitted, the same for every shift [m].
    shifts_m : numpy.ndarray
        Shifts of the whole pattern tried [m].

    Returns
    -------
    numpy.ndarray, int
        Residual sum of squares of the continuous piecewise quadratic with free slope and
        curvature jumps at the shifted kinks [m²] (NaN where the window holds too few samples),
        and its largest number of degrees of freedom.
    """
    x, h = trace.window(low_m, high_m, "height")
    shifts = np.asarray(shifts_m, dtype=float).ravel()
    rss = np.full(shifts.size, np.nan)
    dof = 0
    sel = (x >= low_m) & (x <= high_m)
    u, h = x[sel] - low_m, h[sel]
    knots = np.asarray(kinks_m, dtype=float)[None, :] + shifts[:, None] - low_m
    inside = (knots > 0.0) & (knots < high_m - low_m)
    counts = inside.sum(axis=1)
    # the trials with as many knots inside the window share a design's shape: solved together
    for n_knots in np.unique(counts):
        rows = np.flatnonzero(counts == n_knots)
        if u.size <= 3 + 2 * n_knots + 3:
            continue                              # too few samples for the trials' spline
        rss[rows], dof_i = _spline_rss(u, h, knots[rows][inside[rows]].reshape(rows.size, n_knots))
        dof = max(dof, dof_i)
    return rss, dof


def kink_signal(trace: Trace, grid_m: np.ndarray, half_window_m: float, signal: str = "height") -> np.ndarray:
    """Slope just before minus slope just after each grid point [m/m] (least-squares lines over
    ``half_window_m`` on each side of a resampled trace): large where the signal kinks downwards
    (a dropper in the height, a support in the stagger with alternating sign)."""
    values = trace.height_m if signal == "height" else trace.stagger_m
    ok = np.isfinite(values)
    if ok.sum() < 4:
        return np.full(grid_m.size, np.nan)
    step = float(np.median(np.diff(grid_m)))
    resampled = np.interp(grid_m, trace.chainage_m[ok], values[ok])
    # a point further than one window from any valid sample has no slope there
    nearest = np.abs(np.interp(grid_m, trace.chainage_m[ok], trace.chainage_m[ok]) - grid_m)
    resampled[nearest > half_window_m] = np.nan
    n = max(int(round(half_window_m / step)), 2)
    u = (np.arange(n) - 0.5 * (n - 1)) * step
    kernel = u / np.sum(u * u)
    slope = np.convolve(np.nan_to_num(resampled), kernel[::-1], mode="valid")       # window [i, i + n)
    bad = np.convolve(np.isnan(resampled).astype(float), np.ones(n), mode="valid") > 0
    slope[bad] = np.nan
    out = np.full(grid_m.size, np.nan)
    i = np.arange(n, grid_m.size - n)
    out[i] = slope[i - n] - slope[i + 1]
    return out
