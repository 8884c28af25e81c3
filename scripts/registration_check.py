"""Rule registration_check (validation only): registered masts against the campaign's true masts."""

import pandas as pd

from catenary.measurement.truth_checks import registration_round_trip
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.plumbing.parquet import read_table
from catenary.report.tables import write_shown

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("registration_check", snakemake.log[0])
masts = pd.read_csv(snakemake.input.masts, dtype={"run_id": str, "section_id": str, "mast_id": str})
table = registration_round_trip(masts, pd.read_csv(snakemake.input.masts_truth, dtype={"mast_id": str}),
                                read_table(snakemake.input.truth_runs))
table.to_csv(snakemake.output.summary, index=False, float_format="%.6g")
for row in table.itertuples():
    log.info("run %s: %d of %d true masts found, %d of %d missing inserted, %d of %d extra dropped; position "
             "error RMS %.3f m (trace %.3f m, table %.3f m), max %.3f m", row.run_id, row.n_found, row.n_true_masts,
             row.n_missing_found, row.n_missing_planted, row.n_extra_dropped, row.n_extra_planted, row.rms_error_m,
             row.rms_error_trace_m, row.rms_error_table_m, row.max_error_m)
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
