"""One span type's identification run and its outputs (paper §3–§4.2, Table 2, Figs 7, 10).

:func:`run_identification` does everything the rule needs from the measured deflections W and
the settings: J(s) on a fixed design, s_opt by maximum likelihood with standard errors, the
Henze–Zirkler test of the model samples at s0 and s_opt and of the data, the Gaussian and
kernel marginals of W at several sample sizes (Fig. 7) and the 98 % band of the CW deflection
along the span (Fig. 10). The other functions turn the run into tables, a JSON object and a
Markdown report; :mod:`.figures` draws the figures.

Measured deflections come from the correction rule (``corrected.parquet``): one row per span,
``w1_m`` … ``wn_m`` the static CW deflection from the chord at the droppers [m] (negative
below), and ``converged``; :func:`read_corrected` keeps the converged rows.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa

from ..config import Catenary, SpanType
from ..errors import ConvergenceError, InputError
from ..fast import FastSpanModel
from ..normality import henze_zirkler
from ..model_error.propagation import SpanShifts, budget_table, parameter_shifts, total_intervals
from ..model_error.report import model_error_lines
from ..parquet import read_table
from .band import DeflectionBand, band_abscissae, deflection_band
from .dependence import adjacent_span_pairs, variance_inflation
from .design import MESSENGER_TENSION, SYSTEM_HEIGHT, RandomInput, design_dimension, draw_unit_design
from .fit import ScaledProblem, identify, make_likelihood
from .likelihood import Likelihood, ModelSample, fit_gaussian, kernel_bandwidth
from .profile import ProfileInterval, profile_intervals
from .result import IdentificationResult
from .synthetic import simulate_deflections
from .settings import IdentificationSettings

__all__ = ["CorrectedData", "IdentificationRun", "MarginalDensities", "S_OPT_COLUMNS", "marginal_densities",
           "markdown_report", "normality_report", "read_corrected", "run_identification", "s_opt_table",
           "trace_schema", "trace_table"]

S_OPT_COLUMNS = ("parameter", "mu", "sigma", "mu_se", "sigma_se", "mu_variance_widening", "sigma_variance_widening",
                 "mu_fixed", "mu_profile_low", "mu_profile_high", "sigma_profile_low", "sigma_profile_high",
                 "no_spread_detected", "converged", "status", "mu_systematic", "sigma_systematic",
                 "mu_total_low", "mu_total_high", "sigma_total_low", "sigma_total_high")
_REQUIRED = ("span_id", "converged")
_ADJACENCY = ("section_id", "start_chainage_m", "end_chainage_m")
_LOG = logging.getLogger(__name__)


@dataclass(frozen=True)
class CorrectedData:
    """Measured deflections of one span type, ready for the identification.

    Attributes
    ----------
    w_m : numpy.ndarray, shape (K, n)
        Static CW deflection from the chord at the droppers of the K spans used [m].
    span_id : numpy.ndarray of str, shape (K,)
    left_out : list of (str, str)
        ``(span_id, reason)`` of every row not used.
    mast_pairs : numpy.ndarray of int, shape (P, 2), or None
        Rows of ``w_m`` that share a mast (:func:`.dependence.adjacent_span_pairs`); None when
        the file does not say (no ``section_id``, ``start_chainage_m``, ``end_chainage_m``).
    n_runs : numpy.ndarray of int, shape (K,)
        Converged runs averaged into each row of ``w_m``.
    """

    w_m: np.ndarray
    span_id: np.ndarray
    left_out: list[tuple[str, str]]
    mast_pairs: np.ndarray | None = None
    n_runs: np.ndarray | None = None


#: Largest distance between the registered positions of one mast as two spans of several runs
#: give it, for the two spans to share it [m] (a registration places a mast to centimetres).
_SHARED_MAST_TOLERANCE_M = 0.5


def read_corrected(path: str | Path, span_type: SpanType, flagged: dict[str, str] | None = None) -> CorrectedData:
    """Read ``corrected.parquet`` and keep the spans whose correction converged, each averaged
    over its converged runs.

    Parameters
    ----------
    path : str or pathlib.Path
        Output of the correction rule: ``span_id``, ``w1_m`` … ``wn_m`` [m], ``converged``, one
        row per span and run (``run_id``); ``section_id``, ``start_chainage_m`` and
        ``end_chainage_m`` [m], when present, say which spans share a mast (other columns, e.g.
        ``gap_norm_m`` and ``iterations``, are only reported).
    span_type : SpanType
        Gives n, the number of ``w*_m`` columns expected.
    flagged : dict of str to str, optional
        Spans whose runs disagree beyond the repeatability (:mod:`catenary.repeatability`),
        with the reason: left out.

    Raises
    ------
    InputError
        If the file is unreadable, a column is missing, ``converged`` is not boolean, or a
        converged row has a missing or non-finite W; the message names the file, the column
        and the row.
    """
    df = read_table(path)
    w_cols = [f"w{i + 1}_m" for i in range(span_type.n_droppers)]
    missing = [c for c in (*_REQUIRED, *w_cols) if c not in df.columns]
    if missing:
        raise InputError(f"{path}: missing column(s) {', '.join(missing)}; expected span_id, "
                         f"{w_cols[0]} … {w_cols[-1]} [m] and converged (span type {span_type.name})")
    converged = df["converged"]
    if not (pd.api.types.is_bool_dtype(converged) and not converged.isna().any()):
        raise InputError(f"{path}: column converged: expected true/false on every row, got dtype {converged.dtype}")
    converged = converged.to_numpy(dtype=bool)
    w = df[w_cols].to_numpy(dtype=float, na_value=np.nan)
    bad = np.flatnonzero(converged & ~np.all(np.isfinite(w), axis=1))
    if bad.size:
        row = int(bad[0])
        col = w_cols[int(np.flatnonzero(~np.isfinite(w[row]))[0])]
        raise InputError(f"{path}: row {row + 1} (span {df['span_id'].iloc[row]}), column {col}: expected a "
                         f"finite deflection [m] on a converged span, got {w[row, w_cols.index(col)]!r}")
    flagged = flagged or {}
    several = "run_id" in df.columns and df["run_id"].nunique() > 1
    left_out = []
    for i in np.flatnonzero(~converged):
        why = "dynamic correction did not converge"
        if "gap_norm_m" in df.columns and np.isfinite(df["gap_norm_m"].iloc[i]):
            why += f" (gap norm {1e3 * float(df['gap_norm_m'].iloc[i]):.2f} mm"
            if "iterations" in df.columns:
                why += f" after {int(df['iterations'].iloc[i])} iterations"
            why += ")"
        if several:
            why = f"run {df['run_id'].iloc[i]}: {why}"
        left_out.append((str(df["span_id"].iloc[i]), why))
    used = df[converged].assign(**{c: w[converged][:, k] for k, c in enumerate(w_cols)})
    left_out += [(span, why) for span, why in flagged.items() if span in set(used["span_id"])]
    used = used[~used["span_id"].isin(list(flagged))]
    order = list(dict.fromkeys(used["span_id"]))
    groups = used.groupby("span_id", sort=False)
    mean_w = groups[w_cols].mean().loc[order].to_numpy(dtype=float)
    n_runs = groups.size().loc[order].to_numpy(dtype=int)
    pairs = None
    if all(c in df.columns for c in _ADJACENCY):
        place = groups.agg(section_id=("section_id", "first"), start=("start_chainage_m", "mean"),
                           end=("end_chainage_m", "mean")).loc[order]
        pairs = adjacent_span_pairs(place["section_id"], place["start"], place["end"],
                                    tolerance_m=_SHARED_MAST_TOLERANCE_M if several else 1e-3)
    return CorrectedData(w_m=mean_w, span_id=np.asarray(order, dtype=str), left_out=left_out, mast_pairs=pairs,
                         n_runs=n_runs)


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


def _hz_dict(values: np.ndarray, alpha: float, description: str) -> dict:
    x = np.asarray(values, dtype=float)
    out = {"sample": description}
    if x.shape[0] <= x.shape[1]:
        out.update(statistic=None, p_value=None, normal=None, alpha=float(alpha), n_samples=int(x.shape[0]),
                   dimension=int(x.shape[1]),
                   reason=f"{x.shape[0]} observations for {x.shape[1]} variables: the test needs more "
                          "observations than variables")
        return out
    try:
        r = henze_zirkler(x, alpha=alpha)
    except ValueError as exc:          # e.g. a singular covariance: fewer random inputs than droppers
        out.update(statistic=None, p_value=None, normal=None, alpha=float(alpha), n_samples=int(x.shape[0]),
                   dimension=int(x.shape[1]), reason=str(exc))
        return out
    out.update(statistic=r.statistic, p_value=r.p_value, normal=r.normal, alpha=r.alpha, n_samples=r.n_samples,
               dimension=r.dimension)
    return out


def normality_report(model: FastSpanModel, start: tuple[RandomInput, ...], result: IdentificationResult,
                     data_w_m: np.ndarray, *, n_samples: int = 10_000, seed: int = 0,
                     system_height_mode: str = "shared", alpha: float = 0.05) -> dict:
    """Henze–Zirkler test of the model law of W at s0 and at s_opt, and of the data.

    The model samples are i.i.d.: ``n_samples`` taut spans drawn by plain Monte Carlo from the
    Gamma laws (:func:`.synthetic.simulate_deflections`, seed ``seed``, the same draws at s0 and
    s_opt). The test's null distribution assumes independent observations: a scrambled Sobol
    design is far more even than a random sample and gives p ≈ 1 whatever the law (HZ ≈ 0.96 at
    N = 1e4 for N2, where i.i.d. samples give ≈ 1.0), and a Latin hypercube, stratified in every
    input, is more even than a random sample too; so the design of J is not what is tested.

    Parameters
    ----------
    model : FastSpanModel
        Fast model of the span type.
    start : tuple of RandomInput
        s0.
    result : IdentificationResult
        Gives s_opt.
    data_w_m : numpy.ndarray, shape (K, n)
        Measured W [m].
    n_samples : int
        Size of each model sample.
    seed : int
        Seed of the model samples.
    system_height_mode : {"shared", "independent"}
    alpha : float
        Level of the decisions ``normal``.

    Returns
    -------
    dict
        ``model_s0``, ``model_s_opt``, ``data``: each ``sample`` (description), ``statistic``,
        ``p_value``, ``normal`` (normality not rejected at ``alpha``), ``alpha``, ``n_samples``,
        ``dimension``; the statistic, p-value and decision are ``None`` (with a ``reason``) when
        there are no more observations than variables.
    """
    mu0 = np.array([s.mean for s in start])
    sd0 = np.array([s.sigma for s in start])
    what = f"{n_samples} i.i.d. taut spans (plain Monte Carlo, seed {seed})"
    draw = dict(n_spans=n_samples, seed=seed, system_height_mode=system_height_mode)
    return {
        "model_s0": _hz_dict(simulate_deflections(model, mu0, sd0, **draw), alpha, f"model W at s0: {what}"),
        "model_s_opt": _hz_dict(simulate_deflections(model, result.means, result.sigmas, **draw), alpha,
                                f"model W at s_opt: {what}"),
        "data": _hz_dict(data_w_m, alpha, "measured W (converged spans of corrected.parquet)"),
    }


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
        :func:`normality_report`.
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
        Wall time of the profile intervals [s].
    total_time_s : float
        Wall time of :func:`run_identification` (fast model, identification, normality,
        marginals, band) [s].
    noise_covariance_m2 : numpy.ndarray or None
        The measurement noise of one run in the likelihood [m²] (``measurement_noise``).
    n_runs : numpy.ndarray or None
        Runs averaged into each span's W.
    model_error : pandas.DataFrame or None
        The correction's model-error budget carried to the identified parameters
        (:func:`catenary.model_error.propagation.budget_table`); None when not measured.
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


def run_identification(span_type: SpanType, catenary: Catenary, data_w_m: np.ndarray,
                       settings: IdentificationSettings, *, left_out: list[tuple[str, str]] | None = None,
                       mast_pairs: np.ndarray | None = None, log: logging.Logger | None = None,
                       noise_covariance_m2: np.ndarray | None = None,
                       n_runs: np.ndarray | None = None,
                       w_shifts: SpanShifts | None = None) -> IdentificationRun:
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
        standard uncertainty (:func:`catenary.model_error.propagation.span_shifts`). Given, each
        source is carried to every identified μ and σ (:mod:`catenary.model_error.propagation`)
        and s_opt gets its total intervals.

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
                          n_runs=n_runs)
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
                      covariance=covariance, log=log)
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
        moved = parameter_shifts(problem, result.theta_opt, result.theta_covariance, w_shifts.w_m, s.hessian_step)
        budget = budget_table(problem, result.means, result.sigmas, [r.name for r in start], moved)
        for row in budget.itertuples():
            log.info("%s: model error: %s %s = %.6g, systematic %.3g (dominant: %s)", span_type.name, row.parameter,
                     row.statistic, row.estimate, row.systematic, row.dominant_source)
    elif w_shifts:
        log.warning("%s: no model-error budget of the parameters (%s)", span_type.name,
                    f"identification status {result.status}" if w_shifts.w_m else
                    "no source has a measured shift: " + "; ".join(f"{k}: {v}" for k, v in w_shifts.unmeasured.items()))
    t_profile = time.perf_counter()
    profiled = s.profile_names(n)
    profiles = []
    if profiled and result.status != "ok":
        # A profile needs the maximum and its curvature: none around a point that is neither.
        log.warning("%s: no profile intervals (status %s)", span_type.name, result.status)
    elif profiled:
        profiles = profile_intervals(lik, start, result, parameters=profiled, level=s.profile_level,
                                     max_evaluations=s.profile_max_evaluations)
    profile_time = time.perf_counter() - t_profile
    for p in profiles:
        log.info("%s: %s %s = %.6g, %.0f %% profile interval [%.6g, %.6g]%s (%d evaluations)", span_type.name,
                 p.parameter, p.statistic, p.estimate, 100 * s.profile_level, p.low, p.high,
                 ": consistent with no spread" if p.no_spread_detected else "", p.n_evaluations)
    log.info("%s: profile intervals of %d parameters in %.1f s", span_type.name, len(profiles), profile_time)
    normality = normality_report(lik.model, start, result, data, n_samples=s.normality_n_samples, seed=s.seed + 3,
                                 system_height_mode=s.system_height_mode, alpha=s.normality_alpha)
    for key, value in normality.items():
        log.info("%s: Henze–Zirkler %s: HZ = %s, p = %s", span_type.name, key, value["statistic"], value["p_value"])
    # Estimators figure: one design per N (seed + 2), same fast model, at s_opt.
    sample_opt = lik.model_sample(result.means, result.sigmas)
    fit_opt = fit_gaussian(sample_opt.w_m, sample_opt.weight)
    sd_opt = np.sqrt(np.sum(fit_opt.chol**2, axis=1))
    grid = fit_opt.mean + np.linspace(-4.5, 4.5, 181)[:, None] * sd_opt
    marginals = []
    dim = design_dimension(n, s.system_height_mode)
    for n_est in s.estimators_n_samples:
        est = Likelihood(lik.model, draw_unit_design(n_est, dim, method=s.design, seed=s.seed + 2), data,
                         system_height_mode=s.system_height_mode, bandwidth=s.bandwidth)
        m = marginal_densities(est.model_sample(result.means, result.sigmas), grid, s.bandwidth)
        marginals.append(m)
        log.info("%s: N = %d: mean L1 distance kernel–Gaussian over the droppers %.4f", span_type.name, n_est,
                 float(m.l1_distance.mean()))
    band = deflection_band(lik.model, result.means, result.sigmas, x_m=band_abscissae(span_type, s.band_n_points),
                           n_samples=s.band_n_samples, level=s.band_level, design_method=s.design, seed=s.seed + 1,
                           system_height_mode=s.system_height_mode)
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


def s_opt_table(result: IdentificationResult, profiles: list[ProfileInterval] = (),
                model_error: pd.DataFrame | None = None, profile_level: float = 0.95) -> pd.DataFrame:
    """s_opt with standard errors: columns ``parameter``, ``mu``, ``sigma``, ``mu_se``, ``sigma_se``,
    ``mu_fixed`` (SI, in the unit of each parameter's name; se 0 where not identified, NaN where
    the information is singular), ``mu_variance_widening`` and ``sigma_variance_widening`` (the
    factor ``max(λ, 1)`` by which the sandwich over spans sharing a mast widened the variance:
    1 for the observed information alone, NaN where not identified), the profile-likelihood
    interval ends ``mu_profile_low`` …
    ``sigma_profile_high`` (NaN where not profiled; ``sigma_profile_low`` = 0 when the interval
    reaches no spread), ``no_spread_detected`` (the σ interval reaches 0), ``converged`` and
    ``status`` (:attr:`.result.IdentificationResult.status`, the same on every row), then the
    correction's model error: ``mu_systematic``, ``sigma_systematic`` (one standard uncertainty)
    and the 95 % total intervals ``mu_total_low`` … ``sigma_total_high``
    (:func:`catenary.model_error.propagation.total_intervals`; NaN without a budget)."""
    rows = result.table_rows()
    by_key = {(p.parameter, p.statistic): p for p in profiles}
    widening = dict(zip(result.free_parameters, result.variance_widening))
    for row in rows:
        for statistic in ("mu", "sigma"):
            row[f"{statistic}_variance_widening"] = widening.get(f"{row['parameter']}.{statistic}", np.nan)
        for statistic in ("mu", "sigma"):
            p = by_key.get((row["parameter"], statistic))
            row[f"{statistic}_profile_low"] = p.low if p else np.nan
            row[f"{statistic}_profile_high"] = p.high if p else np.nan
        sigma = by_key.get((row["parameter"], "sigma"))
        row["no_spread_detected"] = bool(sigma.no_spread_detected) if sigma else False
    return total_intervals(pd.DataFrame(rows, columns=list(S_OPT_COLUMNS[:-6])), model_error,
                           profile_level)[list(S_OPT_COLUMNS)]


def trace_schema(parameters: tuple[str, ...] | list[str]) -> pa.Schema:
    """Arrow schema of the J trace: ``evaluation``, ``j``, then ``mu_<input>``, ``sigma_<input>``
    per input (the unit is the input's, read from the name's suffix)."""
    fields = [pa.field("evaluation", pa.int64(), nullable=False), pa.field("j", pa.float64(), nullable=False)]
    for name in parameters:
        fields += [pa.field(f"mu_{name}", pa.float64(), nullable=False),
                   pa.field(f"sigma_{name}", pa.float64(), nullable=False)]
    return pa.schema(fields)


def trace_table(result: IdentificationResult) -> pd.DataFrame:
    """Every optimiser evaluation of J, in order: s (means and σ of every input) and J
    (−inf where the model sample was unusable). The Hessian's evaluations are not included."""
    names = [e.parameter for e in result.estimates]
    columns = {"evaluation": np.arange(1, result.n_evaluations + 1, dtype=np.int64), "j": result.trace_j}
    for k, name in enumerate(names):
        columns[f"mu_{name}"] = result.trace_means[:, k]
        columns[f"sigma_{name}"] = result.trace_sigmas[:, k]
    return pd.DataFrame(columns)


