"""Rule correct_section: iterative dynamic correction of a batch of sections' spans (paper Fig. 5;
catenary.stages.correction.batches), each run of consecutive spans of a section on its own."""

from pathlib import Path

import pandas as pd

from catenary.physics.config import load_catenary
from catenary.physics.pantograph import load_pantographs
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.plumbing.parquet import read_table, settings_hash, write_table
from catenary.stages.correction import CorrectionSettings, correct_spans, corrected_schema, profiles_schema
from catenary.stages.correction.step import read_responses
from catenary.stages.model_error.correction import SectionBudget
from catenary.stages.model_error.sources import ModelErrorSettings

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("correct_section", snakemake.log[0])
sections = list(snakemake.params.sections)
catenary = load_catenary(snakemake.input.catenary)
settings = CorrectionSettings.from_mapping(snakemake.params.correction)
pantograph = load_pantographs(snakemake.input.pantographs)[settings.pantograph]
every = pd.concat([read_table(path).assign(span_type=span_type)
                   for span_type, path in zip(snakemake.params.span_types, snakemake.input.spans)], ignore_index=True)
report = pd.read_csv(snakemake.input.report, dtype={"span_id": str, "run_id": str, "section_id": str,
                                                    "span_type": str}, keep_default_na=False,
                     na_values={c: [""] for c in ("start_chainage_m", "end_chainage_m", "length_m")})
budget = ModelErrorSettings.from_mapping(snakemake.params.model_error)
measured_sections = budget.measured_sections(every)
n_max = max(catenary.span_type(t).n_droppers for t in snakemake.params.span_types)
measure_budget = SectionBudget(catenary, budget.sources, settings.mode, settings.time_step_s, n_max, log)
spans = every[every["section_id"].isin(sections)].reset_index(drop=True)
ids = spans["span_id"].astype(str).tolist()
profiles = pd.concat([read_table(path, filters=[("span_id", "in", ids)]) for path in snakemake.input.profiles],
                     ignore_index=True)  # this batch's rows only: the job's cost does not grow with the line
log.info("%s: %d sections, %d spans, %s pass, tolerance %.2f mm; model-error budget measured on %s",
         snakemake.wildcards.batch, len(sections), len(spans), settings.mode, settings.tolerance_m * 1e3,
         ", ".join(s for s in sections if s in measured_sections) or "other sections" if budget.enabled
         else "no section (model_error disabled)")


def measure_if_listed(rows, *args):
    """The model-error budget of a run of spans, on the sections that measure it only."""
    if rows["section_id"].iloc[0] in measured_sections:
        measure_budget(rows, *args)


responses = read_responses(pd.read_parquet(snakemake.input.response), snakemake.input.response)
corrected, convergence, corrected_profiles = correct_spans(spans, catenary, pantograph, settings, log=log,
                                                           report=report, after_run=measure_if_listed,
                                                           profiles=profiles, responses=responses)
measure_budget.table().to_parquet(snakemake.output.model_error, index=False)
write_table(corrected, Path(snakemake.output.corrected), corrected_schema(corrected.columns),
            config_hash=settings_hash(snakemake.config), kind="corrected_section")
write_table(corrected_profiles, Path(snakemake.output.profiles), profiles_schema(),
            config_hash=settings_hash(snakemake.config), kind="corrected_profiles_section")
convergence.to_csv(snakemake.output.convergence, index=False)
log.info("%s: %d of %d spans converged", snakemake.wildcards.batch, int(corrected["converged"].sum()), len(corrected))
