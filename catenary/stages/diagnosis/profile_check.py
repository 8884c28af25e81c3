"""Each span's whole measured profile against what its model can explain between the droppers.

The projection keeps nine heights per span; the recording holds a sample every 0.1–0.25 m. A
span of the model has no freedom between its droppers: with the droppers taut, its static CW is
a tensioned wire held at the droppers and steady arms by point forces, hence — seen from the
chord — piecewise linear between those points plus the sag of its own weight in each bay,
``q (x − a)(b − x) / (2 T_CW)`` (≈ 3 mm mid-bay on N2), bent over the CW's 9 cm bending length
only. Every input the model treats as random (dropper lengths, T_MW, ΔH) and every effect of
the catalogue (creep, wear, T_CW, a CW shift along the line, a force offset) moves the heights
at the droppers and masts, and at most scales the bays' sag (T_CW, wear; a measuring force error
scales the pantograph's uplift between the droppers, which has the same shape). What the model
cannot produce between two droppers is anything else: the kink of a point load (a clamp, a
connector, a splice), a bent or kinked wire, a hard spot's mass.

The correction's final model is the span's own inputs fitted to its W; its simulated pass at
every recorded sample (``corrected_profiles.parquet``) leaves the residual ``y = measured −
simulated``, which under the model is the measurement noise plus a small remainder of the same
form as the model's freedoms (the correction stops within its tolerance, and its model error
moves the same heights and sag). Per span and run, the **base** is therefore the 11 hat
functions at the masts and droppers and one sag term shared by all bays; the tests read what
lies outside it:

* **global**: the residual sum of squares after the base fit, ``RSS / σ² ~ χ²`` with the
  samples' count minus the base's rank as degrees of freedom;
* **local**: a point load at ``x₀`` in a bay bends the CW into a tent between the bay's ends
  (the droppers' own motion is in the base); its GLS t statistic on a grid of ``x₀``
  (``grid_step_m``, not closer than ``knot_clearance_m`` to a knot, where the tent becomes a
  hat of the base) is scanned, and the largest ``|t|`` is referred to the exact Hunter–Worsley
  bound on the maximum of correlated normals along the grid (the union bound less the joint
  tails of consecutive points, with the correlations of the actual design) — tight in the
  tail, conservative in the bulk.

The noise is estimated from the line, not assumed: an AR(1) correlation of consecutive samples
pooled over every span (the samples are prewhitened with it, Prais–Winsten, restarting at gaps),
and the variance as the median over spans of ``RSS / dof`` (robust: a few anomalous spans do
not raise it). The two p-values are combined as their minimum, calibrated once per span type
and number of runs by Monte Carlo over pure noise on a representative design (the bulk of the
law), with the Bonferroni bound ``2 min`` where the simulation runs out (the tail): the
profile's p-value is uniform under the model and valid in the tail.

The peak — where the residual departs most from the model — is the best tent's position and its
height [m] (negative: the CW lower than its droppers let it hang), with the point load that bends
a string of tension T_CW so, ``P = −h T_CW (b − a) / ((x₀ − a)(b − x₀))`` [N, downward positive].

One module, one concern: the profile's test, from the residual's basis to the span's p-value and
peak; the span's W at the droppers, the false-discovery rate and the sections are
:mod:`.span_check`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import special, stats

from catenary.plumbing.workers import map_each

__all__ = ["PROFILE_COLUMNS", "Influence", "ProfileNoise", "ProfileSettings", "base_columns", "estimate_noise",
           "hunter_max_normal_sf", "profile_tests", "tent_columns"]

#: Columns of ``corrected_profiles.parquet`` the test reads.
PROFILE_COLUMNS = ("span_id", "run_id", "x_m", "height_m", "simulated_height_m")
#: Columns of :func:`profile_tests`' table.
PROFILE_TEST_COLUMNS = ("span_id", "n_runs", "n_samples", "dof", "chi2", "p_global", "t_max", "p_local",
                        "p_profile", "peak_x_m", "peak_height_m", "peak_load_n", "bays_not_scanned")


@dataclass(frozen=True)
class ProfileSettings:
    """Settings of the profile test (config ``diagnosis.spans``).

    Attributes
    ----------
    grid_step_m : float
        Spacing of the point-load positions scanned [m].
    knot_clearance_m : float
        Positions closer than this to a dropper or mast are not scanned [m] (there the tent
        is nearly the base's hat, and a CW clamp a few centimetres off its design position
        bends the wire there).
    slack_risk_force_n : float
        A dropper carrying less than this in the correction's final model goes slack under the
        measuring pass whatever the error of its force (a 36 N pantograph unloads the dropper it
        stands under by ≈ 16 N on N2 and N3, statically; the force's own error is ≈ 3–4 N, from
        W's 0.3 mm at the droppers) [N]: whether the true one does decides the measured profile
        around it by up to ≈ 1 mm, which W cannot tell, so its two bays are not scanned for a
        point load (the global statistic still reads them). Not higher: a load clamped near a
        dropper makes the correction's model hold the CW there with a longer, less loaded
        dropper (15–20 N measured), and masking would hide the very load.
    scale_half_window_m : float
        The point-load statistic's spread over the line's spans is pooled over positions
        within ± this [m] (:func:`local_scale`).
    min_spans_for_scale : int
        Fewer spans of a run count than this: the statistic keeps the white noise's scale.
    calibration_draws : int
        Pure-noise profiles simulated per span type and run count to calibrate the combined
        p-value's bulk.
    seed : int
        Seed of that simulation.
    """

    grid_step_m: float = 0.25
    knot_clearance_m: float = 0.3
    slack_risk_force_n: float = 12.0
    scale_half_window_m: float = 0.75
    min_spans_for_scale: int = 10
    calibration_draws: int = 4000
    seed: int = 24


@dataclass(frozen=True)
class ProfileNoise:
    """The line's residual noise: standard deviation of the innovations after prewhitening [m],
    the AR(1) correlation of consecutive samples, and the sample spacing it holds for [m]."""

    std_m: float
    ar1: float
    step_m: float


def knots_of(length_m: float, dropper_positions_m: np.ndarray) -> np.ndarray:
    """Masts and droppers of a span, from its left mast [m]."""
    return np.r_[0.0, np.asarray(dropper_positions_m, dtype=float), float(length_m)]


def base_columns(x_m: np.ndarray, knots_m: np.ndarray, influence: "Influence | None" = None) -> np.ndarray:
    """The model's freedoms along a span (module docs): a column per knot — its hat, or with an
    ``influence`` the measuring pass's response to the static CW raised there — then the bays'
    sag ``(x − a)(b − x)`` [m²] in one column; shape (len(x), len(knots) + 1)."""
    x = np.asarray(x_m, dtype=float)
    k = np.asarray(knots_m, dtype=float)
    bay = np.clip(np.searchsorted(k, x, side="right") - 1, 0, k.size - 2)
    a, b = k[bay], k[bay + 1]
    if influence is None:
        out = np.zeros((x.size, k.size + 1))
        f = (x - a) / (b - a)
        rows = np.arange(x.size)
        out[rows, bay] = 1.0 - f
        out[rows, bay + 1] += f
    else:
        columns = influence.at(x)
        out = np.zeros((x.size, columns.shape[1] + 1))
        out[:, :-1] = columns
    out[:, -1] = (x - a) * (b - x)
    return out


@dataclass(frozen=True)
class Influence:
    """The measuring pass's response along a span to its static CW raised at each knot
    (:func:`catenary.physics.measuring.profile_influence`, reordered mast, droppers, mast), tabulated at
    ``x_m`` [m], interpolated linearly."""

    x_m: np.ndarray
    columns: np.ndarray

    @classmethod
    def from_measuring(cls, x_m: np.ndarray, columns: np.ndarray, n_droppers: int) -> "Influence":
        """From :func:`catenary.physics.measuring.profile_influence`'s columns for ``n_droppers``
        droppers (droppers, left mast, right mast)."""
        c = np.asarray(columns, dtype=float)
        n = n_droppers
        return cls(np.asarray(x_m, dtype=float), np.column_stack([c[:, n], c[:, :n], c[:, n + 1]]))

    def at(self, x_m: np.ndarray) -> np.ndarray:
        x = np.asarray(x_m, dtype=float)
        return np.column_stack([np.interp(x, self.x_m, c) for c in self.columns.T])


def scan_positions(knots_m: np.ndarray, step_m: float, clearance_m: float) -> np.ndarray:
    """Point-load positions scanned: a grid of ``step_m`` in every bay, ``clearance_m`` from its ends."""
    out = []
    for a, b in zip(knots_m[:-1], knots_m[1:]):
        lo, hi = a + clearance_m, b - clearance_m
        if hi < lo:
            continue
        n = int(np.floor((hi - lo) / step_m + 1e-9)) + 1
        out.append(lo + (hi - lo - (n - 1) * step_m) / 2 + step_m * np.arange(n))
    return np.concatenate(out) if out else np.zeros(0)


def tent_columns(x_m: np.ndarray, knots_m: np.ndarray, centres_m: np.ndarray) -> np.ndarray:
    """A unit tent per centre ``x₀``: 1 at ``x₀``, 0 at and beyond the bay's ends (the CW of a
    string bay bent by a point load with its droppers held); shape (len(x), len(centres))."""
    x = np.asarray(x_m, dtype=float)[:, None]
    c = np.asarray(centres_m, dtype=float)
    bay = np.clip(np.searchsorted(knots_m, c, side="right") - 1, 0, knots_m.size - 2)
    a, b = knots_m[bay][None, :], knots_m[bay + 1][None, :]
    c = c[None, :]
    left = (x - a) / (c - a)
    right = (b - x) / (b - c)
    return np.where((x >= a) & (x <= c), left, np.where((x > c) & (x <= b), right, 0.0))


def _segments(x_m: np.ndarray, step_m: float) -> np.ndarray:
    """True where a sample continues the previous one (spacing within 1.5 steps)."""
    gap = np.diff(x_m)
    return np.r_[False, (gap > 0) & (gap <= 1.5 * step_m)]


def prewhiten(values: np.ndarray, continues: np.ndarray, rho: float) -> np.ndarray:
    """AR(1) prewhitening along the first axis (Prais–Winsten): a segment's first sample scaled by
    √(1 − ρ²), every other ``v_j − ρ v_{j−1}``."""
    v = np.asarray(values, dtype=float)
    if rho == 0.0:
        return v.copy()
    out = v.copy()
    out[1:] = v[1:] - rho * v[:-1]
    first = ~continues
    out[first] = np.sqrt(1.0 - rho * rho) * v[first]
    return out


@dataclass
class _SpanData:
    span_id: str
    runs: list          # per run: (x, y, influence or None)


def _span_data(profiles: pd.DataFrame, influences: dict | None = None,
               directions: dict | None = None) -> list[_SpanData]:
    """Each span's runs (in the order they first appear), each run's samples sorted by ``x_m``
    (stably): one sort of the whole table, then cut at the runs' ends."""
    residual = (profiles["height_m"] - profiles["simulated_height_m"]).to_numpy(dtype=float)
    keep = np.isfinite(residual)
    span_code, span_ids = pd.factorize(profiles["span_id"][keep])
    run_of, run_ids = pd.factorize(profiles["run_id"][keep])
    run_code, _ = pd.factorize(span_code.astype(np.int64) * max(len(run_ids), 1) + run_of)  # (span, run) pairs
    x = profiles["x_m"].to_numpy(dtype=float)[keep]
    y = residual[keep]
    if not _grouped_in_order(span_code, run_code, x):   # a file written span by span, run by run needs no sort
        order = np.lexsort((x, run_code, span_code))
        x, y, run_code, span_code, run_of = x[order], y[order], run_code[order], span_code[order], run_of[order]
    ends = np.flatnonzero(np.diff(run_code)) + 1
    starts = np.r_[0, ends] if x.size else np.zeros(0, dtype=int)
    stops = np.r_[ends, x.size] if x.size else np.zeros(0, dtype=int)
    influences = influences or {}
    directions = directions or {}
    out: list[_SpanData] = []
    for a, b in zip(starts, stops):
        span_id, run_id = str(span_ids[span_code[a]]), str(run_ids[run_of[a]])
        if not out or out[-1].span_id != span_id:
            out.append(_SpanData(span_id, []))
        influence = influences.get(int(directions.get((span_id, run_id), 1)))
        out[-1].runs.append((x[a:b].copy(), y[a:b].copy(), influence))
    return out


