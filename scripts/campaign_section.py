"""Rule campaign_section: simulate the recording car over one section of the drawn truth."""

import time

from catenary.measurement.campaign import simulate_section, truth_schema
from catenary.measurement.recording import RECORDING_SCHEMA
from catenary.measurement.truth import draw_line, load_truth
from catenary.physics.config import load_catenary
from catenary.physics.pantograph import load_pantographs
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.plumbing.parquet import config_hash, write_table

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("campaign_section", snakemake.log[0])
catenary = load_catenary(snakemake.input.catenary)
spec = load_truth(snakemake.input.campaign, catenary)
line = draw_line(spec, catenary)
k = [s.section_id for s in spec.sections].index(snakemake.wildcards.section)
pantograph = load_pantographs(snakemake.input.pantographs)[spec.measurement.pantograph]
log.info("section %s (%d of %d; Snakemake's 'steps done' counts the sections): measuring pass over %d %s spans, "
         "%d run(s)", snakemake.wildcards.section, k + 1, len(spec.sections), spec.sections[k].n_spans,
         spec.sections[k].span_type, len(spec.measurement.runs))
start = time.perf_counter()
recording, truth, truth_runs = simulate_section(line, k, catenary, pantograph, spec.measurement, spec.seed)
digest = config_hash(spec.raw)
write_table(recording, snakemake.output.recording, RECORDING_SCHEMA, config_hash=digest, kind="recording")
write_table(truth, snakemake.output.truth, truth_schema(truth.columns), config_hash=digest, kind="truth")
write_table(truth_runs, snakemake.output.truth_runs, truth_schema(truth_runs.columns), config_hash=digest,
            kind="truth_runs")
log.info("section %s: %d samples (%d missing), %d spans, simulated in %.0f s", snakemake.wildcards.section,
         len(recording), int(recording["height_m"].isna().sum()), len(truth), time.perf_counter() - start)
