"""The measured input of an identification: the corrected W of one span type.

Measured deflections come from the correction rule (``corrected.parquet``): one row per span
(and run), ``w1_m`` … ``wn_m`` the static CW deflection from the chord at the droppers [m]
(negative below), and ``converged``; :func:`read_corrected` keeps the converged rows, averages
the runs of each span and finds the spans that share a mast.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from catenary.measurement.channels.assemble import IDENTIFIED_QUANTITIES, read_observations
from catenary.measurement.channels.observations import Observations
from catenary.measurement.channels.settings import MeasurementSettings
from catenary.physics.config import SpanType
from catenary.plumbing.errors import InputError
from catenary.plumbing.parquet import read_table
from .dependence import adjacent_span_pairs

__all__ = ["CorrectedData", "identification_observations", "read_corrected", "span_places"]

_REQUIRED = ("span_id", "converged")
_ADJACENCY = ("section_id", "start_chainage_m", "end_chainage_m")
_LOG = logging.getLogger(__name__)


@dataclass(frozen=True)
class CorrectedData:
    """Measured deflections of one span type, ready for the identification.

    Attributes
    ----------
    w_m : numpy.ndarray, shape (K, n)
        Static CW deflection from the chord at the droppers of the K spans used [m].
    span_id : numpy.ndarray of str, shape (K,)
    left_out : list of (str, str)
        ``(span_id, reason)`` of every row not used.
    mast_pairs : numpy.ndarray of int, shape (P, 2), or None
        Rows of ``w_m`` that share a mast (:func:`.dependence.adjacent_span_pairs`); None when
        the file does not say (no ``section_id``, ``start_chainage_m``, ``end_chainage_m``).
    n_runs : numpy.ndarray of int, shape (K,)
        Converged runs averaged into each row of ``w_m``.
    observations : Observations or None
        What was measured besides W, row by row (:mod:`catenary.measurement.channels.observations`).
    """

    w_m: np.ndarray
    span_id: np.ndarray
    left_out: list[tuple[str, str]]
    mast_pairs: np.ndarray | None = None
    n_runs: np.ndarray | None = None
    observations: Observations | None = None

    def without(self, leave_out: np.ndarray, reason: str) -> "CorrectedData":
        """The same data with the rows where ``leave_out`` is true left out (their span ids and
        ``reason`` added to ``left_out``), the pairs of spans sharing a mast renumbered."""
        drop = np.asarray(leave_out, dtype=bool)
        keep = np.flatnonzero(~drop)
        pairs = None
        if self.mast_pairs is not None:
            new = np.full(drop.size, -1)
            new[keep] = np.arange(keep.size)
            p = new[np.asarray(self.mast_pairs, dtype=int)].reshape(-1, 2)
            pairs = p[(p >= 0).all(axis=1)]
        return CorrectedData(w_m=self.w_m[keep], span_id=self.span_id[keep],
                             left_out=self.left_out + [(str(s), reason) for s in self.span_id[drop]],
                             mast_pairs=pairs, n_runs=None if self.n_runs is None else self.n_runs[keep],
                             observations=None if self.observations is None else self.observations.rows(keep))


#: Largest distance between the registered positions of one mast as two spans of several runs
#: give it, for the two spans to share it [m] (a registration places a mast to centimetres).
_SHARED_MAST_TOLERANCE_M = 0.5


def read_corrected(path: str | Path, span_type: SpanType, flagged: dict[str, str] | None = None) -> CorrectedData:
    """Read ``corrected.parquet`` and keep the spans whose correction converged, each averaged
    over its converged runs.

    Parameters
    ----------
    path : str or pathlib.Path
        Output of the correction rule: ``span_id``, ``w1_m`` … ``wn_m`` [m], ``converged``, one
        row per span and run (``run_id``); ``section_id``, ``start_chainage_m`` and
        ``end_chainage_m`` [m], when present, say which spans share a mast (other columns, e.g.
        ``gap_norm_m`` and ``iterations``, are only reported).
    span_type : SpanType
        Gives n, the number of ``w*_m`` columns expected.
    flagged : dict of str to str, optional
        Spans whose runs disagree beyond the repeatability (:mod:`catenary.measurement.repeatability`),
        with the reason: left out.

    Raises
    ------
    InputError
        If the file is unreadable, a column is missing, ``converged`` is not boolean, or a
        converged row has a missing or non-finite W; the message names the file, the column
        and the row.
    """
    df = read_table(path)
    w_cols = [f"w{i + 1}_m" for i in range(span_type.n_droppers)]
    missing = [c for c in (*_REQUIRED, *w_cols) if c not in df.columns]
    if missing:
        raise InputError(f"{path}: missing column(s) {', '.join(missing)}; expected span_id, "
                         f"{w_cols[0]} … {w_cols[-1]} [m] and converged (span type {span_type.name})")
    converged = df["converged"]
    if not (pd.api.types.is_bool_dtype(converged) and not converged.isna().any()):
        raise InputError(f"{path}: column converged: expected true/false on every row, got dtype {converged.dtype}")
    converged = converged.to_numpy(dtype=bool)
    w = df[w_cols].to_numpy(dtype=float, na_value=np.nan)
    bad = np.flatnonzero(converged & ~np.all(np.isfinite(w), axis=1))
    if bad.size:
        row = int(bad[0])
        col = w_cols[int(np.flatnonzero(~np.isfinite(w[row]))[0])]
        raise InputError(f"{path}: row {row + 1} (span {df['span_id'].iloc[row]}), column {col}: expected a "
                         f"finite deflection [m] on a converged span, got {w[row, w_cols.index(col)]!r}")
    flagged = flagged or {}
    several = "run_id" in df.columns and df["run_id"].nunique() > 1
    left_out = []
    for i in np.flatnonzero(~converged):
        why = "dynamic correction did not converge"
        if "gap_norm_m" in df.columns and np.isfinite(df["gap_norm_m"].iloc[i]):
            why += f" (gap norm {1e3 * float(df['gap_norm_m'].iloc[i]):.2f} mm"
            if "iterations" in df.columns:
                why += f" after {int(df['iterations'].iloc[i])} iterations"
            why += ")"
        if several:
            why = f"run {df['run_id'].iloc[i]}: {why}"
        left_out.append((str(df["span_id"].iloc[i]), why))
    used = df[converged].assign(**{c: w[converged][:, k] for k, c in enumerate(w_cols)})
    left_out += [(span, why) for span, why in flagged.items() if span in set(used["span_id"])]
    used = used[~used["span_id"].isin(list(flagged))]
    order = list(dict.fromkeys(used["span_id"]))
    groups = used.groupby("span_id", sort=False)
    mean_w = groups[w_cols].mean().loc[order].to_numpy(dtype=float)
    n_runs = groups.size().loc[order].to_numpy(dtype=int)
    pairs = None
    if all(c in df.columns for c in _ADJACENCY):
        place = groups.agg(section_id=("section_id", "first"), start=("start_chainage_m", "mean"),
                           end=("end_chainage_m", "mean")).loc[order]
        pairs = adjacent_span_pairs(place["section_id"], place["start"], place["end"],
                                    tolerance_m=_SHARED_MAST_TOLERANCE_M if several else 1e-3)
    return CorrectedData(w_m=mean_w, span_id=np.asarray(order, dtype=str), left_out=left_out, mast_pairs=pairs,
                         n_runs=n_runs)


def span_places(corrected: pd.DataFrame, span_ids: np.ndarray) -> pd.DataFrame:
    """Where each span lies, in the order of ``span_ids``: ``section_id``, ``start_chainage_m``,
    ``end_chainage_m`` from the correction's table (the first run's; NaN or missing where the table
    does not say)."""
    cols = [c for c in _ADJACENCY if c in corrected.columns]
    places = corrected.groupby("span_id", sort=False)[cols].first() if cols else pd.DataFrame(index=span_ids)
    return places.reindex(span_ids).reindex(columns=list(_ADJACENCY))


def identification_observations(estimator: str, span_ids, spans_path: str | Path, survey_path: str | Path | None,
                                measurements: MeasurementSettings, declared_force_n: float) -> Observations | None:
    """The measurements besides W that the identification's model gives (tensions in spans, ΔH
    at masts: :data:`~catenary.measurement.channels.assemble.IDENTIFIED_QUANTITIES`), on the
    spans ``span_ids``, read from the span type's ``spans.parquet`` and the survey file; None
    where there are none, or where the ``estimator`` (the kernel law) does not read them.

    Parameters
    ----------
    estimator : {"gaussian", "kernel"}
        The identification's law of W; only the Gaussian law reads measurements besides W.
    span_ids : array of str
    spans_path, survey_path : path
        The projection's ``spans.parquet``; the survey file (None: no survey).
    measurements : MeasurementSettings
        Their accuracies (config block ``measurements``).
    declared_force_n : float
        The measuring pantograph's declared static force [N] (``correction.force_n``).
    """
    if estimator != "gaussian":
        return None
    observations, _ = read_observations(span_ids, spans_path, survey_path, measurements, declared_force_n,
                                        IDENTIFIED_QUANTITIES)
    return None if observations.empty else observations