def _grouped_in_order(span_code: np.ndarray, run_code: np.ndarray, x: np.ndarray) -> bool:
    """Whether the rows are already in the order ``np.lexsort((x, run_code, span_code))`` gives
    (codes numbered by first appearance, so a table grouped by span, then run, with ``x``
    ascending in each run is): checked in one pass instead of sorting."""
    if x.size < 2:
        return True
    same_span = span_code[1:] == span_code[:-1]
    same_run = same_span & (run_code[1:] == run_code[:-1])
    return bool(np.all(span_code[1:] >= span_code[:-1]) and np.all(~same_span | (run_code[1:] >= run_code[:-1]))
                and np.all(~same_run | (x[1:] >= x[:-1])))


def _step(spans: list[_SpanData]) -> float:
    steps = np.concatenate([np.diff(x) for s in spans for x, _, _ in s.runs if x.size > 1])
    steps = steps[steps > 0]
    return float(np.median(steps)) if steps.size else 0.1


#: Spans per block of the worker processes of :func:`profile_tests` (any number of workers
#: gives the same blocks, and each span's arithmetic is its own: the same table bit for bit).
SPANS_PER_BLOCK = 250


def _per_span(function, spans: list[_SpanData], workers: int) -> list:
    """``function(span)`` of every span, in order, over blocks of :data:`SPANS_PER_BLOCK` spans
    in ``workers`` processes (:func:`catenary.plumbing.workers.map_each`)."""
    return map_each(lambda k: function(spans[k]), len(spans), workers, SPANS_PER_BLOCK)


