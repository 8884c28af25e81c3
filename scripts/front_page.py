"""Rule front_page: the HTML report's opening panel (catenary.report.front_page)."""

from catenary.measurement.registration import RegistrationSettings
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.report.front_page import write_front_page
from catenary.stages.contact_force.settings import ContactForceSettings

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("front_page", snakemake.log[0])
limits = {t: ContactForceSettings.from_mapping(block).limits for t, block in snakemake.params.contact_force.items()}
path = write_front_page(snakemake.output.front_page, snakemake.input.intro, dict(snakemake.input.items()),
                        RegistrationSettings.from_mapping(snakemake.params.registration).mast_table_std_m, limits)
log.info("front page for %s written to %s", ", ".join(limits) or "no span type", path)
