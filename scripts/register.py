"""Rule register: register the mast table onto every run's trace (or find the masts from it).

The runs go to the job's ``threads`` processes (one run each at a time); each process has one
BLAS thread (set here, before NumPy loads; Snakemake sets the job's ``threads``).
"""

from catenary.plumbing.blas import one_blas_thread

one_blas_thread(override=True)

import pandas as pd  # noqa: E402

from catenary.measurement.recording import run_samples, validate_masts  # noqa: E402
from catenary.measurement.registration import (REGISTRATION_COLUMNS, RegistrationSettings,  # noqa: E402
                                               masts_from_trace, register_runs)
from catenary.measurement.registration.outputs import registration_figure, write_registration  # noqa: E402
from catenary.physics.config import load_catenary  # noqa: E402
from catenary.physics.pantograph import load_pantographs  # noqa: E402
from catenary.plumbing.heap import steady_heap  # noqa: E402
from catenary.plumbing.logs import rule_logger  # noqa: E402
from catenary.plumbing.parquet import distinct_values, read_table  # noqa: E402
from catenary.report.tables import write_shown  # noqa: E402
from catenary.stages.correction import CorrectionSettings  # noqa: E402
from catenary.stages.correction.lag import measuring_lag  # noqa: E402

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("register", snakemake.log[0])
catenary = load_catenary(snakemake.input.catenary)
settings = RegistrationSettings.from_mapping(snakemake.params.registration)
correction = CorrectionSettings.from_mapping(snakemake.params.correction)
lag = measuring_lag(catenary, load_pantographs(snakemake.input.pantographs), correction)
masts = read_table(snakemake.input.masts)
run_ids = distinct_values(snakemake.input.recording, "run_id")


def samples_of(run_id):
    """One run's samples, the columns the registration reads, read alone: the job holds one run
    of the recording at a time."""
    return run_samples(read_table(snakemake.input.recording, columns=REGISTRATION_COLUMNS,
                                  filters=[("run_id", "=", run_id)]), run_id)


found = len(masts) == 0
if found:
    masts = validate_masts(masts_from_trace(samples_of(run_ids[0]), catenary, settings, lag),
                           source=f"masts found along run {run_ids[0]}")
    log.info("no mast table: %d masts in %d sections found along run %s", len(masts),
             masts["section_id"].nunique(), run_ids[0])
masts.to_csv(snakemake.output.table, index=False, float_format="%.4f")
runs = register_runs(samples_of, run_ids, masts, catenary, settings, lag, log=log, table_from_trace=found,
                     workers=snakemake.threads)
for run in runs:
    for row in run.sections[run.sections["reason"] != ""].itertuples():
        log.warning("%s", row.reason)
write_registration(runs, snakemake.output.masts, snakemake.output.sections)
registration_figure(pd.concat([r.masts for r in runs], ignore_index=True), snakemake.output.figure)
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
