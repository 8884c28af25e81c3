"""Rule repeatability_check (validation only): the repeatability estimated from the runs against
the truth's split of their scatter into sensor noise and correction."""

import pandas as pd

from catenary.measurement.truth_checks import repeatability_round_trip
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.plumbing.parquet import read_table
from catenary.report.tables import write_shown

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("repeatability_check", snakemake.log[0])
truth = read_table(snakemake.input.truth)
truth_runs = read_table(snakemake.input.truth_runs)
masts = pd.read_csv(snakemake.input.masts, dtype={"run_id": str, "section_id": str, "mast_id": str})
rows = []
for span_type, summary, corrected, spans in zip(snakemake.params.span_types, snakemake.input.summaries,
                                                snakemake.input.corrected, snakemake.input.spans):
    estimate = pd.read_csv(summary, dtype={"dropper": str}).set_index("dropper")
    figures = repeatability_round_trip(read_table(corrected), read_table(spans), truth, truth_runs, masts)
    row = {"span_type": span_type, "estimate_m": float(estimate.loc["all", "std_m"]) if "all" in estimate.index
           else float("nan"), **figures}
    row["estimate_over_sensor"] = row["estimate_m"] / row["within_sensor_m"]
    row["measured_estimate_m"] = (float(estimate.loc["all", "measured_std_m"])
                                  if "measured_std_m" in estimate.columns and "all" in estimate.index else float("nan"))
    row["measured_over_sensor"] = row["measured_estimate_m"] / row["within_sensor_m"]
    rows.append(row)
    log.info("%s: repeatability %.3f mm (measured W: %.3f mm); truth's run-to-run scatter %.3f mm = sensor %.3f mm "
             "⊕ correction %.3f mm (%d spans)", span_type, 1e3 * row["estimate_m"], 1e3 * row["measured_estimate_m"],
             1e3 * row["within_total_m"], 1e3 * row["within_sensor_m"], 1e3 * row["within_correction_m"],
             row["n_spans"])
pd.DataFrame(rows).to_csv(snakemake.output.summary, index=False, float_format="%.6g")
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
