"""Maximum-likelihood identification of the input laws: s_opt = argmax J(s) (paper eq. 6).

Parameterisation
----------------
Around the starting laws s0 (means μ0, standard deviations σ0), each free mean and σ gets a
dimensionless coordinate of order one:

    μ = μ0 + σ0 θ_μ        (i.e. μ = μ0 (1 + δ) with δ = θ_μ σ0/μ0: the shift in starting σ;
                            a deterministic input's free mean moves in units of 1 % of μ0)
    σ = σ0 exp(θ_σ)

Which means are free is configurable; the default frees the T_MW and ΔH means and fixes the
dropper means at their start (the nominal table), as the paper does to avoid the T_MW /
dropper-length trade-off, and frees every σ (13 parameters for 9 droppers). The coordinates are
kept in a box (:class:`ParameterBox`: means within ±15 %, σ within [σ0/50, 20 σ0] and σ/μ ≤ 0.1).

Optimisers
----------
``"nelder-mead"`` (the paper's; SciPy, adaptive coefficients, bounded) and ``"bobyqa"``
(OpenTURNS ``NLopt("LN_BOBYQA")``, bounded quadratic-model trust region). Both minimise −J; an
infeasible point (J = −inf) is given a large finite penalty. Every evaluation (s, J) is recorded.

Standard errors
---------------
From the observed information: the Hessian H of J in θ at θ_opt by central finite differences
(step ``hessian_step`` in θ, default 0.01: the standard errors change by < 1 % between 0.005
and 0.02; 2p + 2p(p−1) + 1 evaluations), covariance ``C = (−H)⁻¹`` and the
delta method back to (μ, σ): ``se(μ) = σ0 √C_μμ``, ``se(σ) = σ̂ √C_σσ``. They are conditional on
the design (the Monte Carlo error of a finite N is not included) and are NaN when −H is not
positive definite. :meth:`IdentificationResult.intervals` builds the Wald intervals in θ (log
scale for σ). On synthetic Table 2 data the sandwich (misspecification-robust) standard errors
agree with these within ≈ 5 % on average, so the Gaussian law of W is not a source of error.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize

from catenary.physics.config import Catenary, SpanType
from catenary.physics.fast import SAMPLING_DEGREE, FastSpanModel
from catenary.plumbing.progress import Progress
from catenary.plumbing.workers import map_each
from .design import (DEFAULT_DESIGN, MESSENGER_TENSION, SYSTEM_HEIGHT, RandomInput, default_inputs,
                     design_dimension, draw_unit_design)
from .dependence import robust_covariance, widened_covariance
from .likelihood import Likelihood, LikelihoodValue
from .result import IdentificationResult, ParameterEstimate

__all__ = ["COVARIANCES", "METHODS", "ParameterBox", "ScaledProblem", "evaluate_points", "hessian_points", "identify",
           "make_likelihood", "messenger_tension_bounds_n", "observed_covariance", "observed_information",
           "run_nelder_mead"]

METHODS = ("nelder-mead", "bobyqa")
COVARIANCES = ("observed_information", "sandwich")
DEFAULT_FREE_MEANS = (MESSENGER_TENSION, SYSTEM_HEIGHT)
#: A start σ below this fraction of its mean marks a deterministic input (settings.DETERMINISTIC_CV = 1e-9) ...
DETERMINISTIC_SCALE_CV = 1e-6
#: ... whose free mean then moves in units of this fraction of its start value.
DETERMINISTIC_MEAN_STEP = 0.01
#: Objective value (−J) given to the optimisers where J = −inf.
_PENALTY = 1e10


@dataclass(frozen=True)
class ParameterBox:
    """Admissible hyper-parameters around the start s0.

    Attributes
    ----------
    mean_range : float
        Means within ``μ0 (1 ± mean_range)``.
    sigma_ratio_range : (float, float)
        σ within ``σ0 × [lo, hi]``.
    max_cv : float
        σ ≤ ``max_cv × μ0 (1 − mean_range)`` (the Cornish–Fisher fast path covers σ/μ ≤ 0.1).
    """

    mean_range: float = 0.15
    sigma_ratio_range: tuple[float, float] = (0.02, 20.0)
    max_cv: float = 0.1

    def mean_bounds(self, start: RandomInput) -> tuple[float, float]:
        return start.mean * (1.0 - self.mean_range), start.mean * (1.0 + self.mean_range)

    def sigma_bounds(self, start: RandomInput) -> tuple[float, float]:
        lo = start.sigma * self.sigma_ratio_range[0]
        hi = min(start.sigma * self.sigma_ratio_range[1], self.max_cv * self.mean_bounds(start)[0])
        if not lo < start.sigma <= hi:
            raise ValueError(f"{start.name}: starting sigma {start.sigma} outside the box [{lo}, {hi}]")
        return lo, hi


def messenger_tension_bounds_n(start: tuple[RandomInput, ...], box: ParameterBox = ParameterBox(), *,
                               eps: float = 1e-9, margin: float = 0.05) -> tuple[float, float]:
    """T_MW range [N] a fast model needs to serve every law of the box.

    The extreme quantiles ``F⁻¹(eps)``, ``F⁻¹(1 − eps)`` at the corners of the (μ, σ) box of
    T_MW, widened by ``margin`` (room for the Hessian steps).
    """
    t = next(s for s in start if s.name == MESSENGER_TENSION)
    corners = [RandomInput(t.name, m, s) for m in box.mean_bounds(t) for s in box.sigma_bounds(t)]
    lo = min(float(c.quantile(eps)) for c in corners)
    hi = max(float(c.quantile(1.0 - eps)) for c in corners)
    return lo * (1.0 - margin), hi * (1.0 + margin)


def make_likelihood(span_type: SpanType, catenary: Catenary, data_w_m: np.ndarray, *,
                    start: tuple[RandomInput, ...] | None = None, n_samples: int = 10_000,
                    design_method: str = DEFAULT_DESIGN, seed: int = 0, system_height_mode: str = "shared",
                    box: ParameterBox = ParameterBox(), degree: int = SAMPLING_DEGREE, eps: float = 1e-9, neighbours: int = 1,
                    **likelihood_options) -> Likelihood:
    """Build the fast model (T_MW range from the box), draw the design once, return J.

    ``likelihood_options`` go to :class:`~.likelihood.Likelihood` (``estimator``, ...). The
    Chebyshev degree :data:`~catenary.physics.fast.SAMPLING_DEGREE` keeps the fast model within 5e-8 m
    over the wide T_MW range.
    ``neighbours``: the span model (:class:`~catenary.physics.fast.FastSpanModel`; 1, the span in the
    line with wires continuous over its masts; 0, the paper's pinned span).
    """
    start = default_inputs(span_type, catenary) if start is None else start
    bounds = messenger_tension_bounds_n(start, box, eps=eps)
    model = FastSpanModel(span_type, catenary, messenger_tension_bounds_n=bounds, degree=degree,
                          neighbours=neighbours)
    design = draw_unit_design(n_samples, design_dimension(span_type.n_droppers, system_height_mode),
                              method=design_method, seed=seed, eps=eps)
    return Likelihood(model, design, data_w_m, system_height_mode=system_height_mode, **likelihood_options)


@dataclass
class ScaledProblem:
    """J in the optimiser's coordinates θ (module docstring): θ ↔ (means, sigmas), the J trace.

    Attributes
    ----------
    likelihood : Likelihood
    start : tuple of RandomInput
        s0, in design order.
    free_mean_idx, free_sigma_idx : numpy.ndarray of int
        Inputs whose mean / σ are coordinates of θ (means first, then σ).
    trace : list
        ``(θ, means, sigmas, J)`` of every evaluation while ``recording``.
    n_evaluations : int
        Evaluations of J so far (recorded or not).
    progress : Progress or None
        Where the recorded evaluations are reported (:mod:`catenary.plumbing.progress`), with ``best_j``,
        the largest finite J recorded so far.
    """

    likelihood: Likelihood
    start: tuple[RandomInput, ...]
    free_mean_idx: np.ndarray
    free_sigma_idx: np.ndarray
    trace: list = field(default_factory=list)
    recording: bool = True
    n_evaluations: int = 0
    progress: Progress | None = None
    best_j: float = -np.inf

    def __post_init__(self):
        self.mu0 = np.array([s.mean for s in self.start])
        self.sd0 = np.array([s.sigma for s in self.start])
        # A free mean moves in units of its start σ; a deterministic input (σ = 1e-9 μ, not
        # random) whose mean is free moves in units of 1 % of it, or finite differences of J
        # along it would be below rounding.
        self.mean_scale = np.where(self.sd0 > DETERMINISTIC_SCALE_CV * self.mu0, self.sd0,
                                   DETERMINISTIC_MEAN_STEP * self.mu0)

    def laws(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        nm = self.free_mean_idx.size
        means, sigmas = self.mu0.copy(), self.sd0.copy()
        means[self.free_mean_idx] += self.mean_scale[self.free_mean_idx] * theta[:nm]
        sigmas[self.free_sigma_idx] *= np.exp(theta[nm:])
        return means, sigmas

    def evaluate(self, theta: np.ndarray) -> LikelihoodValue:
        """J and its diagnostics at θ (:class:`~.likelihood.LikelihoodValue`); traced as :meth:`j`."""
        theta = np.array(theta, dtype=float)
        return self._record(theta, self.likelihood.evaluate(*self.laws(theta)))

    def _record(self, theta: np.ndarray, result: LikelihoodValue, traced: bool = True) -> LikelihoodValue:
        """Count an evaluation at θ and, while ``recording`` (and ``traced``), trace it."""
        self.n_evaluations += 1
        if traced and self.recording:
            means, sigmas = self.laws(theta)
            self.trace.append((theta, means, sigmas, result.j))
            if self.progress is not None:
                if np.isfinite(result.j) and result.j > self.best_j:
                    self.best_j = result.j
                self.progress.update(len(self.trace), f"best J so far {self.best_j:.3f}")
        return result

    def evaluate_many(self, thetas, workers: int = 1, traced: bool = True) -> list[LikelihoodValue]:
        """:meth:`evaluate` at each θ of ``thetas``, in ``workers`` processes
        (:func:`evaluate_points`); counted and traced here in their order, as one after the other."""
        thetas = [np.array(t, dtype=float) for t in thetas]
        values = evaluate_points(lambda t: self.likelihood.evaluate(*self.laws(t)), thetas, workers)
        return [self._record(t, v, traced) for t, v in zip(thetas, values)]

    def j(self, theta: np.ndarray) -> float:
        return self.evaluate(theta).j

    def log_densities(self, theta: np.ndarray) -> np.ndarray | None:
        """``ln p_W(W_k; s(θ))`` per measured span (None where J is not finite); not traced."""
        self.n_evaluations += 1
        return self.likelihood.evaluate(*self.laws(np.asarray(theta, dtype=float))).log_density

    def log_densities_many(self, thetas, workers: int = 1) -> list[np.ndarray | None]:
        """:meth:`log_densities` at each θ of ``thetas`` in ``workers`` processes."""
        return [v.log_density for v in self.evaluate_many(thetas, workers, traced=False)]

    def objective(self, theta) -> float:
        value = self.j(theta)
        return -value if np.isfinite(value) else _PENALTY

    @classmethod
    def for_inputs(cls, likelihood: Likelihood, start: tuple[RandomInput, ...], free_means: tuple[str, ...],
                   free_sigmas: tuple[str, ...]) -> "ScaledProblem":
        """The problem whose coordinates are the named free means and σ."""
        names = [s.name for s in start]
        return cls(likelihood, tuple(start), np.array([i for i, n in enumerate(names) if n in free_means], dtype=int),
                   np.array([i for i, n in enumerate(names) if n in free_sigmas], dtype=int))

    def bounds(self, box: "ParameterBox") -> tuple[np.ndarray, np.ndarray]:
        """The box in θ: lower and upper bounds of every coordinate."""
        lo, hi = [], []
        for i in self.free_mean_idx:
            a, b = box.mean_bounds(self.start[i])
            lo.append((a - self.mu0[i]) / self.mean_scale[i])
            hi.append((b - self.mu0[i]) / self.mean_scale[i])
        for i in self.free_sigma_idx:
            a, b = box.sigma_bounds(self.start[i])
            lo.append(np.log(a / self.sd0[i]))
            hi.append(np.log(b / self.sd0[i]))
        return np.array(lo), np.array(hi)


#: J evaluations per block of :func:`evaluate_points`' worker processes.
POINTS_PER_BLOCK = 8


def evaluate_points(function, points: list, workers: int = 1) -> list:
    """``function(θ)`` at each of ``points``, in order, over blocks of :data:`POINTS_PER_BLOCK`
    in ``workers`` forked processes (:func:`catenary.plumbing.workers.map_each`): a J is the
    same computation in any process, so the values are the same, bit for bit, for any number.
    What ``function`` changes in a worker (counters, traces) stays there: the caller records."""
    return map_each(lambda k: function(points[k]), len(points), workers, POINTS_PER_BLOCK)


def hessian_points(theta: np.ndarray, step: float) -> list[np.ndarray]:
    """The points :func:`observed_information` evaluates J at, in its order: θ, then per
    coordinate i, θ ± h e_i and, for each k < i, θ + h e_i + h e_k, θ + h e_i − h e_k,
    θ − h e_i + h e_k, θ − h e_i − h e_k."""
    e = np.eye(theta.size) * step
    points = [theta]
    for i in range(theta.size):
        points += [theta + e[i], theta - e[i]]
        for k in range(i):
            points += [theta + e[i] + e[k], theta + e[i] - e[k], theta - e[i] + e[k], theta - e[i] - e[k]]
    return points


def observed_information(j, theta: np.ndarray, step: float, j_many=None) -> np.ndarray:
    """−H: minus the central finite-difference Hessian of ``j`` at ``theta``.

    Diagonal: ``(J(θ+h e_i) − 2J(θ) + J(θ−h e_i)) / h²``; off-diagonal:
    ``(J(++) − J(+−) − J(−+) + J(−−)) / (4h²)``. ``j_many``, given, takes the list of
    :func:`hessian_points` and returns their J at once (e.g. in worker processes); else ``j``
    is called at each in turn.
    """
    p = theta.size
    points = hessian_points(theta, step)
    values = iter(j_many(points) if j_many is not None else [j(x) for x in points])
    j0 = next(values)
    h = np.empty((p, p))
    for i in range(p):
        h[i, i] = (next(values) - 2.0 * j0 + next(values)) / step**2
        for k in range(i):
            h[i, k] = h[k, i] = (next(values) - next(values) - next(values) + next(values)) / (4.0 * step**2)
    return -h


def run_nelder_mead(problem, theta0, lo, hi, initial_step, max_evaluations, xtol, ftol):
    """SciPy's bounded adaptive Nelder–Mead on ``problem.objective`` from ``theta0``; the
    initial simplex steps ``initial_step`` (a number or one per coordinate) inwards from the
    bounds. Returns (converged, message)."""
    steps = np.where(theta0 + initial_step <= hi, initial_step, -initial_step)
    simplex = np.vstack([theta0, theta0 + np.diag(steps)])
    res = minimize(problem.objective, theta0, method="Nelder-Mead", bounds=list(zip(lo, hi)),
                   options=dict(initial_simplex=simplex, xatol=xtol, fatol=ftol,
                                maxfev=max_evaluations, adaptive=True))
    return bool(res.success), str(res.message)


def _run_bobyqa(problem, theta0, lo, hi, initial_step, max_evaluations, xtol, ftol):
    import openturns as ot              # only BOBYQA needs it (0.4 s of a job's imports otherwise)
    fn = ot.PythonFunction(lo.size, 1, lambda x: [problem.objective(np.array(x))])
    ot_problem = ot.OptimizationProblem(fn)
    ot_problem.setBounds(ot.Interval(lo.tolist(), hi.tolist()))
    solver = ot.NLopt(ot_problem, "LN_BOBYQA")
    solver.setStartingPoint(theta0.tolist())
    solver.setInitialStep([initial_step] * lo.size)
    solver.setMaximumCallsNumber(max_evaluations)
    solver.setMaximumAbsoluteError(xtol)
    solver.setMaximumRelativeError(0.0)
    j_start = problem.likelihood(*problem.laws(theta0))
    solver.setMaximumResidualError(ftol / max(1.0, abs(j_start)) if np.isfinite(j_start) else 0.0)
    solver.run()
    message = str(solver.getResult().getStatusMessage())
    converged = len(problem.trace) < max_evaluations and "MAXEVAL" not in message
    return converged, message or ("converged" if converged else "evaluation budget reached")


def observed_covariance(problem, theta_opt, step, interior, workers: int = 1):
    """``problem.j``'s (−H)⁻¹ in θ over the ``interior`` coordinates (rows and columns of the others NaN; all NaN
    if that block of −H is not positive definite) and the number of J evaluations; J at the
    Hessian's points in ``workers`` processes (``problem.evaluate_many``)."""
    theta = np.asarray(theta_opt, dtype=float)
    info = observed_information(problem.j, theta, step, j_many=lambda x: [v.j for v in problem.evaluate_many(x, workers)])
    cov = np.full(info.shape, np.nan)
    block = info[np.ix_(interior, interior)]
    if np.all(np.isfinite(block)):
        try:
            np.linalg.cholesky(block)
            cov[np.ix_(interior, interior)] = np.linalg.inv(block)
        except np.linalg.LinAlgError:
            pass
    return cov, 1 + 2 * theta.size ** 2          # len(hessian_points): θ, 2p, and 4 for each of p(p − 1)/2 pairs


