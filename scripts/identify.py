"""Rule identify: maximum-likelihood identification of one span type's input laws.

The job's ``threads`` processes share each of the optimiser's J evaluations, then the standard
errors' points, what follows s_opt (marginals, normality tests, band, profile intervals) and the
writing of its figures and tables; each process has one BLAS thread (set here, before NumPy
loads; Snakemake sets the job's ``threads``).
"""

from catenary.plumbing.blas import one_blas_thread

one_blas_thread(override=True)

from pathlib import Path  # noqa: E402

from catenary.measurement.channels.settings import MeasurementSettings  # noqa: E402
from catenary.measurement.repeatability import read_noise  # noqa: E402
from catenary.physics.config import load_catenary  # noqa: E402
from catenary.plumbing.heap import steady_heap  # noqa: E402
from catenary.plumbing.logs import rule_logger  # noqa: E402
from catenary.plumbing.parquet import read_table, settings_hash  # noqa: E402
from catenary.report.tables import write_shown  # noqa: E402
from catenary.stages.correction import CorrectionSettings  # noqa: E402
from catenary.stages.identification.data import identification_observations, read_corrected  # noqa: E402
from catenary.stages.identification.outputs import IdentificationPaths, write_identification  # noqa: E402
from catenary.stages.identification.propagation import span_shifts  # noqa: E402
from catenary.stages.identification.runner import run_identification  # noqa: E402
from catenary.stages.identification.settings import IdentificationSettings  # noqa: E402

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("identify", snakemake.log[0])
catenary = load_catenary(snakemake.input.catenary)
span_type = catenary.span_type(snakemake.wildcards.span_type)
settings = IdentificationSettings.from_mapping(snakemake.params.identification)
log.info("settings: %s", settings.as_dict())
repeatability_m2, flagged = read_noise(snakemake.input.noise)
data = read_corrected(snakemake.input.corrected, span_type, flagged)
log.info("%s: %d converged spans used, %d left out", span_type.name, data.w_m.shape[0], len(data.left_out))
for span_id, why in data.left_out:
    log.info("left out %s: %s", span_id, why)
observations = identification_observations(settings.estimator, data.span_id, snakemake.input.spans,
                                           snakemake.input.survey[0] if snakemake.input.survey else None,
                                           MeasurementSettings.from_mapping(snakemake.params.measurements),
                                           CorrectionSettings.from_mapping(snakemake.params.correction).force_n)
w_shifts = None
if snakemake.params.model_error_enabled:
    w_shifts = span_shifts(read_table(snakemake.input.model_error), span_type.name, data.span_id,
                           span_type.n_droppers, read_table(snakemake.input.corrected))
    for source, n in w_shifts.filled.items():
        log.info("model error %s: %d of %d spans with no measured shift of their own take the others' mean", source,
                 n, data.w_m.shape[0])
    for source, why in w_shifts.unmeasured.items():
        log.warning("model error %s: not in the budget (%s)", source, why)
run = run_identification(span_type, catenary, data.w_m, settings, left_out=data.left_out,
                         mast_pairs=data.mast_pairs, log=log, n_runs=data.n_runs,
                         noise_covariance_m2=settings.noise_covariance_m2(span_type.n_droppers, repeatability_m2),
                         w_shifts=w_shifts, observations=observations, workers=snakemake.threads)
out = snakemake.output
write_identification(run, IdentificationPaths(s_opt=Path(out.s_opt), trace=Path(out.trace),
                                              estimators=Path(out.estimators), normality=Path(out.normality),
                                              band=Path(out.band), report=Path(out.report),
                                              model_error=Path(out.model_error)),
                     config_hash=settings_hash(snakemake.config), source=Path(snakemake.input.corrected).name,
                     workers=snakemake.threads)
for row in run.result.table_rows():
    log.info("s_opt %-22s mu %.6g ± %.3g  sigma %.4g ± %.3g%s", row["parameter"], row["mu"], row["mu_se"],
             row["sigma"], row["sigma_se"], "  (mean fixed)" if row["mu_fixed"] else "")
log.info("%s: done in %.1f s", span_type.name, run.total_time_s)
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
