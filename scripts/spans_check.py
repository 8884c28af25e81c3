"""Rule spans_check: the per-span check and the maintenance list against the campaign's truth."""

import pandas as pd

from catenary.measurement.truth import load_truth
from catenary.physics.config import load_catenary
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.plumbing.parquet import read_table
from catenary.report.tables import write_shown
from catenary.stages.diagnosis.validation import span_check_validation

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("spans_check", snakemake.log[0])
catenary = load_catenary(snakemake.input.catenary)
spec = load_truth(snakemake.input.campaign, catenary)
truth = read_table(snakemake.input.truth)
rows = []
for span_type, spans, sections, listed in zip(snakemake.params.span_types, snakemake.input.spans,
                                               snakemake.input.sections, snakemake.input.listed):
    row = span_check_validation(pd.read_csv(spans, dtype={"span_id": str, "section_id": str, "group": str,
                                                          "explained_by": str}, keep_default_na=False,
                                            na_values={c: [""] for c in ("peak_chainage_m", "peak_size_mm")}),
                                pd.read_csv(sections, dtype={"section_id": str}),
                                pd.read_csv(listed, dtype={"span_id": str}), spec, truth, span_type,
                                snakemake.params.campaign)
    log.info("%s", row)
    rows.append(row)
pd.DataFrame(rows).to_csv(snakemake.output.summary, index=False, float_format="%.6g")
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
