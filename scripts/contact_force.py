"""Rule contact_force: gather the batches of one span type; nominal figures, statistics,
violation probabilities, tolerance table, sensitivity, figures and report."""

import pandas as pd

from catenary.physics.config import load_catenary
from catenary.physics.pantograph import load_pantographs
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.plumbing.parquet import read_table, settings_hash
from catenary.report.tables import write_shown
from catenary.stages.contact_force.draws import draw_section, replicate_seeds
from catenary.stages.contact_force.draws import groups
from catenary.stages.contact_force.laws import design_laws, read_laws
from catenary.stages.contact_force.outputs import ContactForcePaths, write_contact_force
from catenary.stages.contact_force.runs import run_section
from catenary.stages.contact_force.sensitivity import sobol_design, sobol_indices
from catenary.stages.contact_force.settings import ContactForceSettings
from catenary.stages.contact_force.summary import criteria_summary, tolerance_table

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("contact_force", snakemake.log[0])
catenary = load_catenary(snakemake.input.catenary)
span_type = catenary.span_type(snakemake.wildcards.span_type)
settings = ContactForceSettings.from_mapping(snakemake.params.contact_force)
pantograph = load_pantographs(snakemake.input.pantographs)[settings.pantograph]
laws = read_laws(snakemake.input.s_opt, snakemake.input.findings, span_type, settings.cw_height)
replicates = pd.concat([read_table(p) for p in snakemake.input.batches], ignore_index=True)
design = design_laws(span_type, catenary)
nominal_section, _ = draw_section(design, span_type, catenary, settings.n_spans, replicate_seeds(0, 0, design))
_, rows = run_section(nominal_section, catenary, pantograph, settings, settings.speeds_kmh)
nominal = pd.DataFrame(rows)
identified = replicates[replicates["case"] == "identified"]
summary = criteria_summary(identified)
tolerance = tolerance_table(replicates, settings.tolerance.sigma_per_tolerance)
sobol = []
if settings.sensitivity_enabled:
    design = sobol_design(laws, settings)
    runs = replicates[replicates["case"] == "sobol"].sort_values("replicate")
    for criterion in ("std_force_n", "statistical_min_n"):
        r = sobol_indices(design, runs[criterion].to_numpy(float), groups(laws), settings.sensitivity_samples,
                          f"{criterion} at {settings.speeds_kmh[0]:g} km/h")
        log.info("Sobol %s: first %s, total %s, first + second %.2f", r.criterion, r.first.round(3),
                 r.total.round(3), r.sum_first_second)
        sobol.append(r)
else:
    log.info("%s: sensitivity skipped (contact_force.sensitivity.n_samples: 0)", span_type.name)
replicates = replicates[replicates["case"] != "sobol"]
write_contact_force(ContactForcePaths.in_folder(snakemake.params.folder), span_type.name, settings, replicates, nominal,
                    summary, tolerance, sobol, laws.summary(), config_hash=settings_hash(snakemake.config))
log.info("%s: %d replicate runs gathered", span_type.name, len(replicates))
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
