"""Rule front_page: the HTML report's opening panel (catenary.report.front_page)."""

from catenary.measurement.registration import RegistrationSettings
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.report.front_page import write_front_page

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("front_page", snakemake.log[0])
inputs = dict(snakemake.input.items())
types = [key.removeprefix("s_opt_") for key in inputs if key.startswith("s_opt_")]
path = write_front_page(snakemake.output.front_page, snakemake.input.intro, snakemake.input.spans_report,
                        snakemake.input.correction_summary, {t: inputs[f"s_opt_{t}"] for t in types},
                        {t: inputs.get(f"findings_{t}") for t in types},
                        {t: inputs.get(f"model_error_{t}") for t in types}, snakemake.input.sections,
                        RegistrationSettings.from_mapping(snakemake.params.registration).mast_table_std_m,
                        {t: (inputs[f"spans_{t}"], inputs[f"sections_{t}"]) if f"spans_{t}" in inputs else None
                         for t in types},
                        {t: inputs.get(f"recommendations_{t}") for t in types})
log.info("front page for %s written to %s", ", ".join(types) or "no span type", path)
