"""Rule identify_explained: one span type's laws identified again without the spans the final
model does not explain (diagnosis/spans.csv), and their difference from the laws of every span."""

import dataclasses
import shutil
from pathlib import Path

import pandas as pd

from catenary.measurement.channels.settings import MeasurementSettings
from catenary.measurement.repeatability import read_noise
from catenary.physics.config import load_catenary
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.plumbing.parquet import read_table
from catenary.report.tables import write_shown
from catenary.stages.correction import CorrectionSettings
from catenary.stages.identification.data import identification_observations, read_corrected
from catenary.stages.identification.explained import identify_explained
from catenary.stages.identification.settings import IdentificationSettings
from catenary.stages.identification.tables import laws_comparison

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("identify_explained", snakemake.log[0])
catenary = load_catenary(snakemake.input.catenary)
span_type = catenary.span_type(snakemake.wildcards.span_type)
settings = IdentificationSettings.from_mapping(snakemake.params.identification)
repeatability_m2, flagged = read_noise(snakemake.input.noise)
data = read_corrected(snakemake.input.corrected, span_type, flagged)
data = dataclasses.replace(data, observations=identification_observations(
    settings.estimator, data.span_id, snakemake.input.projected,
    snakemake.input.survey[0] if snakemake.input.survey else None,
    MeasurementSettings.from_mapping(snakemake.params.measurements),
    CorrectionSettings.from_mapping(snakemake.params.correction).force_n))
measured = snakemake.params.model_error_enabled
laws = identify_explained(span_type, catenary, data, pd.read_csv(snakemake.input.spans, dtype={"span_id": str},
                                                                 keep_default_na=False),
                          settings, repeatability_m2, log=log,
                          model_error=read_table(snakemake.input.model_error) if measured else None,
                          corrected=read_table(snakemake.input.corrected) if measured else None)
all_spans = pd.read_csv(snakemake.input.s_opt)
Path(snakemake.output.s_opt).parent.mkdir(parents=True, exist_ok=True)
if laws.table is None:
    (log.warning if laws.left_out else log.info)("%s: %s: the later stages use the laws of every span",
                                                 span_type.name, laws.why)
    shutil.copyfile(snakemake.input.s_opt, snakemake.output.s_opt)
    table = all_spans
else:
    table = laws.table
    table.to_csv(snakemake.output.s_opt, index=False, float_format="%.17g")
comparison = laws_comparison(all_spans, table, len(data.span_id), laws.n_identified)
comparison.to_csv(snakemake.output.comparison, index=False, float_format="%.10g")
for row in comparison.itertuples():
    log.info("%s %s: %.6g with every span, %.6g without the unexplained (difference %+.3g, z %.2f)",
             row.parameter, row.statistic, row.all_spans, row.explained_spans, row.difference, row.z)
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
