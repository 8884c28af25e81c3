"""Rule maintenance_repair: the contact force over the listed spans as measured and repaired.

The repair windows run in ``threads`` worker processes, each with one BLAS thread (set here,
before NumPy loads; Snakemake sets the job's ``threads``).
"""

from catenary.plumbing.blas import one_blas_thread

one_blas_thread(override=True)

import pandas as pd  # noqa: E402

from catenary.physics.config import load_catenary  # noqa: E402
from catenary.physics.pantograph import load_pantographs  # noqa: E402
from catenary.plumbing.heap import steady_heap  # noqa: E402
from catenary.plumbing.logs import rule_logger  # noqa: E402
from catenary.plumbing.parquet import read_table  # noqa: E402
from catenary.report.tables import write_shown  # noqa: E402
from catenary.stages.contact_force.settings import ContactForceSettings  # noqa: E402
from catenary.stages.maintenance.repair import fixing_buys, repair_summary  # noqa: E402

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("maintenance_repair", snakemake.log[0])
catenary = load_catenary(snakemake.input.catenary)
span_type = catenary.span_type(snakemake.wildcards.span_type)
settings = ContactForceSettings.from_mapping(snakemake.params.contact_force)
pantograph = load_pantographs(snakemake.input.pantographs)[settings.pantograph]
listed = pd.read_csv(snakemake.input.listed)
table, skipped = fixing_buys(read_table(snakemake.input.posterior), listed, span_type, catenary, pantograph, settings,
                              workers=snakemake.threads)
summary = repair_summary(table).assign(reason="")
for section, why in skipped:
    log.warning("section %s: %s", section, why)
summary = pd.concat([summary, pd.DataFrame({"section_id": [s for s, _ in skipped], "reason": [w for _, w in skipped]})],
                    ignore_index=True)
table.to_csv(snakemake.output.table, index=False, float_format="%.6g")
summary.to_csv(snakemake.output.summary, index=False, float_format="%.6g")
for row in summary.dropna(subset=["speed_kmh"]).itertuples():
    log.info("%s %s–%s at %.0f km/h, repairing %s: σ_F %+.2f N, Fm − 3σ margin %+.2f N", row.section_id,
             row.first_span_id, row.last_span_id, row.speed_kmh, row.listed, row.std_force_change_n,
             row.statistical_min_margin_change_n)
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