def estimate_noise(spans: list[_SpanData], knots_m: np.ndarray, workers: int = 1) -> ProfileNoise:
    """The line's AR(1) correlation (pooled lag-1 autocorrelation of the base fits' residuals
    over consecutive samples) and innovation standard deviation (median over spans of their
    prewhitened ``RSS / dof``, debiased by the median of χ²_dof / dof). Each span's fits in
    ``workers`` processes, their sums taken here in the spans' order: the same noise for any
    number."""
    step = _step(spans)

    def lag_products(s: _SpanData) -> list[tuple[float, float]]:
        out = []
        for x, y, influence in s.runs:
            b = base_columns(x, knots_m, influence)
            e = y - b @ np.linalg.lstsq(b, y, rcond=None)[0]
            cont = _segments(x, step)
            out.append((float(np.sum(e[1:][cont[1:]] * e[:-1][cont[1:]])), float(np.sum(e * e))))
        return out

    num = den = 0.0
    for runs in _per_span(lag_products, spans, workers):
        for lag, square in runs:
            num += lag
            den += square
    rho = float(np.clip(num / den, -0.9, 0.9)) if den > 0 else 0.0

    def ratio(s: _SpanData) -> float | None:
        fit = _fit_span(s, knots_m, rho, step)
        return fit.rss / stats.chi2.median(fit.dof) if fit.dof > 0 else None

    ratios = [r for r in _per_span(ratio, spans, workers) if r is not None]
    std = float(np.sqrt(np.median(ratios))) if ratios else float("nan")
    return ProfileNoise(std_m=std, ar1=rho, step_m=step)


