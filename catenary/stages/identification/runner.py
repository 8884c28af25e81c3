"""One span type's identification run (paper §3–§4.2, Table 2, Figs 7, 10).

:func:`run_identification` does everything the rule needs from the measured deflections W and
the settings: J(s) on a fixed design, s_opt by maximum likelihood with standard errors, the
Henze–Zirkler test of the model samples at s0 and s_opt and of the data, the Gaussian and
kernel marginals of W at several sample sizes (Fig. 7) and the 98 % band of the CW deflection
along the span (Fig. 10). :mod:`.tables` turns the run into tables, :mod:`.report` into
Markdown, :mod:`.figures` into figures and :mod:`.outputs` writes them.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from functools import partial

import numpy as np
import pandas as pd

from catenary.physics.config import Catenary, SpanType
from catenary.plumbing.errors import ConvergenceError, InputError
from catenary.plumbing.workers import call_each
from .normality import normality_tests
from .propagation import SpanShifts, budget_table, parameter_shifts
from .band import DeflectionBand, band_abscissae, deflection_band
from .dependence import variance_inflation
from .design import RandomInput, design_dimension, draw_unit_design
from .fit import ScaledProblem, identify, make_likelihood
from .likelihood import Likelihood, ModelSample, fit_gaussian, kernel_bandwidth
from .profile import ProfileInterval, profile_search
from .result import IdentificationResult
from .settings import IdentificationSettings

__all__ = ["COMFORTABLE_SPANS_PER_PARAMETER", "IdentificationRun", "IdentifiedLaws", "identify_laws", "MarginalDensities", "check_span_count",
           "marginal_densities", "run_identification"]

_LOG = logging.getLogger(__name__)


@dataclass(frozen=True)
class MarginalDensities:
    """1-D marginals of the two estimates of p_W at the droppers for one model sample (Fig. 7).

    Attributes
    ----------
    n_samples : int
        Design size N.
    grid_m : numpy.ndarray, shape (g, n)
        Evaluation points of each dropper's W [m].
    gaussian, kernel : numpy.ndarray, shape (g, n)
        Marginal densities [1/m] of the Gaussian fit and of the Gaussian kernel smoothing.
    n_effective : float
        Kish effective sample size of the (taper-weighted) sample.
    l1_distance : numpy.ndarray, shape (n,)
        ``∫ |p_kernel − p_gauss| dW`` per dropper (trapezoid on the grid; 0 … 2).
    """

    n_samples: int
    grid_m: np.ndarray
    gaussian: np.ndarray
    kernel: np.ndarray
    n_effective: float
    l1_distance: np.ndarray


def marginal_densities(sample: ModelSample, grid_m: np.ndarray, bandwidth: str = "scott",
                       block: int = 8192) -> MarginalDensities:
    """Marginals at each dropper of the Gaussian and kernel estimates used by J.

    The Gaussian marginal is ``N(m_i, Σ̂_ii)`` of the weighted fit; the kernel marginal is the
    exact marginal of the n-dimensional kernel smoothing of :func:`.likelihood.kernel_log_density`
    (bandwidth matrix ``h² Σ̂``, h from the n-dimensional rule): a mixture of normals centred on
    the samples with standard deviation ``h √Σ̂_ii``, weighted by the slack taper.

    Parameters
    ----------
    sample : ModelSample
        Model sample (W, taper weights).
    grid_m : numpy.ndarray, shape (g, n)
        Evaluation points per dropper [m].
    bandwidth : {"scott", "silverman"}
    block : int
        Samples processed at once (bounds the memory to g × block per dropper).
    """
    keep = sample.weight > 0
    w, weight = sample.w_m[keep], sample.weight[keep]
    fit = fit_gaussian(w, weight)
    n = w.shape[1]
    sd = np.sqrt(np.sum(fit.chol**2, axis=1))
    grid = np.asarray(grid_m, dtype=float)
    gauss = np.exp(-0.5 * ((grid - fit.mean) / sd) ** 2) / (sd * np.sqrt(2.0 * np.pi))
    h = kernel_bandwidth(fit.n_effective, n, bandwidth)
    kernel = np.zeros_like(grid)
    total = float(weight.sum())
    for i in range(n):
        s = h * sd[i]
        acc = np.zeros(grid.shape[0])
        for start in range(0, w.shape[0], block):
            d = (grid[:, i, None] - w[None, start:start + block, i]) / s
            acc += np.exp(-0.5 * d * d) @ weight[start:start + block]
        kernel[:, i] = acc / (total * s * np.sqrt(2.0 * np.pi))
    l1 = np.trapezoid(np.abs(kernel - gauss), grid, axis=0)
    return MarginalDensities(n_samples=int(sample.w_m.shape[0]), grid_m=grid, gaussian=gauss, kernel=kernel,
                             n_effective=float(fit.n_effective), l1_distance=l1)


@dataclass(frozen=True)
class IdentificationRun:
    """Everything one span type's identification produced.

    Attributes
    ----------
    span_type : SpanType
    settings : IdentificationSettings
    start : tuple of RandomInput
        s0.
    result : IdentificationResult
        s_opt, standard errors, J trace, evaluation counts.
    j_start : float
        J(s0).
    data_w_m : numpy.ndarray, shape (K, n)
        Measured deflections used [m].
    left_out : list of (str, str)
        Spans not used and why.
    normality : dict
        :func:`.normality.normality_report`.
    marginals : list of MarginalDensities
        One per ``settings.estimators_n_samples``, at s_opt.
    band : DeflectionBand
        Band of the CW deflection at s_opt.
    data_in_band : numpy.ndarray, shape (n,)
        Fraction of the measured W inside the band at each dropper.
    identification_time_s : float
        Wall time of the optimisation and the standard errors [s].
    profiles : list of ProfileInterval
        Profile-likelihood intervals of the configured parameters.
    profile_time_s : float
        Wall time of the profile intervals and of the tasks run beside them (the normality
        tests, the estimators figure's marginals, the band) [s].
    total_time_s : float
        Wall time of :func:`run_identification` (fast model, identification, normality,
        marginals, band) [s].
    noise_covariance_m2 : numpy.ndarray or None
        The measurement noise of one run in the likelihood [m²] (``measurement_noise``).
    n_runs : numpy.ndarray or None
        Runs averaged into each span's W.
    model_error : pandas.DataFrame or None
        The correction's model-error budget carried to the identified parameters
        (:func:`catenary.stages.identification.propagation.budget_table`); None when not measured.
    model_error_shifts : SpanShifts or None
        What the budget gave the identification (which spans were filled, which sources could
        not be measured and why).
    """

    span_type: SpanType
    settings: IdentificationSettings
    start: tuple[RandomInput, ...]
    result: IdentificationResult
    j_start: float
    data_w_m: np.ndarray
    left_out: list[tuple[str, str]]
    normality: dict
    marginals: list[MarginalDensities]
    band: DeflectionBand
    data_in_band: np.ndarray
    identification_time_s: float
    profiles: list[ProfileInterval]
    profile_time_s: float
    total_time_s: float
    noise_covariance_m2: np.ndarray | None = None
    n_runs: np.ndarray | None = None
    model_error: pd.DataFrame | None = None
    model_error_shifts: SpanShifts | None = None


#: Spans per identified parameter below which the standard errors are flagged as rough: they
#: rest on the curvature of J, an asymptotic argument; with 117 spans and 13 parameters (the
#: paper's case, 9 per parameter) the coverage of the 95 % intervals was measured at 27–30 of 30
#: replicates, with 20 spans (1.5 per parameter) the small profile's estimates stay within 3
#: standard errors of the truth, but nothing guarantees the intervals there.
COMFORTABLE_SPANS_PER_PARAMETER = 3


def check_span_count(name: str, n_spans: int, n_parameters: int, log, *, n_left_out: int = 0) -> None:
    """Refuse fewer spans than identified parameters; warn below a comfortable number.

    Each span gives one 9-vector W; the σ of an input is seen only through the spread of W over
    spans, so fewer spans than parameters leaves the maximum of J undetermined in some direction.
    ``n_left_out`` spans of the type were left out upstream (correction not converged): the
    message says so, since they, not the recording, are then the reason.
    """
    if n_spans < n_parameters:
        upstream = (f" ({n_left_out} more left out because their correction did not converge: see `reason` "
                    "in corrected.parquet)" if n_left_out else "")
        raise InputError(
            f"span type {name}: {n_spans} measured span(s){upstream} for {n_parameters} identified parameters; "
            f"expected at least {n_parameters} spans (one per parameter), better "
            f"{COMFORTABLE_SPANS_PER_PARAMETER * n_parameters}: add spans or identify fewer parameters "
            "(identification.random_inputs, identification.free_means)")
    if n_spans < COMFORTABLE_SPANS_PER_PARAMETER * n_parameters:
        log.warning("%s: %d spans for %d identified parameters (fewer than %d per parameter): the standard "
                    "errors and intervals rest on asymptotics that may not hold yet; read them as rough",
                    name, n_spans, n_parameters, COMFORTABLE_SPANS_PER_PARAMETER)


@dataclass(frozen=True)
class IdentifiedLaws:
    """The laws of one span type by maximum likelihood, without the reports around them
    (:func:`identify_laws`): the likelihood, its inputs, the result and the model-error budget
    carried to every μ and σ (None when not measured)."""

    likelihood: Likelihood
    start: tuple
    result: IdentificationResult
    model_error: pd.DataFrame | None
    j_start: float = float("nan")


def identify_laws(span_type: SpanType, catenary: Catenary, data_w_m: np.ndarray,
                  settings: IdentificationSettings, *, left_out: list[tuple[str, str]] | None = None,
                  mast_pairs: np.ndarray | None = None, log: logging.Logger | None = None,
                  noise_covariance_m2: np.ndarray | None = None, n_runs: np.ndarray | None = None,
                  w_shifts: SpanShifts | None = None, observations=None, workers: int = 1) -> IdentifiedLaws:
    """s_opt with its standard errors and model-error budget (the first half of
    :func:`run_identification`, whose parameters it takes): what the later stages need of laws
    identified on a subset of the spans (those the final model explains)."""
    log = log or _LOG
    data = np.atleast_2d(np.asarray(data_w_m, dtype=float))
    if data.shape[0] < 2:
        raise InputError(f"span type {span_type.name}: {data.shape[0]} measured span(s); the identification "
                         "needs at least 2")
    s = settings
    start = s.start_inputs(span_type, catenary)
    n = span_type.n_droppers
    lik = make_likelihood(span_type, catenary, data, start=start, n_samples=s.n_samples, design_method=s.design,
                          seed=s.seed, system_height_mode=s.system_height_mode, estimator=s.estimator,
                          bandwidth=s.bandwidth, neighbours=s.neighbours, noise_covariance_m2=noise_covariance_m2,
                          n_runs=n_runs, observations=observations)
    if lik.observations is not None:
        log.info("%s: measured besides W, read with it: %s", span_type.name, ", ".join(
            f"{c} on {int(np.isfinite(lik.observations.values[:, i]).sum())} spans"
            for i, c in enumerate(lik.observations.columns)))
    if noise_covariance_m2 is not None:
        runs = np.ones(data.shape[0], dtype=int) if n_runs is None else np.asarray(n_runs)
        log.info("%s: measurement noise in the likelihood: %.3f mm RMS per run (%s), spans averaged over %s run(s)",
                 span_type.name, 1e3 * float(np.sqrt(np.mean(np.diag(noise_covariance_m2)))), s.measurement_noise,
                 "/".join(str(k) for k in np.unique(runs)))
    mu0 = np.array([r.mean for r in start])
    sd0 = np.array([r.sigma for r in start])
    j_start = lik(mu0, sd0)
    log.info("%s: %d spans, J(s0) = %.3f (N = %d, %s, %s estimator, seed %d)", span_type.name, data.shape[0],
             j_start, s.n_samples, s.design, s.estimator, s.seed)
    random = s.random_names(n)
    check_span_count(span_type.name, data.shape[0], len(random) + len(s.free_mean_names(n)), log,
                     n_left_out=len(left_out or []))
    covariance = s.standard_errors if mast_pairs is not None else "observed_information"
    if s.standard_errors == "sandwich" and mast_pairs is None:
        log.warning("%s: the data do not say which spans share a mast (no section_id, start_chainage_m, "
                    "end_chainage_m): standard errors from the observed information, spans independent",
                    span_type.name)
    result = identify(lik, start, free_means=s.free_mean_names(n), free_sigmas=random, method=s.method,
                      initial_step=s.initial_step, max_evaluations=s.max_evaluations, xtol=s.xtol, ftol=s.ftol,
                      hessian_step=s.hessian_step, mast_pairs=mast_pairs if covariance == "sandwich" else None,
                      covariance=covariance, log=log, workers=workers)
    log.info("%s: %s %s after %d evaluations (+%d for the Hessian) in %.1f s: J(s_opt) = %.3f (%s)",
             span_type.name, s.method, "converged" if result.converged else "did NOT converge",
             result.n_evaluations, result.n_hessian_evaluations, result.time_s, result.j_opt, result.message)
    if result.covariance == "sandwich":
        log.info("%s: %d pairs of spans share a mast; sandwich variance factors λ (widened where > 1): %s",
                 span_type.name, result.n_mast_pairs,
                 ", ".join(f"{p} {v:.2f}" for p, v in zip(result.free_parameters,
                                                          variance_inflation(result.theta_covariance,
                                                                             result.theta_covariance_sandwich))))
    if not result.converged:
        what = (f"span type {span_type.name}: the {s.method} optimiser did not converge after "
                f"{result.n_evaluations} evaluations ({result.message})")
        if s.on_non_convergence == "fail":
            raise ConvergenceError(f"{what}; raise identification.optimiser.max_evaluations, or set "
                                   "identification.on_non_convergence: mark to write outputs marked not converged")
        log.warning("%s; outputs are written with status not_converged (identification.on_non_convergence: mark)",
                    what)
    if not result.standard_errors_available:
        log.warning("%s: the observed information is not positive definite at s_opt: no standard errors "
                    "(status %s)", span_type.name, result.status)
    budget = None
    if w_shifts and w_shifts.w_m and result.status == "ok":
        problem = ScaledProblem.for_inputs(lik, start, s.free_mean_names(n), random)
        moved = parameter_shifts(problem, result.theta_opt, result.theta_covariance, w_shifts.w_m, s.hessian_step,
                                 workers)
        budget = budget_table(problem, result.means, result.sigmas, [r.name for r in start], moved)
        for row in budget.itertuples():
            log.info("%s: model error: %s %s = %.6g, systematic %.3g (dominant: %s)", span_type.name, row.parameter,
                     row.statistic, row.estimate, row.systematic, row.dominant_source)
    elif w_shifts:
        log.warning("%s: no model-error budget of the parameters (%s)", span_type.name,
                    f"identification status {result.status}" if w_shifts.w_m else
                    "no source has a measured shift: " + "; ".join(f"{k}: {v}" for k, v in w_shifts.unmeasured.items()))
    return IdentifiedLaws(lik, start, result, budget, float(j_start))


def run_identification(span_type: SpanType, catenary: Catenary, data_w_m: np.ndarray,
                       settings: IdentificationSettings, *, left_out: list[tuple[str, str]] | None = None,
                       mast_pairs: np.ndarray | None = None, log: logging.Logger | None = None,
                       noise_covariance_m2: np.ndarray | None = None,
                       n_runs: np.ndarray | None = None,
                       w_shifts: SpanShifts | None = None, observations=None, workers: int = 1) -> IdentificationRun:
    """Identify the input laws of ``span_type`` from measured deflections and build every output.

    Parameters
    ----------
    span_type, catenary
        Span type and catenary data.
    data_w_m : numpy.ndarray, shape (K, n)
        Measured static W [m] (deflection from the chord at the droppers, negative below).
    settings : IdentificationSettings
    left_out : list of (str, str), optional
        Spans left out upstream, carried into the report.
    mast_pairs : numpy.ndarray of int, shape (P, 2), optional
        Rows of ``data_w_m`` that share a mast (:attr:`CorrectedData.mast_pairs`). Without them
        the standard errors are the observed information's whatever ``settings.standard_errors``.
    log : logging.Logger, optional
        Progress messages (default: this module's logger).
    noise_covariance_m2 : numpy.ndarray, optional
        Covariance of one run's W error [m²] added to the model's law (divided by ``n_runs``):
        :meth:`.settings.IdentificationSettings.noise_covariance_m2`.
    n_runs : numpy.ndarray of int, optional
        Runs averaged into each row of ``data_w_m`` (default 1).
    w_shifts : SpanShifts, optional
        The correction's model-error budget: per source, the shift of ``data_w_m`` for one
        standard uncertainty (:func:`catenary.stages.identification.propagation.span_shifts`). Given, each
        source is carried to every identified μ and σ (:mod:`catenary.stages.identification.propagation`)
        and s_opt gets its total intervals.
    observations : Observations, optional
        Measurements besides W of the random inputs (a tension in a span, ΔH at a mast), row by
        row with ``data_w_m`` (:class:`catenary.measurement.channels.observations.Observations`; Gaussian
        estimator): J reads them jointly with W.
    workers : int
        Processes for the profile intervals' ends and for the J evaluations of the standard
        errors (the same intervals and errors for any number).

    Returns
    -------
    IdentificationRun

    Notes
    -----
    Seeds: the identification design uses ``settings.seed``, the band ``seed + 1``, the
    designs of the estimators figure ``seed + 2`` and the normality samples ``seed + 3``.
    """
    log = log or _LOG
    t0 = time.perf_counter()
    laws = identify_laws(span_type, catenary, data_w_m, settings, left_out=left_out, mast_pairs=mast_pairs, log=log,
                         noise_covariance_m2=noise_covariance_m2, n_runs=n_runs, w_shifts=w_shifts,
                         observations=observations, workers=workers)
    lik, start, result, budget, j_start = laws.likelihood, laws.start, laws.result, laws.model_error, laws.j_start
    data = lik.data_w_m
    s = settings
    n = span_type.n_droppers
    t_profile = time.perf_counter()
    profiled = s.profile_names(n)
    search = None
    if profiled and result.status != "ok":
        # A profile needs the maximum and its curvature: none around a point that is neither.
        log.warning("%s: no profile intervals (status %s)", span_type.name, result.status)
    elif profiled:
        search = profile_search(lik, start, result, parameters=profiled, level=s.profile_level,
                                max_evaluations=s.profile_max_evaluations)
    # What follows s_opt is independent tasks: the profile intervals' ends, the normality tests,
    # the estimators figure's marginals (one design per N, seed + 2, same fast model, at s_opt)
    # and the band — in worker processes together, the longest first.
    sample_opt = lik.model_sample(result.means, result.sigmas)
    fit_opt = fit_gaussian(sample_opt.w_m, sample_opt.weight)
    sd_opt = np.sqrt(np.sum(fit_opt.chol**2, axis=1))
    grid = fit_opt.mean + np.linspace(-4.5, 4.5, 181)[:, None] * sd_opt
    dim = design_dimension(n, s.system_height_mode)

    def marginals_at(n_est: int) -> MarginalDensities:
        est = Likelihood(lik.model, draw_unit_design(n_est, dim, method=s.design, seed=s.seed + 2), data,
                         system_height_mode=s.system_height_mode, bandwidth=s.bandwidth)
        return marginal_densities(est.model_sample(result.means, result.sigmas), grid, s.bandwidth)

    tests = normality_tests(lik.model, start, result, data, n_samples=s.normality_n_samples, seed=s.seed + 3,
                            system_height_mode=s.system_height_mode, alpha=s.normality_alpha)
    band_x = band_abscissae(span_type, s.band_n_points)
    sizes = sorted(set(s.estimators_n_samples), reverse=True)     # handed out in this order: the largest first
    tasks = ([partial(marginals_at, n_est) for n_est in sizes] + list(tests.values())
             + [partial(deflection_band, lik.model, result.means, result.sigmas, x_m=band_x,
                        n_samples=s.band_n_samples, level=s.band_level, design_method=s.design, seed=s.seed + 1,
                        system_height_mode=s.system_height_mode)]
             + (search.ends if search is not None else []))
    found = call_each(tasks, workers)
    by_size = dict(zip(sizes, found))
    marginals = [by_size[n_est] for n_est in s.estimators_n_samples]
    found = found[len(sizes):]
    normality = dict(zip(tests, found))
    band = found[len(tests)]
    profiles = search.intervals(found[len(tests) + 1:]) if search is not None else []
    profile_time = time.perf_counter() - t_profile
    for p in profiles:
        log.info("%s: %s %s = %.6g, %.0f %% profile interval [%.6g, %.6g]%s (%d evaluations)", span_type.name,
                 p.parameter, p.statistic, p.estimate, 100 * s.profile_level, p.low, p.high,
                 ": consistent with no spread" if p.no_spread_detected else "", p.n_evaluations)
    log.info("%s: profile intervals of %d parameters, the normality tests, the estimators figure and the band "
             "in %.1f s", span_type.name, len(profiles), profile_time)
    for key, value in normality.items():
        log.info("%s: Henze–Zirkler %s: HZ = %s, p = %s", span_type.name, key, value["statistic"], value["p_value"])
    for n_est, m in zip(s.estimators_n_samples, marginals):
        log.info("%s: N = %d: mean L1 distance kernel–Gaussian over the droppers %.4f", span_type.name, n_est,
                 float(m.l1_distance.mean()))
    at = np.searchsorted(band.x_m, span_type.dropper_positions_m)
    inside = (data >= band.lower_m[at]) & (data <= band.upper_m[at])
    log.info("%s: band %.0f %%: %d samples (%d slack dropped); measured W inside per dropper: %s", span_type.name,
             100 * s.band_level, band.n_samples, band.n_slack, np.round(inside.mean(axis=0), 3).tolist())
    return IdentificationRun(span_type=span_type, settings=s, start=start, result=result, j_start=float(j_start),
                             data_w_m=data, left_out=list(left_out or []), normality=normality, marginals=marginals,
                             band=band, data_in_band=inside.mean(axis=0), identification_time_s=result.time_s,
                             profiles=profiles, profile_time_s=profile_time, total_time_s=time.perf_counter() - t0,
                             noise_covariance_m2=noise_covariance_m2, n_runs=n_runs, model_error=budget,
                             model_error_shifts=w_shifts)
