"""Rule correction: gather the corrected sections per span type, with the convergence log."""

from pathlib import Path

import pandas as pd

from catenary.config import load_catenary
from catenary.correction import corrected_of_type, corrected_schema, correction_summary
from catenary.logs import rule_logger
from catenary.parquet import read_table, settings_hash, write_table

log = rule_logger("correction", snakemake.log[0])
catenary = load_catenary(snakemake.input.catenary)
corrected = pd.concat([read_table(p) for p in snakemake.input.sections], ignore_index=True)
convergence = pd.concat([pd.read_csv(p, dtype={"section_id": str, "span_id": str})
                         for p in snakemake.input.convergence], ignore_index=True)
for span_type, path in zip(snakemake.params.span_types, snakemake.output.corrected):
    table = corrected_of_type(corrected, span_type, catenary.span_type(span_type).n_droppers)
    write_table(table, Path(path), corrected_schema(table.columns), config_hash=settings_hash(snakemake.config),
                kind="corrected")
convergence.to_csv(snakemake.output.convergence, index=False)
summary = correction_summary(corrected, convergence)
summary.to_csv(snakemake.output.summary, index=False)
for row in summary.itertuples():
    log.info("%s: %d spans, %d converged, %.1f %% within 3 passes, median passes %.0f",
             row.span_type, row.n_spans, row.n_converged, row.converged_within_3_percent, row.median_iterations)
