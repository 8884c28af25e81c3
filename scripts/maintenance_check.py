"""Rule maintenance_check: per-span posteriors and the maintenance list against the truth."""

import pandas as pd

from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.plumbing.parquet import read_table
from catenary.report.tables import write_shown
from catenary.stages.maintenance.validation import coverage_check, list_check

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("maintenance_check", snakemake.log[0])
truth = read_table(snakemake.input.truth)
coverage, roc = [], []
for span_type, posterior, inversion in zip(snakemake.params.span_types, snakemake.input.posterior,
                                           snakemake.input.inversion):
    post = read_table(posterior)
    coverage.append(coverage_check(post, truth, span_type, read_table(inversion)))
    roc.append(list_check(post, truth, span_type))
coverage = pd.concat(coverage, ignore_index=True)
roc = pd.concat(roc, ignore_index=True)
coverage.to_csv(snakemake.output.coverage, index=False, float_format="%.6g")
roc.to_csv(snakemake.output.roc, index=False, float_format="%.6g")
for row in coverage.itertuples():
    log.info("%s %-22s 90 %% interval covers the truth in %.0f %% of %d spans (± %.0f %%); RMS error of the mean "
             "%.4g (dropper-only inversion %.4g)", row.span_type, row.input, 100 * row.coverage_90, row.n_spans,
             100 * row.coverage_se, row.rmse_posterior_mean, row.rmse_dropper_only)
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
