"""Rule correction_check (validation only): corrected and uncorrected W against the true static W."""

import pandas as pd

from catenary.measurement.truth_checks import correction_round_trip
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.plumbing.parquet import read_table
from catenary.report.tables import write_shown

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("correction_check", snakemake.log[0])
truth = read_table(snakemake.input.truth)
rows = []
for span_type, corrected, spans in zip(snakemake.params.span_types, snakemake.input.corrected, snakemake.input.spans):
    figures = correction_round_trip(read_table(corrected), read_table(spans), truth)
    rows.append({"span_type": span_type, **figures})
    log.info("%s: %s", span_type, figures)
pd.DataFrame(rows).to_csv(snakemake.output.summary, index=False, float_format="%.6g")
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
