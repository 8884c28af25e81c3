"""Rule project: cut the recording into spans and project W at the droppers."""

from pathlib import Path

from catenary.config import load_catenary
from catenary.errors import InputError
from catenary.logs import rule_logger
from catenary.parquet import read_table, settings_hash
from catenary.projection import ProjectionSettings, project, write_projection

log = rule_logger("project", snakemake.log[0])
catenary = load_catenary(snakemake.input.catenary)
result = project(read_table(snakemake.input.recording), read_table(snakemake.input.masts), catenary,
                 ProjectionSettings.from_mapping(snakemake.params.projection))
log.info("spans: %d used, %d rejected", result.n_used, result.n_rejected)
for row in result.report[result.report["status"] != "used"].itertuples():
    log.info("rejected %s: %s", row.span_id, row.reason)
if result.n_used == 0:
    reasons = "; ".join(f"{n} × {r}" for r, n in result.report["reason"].value_counts().items())
    raise InputError(
        f"{snakemake.config.get('recording') or snakemake.input.recording} and "
        f"{snakemake.config.get('masts') or snakemake.input.masts}: the projection kept 0 of "
        f"{len(result.report)} span(s) ({reasons or 'no span between two masts'}); expected a recording "
        "that covers the masts' chainages (same origin, metres)")
write_projection(result, Path(snakemake.output.report).parent, config_hash=settings_hash(snakemake.config),
                 span_types=snakemake.params.span_types, catenary=catenary)
