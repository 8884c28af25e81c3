"""Rule correction: gather the corrected sections per span type, with the convergence log."""

from pathlib import Path

import pandas as pd

from catenary.physics.config import load_catenary
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.plumbing.parquet import read_table, settings_hash, write_table
from catenary.report.tables import write_shown
from catenary.stages.correction import corrected_of_type, corrected_schema, correction_summary, profiles_schema
from catenary.stages.model_error.budget import w_budget

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("correction", snakemake.log[0])
catenary = load_catenary(snakemake.input.catenary)
corrected = pd.concat([read_table(p) for p in snakemake.input.sections], ignore_index=True)
convergence = pd.concat([pd.read_csv(p, dtype={"section_id": str, "span_id": str})
                         for p in snakemake.input.convergence], ignore_index=True)
profiles = pd.concat([read_table(p) for p in snakemake.input.profiles], ignore_index=True)
for span_type, path, profile_path in zip(snakemake.params.span_types, snakemake.output.corrected,
                                         snakemake.output.profiles):
    table = corrected_of_type(corrected, span_type, catenary.span_type(span_type).n_droppers)
    write_table(table, Path(path), corrected_schema(table.columns), config_hash=settings_hash(snakemake.config),
                kind="corrected")
    write_table(profiles[profiles["span_id"].isin(table["span_id"])], Path(profile_path), profiles_schema(),
                config_hash=settings_hash(snakemake.config), kind="corrected_profiles")
convergence.to_csv(snakemake.output.convergence, index=False)
summary = correction_summary(corrected, convergence)
summary.to_csv(snakemake.output.summary, index=False)
for row in summary.itertuples():
    log.info("%s: %d spans, %d converged, %.1f %% within 3 passes, median passes %.0f",
             row.span_type, row.n_spans, row.n_converged, row.converged_within_3_percent, row.median_iterations)
shifts = pd.concat([pd.read_parquet(p) for p in snakemake.input.model_error], ignore_index=True)
shifts.to_parquet(snakemake.output.model_error, index=False)
spans = pd.concat([read_table(p).assign(span_type=t) for t, p in zip(snakemake.params.span_types, snakemake.input.spans)],
                  ignore_index=True)
if "run_id" not in spans:
    spans["run_id"] = "run"
budget = w_budget(shifts, corrected, spans) if len(shifts) else pd.DataFrame()
budget.to_csv(snakemake.output.budget, index=False, float_format="%.6g")
for row in budget.itertuples():
    log.info("%s dropper %d: correction %.3f mm, model-error systematic %.3f mm per σ (ratio %.1f; dominant %s)",
             row.span_type, row.dropper, 1e3 * row.correction_mean_m, 1e3 * row.systematic_m,
             row.correction_over_systematic, row.dominant_source)
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