@dataclass
class _Fit:
    q: np.ndarray       # orthonormal basis of the (whitened) base
    y: np.ndarray       # whitened residual
    x: list             # per run: abscissae
    cont: list          # per run: continues-flags
    rss: float
    dof: int


def _fit_span(span: _SpanData, knots_m: np.ndarray, rho: float, step: float) -> _Fit:
    """The whitened base fit of one span, runs stacked with a base of their own each."""
    n_base = max(base_columns(knots_m[:1], knots_m, influence).shape[1] for _, _, influence in span.runs)
    n = sum(x.size for x, _, _ in span.runs)
    basis = np.zeros((n, n_base * len(span.runs)))
    y = np.zeros(n)
    xs, conts, start = [], [], 0
    for r, (x, v, influence) in enumerate(span.runs):
        cont = _segments(x, step)
        sl = slice(start, start + x.size)
        basis[sl, r * n_base:(r + 1) * n_base] = prewhiten(base_columns(x, knots_m, influence), cont, rho)
        y[sl] = prewhiten(v, cont, rho)
        xs.append(x)
        conts.append(cont)
        start += x.size
    q, r_factor = np.linalg.qr(basis)
    rank = int(np.sum(np.abs(np.diag(r_factor)) > 1e-10 * max(1.0, np.abs(r_factor).max())))
    q = q[:, np.abs(np.diag(r_factor)) > 1e-10 * max(1.0, np.abs(r_factor).max())]
    e = y - q @ (q.T @ y)
    return _Fit(q, y, xs, conts, float(e @ e), n - rank)


