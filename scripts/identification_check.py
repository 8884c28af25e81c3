"""Rule identification_check (validation only): identified laws against the campaign's realized truth."""

import pandas as pd

from catenary.measurement.truth_checks import identification_round_trip
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.plumbing.parquet import read_table
from catenary.report.tables import write_shown

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("identification_check", snakemake.log[0])
truth = read_table(snakemake.input.truth)
tables = []
for span_type, s_opt, corrected in zip(snakemake.params.span_types, snakemake.input.s_opt, snakemake.input.corrected):
    table = identification_round_trip(pd.read_csv(s_opt), read_table(corrected), truth)
    table.insert(0, "span_type", span_type)
    tables.append(table)
    for row in table.itertuples(index=False):
        log.info("%s %s %s: %.6g ± %.3g against realized %.6g (z %+.2f)", span_type, row.parameter, row.statistic,
                 row.estimate, row.standard_error, row.realized, row.z)
pd.concat(tables, ignore_index=True).to_csv(snakemake.output.summary, index=False, float_format="%.8g")
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
