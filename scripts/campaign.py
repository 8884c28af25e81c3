"""Rule campaign: gather the simulated sections into the recording, masts and truth files."""

import pandas as pd

from catenary.campaign import masts_table, truth_schema
from catenary.config import load_catenary
from catenary.logs import rule_logger
from catenary.parquet import config_hash, read_table, write_table
from catenary.recording import RECORDING_SCHEMA
from catenary.truth import draw_line, load_truth

log = rule_logger("campaign", snakemake.log[0])
catenary = load_catenary(snakemake.input.catenary)
spec = load_truth(snakemake.input.campaign, catenary)
digest = config_hash(spec.raw)
recording = pd.concat([read_table(p) for p in snakemake.input.recordings], ignore_index=True)
truth = pd.concat([read_table(p) for p in snakemake.input.truths], ignore_index=True)
recording = recording.sort_values("chainage_m", kind="stable").reset_index(drop=True)
write_table(recording, snakemake.output.recording, RECORDING_SCHEMA, config_hash=digest, kind="recording")
recording.to_csv(snakemake.output.recording_csv, index=False, float_format="%.4f")
masts_table(draw_line(spec, catenary)).to_csv(snakemake.output.masts, index=False, float_format="%.4f")
write_table(truth, snakemake.output.truth, truth_schema(truth.columns), config_hash=digest, kind="truth")
log.info("campaign: %d samples, %d spans", len(recording), len(truth))