def _tents(fit: _Fit, knots_m: np.ndarray, centres: np.ndarray, rho: float) -> np.ndarray:
    """The scanned tents, whitened as the data, stacked over the runs, base removed."""
    cols = np.concatenate([prewhiten(tent_columns(x, knots_m, centres), c, rho) for x, c in zip(fit.x, fit.cont)])
    return cols - fit.q @ (fit.q.T @ cols)


# Gauss–Legendre nodes on [0, 1] for the bivariate normal tail integral.
_GL_X, _GL_W = np.polynomial.legendre.leggauss(64)
_GL_X, _GL_W = 0.5 * (_GL_X + 1.0), 0.5 * _GL_W


def bivariate_upper_tail(u: float, rho: np.ndarray) -> np.ndarray:
    """P(Z₁ ≥ u, Z₂ ≥ u) for standard normals of correlation ``rho`` (vectorised over rho):
    ∫_u^∞ φ(v) Φ̄((u − ρ v)/√(1 − ρ²)) dv by Gauss–Legendre over [u, u + 12]."""
    rho = np.clip(np.asarray(rho, dtype=float), -0.999999, 0.999999)
    v = u + 12.0 * _GL_X
    inner = special.ndtr(-(u - rho[:, None] * v[None, :]) / np.sqrt(1.0 - rho[:, None] ** 2))
    return 12.0 * (inner * (np.exp(-0.5 * v * v) / np.sqrt(2.0 * np.pi) * _GL_W)[None, :]).sum(axis=1)


def hunter_max_normal_sf(u: float, rho_chain: np.ndarray, n_points: int, links: np.ndarray) -> float:
    """Hunter–Worsley upper bound of ``P(max_i |Z_i| ≥ u)`` for ``n_points`` standard normals
    linked in chains: ``Σ_i P(|Z_i| ≥ u) − Σ_links P(|Z_i| ≥ u, |Z_j| ≥ u)``, the link between
    points ``i − 1`` and ``i`` (``links[i]`` true) of correlation ``rho_chain[i]``; clipped to
    [largest single term, 1]."""
    single = 2.0 * special.ndtr(-u)
    rho = rho_chain[links]
    joint = 2.0 * (bivariate_upper_tail(u, rho) + bivariate_upper_tail(u, -rho))
    return float(np.clip(n_points * single - joint.sum(), single, 1.0))


