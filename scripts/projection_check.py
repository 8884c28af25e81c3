"""Rule projection_check (validation only): projected W against the campaign's truth."""

import pandas as pd

from catenary.logs import rule_logger
from catenary.parquet import read_table
from catenary.truth_checks import projection_round_trip

log = rule_logger("projection_check", snakemake.log[0])
truth = read_table(snakemake.input.truth)
truth_runs = read_table(snakemake.input.truth_runs)
rows = []
for span_type, path in zip(snakemake.params.span_types, snakemake.input.spans):
    figures = projection_round_trip(read_table(path), truth, truth_runs)
    rows.append({"span_type": span_type, **figures})
    log.info("%s: %s", span_type, figures)
pd.DataFrame(rows).to_csv(snakemake.output.summary, index=False, float_format="%.6g")
