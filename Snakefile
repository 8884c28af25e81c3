# Catenary geometry identification workflow (see README.md and ../shared/SPEC.md).
from snakemake.utils import min_version, validate

min_version("9.0")


configfile: "config/config.yaml"


validate(config, "workflow/schemas/config.schema.yaml")


include: "workflow/rules/common.smk"
include: "workflow/rules/static.smk"
include: "workflow/rules/dynamics.smk"
include: "workflow/rules/measurements.smk"
include: "workflow/rules/correction.smk"
include: "workflow/rules/inversion.smk"
include: "workflow/rules/identification.smk"


rule all:
    input:
        static_outputs(),
        measurement_outputs(),
        correction_outputs(),
        inversion_outputs(),
        identification_outputs(),
    default_target: True
