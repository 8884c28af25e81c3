"""Dropper-only inversion of measured spans (paper §4.1, Table 1, Fig. 8).

Holding every parameter of a span but its dropper lengths at fixed values (T_CW, T_MW and ΔH
at their design values unless told otherwise, steady arms at the design height), the 9 CW
deflections W at the droppers determine the 9 dropper lengths uniquely: the CW
equilibrium with its heights prescribed at the droppers gives the dropper tensions, the MW
loaded by them gives its heights, and Hooke's law the unstretched lengths. That is the fixed
point of :func:`catenary.physics.dropper_table.dropper_lengths_for_cw_heights` (the solver the dynamic
correction uses) on the single-span model of the paper (:func:`catenary.physics.section.single_span`),
solved for a block of spans at once: one geometry, their targets side by side
(:func:`catenary.physics.dropper_table.dropper_lengths_for_many`; 5 000 spans in ≈ 1.5 s, against
≈ 0.02 s a span one by one).

W is measured from the chord joining the CW at the two steady arms (negative below); the
single-span model has both steady arms at the design height ``h``, so the target CW heights
are ``h + W``. The steady-arm heights themselves do not matter (paper Fig. 3).

Inverting many spans at *fixed* T_MW projects every other source of variability onto the
dropper lengths: a span whose real T_MW is lower than assumed has a deeper MW sag, which the
inversion explains by shorter droppers, most in the middle of the span where the MW sag is
largest. T_MW variability therefore shows as a large spread of the central dropper lengths,
nearly perfectly correlated between them (paper Table 1 and Fig. 8); with T_MW fixed the
inverted lengths are the true ones up to the system-height variability.

Spans whose W cannot be produced by taut droppers (the target would need a dropper to push)
are not inverted; they are reported with the reason, never dropped silently.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa

from catenary.physics.config import Catenary, SpanType
from catenary.physics.dropper_table import dropper_lengths_for_many, nominal_dropper_lengths
from catenary.physics.section import single_span
from catenary.plumbing.errors import InputError, NoTautSolutionError
from catenary.plumbing.workers import map_blocks

#: Spans per block of :func:`invert_spans`' workers, solved together (≈ 0.3 ms a span).
BLOCK_SPANS = 256
CM = 1e2


def w_columns(n_droppers: int) -> list[str]:
    """Names of the W columns, ``w1_m`` … ``w{n}_m`` (CW deflection from the chord [m])."""
    return [f"w{i + 1}_m" for i in range(n_droppers)]


def dropper_columns(n_droppers: int) -> list[str]:
    """Names of the dropper-length columns, ``dropper_1_length_m`` … (unstretched [m])."""
    return [f"dropper_{i + 1}_length_m" for i in range(n_droppers)]


def droppers_schema(n_droppers: int) -> pa.Schema:
    """Arrow schema of ``{results}/{span_type}/inversion/droppers.parquet``."""
    return pa.schema([pa.field("span_id", pa.string(), nullable=False)]
                     + [pa.field(c, pa.float64(), nullable=False) for c in dropper_columns(n_droppers)])


def converged_spans(corrected: pd.DataFrame, n_droppers: int, source: str | Path = "corrected table"
                    ) -> tuple[pd.DataFrame, int]:
    """Check a corrected-W table and keep the rows whose dynamic correction converged.

    Parameters
    ----------
    corrected : pandas.DataFrame
        One row per span with ``span_id``, ``converged`` (bool) and ``w1_m`` … ``w{n}_m``
        (corrected static W [m]); other columns are ignored.
    n_droppers : int
        Droppers per span of the span type.
    source : str or pathlib.Path
        Name of the file, for error messages.

    Returns
    -------
    kept : pandas.DataFrame
        The converged rows, in the input order, index reset.
    n_left_out : int
        Rows left out because their correction did not converge.

    Raises
    ------
    InputError
        Naming the file and the column: a missing column, a ``converged`` column that is not
        boolean, a duplicated ``span_id``, or a missing or non-finite W in a converged row.
    """
    required = ["span_id", "converged", *w_columns(n_droppers)]
    missing = [c for c in required if c not in corrected.columns]
    if missing:
        raise InputError(f"{source}: missing columns {missing}; expected span_id, converged and "
                         f"w1_m…w{n_droppers}_m (corrected static W [m])")
    flag = corrected["converged"]
    if not (pd.api.types.is_bool_dtype(flag) and not flag.isna().any()):
        raise InputError(f"{source}: column 'converged' must hold booleans without missing values, "
                         f"got dtype {flag.dtype}")
    dup = corrected["span_id"][corrected["span_id"].duplicated()]
    if len(dup):
        raise InputError(f"{source}: column 'span_id': duplicated span {dup.iloc[0]!r}; expected one row per span")
    kept = corrected.loc[flag.to_numpy(dtype=bool)].reset_index(drop=True)
    for c in w_columns(n_droppers):
        values = pd.to_numeric(kept[c], errors="coerce").to_numpy(dtype=float, na_value=np.nan)
        if not np.all(np.isfinite(values)):
            row = int(np.flatnonzero(~np.isfinite(values))[0])
            raise InputError(f"{source}: column {c!r}: missing or non-finite W for converged span "
                             f"{kept['span_id'].iloc[row]!r}; expected a deflection in metres")
    return kept, int(len(corrected) - len(kept))


def invert_span(span_type: SpanType, catenary: Catenary, w_m: np.ndarray, *,
                messenger_tension_n: float | None = None, system_height_m: float | None = None,
                initial_lengths_m: np.ndarray | None = None) -> np.ndarray:
    """Dropper lengths of one span that give the CW deflections ``w_m`` (paper §4.1).

    Parameters
    ----------
    span_type : SpanType
    catenary : Catenary
    w_m : array_like, shape (n_droppers,)
        CW deflection from the chord at each dropper [m], positive upwards.
    messenger_tension_n : float, optional
        T_MW held fixed [N]; default the span type's design tension.
    system_height_m : float, optional
        ΔH at both masts [m]; default the design system height.
    initial_lengths_m : array_like, optional
        Starting guess of the lengths [m] (default: the nominal table).

    Returns
    -------
    numpy.ndarray
        Unstretched dropper lengths [m].

    Raises
    ------
    NoTautSolutionError
        If ``w_m`` would need a dropper in compression.
    ValueError
        If ``w_m`` has the wrong size.
    """
    w = np.asarray(w_m, dtype=float)
    if w.shape != span_type.dropper_positions_m.shape:
        raise ValueError(f"w_m: expected {span_type.n_droppers} deflections for span type {span_type.name}, "
                         f"got shape {w.shape}")
    if initial_lengths_m is None:
        initial_lengths_m = nominal_dropper_lengths(span_type, catenary).dropper_lengths_m
    dh = span_type.system_height_m if system_height_m is None else system_height_m
    section = single_span(span_type, initial_lengths_m, messenger_tension_n=messenger_tension_n,
                          system_height_left_m=dh, system_height_right_m=dh)
    lengths, failures = dropper_lengths_for_many(section, catenary, span_type.cw_height_m + w[None, :])
    if failures[0]:
        raise NoTautSolutionError(failures[0])
    return lengths[0]


@dataclass(frozen=True)
class InversionResult:
    """Dropper lengths of a set of spans from their W.

    Attributes
    ----------
    span_id : numpy.ndarray of str
        Inverted spans, in input order.
    dropper_lengths_m : numpy.ndarray
        Unstretched dropper lengths [m], shape (n_spans, n_droppers).
    left_out : pandas.DataFrame
        ``span_id`` and ``reason`` of each span that could not be inverted.
    messenger_tension_n, system_height_m : float
        T_MW [N] and ΔH [m] held fixed.
    """

    span_id: np.ndarray
    dropper_lengths_m: np.ndarray
    left_out: pd.DataFrame
    messenger_tension_n: float
    system_height_m: float

    def table(self) -> pd.DataFrame:
        """``span_id`` and ``dropper_1_length_m`` … (the droppers.parquet layout)."""
        n = self.dropper_lengths_m.shape[1]
        df = pd.DataFrame(self.dropper_lengths_m, columns=dropper_columns(n))
        df.insert(0, "span_id", pd.Series(self.span_id, dtype="str"))
        return df


def invert_spans(span_type: SpanType, catenary: Catenary, span_id, w_m: np.ndarray, *,
                 messenger_tension_n: float | None = None,
                 system_height_m: float | None = None, workers: int = 1) -> InversionResult:
    """Dropper-only inversion of many spans of one type (paper §4.1).

    Parameters
    ----------
    span_type : SpanType
    catenary : Catenary
    span_id : sequence of str
        Span names, one per row of ``w_m``.
    w_m : array_like, shape (n_spans, n_droppers)
        CW deflections from the chord at the droppers [m].
    messenger_tension_n, system_height_m : float, optional
        T_MW [N] and ΔH [m] held fixed; default the span type's design values.
    workers : int
        Processes inverting blocks of :data:`BLOCK_SPANS` spans side by side (each span's
        inversion is its own: the same result for any number).

    Returns
    -------
    InversionResult
        Spans needing a dropper in compression are in ``left_out`` with the reason.
    """
    ids = np.asarray(list(span_id), dtype=object).astype(str)
    n = span_type.n_droppers
    w = np.asarray(w_m, dtype=float)
    w = w.reshape(0, n) if w.size == 0 else np.atleast_2d(w)
    if w.shape[1:] != (n,) or ids.size != w.shape[0]:
        raise ValueError(f"w_m: expected shape ({ids.size}, {n}) for {ids.size} spans of {span_type.name}, "
                         f"got {w.shape}")
    t_mw = span_type.messenger_tension_n if messenger_tension_n is None else float(messenger_tension_n)
    dh = span_type.system_height_m if system_height_m is None else float(system_height_m)
    nominal = nominal_dropper_lengths(span_type, catenary).dropper_lengths_m

    section = single_span(span_type, nominal, messenger_tension_n=t_mw, system_height_left_m=dh,
                          system_height_right_m=dh)

    def block(start: int, stop: int) -> tuple[list, list, list]:
        # the spans of a block together (one geometry: dropper_lengths_for_many)
        found, failures = dropper_lengths_for_many(section, catenary, span_type.cw_height_m + w[start:stop])
        lengths, kept, left_out = [], [], []
        for sid, row, why in zip(ids[start:stop], found, failures):
            if why:
                left_out.append({"span_id": sid, "reason": why})
            else:
                lengths.append(row)
                kept.append(sid)
        return lengths, kept, left_out

    parts = map_blocks(block, ids.size, workers, BLOCK_SPANS)
    lengths = [x for part in parts for x in part[0]]
    kept = [x for part in parts for x in part[1]]
    left_out = [x for part in parts for x in part[2]]
    return InversionResult(
        span_id=np.asarray(kept, dtype=str),
        dropper_lengths_m=np.asarray(lengths, dtype=float).reshape(len(kept), n),
        left_out=pd.DataFrame(left_out, columns=["span_id", "reason"]),
        messenger_tension_n=t_mw, system_height_m=dh)


def dropper_statistics(dropper_lengths_m: np.ndarray, nominal_lengths_m: np.ndarray) -> pd.DataFrame:
    """Paper Table 1: per dropper, mean minus nominal length and standard deviation.

    Parameters
    ----------
    dropper_lengths_m : array_like, shape (n_spans, n_droppers)
        Inverted lengths [m].
    nominal_lengths_m : array_like, shape (n_droppers,)
        Nominal dropper table [m].

    Returns
    -------
    pandas.DataFrame
        ``dropper`` (1-based), ``mean_minus_nominal_cm``, ``std_cm`` (sample standard deviation,
        ddof = 1; NaN with fewer than 2 spans), ``nominal_length_m``, ``mean_length_m``.
    """
    lengths = np.asarray(dropper_lengths_m, dtype=float)
    nominal = np.asarray(nominal_lengths_m, dtype=float)
    if lengths.ndim != 2 or lengths.shape[1] != nominal.size:
        raise ValueError(f"dropper_lengths_m: expected shape (n_spans, {nominal.size}), got {lengths.shape}")
    n_spans = lengths.shape[0]
    mean = lengths.mean(axis=0) if n_spans else np.full(nominal.size, np.nan)
    std = lengths.std(axis=0, ddof=1) if n_spans > 1 else np.full(nominal.size, np.nan)
    return pd.DataFrame({
        "dropper": np.arange(1, nominal.size + 1),
        "mean_minus_nominal_cm": CM * (mean - nominal),
        "std_cm": CM * std,
        "nominal_length_m": nominal,
        "mean_length_m": mean,
    })


def pearson_matrix(dropper_lengths_m: np.ndarray) -> np.ndarray:
    """Pearson correlation matrix of the dropper lengths (paper Fig. 8), shape (n, n).

    NaN where it is undefined (fewer than 2 spans, or a dropper with no spread).
    """
    lengths = np.asarray(dropper_lengths_m, dtype=float)
    n = lengths.shape[1]
    if lengths.shape[0] < 2:
        return np.full((n, n), np.nan)
    centred = lengths - lengths.mean(axis=0)
    cov = centred.T @ centred
    scale = np.sqrt(np.diag(cov))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(scale, scale)
    corr[~np.isfinite(corr)] = np.nan
    return np.clip(corr, -1.0, 1.0)


def min_correlation(matrix: np.ndarray, first: int, last: int) -> float:
    """Smallest correlation among droppers ``first`` … ``last`` (1-based, inclusive)."""
    block = np.asarray(matrix)[first - 1:last, first - 1:last]
    return float(np.nanmin(block)) if np.any(np.isfinite(block)) else float("nan")


def pearson_figure(matrix: np.ndarray, path: str | Path, title: str) -> Path:
    """Write the correlation matrix of the dropper lengths as an annotated heat map (PNG)."""
    from catenary.plumbing.plots import save_figure, subplots

    m = np.asarray(matrix, dtype=float)
    n = m.shape[0]
    fig, ax = subplots(figsize=(6.4, 5.4))
    image = ax.imshow(np.ma.masked_invalid(m), vmin=-1.0, vmax=1.0, cmap="RdBu_r")
    for i in range(n):
        for j in range(n):
            if np.isfinite(m[i, j]):
                ax.text(j, i, f"{m[i, j]:.2f}", ha="center", va="center", fontsize=7,
                        color="white" if abs(m[i, j]) > 0.6 else "black")
    ticks = np.arange(n)
    ax.set_xticks(ticks, [str(i + 1) for i in ticks])
    ax.set_yticks(ticks, [str(i + 1) for i in ticks])
    ax.set_xlabel("dropper")
    ax.set_ylabel("dropper")
    ax.set_title(title, fontsize=10)
    fig.colorbar(image, ax=ax, label="Pearson correlation of dropper lengths")
    return save_figure(fig, path, dpi=120)
