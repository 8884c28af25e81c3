"""Files of the identification rule for one span type (``docs/outputs.md``).

``s_opt.csv`` (:func:`.tables.s_opt_table`), ``trace.parquet`` (:func:`.tables.trace_table`,
explicit Arrow schema :func:`.tables.trace_schema`), ``normality.json``
(:func:`.normality.normality_report`), ``estimators.png``, ``band.png`` (:mod:`.figures`) and
``identification.md`` (:func:`.report.markdown_report`) and, where the correction's model-error
budget was measured, ``model_error.csv`` (:func:`catenary.stages.identification.propagation.budget_table`;
headers only without it).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import pandas as pd

from .propagation import MODEL_ERROR_COLUMNS
from catenary.plumbing.parquet import write_table
from catenary.plumbing.workers import call_each
from .figures import band_figure, estimators_figure
from .report import markdown_report
from .runner import IdentificationRun
from .tables import s_opt_table, trace_schema, trace_table

__all__ = ["IdentificationPaths", "write_identification"]


@dataclass(frozen=True)
class IdentificationPaths:
    """Where :func:`write_identification` writes each output."""

    s_opt: Path
    trace: Path
    estimators: Path
    normality: Path
    band: Path
    report: Path
    model_error: Path | None = None

    @classmethod
    def in_folder(cls, folder: str | Path) -> "IdentificationPaths":
        """The standard names inside ``folder``."""
        f = Path(folder)
        return cls(s_opt=f / "s_opt.csv", trace=f / "trace.parquet", estimators=f / "estimators.png",
                   normality=f / "normality.json", band=f / "band.png", report=f / "identification.md",
                   model_error=f / "model_error.csv")


def write_identification(run: IdentificationRun, paths: IdentificationPaths, *, config_hash: str,
                         source: str = "corrected.parquet", workers: int = 1) -> None:
    """Write every output of one span type's identification.

    Parameters
    ----------
    run : IdentificationRun
    paths : IdentificationPaths
    config_hash : str
        Hash of the workflow config, stored in the Parquet metadata.
    source : str
        Name of the data file, quoted in the report.
    workers : int
        Processes drawing the two figures and writing the tables side by side
        (:func:`catenary.plumbing.workers.call_each`; each file is its own: the same files for any
        number).
    """
    for p in (paths.s_opt, paths.trace, paths.estimators, paths.normality, paths.band, paths.report):
        Path(p).parent.mkdir(parents=True, exist_ok=True)
    st = run.span_type.name
    mark = "" if run.result.status == "ok" else f" [{run.result.status.upper().replace('_', ' ')}]"
    tasks = [partial(estimators_figure, run.marginals, run.data_w_m, paths.estimators,
                     f"{st}: marginals of W at s_opt, Gaussian (dashed) vs kernel (solid){mark}"),
             partial(band_figure, run.band, run.data_w_m, run.span_type.dropper_positions_m, paths.band,
                     f"{st}: {100 * run.band.level:.0f} % band of the CW deflection under s_opt{mark}"),
             partial(_write_tables, run, paths, config_hash, source)]
    call_each(tasks, workers)


def _write_tables(run: IdentificationRun, paths: IdentificationPaths, config_hash: str, source: str) -> None:
    """s_opt.csv, model_error.csv, trace.parquet, normality.json and identification.md."""
    st = run.span_type.name
    s_opt_table(run.result, run.profiles, run.model_error, run.settings.profile_level).to_csv(paths.s_opt, index=False, float_format="%.17g")
    if paths.model_error is not None:
        budget = run.model_error if run.model_error is not None else pd.DataFrame(columns=MODEL_ERROR_COLUMNS)
        budget.to_csv(paths.model_error, index=False, float_format="%.17g")
    names = [e.parameter for e in run.result.estimates]
    status = run.result.status
    write_table(trace_table(run.result), paths.trace, trace_schema(names), config_hash=config_hash,
                kind="identification_trace", extra_metadata={"status": status,
                                                             "converged": str(run.result.converged).lower()})
    with open(paths.normality, "w") as f:
        json.dump({"span_type": st, "identification_status": status, "test": "Henze–Zirkler (lognormal p-value)",
                   **run.normality}, f, indent=2, ensure_ascii=False)
        f.write("\n")
    Path(paths.report).write_text(markdown_report(run, source=source,
                                                  figures=(Path(paths.estimators).name, Path(paths.band).name)))