@dataclass(frozen=True)
class _Scan:
    chi2: float
    dof: int
    p_global: float
    t: np.ndarray             # the point-load statistic at every scanned position (white-noise scale)
    height_m: np.ndarray      # the fitted tent height there [m]
    rho_chain: np.ndarray     # correlation of consecutive positions' statistics
    links: np.ndarray         # consecutive positions in the same bay (both scanned)
    scanned: np.ndarray       # positions with a tent outside the base


def _scan(fit: _Fit, knots_m: np.ndarray, centres: np.ndarray, rho: float, noise_std_m: float) -> _Scan:
    chi2 = fit.rss / noise_std_m ** 2
    p_global = float(stats.chi2.sf(chi2, fit.dof)) if fit.dof > 0 else 1.0
    tents = _tents(fit, knots_m, centres, rho)
    norm2 = np.einsum("ij,ij->j", tents, tents)
    ok = norm2 > 1e-12
    coef = np.where(ok, tents.T @ fit.y / np.where(ok, norm2, 1.0), 0.0)
    t = coef * np.sqrt(norm2) / noise_std_m
    unit = tents / np.sqrt(np.where(ok, norm2, 1.0))
    rho_chain = np.r_[0.0, np.einsum("ij,ij->j", unit[:, 1:], unit[:, :-1])]
    bay = np.searchsorted(knots_m, centres, side="right")
    links = np.r_[False, bay[1:] == bay[:-1]] & ok & np.r_[False, ok[:-1]]
    return _Scan(chi2, fit.dof, p_global, t, coef, rho_chain, links, ok)


def local_scale(t: np.ndarray, centres_m: np.ndarray, knots_m: np.ndarray, half_window_m: float,
                min_spans: int) -> tuple[np.ndarray, np.ndarray]:
    """Centre and scale of the point-load statistic at each scanned position over the line's
    spans (rows of ``t``): median and 1.4826 MAD of every span's statistic within
    ``± half_window_m`` in the same bay — the correction's own error between the droppers,
    which differs from span to span (module docs). The scale is never below 1 (the white
    noise's); with fewer than ``min_spans`` spans, centre 0 and scale 1."""
    m = centres_m.size
    centre, scale = np.zeros(m), np.ones(m)
    if t.shape[0] < min_spans:
        return centre, scale
    bay = np.searchsorted(knots_m, centres_m, side="right")
    for j in range(m):
        near = (bay == bay[j]) & (np.abs(centres_m - centres_m[j]) <= half_window_m + 1e-9)
        pool = t[:, near].ravel()
        pool = pool[np.isfinite(pool)]
        if pool.size < min_spans:
            continue
        centre[j] = float(np.median(pool))
        scale[j] = max(1.0, 1.4826 * float(np.median(np.abs(pool - centre[j]))))
    return centre, scale


