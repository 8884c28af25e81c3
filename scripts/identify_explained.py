"""Rule identify_explained: one span type's laws identified again without the spans the final
model does not explain (diagnosis/spans.csv), and their difference from the laws of every span."""

import dataclasses
import shutil
from pathlib import Path

import pandas as pd

from catenary.measurement.channels.assemble import IDENTIFIED_QUANTITIES, read_observations
from catenary.measurement.channels.settings import MeasurementSettings
from catenary.measurement.repeatability import read_noise
from catenary.physics.config import load_catenary
from catenary.plumbing.errors import InputError
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.plumbing.parquet import read_table
from catenary.stages.correction import CorrectionSettings
from catenary.stages.identification.data import read_corrected
from catenary.stages.identification.propagation import span_shifts
from catenary.stages.identification.runner import identify_laws
from catenary.stages.identification.settings import IdentificationSettings
from catenary.stages.identification.tables import laws_comparison, s_opt_table

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("identify_explained", snakemake.log[0])
catenary = load_catenary(snakemake.input.catenary)
span_type = catenary.span_type(snakemake.wildcards.span_type)
settings = IdentificationSettings.from_mapping(snakemake.params.identification)
repeatability_m2, flagged = read_noise(snakemake.input.noise)
data = read_corrected(snakemake.input.corrected, span_type, flagged)
spans = pd.read_csv(snakemake.input.spans, dtype={"span_id": str}, keep_default_na=False)
departing = set(spans.loc[(spans["unexplained"].astype(str) == "True")
                          | (spans["explained_by"].astype(str) != ""), "span_id"])
leave = pd.Series(data.span_id).isin(departing).to_numpy()
all_spans = pd.read_csv(snakemake.input.s_opt)
if settings.estimator == "gaussian":         # the quantities the identification's model gives, read with W
    observations, _ = read_observations(data.span_id, snakemake.input.projected,
                                        snakemake.input.survey[0] if snakemake.input.survey else None,
                                        MeasurementSettings.from_mapping(snakemake.params.measurements),
                                        CorrectionSettings.from_mapping(snakemake.params.correction).force_n,
                                        IDENTIFIED_QUANTITIES)
    data = dataclasses.replace(data, observations=None if observations.empty else observations)
bulk = data.without(leave, "unexplained by the final model (diagnosis/spans.csv)")
table, why = None, "every span is explained by the final model"
if leave.any():
    log.info("%s: %d spans left out as unexplained (%s); %d identified", span_type.name, int(leave.sum()),
             ", ".join(sorted(departing)), bulk.w_m.shape[0])
    w_shifts = None
    if snakemake.params.model_error_enabled:
        w_shifts = span_shifts(read_table(snakemake.input.model_error), span_type.name, bulk.span_id,
                               span_type.n_droppers, read_table(snakemake.input.corrected))
    try:
        laws = identify_laws(span_type, catenary, bulk.w_m, settings, left_out=bulk.left_out,
                             mast_pairs=bulk.mast_pairs, log=log, n_runs=bulk.n_runs,
                             noise_covariance_m2=settings.noise_covariance_m2(span_type.n_droppers, repeatability_m2),
                             w_shifts=w_shifts, observations=bulk.observations)
        table = s_opt_table(laws.result, (), laws.model_error)
    except InputError as exc:        # too few explained spans for the identified parameters
        why = f"the {bulk.w_m.shape[0]} explained spans cannot identify the laws alone ({exc})"
Path(snakemake.output.s_opt).parent.mkdir(parents=True, exist_ok=True)
if table is None:
    (log.warning if leave.any() else log.info)("%s: %s: the later stages use the laws of every span",
                                               span_type.name, why)
    shutil.copyfile(snakemake.input.s_opt, snakemake.output.s_opt)
    table = all_spans
else:
    table.to_csv(snakemake.output.s_opt, index=False, float_format="%.17g")
comparison = laws_comparison(all_spans, table, len(data.span_id), bulk.w_m.shape[0])
comparison.to_csv(snakemake.output.comparison, index=False, float_format="%.10g")
for row in comparison.itertuples():
    log.info("%s %s: %.6g with every span, %.6g without the unexplained (difference %+.3g, z %.2f)",
             row.parameter, row.statistic, row.all_spans, row.explained_spans, row.difference, row.z)
