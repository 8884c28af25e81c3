"""Rule invert: dropper-only inversion of the corrected spans of one type (paper §4.1,
Table 1, Fig. 8).

The spans are inverted in ``threads`` worker processes, each with one BLAS thread (set here,
before NumPy loads; Snakemake sets the job's ``threads``).
"""

from catenary.plumbing.blas import one_blas_thread

one_blas_thread(override=True)

import pandas as pd  # noqa: E402

from catenary.physics.config import load_catenary  # noqa: E402
from catenary.physics.dropper_table import nominal_dropper_lengths  # noqa: E402
from catenary.plumbing.heap import steady_heap  # noqa: E402
from catenary.plumbing.logs import rule_logger  # noqa: E402
from catenary.plumbing.parquet import read_table, settings_hash, write_table  # noqa: E402
from catenary.report.tables import write_shown  # noqa: E402
from catenary.stages.inversion import (converged_spans, dropper_statistics, droppers_schema,  # noqa: E402
                                       invert_spans, min_correlation, pearson_figure, pearson_matrix, w_columns)

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("invert", snakemake.log[0])
p = snakemake.params.inversion
catenary = load_catenary(snakemake.input.catenary)
span_type = catenary.span_type(snakemake.wildcards.span_type)
n = span_type.n_droppers
corrected, n_unconverged = converged_spans(read_table(snakemake.input.corrected), n, snakemake.input.corrected)
log.info("%s: %d converged spans to invert, %d left out (correction not converged)",
         span_type.name, len(corrected), n_unconverged)
result = invert_spans(span_type, catenary, corrected["span_id"], corrected[w_columns(n)].to_numpy(dtype=float),
                      messenger_tension_n=None if p["messenger_tension_n"] == "design" else p["messenger_tension_n"],
                      system_height_m=None if p["system_height_m"] == "design" else p["system_height_m"],
                      workers=snakemake.threads)
log.info("held fixed: T_MW = %.1f N, ΔH = %.4f m; %d spans inverted, %d left out (infeasible W)",
         result.messenger_tension_n, result.system_height_m, len(result.span_id), len(result.left_out))
for row in result.left_out.itertuples():
    log.warning("left out %s: %s", row.span_id, row.reason)
write_table(result.table(), snakemake.output.droppers, droppers_schema(n),
            config_hash=settings_hash(snakemake.config), kind=f"inversion_droppers:{span_type.name}")
table = dropper_statistics(result.dropper_lengths_m, nominal_dropper_lengths(span_type, catenary).dropper_lengths_m)
table.to_csv(snakemake.output.table1, index=False, float_format="%.6f")
corr = pearson_matrix(result.dropper_lengths_m)
pearson_figure(corr, snakemake.output.pearson,
               f"{span_type.name}: dropper lengths from dropper-only inversion ({len(result.span_id)} spans)")
log.info("Table 1 analogue:\n%s", table.to_string(index=False))
log.info("Pearson correlation, minimum over droppers 3…%d: %.3f", n - 2, min_correlation(corr, 3, n - 2))
log.info("Pearson matrix:\n%s", pd.DataFrame(corr, index=range(1, n + 1), columns=range(1, n + 1)).round(3))
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
