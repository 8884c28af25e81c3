"""Rule register: register the mast table onto every run's trace (or find the masts from it)."""

import pandas as pd

from catenary.measurement.recording import run_samples, validate_masts
from catenary.measurement.registration import REGISTRATION_COLUMNS, RegistrationSettings, masts_from_trace, register_run, unregistered_run
from catenary.measurement.registration.outputs import registration_figure, write_registration
from catenary.physics.config import load_catenary
from catenary.physics.pantograph import load_pantographs
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.plumbing.parquet import distinct_values, read_table
from catenary.report.tables import write_shown
from catenary.stages.correction import CorrectionSettings
from catenary.stages.correction.lag import measuring_lag

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
runs = []
for run_id in run_ids:
    samples = samples_of(run_id)
    run = (register_run(samples, masts, catenary, settings, lag, log=log, table_from_trace=found) if settings.enabled
           else unregistered_run(samples, masts, catenary))
    for row in run.sections[run.sections["reason"] != ""].itertuples():
        log.warning("%s", row.reason)
    runs.append(run)
write_registration(runs, snakemake.output.masts, snakemake.output.sections)
registration_figure(pd.concat([r.masts for r in runs], ignore_index=True), snakemake.output.figure)
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
