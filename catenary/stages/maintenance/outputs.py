"""Files of the maintenance stage: ``posterior.parquet`` (explicit Arrow schema),
``maintenance.csv`` and the population's bands (``population_band.csv``,
``population_coverage.csv``)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pyarrow as pa

from catenary.plumbing.parquet import write_table
from .population import BAND_COLUMNS, COVERAGE_COLUMNS
from .runner import POSTERIOR_COLUMNS, MaintenanceRun

__all__ = ["POSTERIOR_SCHEMA", "write_bands", "write_maintenance"]

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


def write_bands(run: MaintenanceRun, band: str | Path, coverage: str | Path) -> None:
    """Write the prior and posterior bands along the span and their coverage per dropper (header
    only when the run made no band)."""
    for path in (band, coverage):
        Path(path).parent.mkdir(parents=True, exist_ok=True)
    if run.bands is None:
        pd.DataFrame(columns=list(BAND_COLUMNS)).to_csv(band, index=False)
        pd.DataFrame(columns=list(COVERAGE_COLUMNS)).to_csv(coverage, index=False)
        return
    run.bands.band_table().to_csv(band, index=False, float_format="%.6g")
    run.bands.coverage.to_csv(coverage, index=False, float_format="%.6g")
