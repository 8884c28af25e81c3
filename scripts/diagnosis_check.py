"""Rule diagnosis_check: the diagnosis's findings against the campaign's hidden effects."""

from pathlib import Path

import pandas as pd

from catenary.measurement.truth import load_truth
from catenary.physics.config import load_catenary
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.plumbing.parquet import read_table
from catenary.report.tables import write_shown
from catenary.stages.diagnosis.validation import diagnosis_check

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("diagnosis_check", snakemake.log[0])
catenary = load_catenary(snakemake.input.catenary)
spec = load_truth(snakemake.input.campaign, catenary)
findings = {t: pd.read_csv(p) for t, p in zip(snakemake.params.span_types, snakemake.input.findings)}
# Campaign name: config/validation/d_puzzle_campaign.yaml → d_puzzle; config/campaign.yaml → default.
name = Path(snakemake.input.campaign).stem.removesuffix("_campaign")
table = diagnosis_check(findings, spec, read_table(snakemake.input.truth), "default" if name == "campaign" else name)
table.to_csv(snakemake.output.summary, index=False, float_format="%.10g")
for _, r in table.iterrows():
    log.info("%s %s step %d: %s %s %s = %.6g ± %.3g (planted %.6g, realized %.6g, z %+.2f)", r["campaign"],
             r["span_type"], r["step"], r["verdict"], r["effect"], r["parameter"], r["identified"],
             r["standard_error"], r["planted_magnitude"], r["realized_magnitude"], r["z"])
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
