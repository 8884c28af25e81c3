"""What the correction writes: the corrected table's and profiles' Arrow schemas, a span type's
rows and the per-type summary the front page reads."""

from __future__ import annotations

import numpy as np
import pandas as pd

from .runner import PROFILE_COLUMNS, largest_finite

__all__ = ["corrected_of_type", "corrected_schema", "correction_summary", "profiles_schema"]


def corrected_schema(columns) -> "pa.Schema":
    """Arrow schema of ``corrected.parquet``: identifiers as strings, ``iterations`` and
    ``slack_droppers`` int64, ``converged`` bool, every other column float64 (lengths in [m])."""
    import pyarrow as pa

    kinds = {"span_id": pa.string(), "run_id": pa.string(), "section_id": pa.string(), "span_type": pa.string(),
             "reason": pa.string(), "direction": pa.int64(), "iterations": pa.int64(), "slack_droppers": pa.int64(),
             "converged": pa.bool_()}
    return pa.schema([pa.field(c, kinds.get(c, pa.float64())) for c in columns])


def profiles_schema() -> "pa.Schema":
    """Arrow schema of the corrected profiles (:data:`PROFILE_COLUMNS`): ids as strings, the rest
    float64 [m]."""
    import pyarrow as pa

    return pa.schema([pa.field(c, pa.string() if c in ("span_id", "run_id") else pa.float64(), nullable=False)
                      for c in PROFILE_COLUMNS])


def corrected_of_type(corrected: pd.DataFrame, span_type: str, n_droppers: int) -> pd.DataFrame:
    """The rows of ``span_type`` in chainage order, with its ``n_droppers`` W and dropper-force
    columns only."""
    table = corrected[corrected["span_type"] == span_type].sort_values("start_chainage_m").reset_index(drop=True)
    extra = [c for i in range(n_droppers + 1, 100) for c in (f"w{i}_m", f"dropper_{i}_force_n") if c in table]
    return table.drop(columns=extra)


def correction_summary(corrected: pd.DataFrame, convergence: pd.DataFrame) -> pd.DataFrame:
    """Per span type: spans, converged spans, the share converged within 3 passes [%], the
    median number of passes and the largest final gap [m]."""
    rows = []
    for span_type, table in corrected.groupby("span_type", sort=True):
        ok = table["converged"].to_numpy(dtype=bool)
        rows.append({"span_type": span_type, "n_spans": len(table), "n_converged": int(ok.sum()),
                     "converged_within_3_percent": 100.0 * float(np.mean(ok & (table["iterations"] <= 3))),
                     "median_iterations": float(np.median(table["iterations"])),
                     "max_gap_norm_m": largest_finite(table["gap_norm_m"].to_numpy(dtype=float))})
    return pd.DataFrame(rows, columns=["span_type", "n_spans", "n_converged", "converged_within_3_percent",
                                       "median_iterations", "max_gap_norm_m"])

