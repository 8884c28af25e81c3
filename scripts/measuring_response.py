"""Rule measuring_response: the measuring pass's response to the static CW per span type and
direction of travel (catenary.stages.correction.step), the step of the correction's dynamic passes."""

import pandas as pd

from catenary.physics.config import load_catenary
from catenary.physics.pantograph import load_pantographs
from catenary.plumbing.logs import rule_logger
from catenary.plumbing.parquet import read_table
from catenary.stages.correction import CorrectionSettings
from catenary.stages.correction.step import line_responses, response_table

log = rule_logger("measuring_response", snakemake.log[0])
catenary = load_catenary(snakemake.input.catenary)
settings = CorrectionSettings.from_mapping(snakemake.params.correction)
pantograph = load_pantographs(snakemake.input.pantographs)[settings.pantograph]
columns = ["direction", "speed_kmh", "force_n"]
spans = pd.concat([read_table(path).reindex(columns=columns).assign(span_type=span_type)
                   for span_type, path in zip(snakemake.params.span_types, snakemake.input.spans)], ignore_index=True)
responses = line_responses(spans, catenary, pantograph, settings, workers=snakemake.threads)
for r in responses:
    own = r.own_response
    log.info("%s, direction %+d, %.1f km/h, %.1f N: a raised dropper moves the height measured there by %.2f–%.2f "
             "of the raise", r.span_type, r.direction, r.speed_m_s * 3.6, r.force_n, own.min(), own.max())
response_table(responses).to_parquet(snakemake.output.response, index=False)
log.info("%d responses (%s pass)", len(responses), settings.mode)
