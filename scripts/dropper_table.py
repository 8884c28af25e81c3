"""Rule dropper_table: nominal dropper table of one span type."""

import pandas as pd

from catenary.physics.config import load_catenary
from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.report.tables import write_shown

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("dropper_table", snakemake.log[0])
catenary = load_catenary(snakemake.input.catenary)
span_type = catenary.span_type(snakemake.wildcards.span_type)
result = nominal_dropper_lengths(span_type, catenary)
table = pd.DataFrame({
    "dropper": range(1, span_type.n_droppers + 1),
    "x_m": span_type.dropper_positions_m,
    "length_m": result.dropper_lengths_m,
    "static_tension_n": result.dropper_force_n,
})
table.to_csv(snakemake.output.table, index=False, float_format="%.6f")
log.info("span type %s: dropper lengths [m] %s", span_type.name, result.dropper_lengths_m.round(4).tolist())
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
