"""Rule contact_force_batch: dynamic runs over one batch of random sections of one span type."""

from pathlib import Path

from catenary.physics.config import load_catenary
from catenary.physics.pantograph import load_pantographs
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.plumbing.parquet import settings_hash, write_table
from catenary.stages.contact_force.draws import draw_section, replicate_seeds
from catenary.stages.contact_force.laws import design_laws, read_laws
from catenary.stages.contact_force.outputs import replicates_schema
from catenary.stages.contact_force.runs import run_case_batch, run_sobol_batch
from catenary.stages.contact_force.sensitivity import sobol_design
from catenary.stages.contact_force.settings import ContactForceSettings, batch_replicates

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("contact_force_batch", snakemake.log[0])
catenary = load_catenary(snakemake.input.catenary)
span_type = catenary.span_type(snakemake.wildcards.span_type)
settings = ContactForceSettings.from_mapping(snakemake.params.contact_force)
case, batch = snakemake.wildcards.case, int(snakemake.wildcards.batch)
pantograph = load_pantographs(snakemake.input.pantographs)[settings.pantograph]
laws = read_laws(snakemake.input.s_opt, snakemake.input.findings, span_type, settings.cw_height)
replicates, speeds = batch_replicates(settings, case, batch, span_type.n_droppers)
log.info("%s %s batch %d: indices %s at %s km/h; laws %s", span_type.name, case, batch, replicates, speeds,
         laws.summary())
if case == "sobol":
    table = run_sobol_batch(laws, span_type, catenary, pantograph, settings, replicates, sobol_design(laws, settings),
                            speeds[0], log=log)
else:
    design = design_laws(span_type, catenary)
    nominal, _ = draw_section(design, span_type, catenary, settings.n_spans, replicate_seeds(0, 0, design))
    table = run_case_batch(laws, nominal, span_type, catenary, pantograph, settings, replicates, case=case,
                           speeds_kmh=speeds, log=log)
write_table(table, Path(snakemake.output.batch), replicates_schema(table.columns),
            config_hash=settings_hash(snakemake.config), kind="contact_force_batch")
