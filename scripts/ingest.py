"""Rule ingest: check the recording file(s) and the masts file and write them as Parquet."""

from catenary.measurement.recording import read_masts, read_recordings, runs_table, write_masts, write_recording
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.plumbing.parquet import settings_hash

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("ingest", snakemake.log[0])
digest = settings_hash(snakemake.config)
recording = read_recordings(list(snakemake.input.recording))
write_recording(recording, snakemake.output.recording, config_hash=digest)
runs = runs_table(recording)
runs.to_csv(snakemake.output.runs, index=False, float_format="%.3f")
# no mast table: the registration finds the masts from the trace
masts = read_masts(snakemake.input.masts[0]) if snakemake.input.masts else None
write_masts(masts, snakemake.output.masts, config_hash=digest)
ignored = recording.attrs.get("ignored_columns") or []
log.info("recording: %d samples in %d run(s) (%s)%s; masts: %s", len(recording), len(runs),
         ", ".join(f"{r.run_id} {'+' if r.direction > 0 else '-'}" for r in runs.itertuples()),
         f" (ignored columns {ignored})" if ignored else "", len(masts) if masts is not None else "none given")
