"""Rule project: cut the recording into spans and project W at the droppers (SPEC §5)."""

from pathlib import Path

from catenary.config import load_catenary
from catenary.logs import rule_logger
from catenary.parquet import config_hash, read_table
from catenary.projection import ProjectionSettings, project, write_projection

log = rule_logger("project", snakemake.log[0])
catenary = load_catenary(snakemake.input.catenary)
result = project(read_table(snakemake.input.recording), read_table(snakemake.input.masts), catenary,
                 ProjectionSettings.from_mapping(snakemake.params.projection))
write_projection(result, Path(snakemake.output.report).parent, config_hash=config_hash(snakemake.config),
                 span_types=snakemake.params.span_types, catenary=catenary)
log.info("spans: %d used, %d rejected", result.n_used, result.n_rejected)
for row in result.report[result.report["status"] != "used"].itertuples():
    log.info("rejected %s: %s", row.span_id, row.reason)
