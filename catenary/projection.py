"""Cut a recording into spans and project the CW heights at the droppers onto the chord.

For every pair of consecutive masts of a section (a *span*, id ``"{left_mast_id}-{right_mast_id}"``):

1. **Type.** The ``span_type`` of the left mast in the masts file if given (it must be a type of
   the catenary config and the measured length must match its length within
   ``span_type_tolerance_m``), else the type whose length is nearest to the measured one within
   that tolerance.
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

A span that fails a step is **rejected** with its reason(s) in the report; only file-level
problems raise :class:`~catenary.errors.InputError`. Every span of the masts file is in the report,
either ``used`` (and then in exactly one ``spans[type]`` table) or ``rejected`` with a non-empty
reason: :func:`project` checks this before returning.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import pandas as pd
import pyarrow as pa

from .config import Catenary, SpanType
from .schema import check
from .parquet import write_table
from .recording import row_label, rows_label, validate_masts, validate_recording

STATUS_USED = "used"
STATUS_REJECTED = "rejected"

REPORT_COLUMNS = ("span_id", "section_id", "span_type", "status", "reason", "left_mast_id", "right_mast_id",
                  "start_chainage_m", "end_chainage_m", "length_m")
"""Columns of the span report: one row per span of the masts file, in file order."""

QUALITY_COLUMNS = ("fit_rms_m", "min_samples_per_point", "outliers_removed", "max_gap_m")


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
    """

    span_type_tolerance_m: float = 0.5
    fit_half_window_m: float = 1.0
    min_samples: int = 5
    outlier_threshold: float = 4.0
    max_gap_m: float | None = None
    scale_floor_m: float = 5e-4
    fit_model: str = "quadratic"
    max_iterations: int = 20

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
        span, in line order: ``span_id``, ``section_id``, ``left_mast_id``, ``right_mast_id``,
        ``start_chainage_m``, ``end_chainage_m``, ``length_m``, ``cw_height_left_m``,
        ``cw_height_right_m`` (fitted steady-arm heights), ``w1_m`` … ``wn_m`` (deflections
        from the chord, negative below), ``fit_rms_m`` (RMS of the inlier residuals of all the
        span's local fits), ``min_samples_per_point`` (fewest inliers of a local fit),
        ``outliers_removed`` (samples rejected as spikes, summed over the span's fits),
        ``max_gap_m`` (longest run without a valid height inside the span).
    report : pandas.DataFrame
        One row per span of the masts file (:data:`REPORT_COLUMNS`), ``status`` ``"used"`` or
        ``"rejected"``, ``reason`` empty when used, else every reason joined by ``"; "``.
    settings : ProjectionSettings
    """

    spans: dict[str, pd.DataFrame]
    report: pd.DataFrame
    settings: ProjectionSettings = field(default_factory=ProjectionSettings)

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
    settled : bool
        False when the inlier set still changed after ``max_iterations`` reweighting passes:
        the height is then not a converged robust estimate and the span is rejected.
    """

    height_m: float
    n_inliers: int
    n_outliers: int
    rms_m: float
    residual_sq_sum_m2: float
    settled: bool = True


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
    return LocalFit(float(coef[0]), n_in, n - n_in, float(np.sqrt(ss / n_in)), ss, settled)


# --------------------------------------------------------------------------------------------
# span bookkeeping
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class _Span:
    index: int
    span_id: str
    section_id: str
    left_row: int
    right_row: int
    left_mast_id: str
    right_mast_id: str
    start_m: float
    end_m: float
    declared_type: str | None

    @property
    def length_m(self) -> float:
        return self.end_m - self.start_m


def _spans_of(masts: pd.DataFrame) -> list[_Span]:
    """The spans of validated masts: consecutive masts of the same section, in file order."""
    ids = masts["mast_id"].to_numpy(dtype=object)
    sec = masts["section_id"].to_numpy(dtype=object)
    ch = masts["chainage_m"].to_numpy(dtype=float)
    types = masts["span_type"].to_numpy(dtype=object)
    out = []
    for i in range(len(masts) - 1):
        if sec[i] != sec[i + 1]:
            continue
        declared = None if (types[i] is None or (isinstance(types[i], float) and np.isnan(types[i]))
                            or str(types[i]) == "") else str(types[i])
        out.append(_Span(len(out), f"{ids[i]}-{ids[i + 1]}", str(sec[i]), i, i + 1, str(ids[i]), str(ids[i + 1]),
                         float(ch[i]), float(ch[i + 1]), declared))
    return out


def smallest_spacing_m(span_type: SpanType) -> float:
    """Smallest distance between consecutive supports of a span type (masts and droppers) [m]."""
    points = np.r_[0.0, span_type.dropper_positions_m, span_type.length_m]
    return float(np.min(np.diff(points)))


def _assign_type(span: _Span, catenary: Catenary, settings: ProjectionSettings,
                 masts_src: str) -> tuple[SpanType | None, str]:
    tol = settings.span_type_tolerance_m
    known = sorted(catenary.span_types)
    length = span.length_m
    if span.declared_type is not None:
        st = catenary.span_types.get(span.declared_type)
        if st is None:
            return None, (f"unknown span type {span.declared_type!r} (mast {span.left_mast_id}, "
                          f"{row_label(span.left_row, masts_src)} of {masts_src}); known: {', '.join(known)}")
        if abs(length - st.length_m) > tol:
            return st, (f"length mismatch: measured {length:.3f} m between masts {span.left_mast_id} and "
                        f"{span.right_mast_id}, span type {st.name} is {st.length_m:g} m (tolerance ±{tol:g} m)")
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
            settings: ProjectionSettings | None = None) -> ProjectionResult:
    """Cut ``recording`` into the spans of ``masts`` and project each span's heights (module docs).

    Parameters
    ----------
    recording : pandas.DataFrame
        A recording (:func:`catenary.recording.read_recording`); checked again here.
    masts : pandas.DataFrame
        Masts (:func:`catenary.recording.read_masts`); checked again here.
    catenary : Catenary
        Its ``span_types`` give the lengths and dropper positions.
    settings : ProjectionSettings, optional

    Returns
    -------
    ProjectionResult

    Raises
    ------
    InputError
        If a table is malformed (file-level problem); span-level problems reject the span.
    RuntimeError
        If the bookkeeping invariant (every span used once or rejected with a reason) breaks:
        a bug, never a data problem.
    """
    settings = settings or ProjectionSettings()
    rec = validate_recording(recording)
    mst = validate_masts(masts)
    rec_src = str(rec.attrs.get("source", "recording"))
    masts_src = str(mst.attrs.get("source", "masts"))
    x = rec["chainage_m"].to_numpy(dtype=float)
    h = rec["height_m"].to_numpy(dtype=float)
    valid = np.isfinite(h)
    xv, hv = x[valid], h[valid]
    hw = settings.fit_half_window_m
    global_min_gap = min(smallest_spacing_m(st) for st in catenary.span_types.values())

    spans = _spans_of(mst)
    report_rows: list[dict[str, Any]] = []
    used_rows: dict[str, list[dict[str, Any]]] = {name: [] for name in catenary.span_types}
    for span in spans:
        reasons: list[str] = []
        st, why = _assign_type(span, catenary, settings, masts_src)
        if why:
            reasons.append(why)
        a, b = span.start_m, span.end_m
        # Coverage: raw samples in [a, b], then runs without a valid height.
        r0, r1 = np.searchsorted(x, a, "left"), np.searchsorted(x, b, "right")
        gap_max = float("nan")
        if r1 <= r0:
            cover = (f"recording covers {x[0]:.3f}–{x[-1]:.3f} m" if x.size else "recording is empty")
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
                inside = (f"{rec_src} {rows_label(int(q0), int(q1) - 1, rec_src)}: height_m is missing"
                          if q1 > q0 else f"no samples in {rec_src} there")
                basis = "max_gap_m" if settings.max_gap_m is not None else (
                    f"smallest dropper spacing of {st.name}" if st is not None else "smallest dropper spacing")
                reasons.append(f"gap without valid height of {gap_max:.3f} m from chainage {g0:.3f} to "
                               f"{g1:.3f} m ({inside}) exceeds {limit:.3f} m ({basis})")
        if reasons or st is None:
            report_rows.append(_report_row(span, st, STATUS_REJECTED, "; ".join(reasons)))
            continue
        # Robust local fits at the masts and the droppers.
        labels = (["left mast " + span.left_mast_id]
                  + [f"dropper {i + 1}" for i in range(st.n_droppers)]
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
        if reasons:
            report_rows.append(_report_row(span, st, STATUS_REJECTED, "; ".join(reasons)))
            continue
        heights = np.array([f.height_m for f in fits])
        h_left, h_right = heights[0], heights[-1]
        chord = h_left + (h_right - h_left) * (where[1:-1] - a) / (b - a)
        w = heights[1:-1] - chord
        n_in = np.array([f.n_inliers for f in fits])
        row: dict[str, Any] = {
            "span_id": span.span_id, "section_id": span.section_id,
            "left_mast_id": span.left_mast_id, "right_mast_id": span.right_mast_id,
            "start_chainage_m": a, "end_chainage_m": b, "length_m": span.length_m,
            "cw_height_left_m": h_left, "cw_height_right_m": h_right,
        }
        row.update({f"w{i + 1}_m": float(v) for i, v in enumerate(w)})
        row.update({
            "fit_rms_m": float(np.sqrt(sum(f.residual_sq_sum_m2 for f in fits) / n_in.sum())),
            "min_samples_per_point": int(n_in.min()),
            "outliers_removed": int(sum(f.n_outliers for f in fits)),
            "max_gap_m": gap_max,
        })
        used_rows[st.name].append(row)
        report_rows.append(_report_row(span, st, STATUS_USED, ""))

    tables = {name: _spans_frame(rows, catenary.span_types[name].n_droppers) for name, rows in used_rows.items()}
    report = pd.DataFrame(report_rows, columns=list(REPORT_COLUMNS))
    report = report.astype({"span_id": "str", "section_id": "str", "span_type": "str", "status": "str",
                            "reason": "str", "left_mast_id": "str", "right_mast_id": "str",
                            "start_chainage_m": float, "end_chainage_m": float, "length_m": float})
    result = ProjectionResult(spans=tables, report=report, settings=settings)
    check_reconciliation(result, len(spans))
    return result


def _report_row(span: _Span, st: SpanType | None, status: str, reason: str) -> dict[str, Any]:
    return {"span_id": span.span_id, "section_id": span.section_id, "span_type": st.name if st else "",
            "status": status, "reason": reason, "left_mast_id": span.left_mast_id,
            "right_mast_id": span.right_mast_id, "start_chainage_m": span.start_m, "end_chainage_m": span.end_m,
            "length_m": span.length_m}


def spans_columns(n_droppers: int) -> list[str]:
    """Column names of ``results/{span_type}/spans.parquet`` for a type with ``n_droppers`` droppers."""
    return (["span_id", "section_id", "left_mast_id", "right_mast_id", "start_chainage_m", "end_chainage_m",
             "length_m", "cw_height_left_m", "cw_height_right_m"]
            + [f"w{i + 1}_m" for i in range(n_droppers)] + list(QUALITY_COLUMNS))


def spans_schema(n_droppers: int) -> pa.Schema:
    """Arrow schema of ``results/{span_type}/spans.parquet`` for a type with ``n_droppers`` droppers."""
    out = []
    for name in spans_columns(n_droppers):
        if name in ("span_id", "section_id", "left_mast_id", "right_mast_id"):
            out.append(pa.field(name, pa.string(), nullable=False))
        elif name in ("min_samples_per_point", "outliers_removed"):
            out.append(pa.field(name, pa.int64(), nullable=False))
        else:
            out.append(pa.field(name, pa.float64(), nullable=False))
    return pa.schema(out)


REPORT_SCHEMA = pa.schema([pa.field(c, pa.float64() if c.endswith("_m") else pa.string(), nullable=False)
                           for c in REPORT_COLUMNS])
"""Arrow schema of the span report (if written as Parquet)."""


def _spans_frame(rows: list[dict[str, Any]], n_droppers: int) -> pd.DataFrame:
    columns = spans_columns(n_droppers)
    df = pd.DataFrame(rows, columns=columns)
    dtypes: dict[str, Any] = {}
    for name in columns:
        if name in ("span_id", "section_id", "left_mast_id", "right_mast_id"):
            dtypes[name] = "str"
        elif name in ("min_samples_per_point", "outliers_removed"):
            dtypes[name] = "int64"
        else:
            dtypes[name] = "float64"
    return df.astype(dtypes)


def check_reconciliation(result: ProjectionResult, n_spans: int) -> None:
    """Spans in = used + rejected: every span in the report once, used spans in exactly one table,
    rejected spans with a reason.

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
    used_ids: list[str] = []
    for name, table in result.spans.items():
        used_ids.extend(table["span_id"].tolist())
        types = report.loc[report["span_id"].isin(table["span_id"]) & (report["status"] == STATUS_USED), "span_type"]
        if (types != name).any():
            problems.append(f"a span in the {name} table is reported with another type")
    expected = report.loc[report["status"] == STATUS_USED, "span_id"].tolist()
    if sorted(used_ids) != sorted(expected):
        problems.append(f"{len(used_ids)} spans in the tables, {len(expected)} reported used")
    if (~rejected).sum() + rejected.sum() != len(report):
        problems.append("used + rejected != spans")
    if problems:
        raise RuntimeError("projection bookkeeping broken: " + "; ".join(problems))


def write_projection(result: ProjectionResult, results_dir: str | Path, *, config_hash: str,
                     span_types: list[str] | None = None, catenary: Catenary | None = None) -> list[Path]:
    """Write ``{results_dir}/{span_type}/spans.parquet`` and ``{results_dir}/spans_report.csv``.

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
    report_path = results_dir / "spans_report.csv"
    report_path.parent.mkdir(parents=True, exist_ok=True)
    result.report.to_csv(report_path, index=False, lineterminator="\n", float_format="%.6f")
    written.append(report_path)
    return written
