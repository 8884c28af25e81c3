"""Files of the maintenance stage: ``posterior.parquet`` (explicit Arrow schema) and
``maintenance.csv``."""

from __future__ import annotations

from pathlib import Path

import pyarrow as pa

from ..parquet import write_table
from .runner import POSTERIOR_COLUMNS, MaintenanceRun

__all__ = ["POSTERIOR_SCHEMA", "write_maintenance"]

_TEXT = {"span_id", "input", "section_id", "status"}
#: One row per span and input; values in the input's own unit (``input`` names it: ``_m``, ``_n``).
POSTERIOR_SCHEMA = pa.schema([pa.field(c, pa.string() if c in _TEXT else pa.float64(), nullable=c not in
                                       {"span_id", "input", "status"}) for c in POSTERIOR_COLUMNS])


def write_maintenance(run: MaintenanceRun, posterior: str | Path, listed: str | Path, *, config_hash: str,
                      noise: str) -> None:
    """Write the posterior table (with the W error it assumed in the file's metadata) and the list."""
    write_table(run.posterior, posterior, POSTERIOR_SCHEMA, config_hash=config_hash, kind="posterior",
                extra_metadata={"measurement_error": noise})
    Path(listed).parent.mkdir(parents=True, exist_ok=True)
    run.listed.to_csv(listed, index=False, float_format="%.6g")