# --- Markdown report ------------------------------------------------------------------------

def _label(name: str) -> tuple[str, str, float, str, float]:
    """Display name, unit and scale of μ, unit and scale of σ for an input name."""
    if name == MESSENGER_TENSION:
        return "T_MW", "N", 1.0, "N", 1.0
    if name == SYSTEM_HEIGHT:
        return "ΔH", "m", 1.0, "mm", 1e3
    return f"L_drop,{name.split('_')[1]}", "m", 1.0, "mm", 1e3


def _fmt(value: float, unit: str) -> str:
    if value is None or not np.isfinite(value):
        return "–"
    if unit == "N":
        return f"{value:.0f}"
    if unit == "m":
        return f"{value:.5f}"
    return f"{value:.2f}"


def _p(value) -> str:
    return "–" if value is None else f"{value:.3g}"


def markdown_report(run: IdentificationRun, *, source: str = "corrected.parquet",
                    figures: tuple[str, str] = ("estimators.png", "band.png")) -> str:
    """The identification report of one span type (Markdown).

    A Table-2-style table of s_opt (μ, σ, standard errors, what was identified), the run's
    figures (data, settings, evaluation counts, wall time, J at s0 and s_opt, how the standard
    errors were computed), the normality tests, the estimator comparison and the band.
    """
    r, s, st = run.result, run.settings, run.span_type
    n = st.n_droppers
    random = set(s.random_names(n))
    lines = [f"# Stochastic identification — span type {st.name}", ""]
    if r.status != "ok":
        why = (f"the {r.method} optimiser did NOT converge ({r.message}); s_opt below is only the best point "
               "evaluated" if not r.converged else
               "the observed information is not positive definite at s_opt: no standard errors")
        lines += [f"> **Status: {r.status}** — {why}. Do not use these laws as identified.", ""]
    lines += [f"Maximum likelihood of the measured static deflections W under independent Gamma inputs "
              f"(paper §3). Data: {run.data_w_m.shape[0]} spans from `{source}` (converged "
              f"correction); {len(run.left_out)} left out.", ""]
    runs = run.n_runs if run.n_runs is not None else np.ones(run.data_w_m.shape[0], dtype=int)
    if runs.max() > 1:
        counts = ", ".join(f"{int((runs == k).sum())} spans × {k} run(s)" for k in np.unique(runs))
        lines += [f"Several runs: each span's W is the mean of its converged runs ({counts}).", ""]
    if run.noise_covariance_m2 is not None:
        lines += [f"Measurement noise in the likelihood (`measurement_noise: {s.measurement_noise}`): "
                  f"{1e3 * float(np.sqrt(np.mean(np.diag(run.noise_covariance_m2)))):.3f} mm RMS per dropper and run, "
                  "divided by each span's number of runs; the dropper σ are the geometry's alone.", ""]
    else:
        lines += ["No measurement noise in the likelihood (one run, or `measurement_noise: none`): the "
                  "measured W's own error (≈ 0.4–0.6 mm) is in the dropper σ.", ""]
    for span_id, why in run.left_out:
        lines.append(f"- left out {span_id}: {why}")
    if run.left_out:
        lines.append("")
    lines += ["## s_opt (paper Table 2)", "",
              "| parameter | μ | se(μ) | σ | se(σ) | μ unit | σ unit | s0: μ | s0: σ | identified |",
              "|---|---:|---:|---:|---:|---|---|---:|---:|---|"]
    for e, s0 in zip(r.estimates, run.start):
        label, mu_unit, mu_scale, sd_unit, sd_scale = _label(e.parameter)
        what = ["μ fixed at s0" if e.mu_fixed else "μ",
                "σ" if e.parameter in random else "deterministic (σ ≈ 0)"]
        lines.append(
            f"| {label} | {_fmt(e.mu * mu_scale, mu_unit)} | "
            f"{'–' if e.mu_fixed else _fmt(e.mu_se * mu_scale, mu_unit)} | "
            f"{_fmt(e.sigma * sd_scale, sd_unit) if e.parameter in random else '0'} | "
            f"{_fmt(e.sigma_se * sd_scale, sd_unit) if e.parameter in random else '–'} | {mu_unit} | {sd_unit} | "
            f"{_fmt(s0.mean * mu_scale, mu_unit)} | "
            f"{_fmt(s0.sigma * sd_scale, sd_unit) if e.parameter in random else '0'} | {', '.join(what)} |")
    mode = ("one ΔH per span, used at both masts (ΔH_left = ΔH_right)" if s.system_height_mode == "shared" else
            "ΔH_left and ΔH_right independent draws of the same ΔH law (one law per mast)")
    span = ("the span as it hangs in the line: the central one of "
            f"{2 * s.neighbours + 1} identical spans, both wires continuous over its masts, neighbours at the "
            "nominal table" if s.neighbours else "one span pinned at its masts (the paper's model)")
    lines += ["", f"ΔH law: {mode}. Span model: {span}. se: standard error. The machine-readable table is "
              "`s_opt.csv` (SI).", ""]
    if run.profiles:
        wald = {(w["parameter"], k): (w[f"{k}_low"], w[f"{k}_high"]) for w in r.intervals(s.profile_level)
                for k in ("mu", "sigma")}
        lines += [f"## {100 * s.profile_level:.0f} % intervals", "",
                  "Profile likelihood (the other parameters re-optimised at each value, same design) beside the "
                  "Wald interval of the standard errors (log scale for σ, which can never reach 0). A σ whose "
                  "profile interval reaches 0 is consistent with no spread of that input.", "",
                  "| parameter | statistic | estimate | profile interval | Wald interval | unit | verdict |",
                  "|---|---|---:|---|---|---|---|"]
        for p in run.profiles:
            label, mu_unit, mu_scale, sd_unit, sd_scale = _label(p.parameter)
            unit, scale = (mu_unit, mu_scale) if p.statistic == "mu" else (sd_unit, sd_scale)
            lo, hi = wald[(p.parameter, p.statistic)]
            verdict = ("consistent with no spread" if p.no_spread_detected else
                       "spread detected" if p.statistic == "sigma" else "")
            if p.high_at_boundary or (p.low_at_boundary and p.statistic == "mu"):
                verdict += " (interval reaches the edge of the admissible box)"
            lines.append(f"| {label} | {'μ' if p.statistic == 'mu' else 'σ'} | {_fmt(p.estimate * scale, unit)} | "
                         f"[{_fmt(p.low * scale, unit)}, {_fmt(p.high * scale, unit)}] | "
                         f"[{_fmt(lo * scale, unit)}, {_fmt(hi * scale, unit)}] | {unit} | {verdict} |")
        lines += ["", f"{sum(p.n_evaluations for p in run.profiles)} J evaluations, {run.profile_time_s:.1f} s.", ""]
    lines += model_error_lines(run.model_error, s_opt_table(r, run.profiles, run.model_error, s.profile_level),
                               run.model_error_shifts, run.data_w_m.shape[0], _label)
    lines += ["## Run", "",
              "| item | value |", "|---|---|",
              f"| spans used | {run.data_w_m.shape[0]} |",
              f"| estimator of p_W | {s.estimator}" + (f" (bandwidth rule {s.bandwidth})" if s.estimator == "kernel" else "") + " |",
              f"| design | {s.design}, N = {s.n_samples}, seed {s.seed} (common random numbers: J(s) deterministic) |",
              f"| optimiser | {r.method} (initial step {s.initial_step} in θ, budget {s.max_evaluations}); "
              f"{'converged' if r.converged else 'NOT converged'}: {r.message} |",
              f"| free parameters | {len(r.free_parameters)}: {', '.join(r.free_parameters)} |",
              f"| J evaluations | {r.n_evaluations} by the optimiser (all in `trace.parquet`) + "
              f"{r.n_hessian_evaluations} for the standard errors = {r.n_evaluations + r.n_hessian_evaluations} |",
              f"| wall time | {run.identification_time_s:.1f} s optimisation and standard errors; "
              f"{run.total_time_s:.1f} s with fast model, normality tests, estimators and band |",
              f"| J(s0) | {run.j_start:.3f} |",
              f"| J(s_opt) | {r.j_opt:.3f} |",
              f"| slack fraction at s_opt | {r.slack_fraction:.4f} (model samples with a slack dropper, "
              f"tapered out of p_W) |", ""]
    lines += ["Standard errors: observed information — the Hessian H of J in the optimiser's coordinates θ "
              f"(μ = μ0 + σ0 θ_μ, σ = σ0 exp θ_σ) by central finite differences at s_opt (step {s.hessian_step}), "
              "covariance (−H)⁻¹, delta method back to μ and σ (the profile-likelihood intervals are above). "
              "They are conditional on the design (the Monte Carlo error of a finite N is not included) and are "
              "blank (–) where −H is not positive definite.", ""]
    if r.at_lower_bound:
        names = ", ".join(f"{_label(p.rsplit('.', 1)[0])[0]} σ" for p in r.at_lower_bound)
        lines += [f"{names}: at the lower edge of the admissible box (σ0/50, a spread W cannot resolve), on the "
                  "boundary of the parameter space where J is flat: no standard error (–); the profile interval "
                  "is the one to read. The other standard errors come from the information of the other "
                  "parameters.", ""]
    if r.covariance == "sandwich" and r.sandwich_available:
        widening = dict(zip(r.free_parameters, r.variance_widening))
        widened = [f"{_label(p.rsplit('.', 1)[0])[0]} {'μ' if p.endswith('.mu') else 'σ'} ×{w:.2f}"
                   for p, w in widening.items() if w > 1.0]
        lines += ["Spans that share a mast are not independent: every variance above is the observed "
                  "information's widened by the sandwich H⁻¹KH⁻¹ (K from the per-span scores, with the cross "
                  "terms of the " + f"{r.n_mast_pairs} pairs of spans sharing a mast) where that is wider; the "
                  "profile intervals' critical drop is widened by the same factor. Variance factors: "
                  + (", ".join(widened) if widened else "none above 1") + " (`*_variance_widening` in `s_opt.csv`).", ""]
    else:
        lines += ["The spans are treated as independent (observed information alone"
                  + (": the data do not say which spans share a mast)." if s.standard_errors == "sandwich" else
                     ", `identification.standard_errors: observed_information`).") , ""]
    lines += ["## Normality of W (Henze–Zirkler)", "",
              f"Model samples: i.i.d. Monte Carlo draws of taut spans (seed {s.seed + 3}), not the design of J "
              "(a Sobol design is too even for the test's null law and would always pass).", "",
              "| sample | n | HZ | p-value | normal at α |", "|---|---:|---:|---:|---|"]
    for key, label in (("model_s0", "model at s0"), ("model_s_opt", "model at s_opt"), ("data", "measured")):
        v = run.normality[key]
        verdict = "–" if v["normal"] is None else ("not rejected" if v["normal"] else "rejected")
        lines.append(f"| {label} | {v['n_samples']} | {_p(v['statistic'])} | {_p(v['p_value'])} | "
                     f"{verdict} (α = {v['alpha']}) |")
    lines += ["", "## Gaussian against kernel estimate (paper Fig. 7)", "",
              f"Marginals of W at the droppers at s_opt, one design per N ({s.design}, seed {s.seed + 2}). "
              "L1 distance ∫|p_kernel − p_Gauss| dW (0: identical, 2: disjoint).", "",
              "| N | effective N | mean L1 over droppers | max L1 |", "|---:|---:|---:|---:|"]
    for m in run.marginals:
        lines.append(f"| {m.n_samples} | {m.n_effective:.0f} | {m.l1_distance.mean():.4f} | {m.l1_distance.max():.4f} |")
    b = run.band
    width = 1e3 * (b.upper_m - b.lower_m)
    widest = int(np.argmax(width))
    lines += ["", f"![Gaussian and kernel marginals]({figures[0]})", "",
              f"## {100 * b.level:.0f} % band of the CW deflection (paper Fig. 10)", "",
              f"Pointwise quantiles {50 * (1 - b.level):.0f} % and {50 * (1 + b.level):.0f} % of the CW deflection "
              f"from the chord at {b.x_m.size} points along the span, from {b.n_samples} samples of the inputs "
              f"at s_opt ({s.design}, seed {s.seed + 1}; {b.n_slack} with a slack dropper dropped), each solved "
              f"by the static model of one span. Largest width {width[widest]:.1f} mm, at x = {b.x_m[widest]:.2f} m.", "",
              "| dropper | x [m] | lower [mm] | upper [mm] | measured W inside |", "|---:|---:|---:|---:|---:|"]
    at = np.searchsorted(b.x_m, st.dropper_positions_m)
    for i, (x, k) in enumerate(zip(st.dropper_positions_m, at)):
        lines.append(f"| {i + 1} | {x:.2f} | {1e3 * b.lower_m[k]:.1f} | {1e3 * b.upper_m[k]:.1f} | "
                     f"{100 * run.data_in_band[i]:.1f} % |")
    lines += ["", f"![{100 * b.level:.0f} % band]({figures[1]})", ""]
    return "\n".join(lines)
