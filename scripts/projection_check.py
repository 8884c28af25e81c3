"""Rule projection_check (validation only): projected W against the campaign's truth."""

import pandas as pd

from catenary.measurement.truth_checks import projection_round_trip
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.plumbing.parquet import read_table
from catenary.report.tables import write_shown

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("projection_check", snakemake.log[0])
truth = read_table(snakemake.input.truth)
truth_runs = read_table(snakemake.input.truth_runs)
# spans matched to the truth in each run's recorded chainage: the frame-free comparison, valid
# also when the masts were found from the trace without a table
masts = pd.read_csv(snakemake.input.masts, dtype={"run_id": str, "section_id": str, "mast_id": str})
truth_runs = truth_runs.assign(run_id=truth_runs["run_id"].astype(str))
rows = []
for span_type, path in zip(snakemake.params.span_types, snakemake.input.spans):
    figures = projection_round_trip(read_table(path), truth, truth_runs, masts)
    rows.append({"span_type": span_type, **figures})
    log.info("%s: %s", span_type, figures)
pd.DataFrame(rows).to_csv(snakemake.output.summary, index=False, float_format="%.6g")
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
