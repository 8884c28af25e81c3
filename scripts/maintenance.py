"""Rule maintenance: each span's posterior given its W and the maintenance list, one span type.

The posteriors and the band's coverages run in ``threads`` worker processes over blocks of spans,
each with one BLAS thread (set here, before NumPy loads; Snakemake sets the job's ``threads``).
"""

from catenary.plumbing.blas import one_blas_thread

one_blas_thread(override=True)

import pandas as pd  # noqa: E402

from catenary.measurement.repeatability import read_noise  # noqa: E402
from catenary.physics.config import load_catenary  # noqa: E402
from catenary.plumbing.heap import steady_heap  # noqa: E402
from catenary.plumbing.logs import rule_logger  # noqa: E402
from catenary.plumbing.parquet import read_table, settings_hash  # noqa: E402
from catenary.report.tables import write_shown  # noqa: E402
from catenary.stages.identification.data import read_corrected  # noqa: E402
from catenary.stages.identification.propagation import span_shifts  # noqa: E402
from catenary.stages.identification.settings import IdentificationSettings  # noqa: E402
from catenary.stages.maintenance.figures import chainage_figure, population_band_figure  # noqa: E402
from catenary.stages.maintenance.outputs import write_bands, write_maintenance  # noqa: E402
from catenary.stages.maintenance.runner import run_maintenance  # noqa: E402
from catenary.stages.maintenance.settings import MaintenanceSettings  # noqa: E402

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("maintenance", snakemake.log[0])
catenary = load_catenary(snakemake.input.catenary)
span_type = catenary.span_type(snakemake.wildcards.span_type)
identification = IdentificationSettings.from_mapping(snakemake.params.identification)
settings = MaintenanceSettings.from_mapping(snakemake.params.maintenance)
log.info("settings: %s", settings.as_dict())
repeatability_m2, flagged = read_noise(snakemake.input.noise)
data = read_corrected(snakemake.input.corrected, span_type, flagged)
corrected = read_table(snakemake.input.corrected)
w_shifts = None
if snakemake.params.model_error_enabled:
    w_shifts = span_shifts(read_table(snakemake.input.model_error), span_type.name, data.span_id,
                           span_type.n_droppers, corrected)
spans_check = pd.read_csv(snakemake.input.spans, dtype={"span_id": str, "section_id": str, "group": str,
                                                       "explained_by": str}, keep_default_na=False,
                          na_values={c: [""] for c in ("peak_chainage_m", "peak_size_mm", "peak_load_n")})
sections_check = pd.read_csv(snakemake.input.sections, dtype={"section_id": str})
run = run_maintenance(span_type, catenary, data, corrected, pd.read_csv(snakemake.input.s_opt), identification,
                      settings, one_run_m2=identification.noise_covariance_m2(span_type.n_droppers, repeatability_m2),
                      w_shifts=w_shifts, spans_check=spans_check, sections_check=sections_check,
                      workers=snakemake.threads)
log.info("%s: %d spans, W error %s; posterior in %.1f s", span_type.name, data.w_m.shape[0], run.noise, run.time_s)
marked = run.posterior.drop_duplicates("span_id").query("status != 'ok'")
for row in marked.itertuples():
    log.warning("%s: posterior %s (effective samples %.0f of %d)", row.span_id, row.status, row.effective_samples,
                settings.n_samples)
write_maintenance(run, snakemake.output.posterior, snakemake.output.listed, config_hash=settings_hash(snakemake.config),
                  noise=run.noise)
chainage_figure(run.posterior, settings.threshold, snakemake.output.figure,
                f"{span_type.name}: dropper most likely out of tolerance per span")
inspect = run.listed["status"] == "unexplained"
log.info("%s: %d span input(s) listed (P(out of tolerance) > %g), %d inspection(s) where the model does not explain "
         "the data", span_type.name, int((~inspect).sum()), settings.threshold, int(inspect.sum()))
write_bands(run, snakemake.output.band, snakemake.output.band_coverage)
if run.bands is not None:
    cov = run.bands.coverage
    log.info("%s: posterior band / prior band width %.2f–%.2f at the droppers; leave-one-out coverage %.3f "
             "(prior band %.3f, nominal %.2f)", span_type.name, cov["width_ratio"].min(), cov["width_ratio"].max(),
             cov["posterior_coverage_loo"].mean(), cov["prior_coverage"].mean(), identification.band_level)
population_band_figure(run.bands, data.w_m, span_type.dropper_positions_m, snakemake.output.band_figure,
                       f"{span_type.name}: the population's posterior band beside the prior band")
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