def _calibration(knots_m: np.ndarray, centres: np.ndarray, n_runs: int, noise: ProfileNoise,
                 settings: ProfileSettings, influence: "Influence | None" = None, workers: int = 1) -> np.ndarray:
    """Sorted null draws of ``min(p_global, p_local)`` on a representative design: the span's
    runs sampled every ``noise.step_m``, white innovations of the line's σ (drawn here, in
    order; their Hunter–Worsley bounds in ``workers`` processes, the same for any number)."""
    rng = np.random.default_rng([settings.seed, n_runs])
    x = np.arange(0.0, knots_m[-1] + 1e-9, noise.step_m)
    template = _fit_span(_SpanData("", [(x, np.zeros_like(x), influence)] * n_runs), knots_m, 0.0, noise.step_m)
    tents = _tents(template, knots_m, centres, 0.0)
    norm = np.sqrt(np.einsum("ij,ij->j", tents, tents))
    unit = tents / np.where(norm > 1e-12, norm, 1.0)
    rho_chain = np.r_[0.0, np.einsum("ij,ij->j", unit[:, 1:], unit[:, :-1])]
    bay = np.searchsorted(knots_m, centres, side="right")
    links = np.r_[False, bay[1:] == bay[:-1]]
    p_global, t_max = np.empty(settings.calibration_draws), np.empty(settings.calibration_draws)
    for start in range(0, settings.calibration_draws, 500):
        m = min(500, settings.calibration_draws - start)
        z = rng.standard_normal((template.y.size, m))
        e = z - template.q @ (template.q.T @ z)
        chi2 = np.einsum("ij,ij->j", e, e)
        p_global[start:start + m] = stats.chi2.sf(chi2, template.dof)
        t_max[start:start + m] = np.abs(unit.T @ e).max(axis=0)
    p_local = np.array(map_each(lambda k: hunter_max_normal_sf(float(t_max[k]), rho_chain, centres.size, links),
                                t_max.size, workers, 500))
    return np.sort(np.minimum(p_global, p_local))


def combined_p(p_min: float, null_sorted: np.ndarray, min_count: int = 40) -> float:
    """P(min(p_global, p_local) ≤ observed) under the model: the calibration's share where it
    holds at least ``min_count`` draws below, else the Bonferroni bound ``2 min`` (valid in the
    tail, where the simulation runs out)."""
    count = int(np.searchsorted(null_sorted, p_min, side="right"))
    if count >= min_count:
        return float((count + 1) / (null_sorted.size + 1))
    return float(min(1.0, 2.0 * p_min))


