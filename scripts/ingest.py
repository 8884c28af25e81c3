"""Rule ingest: check the recording and masts files and write them as Parquet."""

from catenary.logs import rule_logger
from catenary.parquet import settings_hash
from catenary.recording import read_masts, read_recording, write_masts, write_recording

log = rule_logger("ingest", snakemake.log[0])
digest = settings_hash(snakemake.config)
recording = read_recording(snakemake.input.recording)
masts = read_masts(snakemake.input.masts)
write_recording(recording, snakemake.output.recording, config_hash=digest)
write_masts(masts, snakemake.output.masts, config_hash=digest)
ignored = recording.attrs.get("ignored_columns") or []
log.info("recording: %d samples%s; masts: %d", len(recording),
         f" (ignored columns {ignored})" if ignored else "", len(masts))
