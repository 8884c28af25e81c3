# Catenary geometry identification workflow (see README.md).
import os
import sys

from snakemake.exceptions import WorkflowError
from snakemake.utils import min_version

from catenary.plumbing.errors import ConfigError
from catenary.plumbing.schema import check as check_config

min_version("9.0")


configfile: "config/config.yaml"


# The package's check of the shipped schema (workflow/schemas/config.schema.yaml links to it): one
# or two lines naming the files and key, not a dump of the schema. The schema sets no defaults, so
# Snakemake's own validate() would only repeat it.
try:
    check_config(config, "config")
except ConfigError as error:
    files = ", ".join(dict.fromkeys(map(str, workflow.configfiles)))
    raise WorkflowError(f"invalid configuration ({files}): {error}") from None


include: "workflow/rules/common.smk"
include: "workflow/rules/static.smk"
include: "workflow/rules/dynamics.smk"
include: "workflow/rules/measurements.smk"
include: "workflow/rules/correction.smk"
include: "workflow/rules/inversion.smk"
include: "workflow/rules/identification.smk"
include: "workflow/rules/diagnosis.smk"
include: "workflow/rules/maintenance.smk"
include: "workflow/rules/contact_force.smk"
include: "workflow/rules/report.smk"


# The HTML report (make run: `--report results/report.html --report-after-run`; after the run,
# Snakemake knows the jobs behind the projection checkpoint, which a separate `--report` call
# misses): its opening panel is this run's front page (rule front_page, written before the report),
# or the method alone when the run writes no front page (`make paper`).
# `make own-data` asks for target `measurements`, whose front page has no contact-force study.
_FRONT_PAGE = FRONT_PAGE_MEASUREMENTS if "measurements" in sys.argv else FRONT_PAGE
_WRITES_FRONT_PAGE = os.path.exists(_FRONT_PAGE) or "--report-after-run" in sys.argv


report: os.path.abspath(_FRONT_PAGE) if _WRITES_FRONT_PAGE else "workflow/report/workflow.rst"


rule all:
    """Everything: the paper-reproduction simulations and the measurement pipeline with the
    contact-force study, for the span types the recording holds."""
    input:
        paper_outputs(),
        measurement_outputs(),
        correction_outputs(),
        measured_outputs,
    default_target: True


rule measurements:
    """Your recording only: ingest → projection → correction → inversion → identification →
    diagnosis, for the span types the projection finds (`make own-data`)."""
    input:
        measurement_outputs(),
        correction_outputs(),
        lambda wildcards: measured_outputs(wildcards, contact_force=False),


rule paper:
    """The paper-reproduction simulations only (no recording needed): `make paper`."""
    input:
        paper_outputs(),
