"""Cut a recording into spans and project the CW heights at the droppers onto the chord.

Each run of the recording is cut on its own, along the masts the registration placed on its
trace (:mod:`catenary.measurement.registration`; with the registration switched off, the mast table as it
is), its samples brought into the mast table's chainage by the registration's map of each
section. For every pair of consecutive masts of a section (a *span*, id
``"{left_mast_id}-{right_mast_id}"``) and every run:

1. **Type.** The ``span_type`` of the left mast in the masts file if given (it must be a type of
   the catenary config and the measured length must match its length within
   ``span_type_tolerance_m``; where the masts file alone placed one of the span's masts, a
   mismatch names that mast and how far off it puts it), else the type whose length is nearest
   to the measured one within that tolerance.
2. **Coverage.** The span must hold recording samples, and no run without a valid height
   (drop-outs, or no samples at all) inside the span may be longer than ``max_gap_m`` (default:
   the smallest dropper spacing of the span type, masts included), otherwise a dropper could sit
   in a hole of the data.
3. **Robust local fit.** The CW height is estimated at the two masts (the steady arms: the car
   runs under them too) and at each dropper ``x_i = left mast chainage + dropper_positions_m[i]``
   from the valid samples within ``± fit_half_window_m``. The local model is, by default, a
   quadratic ``h = a + b·u + c·u²`` (``u`` = distance to the point). The CW is held at droppers
   and steady arms by point forces, so its slope jumps there (a kink of ≈ 3–4 mm/m at a N2
   dropper); a quadratic centred on a kink reads it ≈ 0.19 × (slope jump / 2) × half-window too
   low (≈ 0.3 mm), but the same at masts and droppers, so it largely cancels in W. The kinked
   line ``h = a + b·u + c·|u|`` (``fit_model="kinked"``) has no kink bias but 1.3× the noise of
   the quadratic (0.43 σ against 0.33 σ for 21 samples); on synthetic spans with 1 mm noise the
   quadratic gave the smaller W error, so it is the default. ``"linear"`` is also available.
   Spikes are removed by iterated hard-rejection reweighting: fit the inliers, scale the
   residuals of all window samples by ``σ = max(1.4826·MAD, scale_floor_m)``, keep
   ``|r| ≤ outlier_threshold·σ``, repeat until the inlier set settles (the start excludes
   samples far from the window median, so that a spike cannot pull the first fit).
4. **Projection.** ``W_i = h(x_i) − chord(x_i)``, the chord joining the fitted heights at the left
   and the right mast (negative = below the chord).
5. **Check of the cut** (``check_cuts``), whatever placed the masts: a span cut in the wrong place
   gives a W that looks measured and is wrong by the CW's slope times the error (≈ 2 mm per
   metre). Where the run records the stagger, its reversal at each inner mast
   (:func:`catenary.measurement.registration.supports.locate_stagger_support`) must lie within
   ``max_cut_error_m`` of the cut (looked for within ``± cut_search_m``; a reversal not found
   there, where the stagger is recorded on both sides, rejects the span too). Without stagger,
   the height is read: (a) the span's droppers are looked for by the comb of the height's kink
   signal within ``± cut_reach_m`` of where the cut puts them, and a line fitted along the
   section to these shifts (an offset and an odometer scale, robust to the spans matched a
   dropper off), when most masts agree on it, rejects every span it puts beyond
   ``max_cut_error_m`` plus the height's own bias along a section (:data:`SECTION_LINE_BIAS_M`):
   a drift of the chainage that no single span shows reliably; (b) the span's whole
   pattern of kinks — its two masts and its droppers, read with the dynamic pass's lag — is
   fitted to the height (:func:`catenary.measurement.registration.supports.align_pattern`) within
   ``± cut_search_m``: the span is rejected when the best shift is beyond ``max_cut_error_m`` and
   explains the trace better than the cut by more than ``cut_statistic`` residual variances.
6. **Uncertainty of the cut.** Where the registration gives each mast's position with a
   standard error (and, for a height trace's section fit, the correlation of neighbours'), the
   error of W it causes (through the slopes of the local fits) must stay below
   ``max_cut_w_error_m``: a span whose end the trace does not show (a section's end, with a
   mast table of decimetres) is rejected rather than used with a W a few millimetres off. A used
   span carries it (``w_support_std_m``) beside the local fits' own (``w_noise_std_m``).

A span that fails a step is **rejected** with its reason(s) in the report; only file-level
problems raise :class:`~catenary.plumbing.errors.InputError`. Every span of every run is in the report,
either ``used`` (and then in exactly one ``spans[type]`` table) or ``rejected`` with a non-empty
reason: :func:`project` checks this before returning.

One module, one concern: whether each recorded span yields a W to trust. The local fit, the
checks of the cut and the bookkeeping of used and rejected spans act on the same span and
section state, and the reconciliation that no span is lost (:func:`check_reconciliation`) is a
contract on all of them; the spans' table and its schema are written here so that the columns
the projection fills and the columns the file declares cannot drift apart.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np
import pandas as pd
import pyarrow as pa

from catenary.physics.config import Catenary, SpanType
from catenary.plumbing.parquet import write_table
from catenary.plumbing.workers import map_blocks
from .recording import row_label, rows_label, run_samples, validate_masts, validate_recording
from catenary.measurement.registration.mapping import ChainageMap
from catenary.measurement.registration.runner import EXTRA, MARGIN_M, NOT_COVERED, REFUSED, UNREGISTERED, RunRegistration, support_kinks, support_line
from catenary.measurement.registration.supports import Trace, align_pattern, locate_stagger_support, trace_of
from catenary.plumbing.schema import check

STATUS_USED = "used"
STATUS_REJECTED = "rejected"

REPORT_COLUMNS = ("span_id", "run_id", "section_id", "span_type", "status", "reason", "left_mast_id",
                  "right_mast_id", "start_chainage_m", "end_chainage_m", "length_m")
"""Columns of the span report: one row per span and run, runs in the recording's order, spans in
line order."""

#: Columns of ``results/{span_type}/profiles.parquet``: the measured samples of each used span
#: and run (:attr:`ProjectionResult.profiles`).
PROFILE_COLUMNS = ("span_id", "run_id", "x_m", "height_m")
QUALITY_COLUMNS = ("fit_rms_m", "min_samples_per_point", "outliers_removed", "max_gap_m", "cut_shift_m",
                   "w_support_std_m", "w_noise_std_m")
#: What the recording's other channels say of each span (NaN where the recording has none): the
#: mean residual thickness of the CW and its standard error over the span's samples, and the mean
#: measured contact force (:mod:`catenary.measurement.channels`).
CHANNEL_COLUMNS = ("cw_residual_thickness_m", "cw_residual_thickness_se_m", "contact_force_n")
RUN_COLUMNS = ("run_id", "direction", "speed_kmh", "force_n")
#: Margin of the section-wide check of the cuts (module docs, step 5a) on a height trace [m]. Its
#: line is read from the kink signals' comb on a 0.05 m grid and carries the dynamic lag's bias,
#: which changes along a section: on exact cuts it lay up to 0.60 m from them at a section's end
#: (default campaign, section S07; the registration's finer fits, −0.45 to +0.26 m over the 54
#: section ends of the default line's three runs), where the 0.5 m tolerance alone rejected three
#: right spans. The drifts the check is for are metres (``r_off``: 7–10 m).
SECTION_LINE_BIAS_M = 0.5


@dataclass(frozen=True)
class ProjectionSettings:
    """Settings of the projection.

    Attributes
    ----------
    span_type_tolerance_m : float
        Largest difference between the measured span length and its type's length [m], both to
        assign a type by length and to accept a type given in the masts file.
    fit_half_window_m : float
        Samples within ± this distance of a mast or dropper enter its local fit [m].
    min_samples : int
        Fewest valid inlier samples a local fit needs; fewer rejects the span.
    outlier_threshold : float
        A sample whose residual exceeds this many robust standard deviations (1.4826·MAD) is an
        outlier (a spike) and leaves the fit.
    max_gap_m : float or None
        Longest run without a valid height inside a span [m]; ``None``: the span type's
        smallest dropper spacing (masts included).
    scale_floor_m : float
        Smallest robust standard deviation used for outlier rejection [m] (≈ the recording
        resolution): with quantised, nearly noise-free data the MAD can be 0, and a sample only
        a quantum off the fit must not count as a spike.
    fit_model : str
        ``"quadratic"`` (a + b·u + c·u², default), ``"kinked"`` (a + b·u + c·|u|) or ``"linear"``.
    max_iterations : int
        Largest number of reweighting passes of a local fit.
    check_cuts : bool
        Check each span's cut against the trace (module docs, step 5).
    max_cut_error_m : float
        Largest distance between a cut and where the trace puts the support [m].
    cut_search_m : float
        Shifts of a span's pattern (or of a stagger reversal) tried by the fine check [m].
    cut_reach_m : float
        Shifts of a span's droppers tried by the comb of the height's kinks [m]; below half the
        shortest span.
    cut_statistic : float
        How much better (in residual variances) the best shift must explain the trace than the
        cut for the cut to be wrong.
    max_cut_w_error_m : float
        Largest RMS error of W that the uncertainty of the span's two mast positions (the
        registration's standard errors) may cause through the trace's slopes [m] (step 6).
    """

    span_type_tolerance_m: float = 0.5
    fit_half_window_m: float = 1.0
    min_samples: int = 5
    outlier_threshold: float = 4.0
    max_gap_m: float | None = None
    scale_floor_m: float = 5e-4
    fit_model: str = "quadratic"
    max_iterations: int = 20
    check_cuts: bool = True
    max_cut_error_m: float = 0.5
    cut_search_m: float = 3.0
    cut_reach_m: float = 15.0
    cut_statistic: float = 50.0
    max_cut_w_error_m: float = 1e-3

    def __post_init__(self) -> None:
        # The config schema's projection block is the contract (min_samples against fit_model too).
        check(asdict(self), "config", "projection")

    @classmethod
    def from_mapping(cls, mapping: Mapping[str, Any] | None, where: str = "projection") -> "ProjectionSettings":
        """Settings from a config mapping (missing keys take their defaults).

        Raises
        ------
        ConfigError
            On an unknown key or a bad value (checked against the config schema).
        """
        mapping = {} if mapping is None else mapping
        check({**asdict(cls()), **mapping} if isinstance(mapping, Mapping) else mapping, "config", "projection",
              where=where)
        return cls(**mapping)


@dataclass
class ProjectionResult:
    """What :func:`project` returns.

    Attributes
    ----------
    spans : dict of str to pandas.DataFrame
        Per span type of the catenary config (present even when empty), one row per used
        span and run, runs in order, spans in line order: ``span_id``, ``run_id``, ``direction``
        (of travel, ±1), ``speed_kmh`` and ``force_n`` (medians of the run's samples over the span,
        NaN when not recorded), ``section_id``, ``left_mast_id``, ``right_mast_id``,
        ``start_chainage_m``, ``end_chainage_m``, ``length_m``, ``cw_height_left_m``,
        ``cw_height_right_m`` (fitted steady-arm heights), ``w1_m`` … ``wn_m`` (deflections
        from the chord, negative below), ``fit_rms_m`` (RMS of the inlier residuals of all the
        span's local fits), ``min_samples_per_point`` (fewest inliers of a local fit),
        ``outliers_removed`` (samples rejected as spikes, summed over the span's fits),
        ``max_gap_m`` (longest run without a valid height inside the span), ``cut_shift_m`` (where the
        check of the cut puts the span's pattern relative to the cut; NaN unchecked),
        ``w_support_std_m`` (RMS over the droppers of W's standard error caused by the errors of
        the span's two mast positions, step 6; NaN where the registration gives none),
        ``w_noise_std_m`` (RMS over the droppers of W's standard error from the local fits'
        residuals: the sensor's part).
    report : pandas.DataFrame
        One row per span and run (:data:`REPORT_COLUMNS`), ``status`` ``"used"`` or
        ``"rejected"``, ``reason`` empty when used, else every reason joined by ``"; "``.
    settings : ProjectionSettings
    profiles : dict of str to pandas.DataFrame
        Per span type, the whole measured profile of every used span and run
        (:data:`PROFILE_COLUMNS`): one row per valid sample between the span's masts, spikes
        and drop-outs left out, ``x_m`` from the left mast in the mast table's chainage. The
        diagnosis reads it between the droppers, where W holds nothing (the per-span check).
    """

    spans: dict[str, pd.DataFrame]
    report: pd.DataFrame
    settings: ProjectionSettings = field(default_factory=ProjectionSettings)
    profiles: dict[str, pd.DataFrame] = field(default_factory=dict)

    @property
    def n_used(self) -> int:
        return int((self.report["status"] == STATUS_USED).sum())

    @property
    def n_rejected(self) -> int:
        return int((self.report["status"] == STATUS_REJECTED).sum())


@dataclass(frozen=True)
class LocalFit:
    """A robust local estimate of the CW height at one point.

    Attributes
    ----------
    height_m : float
        Fitted height at the point [m] (NaN if the fit failed).
    n_inliers, n_outliers : int
        Samples kept and samples rejected as spikes.
    rms_m : float
        RMS of the inlier residuals [m].
    residual_sq_sum_m2 : float
        Sum of squared inlier residuals [m²].
    slope : float
        Fitted slope of the height at the point [m/m] (the mean of both sides for the kinked line).
    height_std_m : float
        Standard error of ``height_m`` from the inliers' residuals [m].
    settled : bool
        False when the inlier set still changed after ``max_iterations`` reweighting passes:
        the height is then not a converged robust estimate and the span is rejected.
    """

    height_m: float
    n_inliers: int
    n_outliers: int
    rms_m: float
    residual_sq_sum_m2: float
    slope: float = float("nan")
    settled: bool = True
    height_std_m: float = float("nan")


def _n_params(model: str) -> int:
    return {"kinked": 3, "quadratic": 3, "linear": 2}[model]


def _design(u: np.ndarray, model: str) -> np.ndarray:
    if model == "kinked":
        return np.column_stack([np.ones_like(u), u, np.abs(u)])
    if model == "quadratic":
        return np.column_stack([np.ones_like(u), u, u * u])
    return np.column_stack([np.ones_like(u), u])


def robust_local_fit(x_m: np.ndarray, h_m: np.ndarray, x0_m: float, settings: ProjectionSettings) -> LocalFit:
    """Robust estimate of the height at ``x0_m`` from valid samples ``(x_m, h_m)`` of its window.

    Parameters
    ----------
    x_m, h_m : numpy.ndarray
        Chainages [m] and heights [m] of the valid (finite) samples within
        ``± settings.fit_half_window_m`` of ``x0_m``.
    x0_m : float
        Where the height is wanted [m].
    settings : ProjectionSettings

    Returns
    -------
    LocalFit
        With ``height_m`` NaN when fewer than ``settings.min_samples`` inliers remain.
    """
    n = x_m.size
    if n < settings.min_samples:
        return LocalFit(float("nan"), n, 0, float("nan"), float("nan"))
    u = (x_m - x0_m) / settings.fit_half_window_m
    a = _design(u, settings.fit_model)
    thr = settings.outlier_threshold
    floor = settings.scale_floor_m
    # Start: drop samples far from the window median (a spike must not pull the first fit).
    dev = h_m - np.median(h_m)
    scale = max(1.4826 * float(np.median(np.abs(dev - np.median(dev)))), floor)
    keep = np.abs(dev - np.median(dev)) <= thr * scale
    if keep.sum() < settings.min_samples:
        keep = np.ones(n, dtype=bool)
    coef = np.zeros(a.shape[1])
    settled = True
    seen = [keep]
    for _ in range(settings.max_iterations):
        coef = np.linalg.lstsq(a[keep], h_m[keep], rcond=None)[0]
        r = h_m - a @ coef
        scale = max(1.4826 * float(np.median(np.abs(r - np.median(r)))), floor)
        new_keep = np.abs(r) <= thr * scale
        if new_keep.sum() < settings.min_samples:
            break
        if np.array_equal(new_keep, keep):
            break
        cycle = next((i for i, k in enumerate(seen) if np.array_equal(k, new_keep)), None)
        if cycle is not None:
            # The inlier set cycles (a sample on the threshold enters and leaves): keep only the
            # samples that every set of the cycle keeps, a fixed and conservative answer.
            keep = np.logical_and.reduce(seen[cycle:])
            break
        keep = new_keep
        seen.append(keep)
    else:
        settled = False            # the inlier set was still changing, without a cycle, at the last pass
    n_in = int(keep.sum())
    if n_in < settings.min_samples:
        return LocalFit(float("nan"), n_in, n - n_in, float("nan"), float("nan"))
    coef = np.linalg.lstsq(a[keep], h_m[keep], rcond=None)[0]
    r = h_m[keep] - a[keep] @ coef
    ss = float(r @ r)
    # the intercept's variance: σ² (AᵀA)⁻¹₀₀, σ² from the inliers' residuals
    inverse = np.linalg.pinv(a[keep].T @ a[keep])
    height_std = float(np.sqrt(ss / max(n_in - a.shape[1], 1) * inverse[0, 0]))
    return LocalFit(float(coef[0]), n_in, n - n_in, float(np.sqrt(ss / n_in)), ss,
                    float(coef[1]) / settings.fit_half_window_m, settled, height_std)


# --------------------------------------------------------------------------------------------
# span bookkeeping
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class _Span:
    index: int
    span_id: str
    run_id: str
    section_id: str
    left_mast_id: str
    right_mast_id: str
    start_m: float
    end_m: float
    declared_type: str | None
    where: str                   # how a user finds the declared type (for messages)
    refused: str = ""            # why the registration could not place this span's section
    left_std_m: float = float("nan")     # standard errors of the masts' registered positions
    right_std_m: float = float("nan")
    corr: float = float("nan")           # correlation of the two positions' errors (NaN: independent)
    left_method: str = ""                # what placed each mast (registration/masts.csv's method)
    right_method: str = ""

    @property
    def length_m(self) -> float:
        return self.end_m - self.start_m


def _declared(value: Any) -> str | None:
    if value is None or (isinstance(value, float) and np.isnan(value)) or str(value) == "":
        return None
    return str(value)


def _spans_of(masts: pd.DataFrame, run_id: str, masts_src: str) -> list[_Span]:
    """The spans of validated masts: consecutive masts of the same section, in file order."""
    ids = masts["mast_id"].to_numpy(dtype=object)
    sec = masts["section_id"].to_numpy(dtype=object)
    ch = masts["chainage_m"].to_numpy(dtype=float)
    types = masts["span_type"].to_numpy(dtype=object)
    out = []
    for i in range(len(masts) - 1):
        if sec[i] != sec[i + 1]:
            continue
        out.append(_Span(len(out), f"{ids[i]}-{ids[i + 1]}", run_id, str(sec[i]), str(ids[i]), str(ids[i + 1]),
                         float(ch[i]), float(ch[i + 1]), _declared(types[i]),
                         f"mast {ids[i]}, {row_label(i, masts_src)} of {masts_src}"))
    return out


def _registered_spans(run: RunRegistration) -> list[_Span]:
    """The spans of one run's registered masts (extra masts dropped, missing ones inserted)."""
    refused = {r.section_id: r.reason for r in run.sections.itertuples() if r.status in (REFUSED, NOT_COVERED)}
    out = []
    for section_id, rows in run.masts[run.masts["status"] != EXTRA].groupby("section_id", sort=False):
        ids = rows["mast_id"].to_numpy(dtype=object)
        ch = rows["chainage_m"].to_numpy(dtype=float)
        std = rows["std_m"].to_numpy(dtype=float)
        corr = rows["corr_next"].to_numpy(dtype=float) if "corr_next" in rows else np.full(len(rows), np.nan)
        method = rows["method"].astype(str).to_numpy(dtype=object)
        types = rows["span_type"].to_numpy(dtype=object)
        for i in range(len(rows) - 1):
            out.append(_Span(len(out), f"{ids[i]}-{ids[i + 1]}", run.run_id, str(section_id), str(ids[i]),
                             str(ids[i + 1]), float(ch[i]), float(ch[i + 1]), _declared(types[i]),
                             f"mast {ids[i]} of the registered masts", refused.get(str(section_id), ""),
                             float(std[i]), float(std[i + 1]), float(corr[i]), str(method[i]), str(method[i + 1])))
    return out


def smallest_spacing_m(span_type: SpanType) -> float:
    """Smallest distance between consecutive supports of a span type (masts and droppers) [m]."""
    points = np.r_[0.0, span_type.dropper_positions_m, span_type.length_m]
    return float(np.min(np.diff(points)))


def _table_at_fault(span: _Span, excess_m: float) -> str:
    """What a length mismatch says when the mast table placed one of the span's masts: that mast,
    and how far the table puts it from where the span's type would (the trace did not show it)."""
    table = [(m, other) for m, how, other in ((span.left_mast_id, span.left_method, span.right_mast_id),
                                              (span.right_mast_id, span.right_method, span.left_mast_id))
             if how == "table"]
    if not table:
        return ""
    mast, other = table[0]
    return (f": mast {mast} is placed by the mast table alone (the trace does not show its support), "
            f"{abs(excess_m):.2f} m {'further from' if excess_m > 0 else 'closer to'} mast {other} than the span "
            "type's length puts it")


def _assign_type(span: _Span, catenary: Catenary, settings: ProjectionSettings) -> tuple[SpanType | None, str]:
    tol = settings.span_type_tolerance_m
    known = sorted(catenary.span_types)
    length = span.length_m
    if span.declared_type is not None:
        st = catenary.span_types.get(span.declared_type)
        if st is None:
            return None, f"unknown span type {span.declared_type!r} ({span.where}); known: {', '.join(known)}"
        if abs(length - st.length_m) > tol:
            return st, (f"length mismatch: measured {length:.3f} m between masts {span.left_mast_id} and "
                        f"{span.right_mast_id}, span type {st.name} is {st.length_m:g} m (tolerance ±{tol:g} m)"
                        + _table_at_fault(span, length - st.length_m))
        return st, ""
    candidates = [(abs(length - st.length_m), name) for name, st in catenary.span_types.items()
                  if abs(length - st.length_m) <= tol]
    if not candidates:
        lengths = ", ".join(f"{name} {catenary.span_types[name].length_m:g} m" for name in known)
        return None, (f"length {length:.3f} m matches no span type within ±{tol:g} m (known: {lengths}) and "
                      f"mast {span.left_mast_id} gives no span_type")
    return catenary.span_types[min(candidates)[1]], ""


# --------------------------------------------------------------------------------------------
# projection
# --------------------------------------------------------------------------------------------

def project(recording: pd.DataFrame, masts: pd.DataFrame, catenary: Catenary,
            settings: ProjectionSettings | None = None, registration: Mapping[str, RunRegistration] | None = None,
            lag: Callable[[str, float], float] | None = None, workers: int = 1) -> ProjectionResult:
    """Cut every run of ``recording`` into spans and project each span's heights (module docs).

    Parameters
    ----------
    recording : pandas.DataFrame
        A recording of one run or several (:func:`catenary.measurement.recording.read_recordings`); checked
        again here.
    masts : pandas.DataFrame
        Masts (:func:`catenary.measurement.recording.read_masts`); checked again here. Used as they are for a
        run without a registration.
    catenary : Catenary
        Its ``span_types`` give the lengths and dropper positions.
    settings : ProjectionSettings, optional
    registration : mapping of run id to RunRegistration, optional
        Where the registration placed the masts on each run (:mod:`catenary.measurement.registration`); a run
        missing here is cut at the masts' chainages.
    lag : callable, optional
        ``lag(span_type, speed_kmh)``: where the dynamic pass shows the droppers' kinks, for a
        run towards increasing chainage [m] (:func:`catenary.measurement.registration.lag.height_lag_m`);
        default 0 (a quasi-static pass).
    workers : int
        Processes over blocks of sections (:func:`catenary.plumbing.workers.map_blocks`): each
        section is cut from its own samples, so the result is the same for any number.

    Returns
    -------
    ProjectionResult

    Raises
    ------
    InputError
        If a table is malformed (file-level problem); span-level problems reject the span.
    RuntimeError
        If the bookkeeping invariant (every span of every run used once or rejected with a
        reason) breaks: a bug, never a data problem.
    """
    settings = settings or ProjectionSettings()
    rec = validate_recording(recording)
    mst = validate_masts(masts)
    rec_src = str(rec.attrs.get("source", "recording"))
    masts_src = str(mst.attrs.get("source", "masts"))
    registration = registration or {}
    lag = lag or (lambda name, speed: 0.0)
    report_rows: list[dict[str, Any]] = []
    used_rows: dict[str, list[dict[str, Any]]] = {name: [] for name in catenary.span_types}
    profile_parts: dict[str, list[pd.DataFrame]] = {name: [] for name in catenary.span_types}
    n_spans = 0
    rec = rec.assign(row=np.arange(len(rec)))          # the file's row of each sample, for messages
    for run_id in rec["run_id"].unique():
        samples = run_samples(rec, str(run_id))
        direction = int(samples["direction"].iloc[0])
        run = registration.get(str(run_id))
        spans = _registered_spans(run) if run is not None else _spans_of(mst, str(run_id), masts_src)
        n_spans += len(spans)
        maps = run.maps if run is not None else {}
        by_section: dict[str, list[_Span]] = {}
        for span in spans:
            by_section.setdefault(span.section_id, []).append(span)
        sections = list(by_section.items())
        source = rec_src if rec["run_id"].nunique() == 1 else f"run {run_id} of {rec_src}"

        def block(start: int, stop: int) -> list[list[_Outcome]]:
            """The outcomes of sections ``start:stop``: each section is cut from its own samples."""
            out = []
            for section_id, section_spans in sections[start:stop]:
                frame = _section_samples(samples, maps.get(section_id), run, section_id)
                outcomes = [_project_span(span, frame, direction, catenary, settings, lag, source)
                            for span in section_spans]
                if settings.check_cuts and frame.chainage_m.size:
                    _check_section_drift(section_spans, outcomes, frame, direction, catenary, settings, lag)
                out.append(outcomes)
            return out

        found = [o for part in map_blocks(block, len(sections), workers, SECTIONS_PER_BLOCK) for o in part]
        for (section_id, section_spans), outcomes in zip(sections, found):
            for span, outcome in zip(section_spans, outcomes):
                if outcome.reasons or outcome.span_type is None:
                    report_rows.append(_report_row(span, outcome.span_type, STATUS_REJECTED,
                                                   "; ".join(outcome.reasons)))
                else:
                    used_rows[outcome.span_type.name].append(outcome.row)
                    profile_parts[outcome.span_type.name].append(outcome.profile)
                    report_rows.append(_report_row(span, outcome.span_type, STATUS_USED, ""))
    tables = {name: _spans_frame(rows, catenary.span_types[name].n_droppers) for name, rows in used_rows.items()}
    report = pd.DataFrame(report_rows, columns=list(REPORT_COLUMNS))
    report = report.astype({c: (float if c.endswith("_m") else "str") for c in REPORT_COLUMNS})
    profiles = {name: _profiles_frame(parts) for name, parts in profile_parts.items()}
    result = ProjectionResult(spans=tables, report=report, settings=settings, profiles=profiles)
    check_reconciliation(result, n_spans)
    return result


@dataclass
class _Outcome:
    """What the projection made of one span of one run."""

    span_type: SpanType | None
    reasons: list
    row: dict
    profile: pd.DataFrame | None = None


@dataclass(frozen=True)
class _Frame:
    """One run's samples around one section, in the table's chainage."""

    trace: Trace                     # the samples with spikes removed, for the check of the cuts
    height_m: np.ndarray             # the samples as recorded, for the robust local fits
    speed_kmh: np.ndarray
    force_n: np.ndarray
    rows: np.ndarray                 # row of each sample in the recording file (0-based)
    thickness_m: np.ndarray          # the wear channel's residual thickness (NaN: none)
    contact_force_n: np.ndarray      # the measured contact force (NaN: none)

    @property
    def chainage_m(self) -> np.ndarray:
        return self.trace.chainage_m

    @property
    def stagger_m(self) -> np.ndarray | None:
        return self.trace.stagger_m


def _section_samples(samples: pd.DataFrame, chainage_map: ChainageMap | None, run: RunRegistration | None,
                     section_id: str) -> _Frame:
    """One run's samples around one section, in the table's chainage (the registration's map)."""
    x = samples["chainage_m"].to_numpy(dtype=float)
    row = run.sections[run.sections["section_id"] == section_id].iloc[0] if run is not None else None
    if chainage_map is not None and row is not None and row.status != UNREGISTERED:
        keep = (x >= row.recorded_low_m - MARGIN_M) & (x <= row.recorded_high_m + MARGIN_M)
        samples = samples[keep]
        x = chainage_map.to_table(x[keep])
    stagger = samples["stagger_m"].to_numpy(dtype=float)
    height = samples["height_m"].to_numpy(dtype=float)
    trace = trace_of(x, height, stagger if np.isfinite(stagger).any() else None)
    return _Frame(trace, height, samples["speed_kmh"].to_numpy(dtype=float), samples["force_n"].to_numpy(dtype=float),
                  samples["row"].to_numpy(dtype=int), samples["cw_residual_thickness_m"].to_numpy(dtype=float),
                  samples["contact_force_n"].to_numpy(dtype=float))


def _project_span(span: _Span, frame: _Frame, direction: int, catenary: Catenary, settings: ProjectionSettings,
                  lag: Callable[[str, float], float], rec_src: str) -> _Outcome:
    """One span of one run through the steps of the module docs."""
    reasons: list[str] = []
    if span.refused:
        return _Outcome(None, [span.refused], {})
    st, why = _assign_type(span, catenary, settings)
    if why:
        reasons.append(why)
    a, b = span.start_m, span.end_m
    x, h = frame.chainage_m, frame.height_m
    valid = np.isfinite(h)
    xv, hv = x[valid], h[valid]
    hw = settings.fit_half_window_m
    global_min_gap = min(smallest_spacing_m(t) for t in catenary.span_types.values())
    r0, r1 = np.searchsorted(x, a, "left"), np.searchsorted(x, b, "right")
    gap_max = float("nan")
    if r1 <= r0:
        cover = (f"{rec_src} covers {x[0]:.3f}–{x[-1]:.3f} m" if x.size else f"{rec_src} has no samples here")
        reasons.append(f"no recording samples between chainage {a:.3f} and {b:.3f} m ({cover})")
    else:
        j0, j1 = np.searchsorted(xv, a, "left"), np.searchsorted(xv, b, "right")
        pts = np.r_[a, xv[j0:j1], b]
        gaps = np.diff(pts)
        k = int(np.argmax(gaps))
        gap_max = float(gaps[k])
        limit = settings.max_gap_m if settings.max_gap_m is not None else (
            smallest_spacing_m(st) if st is not None else global_min_gap)
        if gap_max > limit:
            g0, g1 = float(pts[k]), float(pts[k + 1])
            q0, q1 = np.searchsorted(x, g0, "right"), np.searchsorted(x, g1, "left")
            rows = frame.rows[q0:q1]
            inside = (f"{rec_src} {rows_label(int(rows.min()), int(rows.max()), rec_src)}: height_m is missing"
                      if q1 > q0 else f"no samples in {rec_src} there")
            basis = "max_gap_m" if settings.max_gap_m is not None else (
                f"smallest dropper spacing of {st.name}" if st is not None else "smallest dropper spacing")
            reasons.append(f"gap without valid height of {gap_max:.3f} m from chainage {g0:.3f} to "
                           f"{g1:.3f} m ({inside}) exceeds {limit:.3f} m ({basis})")
    if reasons or st is None:
        return _Outcome(st, reasons, {})
    labels = (["left mast " + span.left_mast_id] + [f"dropper {i + 1}" for i in range(st.n_droppers)]
              + ["right mast " + span.right_mast_id])
    where = np.r_[a, a + st.dropper_positions_m, b]
    fits = []
    for xp in where:
        w0, w1 = np.searchsorted(xv, xp - hw, "left"), np.searchsorted(xv, xp + hw, "right")
        fits.append(robust_local_fit(xv[w0:w1], hv[w0:w1], float(xp), settings))
    failed = [f"{label} at chainage {xp:.3f} m has {f.n_inliers} valid samples within ±{hw:g} m"
              + (f" after removing {f.n_outliers} outliers" if f.n_outliers else "")
              for label, xp, f in zip(labels, where, fits) if not np.isfinite(f.height_m)]
    if failed:
        reasons.append(f"too few samples for a local fit (need {settings.min_samples}): " + ", ".join(failed))
    unsettled = [f"{label} at chainage {xp:.3f} m" for label, xp, f in zip(labels, where, fits)
                 if np.isfinite(f.height_m) and not f.settled]
    if unsettled:
        reasons.append(f"robust local fit did not settle in {settings.max_iterations} reweighting passes "
                       "(the outlier set kept changing): " + ", ".join(unsettled))
    support_error = float("nan")
    if not reasons and np.isfinite([span.left_std_m, span.right_std_m]).any():
        error = support_error = _cut_w_error(fits, where, span)
        if error > settings.max_cut_w_error_m:
            reasons.append(f"masts placed too loosely for this span: {span.left_mast_id} to ±"
                           f"{span.left_std_m:.2f} m and {span.right_mast_id} to ±{span.right_std_m:.2f} m, where the "
                           f"trace's slopes make W uncertain by {1e3 * error:.2f} mm RMS (max_cut_w_error_m "
                           f"{1e3 * settings.max_cut_w_error_m:g} mm)")
    inside = (x >= a) & (x <= b)
    speed = _median(frame.speed_kmh[inside])
    shift = float("nan")
    if settings.check_cuts and not reasons:
        lag_m = direction * lag(st.name, speed)
        shift, why = _check_cut(span, st, frame, lag_m, settings)
        if why:
            reasons.append(why)
    if reasons:
        return _Outcome(st, reasons, {})
    heights = np.array([f.height_m for f in fits])
    h_left, h_right = heights[0], heights[-1]
    chord = h_left + (h_right - h_left) * (where[1:-1] - a) / (b - a)
    w = heights[1:-1] - chord
    n_in = np.array([f.n_inliers for f in fits])
    row: dict[str, Any] = {
        "span_id": span.span_id, "run_id": span.run_id, "direction": direction, "speed_kmh": speed,
        "force_n": _median(frame.force_n[inside]), "section_id": span.section_id,
        "left_mast_id": span.left_mast_id, "right_mast_id": span.right_mast_id,
        "start_chainage_m": a, "end_chainage_m": b, "length_m": span.length_m,
        "cw_height_left_m": h_left, "cw_height_right_m": h_right,
    }
    row.update({f"w{i + 1}_m": float(v) for i, v in enumerate(w)})
    row.update({
        "fit_rms_m": float(np.sqrt(sum(f.residual_sq_sum_m2 for f in fits) / n_in.sum())),
        "min_samples_per_point": int(n_in.min()),
        "outliers_removed": int(sum(f.n_outliers for f in fits)),
        "max_gap_m": gap_max, "cut_shift_m": shift,
        "w_support_std_m": support_error, "w_noise_std_m": _noise_w_error(fits, where),
    })
    thickness = frame.thickness_m[inside][np.isfinite(frame.thickness_m[inside])]
    row.update({"cw_residual_thickness_m": float(thickness.mean()) if thickness.size else float("nan"),
                "cw_residual_thickness_se_m": float(thickness.std(ddof=1) / np.sqrt(thickness.size))
                if thickness.size > 1 else float("nan"),
                "contact_force_n": float(np.nanmean(frame.contact_force_n[inside]))
                if np.isfinite(frame.contact_force_n[inside]).any() else float("nan")})
    xs, hs = frame.trace.window(a, b)
    profile = pd.DataFrame({"span_id": span.span_id, "run_id": span.run_id, "x_m": xs - a, "height_m": hs})
    return _Outcome(st, reasons, row, profile)


def _cut_w_error(fits: list, where: np.ndarray, span: _Span) -> float:
    """RMS error of W over the droppers caused by the standard errors of the two masts'
    positions (the droppers move with the left mast), through the fitted slopes h' [m]:
    ∂W_i/∂a = h'(x_i) − (1 − f_i) h'(a) − f_i s, ∂W_i/∂b = −f_i (h'(b) − s), s the chord's slope;
    the two errors correlated by ``span.corr`` where the registration ties them (a height trace's
    section fit, :mod:`catenary.measurement.registration.section_fit`)."""
    slope = np.array([f.slope for f in fits])
    heights = np.array([f.height_m for f in fits])
    length = where[-1] - where[0]
    f = (where[1:-1] - where[0]) / length
    chord = (heights[-1] - heights[0]) / length
    d_left = slope[1:-1] - (1.0 - f) * slope[0] - f * chord
    d_right = -f * (slope[-1] - chord)
    sa, sb = np.nan_to_num(span.left_std_m), np.nan_to_num(span.right_std_m)
    variance = (sa * d_left) ** 2 + (sb * d_right) ** 2 + 2.0 * np.nan_to_num(span.corr) * sa * sb * d_left * d_right
    return float(np.sqrt(max(np.mean(variance), 0.0)))


def _noise_w_error(fits: list, where: np.ndarray) -> float:
    """RMS over the droppers of W's standard error from the local fits' own errors [m]: W_i = h_i −
    (1 − f_i) h_a − f_i h_b with independent fits."""
    std = np.array([f.height_std_m for f in fits])
    f = (where[1:-1] - where[0]) / (where[-1] - where[0])
    variance = std[1:-1] ** 2 + ((1.0 - f) * std[0]) ** 2 + (f * std[-1]) ** 2
    return float(np.sqrt(np.mean(variance)))


def _median(values: np.ndarray) -> float:
    finite = values[np.isfinite(values)]
    return float(np.median(finite)) if finite.size else float("nan")


def _check_cut(span: _Span, st: SpanType, frame: _Frame, lag_m: float,
               settings: ProjectionSettings) -> tuple[float, str]:
    """Where the trace puts this span's supports against the cut (module docs, step 5): the
    span's shift and, if the cut is wrong, why."""
    tol = settings.max_cut_error_m
    a, b = span.start_m, span.end_m
    if frame.stagger_m is not None:
        shifts = []
        for mast, x0 in ((span.left_mast_id, a), (span.right_mast_id, b)):
            fit = locate_stagger_support(frame.trace, x0, settings.cut_search_m)
            if not np.isfinite(fit.position_m):
                continue                  # the stagger is not recorded on both sides: nothing to check there
            if fit.at_edge or abs(fit.position_m - x0) > tol:
                where = (f"{fit.position_m - x0:+.2f} m from" if not fit.at_edge else
                         f"nowhere within ±{settings.cut_search_m:g} m of")
                return (fit.position_m - x0, f"cut in the wrong place: the stagger reverses {where} mast {mast} "
                        f"at chainage {x0:.3f} m (tolerance ±{tol:g} m)")
            shifts.append(fit.position_m - x0)
        return (float(np.mean(shifts)) if shifts else float("nan")), ""
    pattern = np.r_[a, a + st.dropper_positions_m, b]
    fit = align_pattern(frame.trace, pattern, a - 1.0, b + 1.0, settings.cut_search_m, lag_m=lag_m)
    if not fit.found:
        return float("nan"), ""
    if abs(fit.position_m) > tol and fit.statistic > settings.cut_statistic:
        return fit.position_m, (f"cut in the wrong place: the span's dropper pattern fits the height trace "
                                f"{fit.position_m:+.2f} m from the cut at masts {span.left_mast_id} "
                                f"({a:.3f} m) and {span.right_mast_id} (misfit lower by {fit.statistic:.0f} "
                                f"residual variances > cut_statistic {settings.cut_statistic:g}; tolerance ±{tol:g} m)")
    return fit.position_m, ""


def _check_section_drift(spans: list[_Span], outcomes: list[_Outcome], frame: _Frame, direction: int,
                         catenary: Catenary, settings: ProjectionSettings, lag: Callable[[str, float], float]) -> None:
    """Reject, in place, the spans that their whole section's supports put beyond the tolerance
    (module docs, step 5a): the registration's coarse search (:func:`catenary.measurement.registration.runner.support_line`)
    run again on the cut masts. When at least 3 masts, and twice as many as find their support at
    the cut itself (+ 2), agree on a line of shifts, a span whose masts it puts further than
    ``max_cut_error_m`` from the cut — plus :data:`SECTION_LINE_BIAS_M` on a height trace — is
    rejected. (Where the cuts are right, about half the masts find their support at the cut:
    measured on the small campaign's height, 7–12 of ≈ 20.)"""
    masts = np.array([s.start_m for s in spans] + [spans[-1].end_m])
    if masts.size < 4 or np.any(np.diff(masts) <= 0):
        return
    types = [s.declared_type if s.declared_type in catenary.span_types else min(
        catenary.span_types, key=lambda t: abs(catenary.span_types[t].length_m - s.length_m)) for s in spans] + [None]
    speed = _median(frame.speed_kmh)
    lag_m = float(np.mean([direction * lag(t, speed) for t in set(types) - {None}])) if not frame.trace.has_stagger else 0.0
    line = support_line(frame.trace, support_kinks(frame.trace), masts, types, masts, catenary, scale=1.0, lag_m=lag_m,
                        reach_m=settings.cut_reach_m, max_scale_error=0.01, tolerance_m=settings.max_cut_error_m)
    if line is None:
        return
    supports, agree, own = line
    at_cut = int(np.sum(np.abs(own) <= settings.max_cut_error_m))
    if agree.sum() < max(3, 2 * at_cut + 2):
        return
    shift = supports - masts
    tolerance = settings.max_cut_error_m + (0.0 if frame.trace.has_stagger else SECTION_LINE_BIAS_M)
    for k, outcome in enumerate(outcomes):
        worst = shift[k] if abs(shift[k]) >= abs(shift[k + 1]) else shift[k + 1]
        if abs(worst) > tolerance:
            outcome.reasons.append(
                f"cut in the wrong place: {int(agree.sum())} of the {masts.size} masts of section {spans[k].section_id} "
                f"agree that the trace's supports lie {shift[0]:+.2f} to {shift[-1]:+.2f} m from the cuts, "
                f"{worst:+.2f} m at this span (tolerance ±{tolerance:g} m; a drift of the chainage: "
                "an odometer error?)")
            outcome.row = {}


def _report_row(span: _Span, st: SpanType | None, status: str, reason: str) -> dict[str, Any]:
    return {"span_id": span.span_id, "run_id": span.run_id, "section_id": span.section_id,
            "span_type": st.name if st else "", "status": status, "reason": reason, "left_mast_id": span.left_mast_id,
            "right_mast_id": span.right_mast_id, "start_chainage_m": span.start_m, "end_chainage_m": span.end_m,
            "length_m": span.length_m}


def spans_columns(n_droppers: int) -> list[str]:
    """Column names of ``results/{span_type}/spans.parquet`` for a type with ``n_droppers`` droppers."""
    return (["span_id", *RUN_COLUMNS, "section_id", "left_mast_id", "right_mast_id", "start_chainage_m",
             "end_chainage_m", "length_m", "cw_height_left_m", "cw_height_right_m"]
            + [f"w{i + 1}_m" for i in range(n_droppers)] + list(QUALITY_COLUMNS) + list(CHANNEL_COLUMNS))


def spans_schema(n_droppers: int) -> pa.Schema:
    """Arrow schema of ``results/{span_type}/spans.parquet`` for a type with ``n_droppers`` droppers."""
    out = []
    for name in spans_columns(n_droppers):
        if name in _TEXT_COLUMNS:
            out.append(pa.field(name, pa.string(), nullable=False))
        elif name in _INT_COLUMNS:
            out.append(pa.field(name, pa.int64(), nullable=False))
        else:
            out.append(pa.field(name, pa.float64(), nullable=name in _NULLABLE))
    return pa.schema(out)


#: Columns that may be NaN: what the recording did not give, a check not made.
_NULLABLE = ("speed_kmh", "force_n", "cut_shift_m", "w_support_std_m", *CHANNEL_COLUMNS)
_TEXT_COLUMNS = ("span_id", "run_id", "section_id", "left_mast_id", "right_mast_id")
_INT_COLUMNS = ("direction", "min_samples_per_point", "outliers_removed")


REPORT_SCHEMA = pa.schema([pa.field(c, pa.float64() if c.endswith("_m") else pa.string(), nullable=False)
                           for c in REPORT_COLUMNS])
"""Arrow schema of the span report (if written as Parquet)."""


def _spans_frame(rows: list[dict[str, Any]], n_droppers: int) -> pd.DataFrame:
    columns = spans_columns(n_droppers)
    df = pd.DataFrame(rows, columns=columns)
    dtypes: dict[str, Any] = {}
    for name in columns:
        if name in _TEXT_COLUMNS:
            dtypes[name] = "str"
        elif name in _INT_COLUMNS:
            dtypes[name] = "int64"
        else:
            dtypes[name] = "float64"
    return df.astype(dtypes)


#: Arrow schema of ``results/{span_type}/profiles.parquet``.
PROFILE_SCHEMA = pa.schema([pa.field("span_id", pa.string(), nullable=False),
                            pa.field("run_id", pa.string(), nullable=False),
                            pa.field("x_m", pa.float64(), nullable=False),
                            pa.field("height_m", pa.float64(), nullable=False)])


#: Sections per block of the worker processes of :func:`project`.
SECTIONS_PER_BLOCK = 2
#: Rows per row group of ``profiles.parquet``: ≈ 55 spans of ≈ 600 samples.
PROFILE_ROW_GROUP_ROWS = 1 << 15


def _profiles_frame(parts: list[pd.DataFrame]) -> pd.DataFrame:
    if not parts:
        return pd.DataFrame({"span_id": pd.Series(dtype="str"), "run_id": pd.Series(dtype="str"),
                             "x_m": pd.Series(dtype=float), "height_m": pd.Series(dtype=float)})
    return pd.concat(parts, ignore_index=True).astype({"span_id": "str", "run_id": "str"})


def check_reconciliation(result: ProjectionResult, n_spans: int) -> None:
    """Spans in = used + rejected: every span of every run in the report once, used ones in exactly
    one table, rejected ones with a reason.

    Raises
    ------
    RuntimeError
        Naming what does not reconcile (a bug in the projection, never a data problem).
    """
    report = result.report
    problems = []
    if len(report) != n_spans:
        problems.append(f"report has {len(report)} rows for {n_spans} spans")
    status = report["status"].to_numpy(dtype=object)
    if not np.isin(status, [STATUS_USED, STATUS_REJECTED]).all():
        problems.append("a status is neither used nor rejected")
    reasons = report["reason"].fillna("").to_numpy(dtype=object)
    rejected = status == STATUS_REJECTED
    if any(str(r).strip() == "" for r in reasons[rejected]):
        problems.append("a rejected span has no reason")
    if any(str(r) != "" for r in reasons[~rejected]):
        problems.append("a used span has a reason")
    if report.duplicated(["span_id", "run_id"]).any():
        problems.append("a span of a run is reported twice")
    key = report["span_id"] + "@" + report["run_id"]
    used_ids: list[str] = []
    for name, table in result.spans.items():
        ids = (table["span_id"] + "@" + table["run_id"]).tolist()
        used_ids.extend(ids)
        types = report.loc[key.isin(ids) & (report["status"] == STATUS_USED), "span_type"]
        if (types != name).any():
            problems.append(f"a span in the {name} table is reported with another type")
    expected = key[report["status"] == STATUS_USED].tolist()
    if sorted(used_ids) != sorted(expected):
        problems.append(f"{len(used_ids)} spans in the tables, {len(expected)} reported used")
    if (~rejected).sum() + rejected.sum() != len(report):
        problems.append("used + rejected != spans")
    if problems:
        raise RuntimeError("projection bookkeeping broken: " + "; ".join(problems))


def write_projection(result: ProjectionResult, results_dir: str | Path, *, config_hash: str,
                     span_types: list[str] | None = None, catenary: Catenary | None = None) -> list[Path]:
    """Write ``{results_dir}/{span_type}/spans.parquet``, ``{results_dir}/{span_type}/profiles.parquet``
    and ``{results_dir}/spans_report.csv``.

    Parameters
    ----------
    result : ProjectionResult
    results_dir : str or pathlib.Path
    config_hash : str
        Hash of the configuration (file metadata of the Parquet outputs).
    span_types : list of str, optional
        Types to write (default: every table of ``result``); a listed type without used spans
        gets an empty table with the full schema.
    catenary : Catenary, optional
        Needed only to write a type that ``result.spans`` does not hold.

    Returns
    -------
    list of pathlib.Path
        The files written.
    """
    results_dir = Path(results_dir)
    written = []
    for name in span_types if span_types is not None else list(result.spans):
        if name in result.spans:
            table = result.spans[name]
            n_w = sum(1 for c in table.columns if c[:1] == "w" and c.endswith("_m") and c[1:-2].isdigit())
            schema = spans_schema(n_w)
        elif catenary is not None:
            n_w = catenary.span_type(name).n_droppers
            table, schema = _spans_frame([], n_w), spans_schema(n_w)
        else:
            raise ValueError(f"span type {name!r} not in the projection result; pass catenary= to write it empty")
        path = results_dir / name / "spans.parquet"
        write_table(table, path, schema, config_hash=config_hash, kind=f"spans:{name}")
        written.append(path)
        path = results_dir / name / "profiles.parquet"
        # Row groups of a few dozen spans: a section's correction reads its spans' rows only
        # (by the groups' span_id statistics), not the whole line's.
        write_table(result.profiles.get(name, _profiles_frame([])), path, PROFILE_SCHEMA, config_hash=config_hash,
                    kind=f"profiles:{name}", row_group_rows=PROFILE_ROW_GROUP_ROWS)
        written.append(path)
    report_path = results_dir / "spans_report.csv"
    report_path.parent.mkdir(parents=True, exist_ok=True)
    result.report.to_csv(report_path, index=False, lineterminator="\n", float_format="%.6f")
    written.append(report_path)
    return written