def identify(likelihood: Likelihood, start: tuple[RandomInput, ...], *,
             free_means: tuple[str, ...] = DEFAULT_FREE_MEANS, free_sigmas: tuple[str, ...] | None = None,
             method: str = "nelder-mead", box: ParameterBox = ParameterBox(), initial_step: float = 0.5,
             max_evaluations: int = 6000, xtol: float | None = None, ftol: float | None = None,
             standard_errors: bool = True, hessian_step: float = 0.01, mast_pairs: np.ndarray | None = None,
             covariance: str = "observed_information", log=None, workers: int = 1) -> IdentificationResult:
    """Maximise J over the free hyper-parameters, from the laws ``start``.

    Parameters
    ----------
    likelihood : Likelihood
        J(s) (fixed design, data, estimator).
    start : tuple of RandomInput
        s0 in design order (droppers, T_MW, ΔH); fixed means stay at their start.
    free_means : tuple of str
        Inputs whose mean is identified (default T_MW and ΔH).
    free_sigmas : tuple of str, optional
        Inputs whose σ is identified (default: all).
    method : {"nelder-mead", "bobyqa"}
    box : ParameterBox
        Admissible region (see :class:`ParameterBox`).
    initial_step : float
        Initial simplex / trust-region size in θ.
    max_evaluations : int
        Budget of J evaluations of the optimiser.
    xtol : float, optional
        Convergence tolerance on θ (absolute); default 1e-3 for Nelder–Mead (with ``ftol``,
        both must hold) and 1e-5 for BOBYQA (whose looser stops end short of the maximum).
    ftol : float, optional
        Convergence tolerance on J (absolute); default 1e-4 for Nelder–Mead, unused (0) for
        BOBYQA, where NLopt's relative criterion is set to ``ftol / |J(s0)|``.
    standard_errors : bool
        Compute the observed-information standard errors (module docstring).
    hessian_step : float
        Finite-difference step in θ.
    mast_pairs : numpy.ndarray of int, shape (P, 2), optional
        Rows of the data that share a mast (:func:`.dependence.adjacent_span_pairs`; empty for
        independent spans). Given, the sandwich covariance ``H⁻¹ K H⁻¹`` is computed too
        (2p more evaluations of J).
    covariance : {"observed_information", "sandwich"}
        Where the standard errors come from: the observed information, or the observed
        information with each variance widened by the sandwich where that is wider
        (:func:`.dependence.widened_covariance`; needs ``mast_pairs``).
    workers : int
        Processes that share each of the optimiser's J evaluations (:meth:`.Likelihood.parallel`)
        and over which the J evaluations of the standard errors are spread (the Hessian's and
        the sandwich's points, :func:`evaluate_points`): the same s_opt and standard errors for
        any number.
    log : logging.Logger, optional
        Where the optimiser's progress goes (evaluations against the budget, elapsed time).

    Returns
    -------
    IdentificationResult
    """
    if method not in METHODS:
        raise ValueError(f"method: expected one of {METHODS}, got {method!r}")
    if covariance not in COVARIANCES:
        raise ValueError(f"covariance: expected one of {COVARIANCES}, got {covariance!r}")
    if covariance == "sandwich" and mast_pairs is None:
        raise ValueError("covariance='sandwich' needs mast_pairs (an empty array for independent spans)")
    if xtol is None:
        xtol = 1e-3 if method == "nelder-mead" else 1e-5
    if ftol is None:
        ftol = 1e-4 if method == "nelder-mead" else 0.0
    names = [s.name for s in start]
    unknown = (set(free_means) | set(free_sigmas or ())) - set(names)
    if unknown:
        raise ValueError(f"unknown inputs {sorted(unknown)}; inputs are {names}")
    free_sigmas = tuple(names) if free_sigmas is None else free_sigmas
    problem = ScaledProblem.for_inputs(likelihood, start, free_means, free_sigmas)
    problem.progress = Progress(log, f"{method} optimiser", max_evaluations, "evaluations", bound=True)
    lo, hi = problem.bounds(box)
    theta0 = np.clip(np.zeros(lo.size), lo, hi)
    t_start = time.perf_counter()
    run = run_nelder_mead if method == "nelder-mead" else _run_bobyqa
    with likelihood.parallel(workers):         # J after J: each J's model sample shared by the workers
        converged, message = run(problem, theta0, lo, hi, initial_step, max_evaluations, xtol, ftol)
    # s_opt: the best evaluated point (what both optimisers return, up to ties).
    trace = list(problem.trace)
    n_eval = len(trace)
    best = int(np.argmax([t[3] for t in trace]))
    theta_opt, means_opt, sigmas_opt, j_opt = trace[best]
    problem.recording = False
    # A σ at the lower edge of the box (σ0/50: a spread W cannot resolve) sits on the boundary of
    # the parameter space, where J is flat in it and −H singular: its standard error is not
    # defined (the profile interval, which then reaches 0, is the one to read) and the others'
    # come from the information of the interior coordinates.
    nm = problem.free_mean_idx.size
    interior = np.ones(theta_opt.size, dtype=bool)
    interior[nm:] = np.asarray(theta_opt)[nm:] > lo[nm:] + hessian_step
    cov, n_hess = (observed_covariance(problem, theta_opt, hessian_step, interior, workers) if standard_errors
                   else (np.full((theta_opt.size, theta_opt.size), np.nan), 0))
    sandwich = None
    if standard_errors and mast_pairs is not None:
        sandwich = robust_covariance(problem.log_densities, np.asarray(theta_opt, dtype=float), hessian_step, cov,
                                     interior, mast_pairs,
                                     log_density_many=lambda x: problem.log_densities_many(x, workers))
        n_hess += 2 * theta_opt.size
    elapsed = time.perf_counter() - t_start
    reported = widened_covariance(cov, sandwich) if covariance == "sandwich" and sandwich is not None else cov
    se = np.sqrt(np.diag(reported))
    mu_se = np.zeros(len(start))
    sigma_se = np.zeros(len(start))
    mu_se[problem.free_mean_idx] = problem.mean_scale[problem.free_mean_idx] * se[:nm]
    sigma_se[problem.free_sigma_idx] = sigmas_opt[problem.free_sigma_idx] * se[nm:]
    free_mean_set = set(problem.free_mean_idx.tolist())
    estimates = tuple(ParameterEstimate(parameter=names[i], mu=float(means_opt[i]), sigma=float(sigmas_opt[i]),
                                        mu_se=float(mu_se[i]), sigma_se=float(sigma_se[i]),
                                        mu_fixed=i not in free_mean_set) for i in range(len(start)))
    free_names = tuple([f"{names[i]}.mu" for i in problem.free_mean_idx]
                       + [f"{names[i]}.sigma" for i in problem.free_sigma_idx])
    slack = likelihood.evaluate(means_opt, sigmas_opt).slack_fraction
    return IdentificationResult(
        estimates=estimates, j_opt=float(j_opt), n_evaluations=n_eval,
        trace_means=np.array([t[1] for t in trace]), trace_sigmas=np.array([t[2] for t in trace]),
        trace_j=np.array([t[3] for t in trace]), time_s=elapsed, method=method, converged=converged,
        message=message, free_parameters=free_names, theta_opt=np.asarray(theta_opt, dtype=float),
        theta_covariance=cov, n_hessian_evaluations=n_hess, slack_fraction=float(slack),
        theta_covariance_sandwich=sandwich, covariance=covariance,
        n_mast_pairs=0 if mast_pairs is None else int(np.asarray(mast_pairs).reshape(-1, 2).shape[0]),
        at_lower_bound=tuple(n for n, inside in zip(free_names, interior) if not inside))
