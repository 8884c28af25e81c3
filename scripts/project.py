"""Rule project: cut every run into spans along its registered masts and project W at the droppers.

The sections are cut in ``threads`` worker processes, each with one BLAS thread (set here, before
NumPy loads; Snakemake sets the job's ``threads``).
"""

from catenary.plumbing.blas import one_blas_thread

one_blas_thread(override=True)

from pathlib import Path  # noqa: E402

import pandas as pd  # noqa: E402

from catenary.measurement.projection import ProjectionSettings, project, write_projection  # noqa: E402
from catenary.measurement.recording import read_masts, runs_table  # noqa: E402
from catenary.measurement.registration import RegistrationSettings  # noqa: E402
from catenary.measurement.registration.outputs import read_registration  # noqa: E402
from catenary.physics.config import load_catenary  # noqa: E402
from catenary.physics.pantograph import load_pantographs  # noqa: E402
from catenary.plumbing.errors import InputError  # noqa: E402
from catenary.plumbing.heap import steady_heap  # noqa: E402
from catenary.plumbing.logs import rule_logger  # noqa: E402
from catenary.plumbing.parquet import read_table, settings_hash  # noqa: E402
from catenary.report.tables import write_shown  # noqa: E402
from catenary.stages.correction import CorrectionSettings  # noqa: E402
from catenary.stages.correction.lag import measuring_lag  # noqa: E402

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("project", snakemake.log[0])
catenary = load_catenary(snakemake.input.catenary)
correction = CorrectionSettings.from_mapping(snakemake.params.correction)
lag = measuring_lag(catenary, load_pantographs(snakemake.input.pantographs), correction)
recording = read_table(snakemake.input.recording)
masts = read_masts(snakemake.input.table)
registration = None
if RegistrationSettings.from_mapping(snakemake.params.registration).enabled:
    directions = dict(zip(*runs_table(recording)[["run_id", "direction"]].T.to_numpy()))
    registration = read_registration(snakemake.input.registered_masts, snakemake.input.sections, directions)
result = project(recording, masts, catenary, ProjectionSettings.from_mapping(snakemake.params.projection),
                 registration, lag, workers=snakemake.threads)
log.info("spans: %d used, %d rejected (over %d run(s))", result.n_used, result.n_rejected,
         result.report["run_id"].nunique())
for row in result.report[result.report["status"] != "used"].itertuples():
    log.info("rejected %s (run %s): %s", row.span_id, row.run_id, row.reason)
if result.n_used == 0:
    reasons = "; ".join(f"{n} × {r}" for r, n in result.report["reason"].value_counts().head(5).items())
    files = snakemake.config.get("recording") or snakemake.input.recording
    raise InputError(
        f"{', '.join(files) if isinstance(files, list) else files} and {snakemake.config.get('masts') or 'the masts'}: "
        f"the projection kept 0 of {len(result.report)} span(s) ({reasons or 'no span between two masts'}); "
        "expected a recording that covers the masts' chainages (same line, metres)")
write_projection(result, Path(snakemake.output.report).parent, config_hash=settings_hash(snakemake.config),
                 span_types=snakemake.params.span_types, catenary=catenary)
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
