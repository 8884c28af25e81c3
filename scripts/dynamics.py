"""Rule dynamics: high-speed runs over a section of one span type, EN 50318-style statistics
beside the EN 50318:2002 reference ranges, and a figure."""

import pandas as pd

from catenary.physics.config import load_catenary
from catenary.physics.contact_statistics import contact_statistics, en50318_table
from catenary.physics.contact_statistics import dynamics_figure
from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.physics.dynamics import CatenaryDynamics, run_pantograph
from catenary.physics.pantograph import load_pantographs
from catenary.physics.section import uniform_section
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.report.tables import write_shown

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("dynamics", snakemake.log[0])
p = snakemake.params.dynamics
catenary = load_catenary(snakemake.input.catenary)
span_type = catenary.span_type(snakemake.wildcards.span_type)
pantograph = load_pantographs(snakemake.input.pantographs)[p["pantograph"]]
lengths = nominal_dropper_lengths(span_type, catenary).dropper_lengths_m
section = uniform_section(span_type, p["n_spans"], lengths)
ops = CatenaryDynamics(section, catenary)
masts = section.mast_chainage_m
first, last = p["analysis_masts"]
window = (masts[first], masts[last])
runs, stats = {}, {}
for speed_kmh in p["speeds_kmh"]:
    run = run_pantograph(ops, pantograph, speed_kmh / 3.6)
    runs[f"{speed_kmh} km/h"] = run
    stats[speed_kmh] = contact_statistics(run, *window, masts, cutoff_hz=p["filter_cutoff_hz"])
    log.info("%s at %s km/h: %s", span_type.name, speed_kmh, stats[speed_kmh].as_dict())
table = en50318_table(stats, {int(k): v for k, v in p["en50318_ranges"].items()})
table.to_csv(snakemake.output.statistics, index=False, float_format="%.4f")
dynamics_figure(runs, masts, window, f"{span_type.name}: {p['n_spans']} spans, {pantograph.name}",
                snakemake.output.figure, cutoff_hz=p["filter_cutoff_hz"])
log.info("statistics:\n%s", table.to_string(index=False))
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
