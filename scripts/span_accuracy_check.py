"""Rule span_accuracy_check (validation only): the spans, their stated W uncertainty and the table's
estimated accuracy against the campaign's truth."""

import numpy as np
import pandas as pd

from catenary.measurement.truth import load_truth
from catenary.measurement.truth_checks import span_accuracy_round_trip
from catenary.physics.config import load_catenary
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.plumbing.parquet import read_table

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("span_accuracy_check", snakemake.log[0])
spec = load_truth(snakemake.input.campaign, load_catenary(snakemake.input.catenary))
planted = (spec.mast_table.position_error_m if spec.mast_table else 0.0) / np.sqrt(3.0)    # uniform ±a: a/√3
spans = pd.concat([read_table(path) for path in snakemake.input.spans], ignore_index=True)
read = {"dtype": {"run_id": str, "section_id": str, "mast_id": str, "span_id": str}}
table = span_accuracy_round_trip(pd.read_csv(snakemake.input.report, **read), spans,
                                 pd.read_csv(snakemake.input.sections, **read), pd.read_csv(snakemake.input.masts, **read),
                                 pd.read_csv(snakemake.input.masts_truth, **read), read_table(snakemake.input.truth),
                                 read_table(snakemake.input.truth_runs).astype({"run_id": str}), float(planted))
table.to_csv(snakemake.output.summary, index=False, float_format="%.6g")
for row in table.itertuples():
    log.info("run %s: %d of %d true spans not next to a missing mast used under their own id, %d (%.1f %%) with W "
             "within 1 mm RMS of the truth; %d true spans rejected as a length mismatch; %d of %d used spans with "
             "a W error beyond 3 times its stated uncertainty (at most %.2f expected by chance); %d of %d sections "
             "refused; the table's accuracy estimated %.3f–%.3f m (pooled %.3f m) for %.3f m planted (%.3f m realized)",
             row.run_id, row.n_used_own_id, row.n_eligible, row.n_within, 100 * row.fraction_within,
             row.n_true_length_mismatch, row.n_beyond_3_sigma, row.n_used, row.expected_beyond_3_sigma_max,
             row.n_refused, row.n_sections, row.table_std_min_m, row.table_std_max_m, row.table_std_pooled_m,
             row.planted_table_std_m, row.realized_table_std_m)
