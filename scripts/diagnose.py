"""Rule diagnose: locate, name, add the missing effects of one span type's identification model,
then check every span (and section) against the final model and diagnose again without the spans
it does not explain.

The refits, and the writing of the figures and tables, run in ``threads`` worker processes.
Snakemake sets OPENBLAS_NUM_THREADS and its kin to the job's ``threads`` (2); each process must use
one BLAS thread instead, or the 3 processes start 6 spinning threads on 2 cores (measured: the
small profile's diagnosis 4× slower), so they are reset here, before NumPy loads.
"""

from catenary.plumbing.blas import one_blas_thread

one_blas_thread(override=True)

import dataclasses  # noqa: E402
import numpy as np  # noqa: E402
from pathlib import Path  # noqa: E402

from catenary.measurement.channels.assemble import read_observations  # noqa: E402
from catenary.measurement.channels.settings import MeasurementSettings  # noqa: E402
from catenary.physics.config import load_catenary  # noqa: E402
from catenary.physics.effects import load_modules  # noqa: E402
from catenary.physics.pantograph import load_pantographs  # noqa: E402
from catenary.plumbing.heap import steady_heap  # noqa: E402
from catenary.plumbing.logs import rule_logger  # noqa: E402
from catenary.plumbing.parquet import read_table  # noqa: E402
from catenary.report.tables import write_shown  # noqa: E402
from catenary.stages.correction import CorrectionSettings  # noqa: E402
from catenary.stages.diagnosis.candidates import register_plugins  # noqa: E402
from catenary.stages.diagnosis.inputs import measuring_pass_of, profile_check_of  # noqa: E402
from catenary.stages.diagnosis.outputs import DiagnosisPaths, write_line_diagnosis  # noqa: E402
from catenary.stages.diagnosis.recommend import Extent, questions, recommend  # noqa: E402
from catenary.stages.diagnosis.runner import diagnose_line  # noqa: E402
from catenary.stages.diagnosis.settings import DiagnosisSettings  # noqa: E402
from catenary.stages.diagnosis.span_effects import MeasuringSetup, span_candidates, span_effect_fitter  # noqa: E402
from catenary.stages.identification.data import read_corrected, span_places  # noqa: E402
from catenary.stages.identification.propagation import span_shifts  # noqa: E402
from catenary.stages.identification.settings import IdentificationSettings  # noqa: E402
from catenary.stages.maintenance.settings import MaintenanceSettings  # noqa: E402
from catenary.stages.model_error.sources import ModelErrorSettings  # noqa: E402

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("diagnose", snakemake.log[0])
own = load_modules(snakemake.params.effects_modules)
if own:
    log.info("effects of one's own (effects_modules): %s; candidates on the law of W: %s", ", ".join(own),
             ", ".join(register_plugins()) or "none")
catenary = load_catenary(snakemake.input.catenary)
span_type = catenary.span_type(snakemake.wildcards.span_type)
identification = IdentificationSettings.from_mapping(snakemake.params.identification)
settings = DiagnosisSettings.from_mapping(snakemake.params.diagnosis)
# A dropper made or fitted wrong is the maintenance stage's fault, with its prior probability.
maintenance = MaintenanceSettings.from_mapping(snakemake.params.maintenance)
settings = dataclasses.replace(settings, spans=dataclasses.replace(settings.spans,
                                                                   fault_probability=maintenance.fault_probability))
correction = CorrectionSettings.from_mapping(snakemake.params.correction)
log.info("settings: %s", settings.as_mapping())
data = read_corrected(snakemake.input.corrected, span_type)
log.info("%s: %d converged spans used, %d left out", span_type.name, data.w_m.shape[0], len(data.left_out))
pantograph = load_pantographs(snakemake.input.pantographs)[correction.pantograph]
measuring = measuring_pass_of(snakemake.input.corrected, span_type, catenary, pantograph, correction,
                              workers=snakemake.threads)
log.info("measuring pass: %.1f km/h, declared force %.1f N; ∂W/∂F at the droppers %s mm/N", 3.6 * measuring.speed_m_s,
         measuring.force_n, " ".join(f"{1e3 * g:.3f}" for g in measuring.influence_m_n))
measurements = MeasurementSettings.from_mapping(snakemake.params.measurements)
observations, unused = read_observations(data.span_id, snakemake.input.spans,
                                         snakemake.input.survey[0] if snakemake.input.survey else None,
                                         measurements, measuring.force_n)
data = dataclasses.replace(data, observations=None if observations.empty else observations)
log.info("%s: measured besides W: %s; line: %s; %d survey rows not on this type's spans", span_type.name,
         {q: int(np.isfinite(observations.values[:, i]).sum()) for i, q in enumerate(observations.columns)} or "nothing",
         [f"{o.quantity} {o.value:.2f} ± {o.std:.2f}" for o in observations.line] or "nothing", len(unused))
profile_check = profile_check_of(snakemake.input.corrected, snakemake.input.profiles, span_type, catenary, pantograph,
                                 correction, settings.span_check().profile, measuring.speed_m_s, measuring.force_n,
                                 workers=snakemake.threads)
profile, noise = profile_check.table, profile_check.noise
log.info("%s: whole profiles of %d spans read between the droppers: noise %.3f mm per sample (AR(1) %.2f, every "
         "%.2f m)", span_type.name, len(profile), 1e3 * noise.std_m, noise.ar1, noise.step_m)
extra = None
if snakemake.params.model_error_enabled:
    extra = span_shifts(read_table(snakemake.input.model_error), span_type.name, data.span_id,
                        span_type.n_droppers, read_table(snakemake.input.corrected)).covariance_m2()
fit_local = span_effect_fitter(span_candidates(settings.candidates), profile_check, span_type, catenary,
                               settings.span_check().profile, settings.level,
                               MeasuringSetup(pantograph.with_static_force(measuring.force_n), measuring.speed_m_s,
                                              correction.mode, correction.time_step_s), log=log)
places = span_places(read_table(snakemake.input.corrected), data.span_id)
line = diagnose_line(span_type, catenary, data, places,
                     identification, settings, profile=profile, extra_covariance_m2=extra, span_effects=fit_local,
                     force_influence_m_n=measuring.influence_m_n, declared_force_n=measuring.force_n,
                     workers=snakemake.threads, n_left_out=len(data.left_out), log=log)
# What to measure next: every question W alone leaves open, and the car — whether W can tell its force
# from the declared one within the model-error budget's 95 % bound.
budget = ModelErrorSettings.from_mapping(snakemake.params.model_error)
asked = questions(line.run, car_force_n=budget.force_bound_n(measuring.force_n)
                  if snakemake.params.model_error_enabled else None)
recommendations = recommend(line.run.context, asked, measurements, Extent.of_line(line.run.n_spans, places),
                            settings.power, workers=snakemake.threads)
for r in recommendations[recommendations["recommended"]].itertuples():
    log.info("%s: %s — %s: measure %s on %d (%s; %.3g h), predicted power %.2f%s", span_type.name, r.kind, r.question,
             r.quantity, r.extent, r.per, r.cost_h, r.power, "" if r.enough else " (not enough)")
write_line_diagnosis(line, DiagnosisPaths.in_folder(Path(snakemake.output.findings).parent), recommendations,
                     workers=snakemake.threads)
log.info("%s: named %s in %.0f s; %d spans unexplained", span_type.name, line.run.named or "nothing", line.run.time_s,
         line.check.n_unexplained)
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
