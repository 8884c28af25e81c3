"""Rule campaign_copy: the campaign's outputs from the copy shipped for these very files
(catenary.measurement.shipped), in place of simulating them."""

from pathlib import Path

from catenary.measurement.campaign import write_recording_csv
from catenary.measurement.shipped import copy_out
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.plumbing.parquet import read_table

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("campaign_copy", snakemake.log[0])
copy_out(snakemake.params.folder, Path(snakemake.output.recording).parent)
recording = read_table(snakemake.output.recording)
write_recording_csv(recording, snakemake.output.recording_csv)
log.info("campaign: copied from %s (%s), not simulated: %d samples in %d run(s)", snakemake.params.folder,
         snakemake.params.why, len(recording), recording["run_id"].nunique())
