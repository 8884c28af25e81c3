"""Rule tension_impact: paper Fig. 6 analogue, measured sags of two catenaries with the same
static sag at two messenger-wire tensions."""

from catenary.physics.config import load_catenary
from catenary.physics.pantograph import load_pantographs
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.report.tables import write_shown
from catenary.stages.tension_impact import tension_impact, tension_impact_figure

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("tension_impact", snakemake.log[0])
p = snakemake.params.tension_impact
catenary = load_catenary(snakemake.input.catenary)
span_type = catenary.span_type(snakemake.wildcards.span_type)
pantograph = load_pantographs(snakemake.input.pantographs)[p["pantograph"]]
result = tension_impact(span_type, catenary, pantograph, messenger_tensions_n=p["messenger_tensions_n"],
                        n_spans=p["n_spans"], speed_m_s=p["speed_kmh"] / 3.6, force_n=p["force_n"],
                        time_step_s=p["time_step_s"], sampling_step_m=p["sampling_step_m"],
                        common_sag=p["common_sag"])
summary = result.summary()
summary.to_csv(snakemake.output.summary, index=False, float_format="%.6g")
tension_impact_figure(result, snakemake.output.figure)
log.info("%s: dropper lengths of the central span [m]\n  T_MW %s N: %s\n  T_MW %s N: %s", span_type.name,
         p["messenger_tensions_n"][0], result.dropper_lengths_m[0].round(4).tolist(),
         p["messenger_tensions_n"][1], result.dropper_lengths_m[1].round(4).tolist())
log.info("summary:\n%s", summary.to_string(index=False))
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