def profile_tests(profiles: pd.DataFrame, length_m: float, dropper_positions_m: np.ndarray,
                  contact_tension_n: float, settings: ProfileSettings | None = None,
                  noise: ProfileNoise | None = None, influences: dict | None = None,
                  directions: dict | None = None,
                  dropper_forces_n: dict | None = None, workers: int = 1) -> tuple[pd.DataFrame, ProfileNoise]:
    """The profile test of every span in ``profiles`` (module docs).

    Parameters
    ----------
    profiles : pandas.DataFrame
        ``corrected_profiles.parquet`` rows of one span type: ``span_id``, ``run_id``, ``x_m``,
        ``height_m``, ``simulated_height_m``.
    length_m, dropper_positions_m : float, numpy.ndarray
        The span type's length and dropper positions [m] (the knots).
    contact_tension_n : float
        T_CW for the peak's point load [N].
    settings : ProfileSettings, optional
    noise : ProfileNoise, optional
        The noise to test against (default: estimated from ``profiles``).
    influences : dict of int to Influence, optional
        The measuring pass's response to the static CW at the knots per direction of travel
        (±1): the base's columns (default: the static hats).
    directions : dict of (span_id, run_id) to int, optional
        Each run's direction over each span (default +1).
    dropper_forces_n : dict of span_id to numpy.ndarray, optional
        Static dropper tensions of each span in the correction's final model [N] (the smallest
        over its runs): the bays next to one below ``settings.slack_risk_force_n`` are not
        scanned for a point load.
    workers : int
        Processes over the spans (blocks of :data:`SPANS_PER_BLOCK`): each span's fits, scan and
        p-values are its own, so the table is the same, bit for bit, for any number.

    Returns
    -------
    table : pandas.DataFrame
        One row per span (:data:`PROFILE_TEST_COLUMNS`): the samples and runs read, the global
        statistic and its degrees of freedom, ``p_global``, the largest standardised point-load
        statistic ``t_max`` and ``p_local``, the combined ``p_profile``, the peak:
        ``peak_x_m`` (from the left mast), ``peak_height_m`` and ``peak_load_n``, and
        ``bays_not_scanned`` (next to a dropper that may go slack under the pass).
    noise : ProfileNoise
    """
    settings = settings or ProfileSettings()
    knots = knots_of(length_m, dropper_positions_m)
    spans = _span_data(profiles, influences, directions)
    if not spans:
        return pd.DataFrame(columns=list(PROFILE_TEST_COLUMNS)), noise or ProfileNoise(float("nan"), 0.0, 0.1)
    noise = noise or estimate_noise(spans, knots, workers)
    centres = scan_positions(knots, settings.grid_step_m, settings.knot_clearance_m)
    scans = _per_span(lambda s: _scan(_fit_span(s, knots, noise.ar1, noise.step_m), knots, centres, noise.ar1,
                                      noise.std_m), spans, workers)
    n_runs = np.array([len(s.runs) for s in spans])
    centre_bay = np.clip(np.searchsorted(knots, centres, side="right") - 1, 0, knots.size - 2)
    usable, unread = [], []
    for s, scan in zip(spans, scans):
        forces = np.asarray((dropper_forces_n or {}).get(s.span_id, []), dtype=float)
        weak = np.flatnonzero(forces < settings.slack_risk_force_n)      # dropper i is knot i + 1
        bays = np.unique(np.concatenate([weak, weak + 1])) if weak.size else np.zeros(0, int)
        usable.append(scan.scanned & ~np.isin(centre_bay, bays))
        unread.append(int(bays.size))
    # Each span's statistic standardised by the line's centre and scale at each position (over
    # the spans of as many runs), then its p-values, span by span.
    t_std = [np.empty(0)] * len(spans)
    null = {}
    for runs in np.unique(n_runs):
        group = np.flatnonzero(n_runs == runs)
        t = np.array([np.where(usable[k], scans[k].t, np.nan) for k in group])
        centre, scale = local_scale(t, centres, knots, settings.scale_half_window_m, settings.min_spans_for_scale)
        null[int(runs)] = _calibration(knots, centres, int(runs), noise, settings,
                                       next(iter((influences or {}).values()), None), workers)
        for k, row in zip(group, (t - centre) / scale):
            t_std[k] = row

    def span_row(k: int) -> dict:
        scan, t_k = scans[k], t_std[k]
        finite = np.isfinite(t_k)
        j = int(np.nanargmax(np.abs(t_k))) if finite.any() else 0
        t_max = float(t_k[j]) if finite.any() else 0.0
        links = scan.links & finite & np.r_[False, finite[:-1]]
        p_local = hunter_max_normal_sf(abs(t_max), scan.rho_chain, int(finite.sum()), links) if finite.any() else 1.0
        p_profile = combined_p(min(scan.p_global, p_local), null[int(n_runs[k])])
        x0 = float(centres[j]) if finite.any() else float("nan")
        height = float(scan.height_m[j]) if finite.any() else float("nan")
        bay = int(np.clip(np.searchsorted(knots, x0, side="right") - 1, 0, knots.size - 2)) if finite.any() else 0
        a, b = knots[bay], knots[bay + 1]
        load = -height * contact_tension_n * (b - a) / ((x0 - a) * (b - x0)) if finite.any() else float("nan")
        return {"span_id": spans[k].span_id, "n_runs": int(n_runs[k]),
                "n_samples": int(sum(x.size for x, _, _ in spans[k].runs)), "dof": scan.dof, "chi2": scan.chi2,
                "p_global": scan.p_global, "t_max": t_max, "p_local": p_local, "p_profile": p_profile,
                "peak_x_m": x0, "peak_height_m": height, "peak_load_n": load, "bays_not_scanned": unread[k]}

    rows = map_each(span_row, len(spans), workers, SPANS_PER_BLOCK)
    order = {s.span_id: i for i, s in enumerate(spans)}
    table = pd.DataFrame(rows, columns=list(PROFILE_TEST_COLUMNS))
    return table.sort_values("span_id", key=lambda c: c.map(order)).reset_index(drop=True), noise
