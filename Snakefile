# Catenary geometry identification workflow (see README.md and ../shared/SPEC.md).
from snakemake.utils import min_version, validate

min_version("9.0")


configfile: "config/config.yaml"


validate(config, "workflow/schemas/config.schema.yaml")


include: "workflow/rules/common.smk"
include: "workflow/rules/static.smk"
include: "workflow/rules/dynamics.smk"
include: "workflow/rules/measurements.smk"


rule all:
    input:
        static_outputs(),
        measurement_outputs(),
    default_target: True
