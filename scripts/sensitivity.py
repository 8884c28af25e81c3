"""Rule sensitivity: paper Figs 2–4 analogues and their summary for one span type."""

from pathlib import Path

import pandas as pd

from catenary.physics.config import load_catenary
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.report.tables import write_shown
from catenary.stages.sensitivity import run_sensitivity, sensitivity_figures

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("sensitivity", snakemake.log[0])
catenary = load_catenary(snakemake.input.catenary)
result = run_sensitivity(catenary.span_type(snakemake.wildcards.span_type), catenary,
                         n_points=snakemake.params.n_points)
summary = pd.DataFrame(result.summary_rows())
summary.to_csv(snakemake.output.summary, index=False, float_format="%.4f")
sensitivity_figures(result, Path(snakemake.output.summary).parent)
log.info("sensitivity summary:\n%s", summary.to_string(index=False))
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
