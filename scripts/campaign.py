"""Rule campaign: gather the simulated sections into the recording, masts and truth files."""

import pandas as pd

from catenary.measurement.campaign import campaign_masts, campaign_survey, gather_recording, truth_schema, write_recording_csv
from catenary.measurement.recording import RECORDING_SCHEMA
from catenary.measurement.truth import draw_line, load_truth
from catenary.physics.config import load_catenary
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.plumbing.parquet import config_hash, read_table, write_table

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("campaign", snakemake.log[0])
catenary = load_catenary(snakemake.input.catenary)
spec = load_truth(snakemake.input.campaign, catenary)
digest = config_hash(spec.raw)
recording = gather_recording([read_table(p) for p in snakemake.input.recordings], spec)
truth = pd.concat([read_table(p) for p in snakemake.input.truths], ignore_index=True)
truth_runs = pd.concat([read_table(p) for p in snakemake.input.truth_runs], ignore_index=True)
write_table(recording, snakemake.output.recording, RECORDING_SCHEMA, config_hash=digest, kind="recording")
write_recording_csv(recording, snakemake.output.recording_csv)
line = draw_line(spec, catenary)
masts, masts_truth = campaign_masts(line, spec)
survey = campaign_survey(line, spec, catenary)
survey.to_csv(snakemake.output.survey, index=False, float_format="%.6g")
masts.to_csv(snakemake.output.masts, index=False, float_format="%.4f")
masts_truth.to_csv(snakemake.output.masts_truth, index=False, float_format="%.4f")
write_table(truth, snakemake.output.truth, truth_schema(truth.columns), config_hash=digest, kind="truth")
write_table(truth_runs, snakemake.output.truth_runs, truth_schema(truth_runs.columns), config_hash=digest,
            kind="truth_runs")
log.info("campaign: %d samples in %d run(s), %d spans; mast table: %s; survey: %s", len(recording),
         recording["run_id"].nunique(), len(truth), masts_truth["status"].value_counts().to_dict(),
         survey["quantity"].value_counts().to_dict() or "none")
