"""The test of one candidate effect at a step of the diagnosis, and the candidates of a step
side by side.

For a candidate E added to the step's model M (:mod:`.runner`), :func:`refit_and_test`

1. screens E at its null without a refit: the efficient score test and the smallest magnitude
   of each of its parameters that the step's test would detect (Fisher information by finite
   differences of the Gaussian law of W, :mod:`.locate`);
2. refits M + E from M's optimum with E at its null (same design, N and likelihood; Fisher
   scoring where it certifies its maximum, Nelder–Mead otherwise: :func:`.problem.refit`);
3. tests the refit: ``LR = 2 (J(M + E) − J(M))`` under the boundary-mixture null law,
   Bonferroni over the step's candidates.

:func:`refit_and_test_all` runs a step's candidates in forked worker processes, the costliest
first; :func:`continue_refit` restarts a refit that spent its budget. :func:`sandwich_leaders`
then divides the LR of the candidates the verdict reads — the leader by BIC among the
significant ones and its runner-up — by the sandwich factor of their parameters (spans sharing
a mast), tests them again and gives their standard errors. It needs J's Hessian (≈ 2p²
evaluations for p coordinates, as much as a refit): computed for every significant candidate,
it was 15 % of a diagnosis on the default campaign (five or six Hessians per step 1, the CW
offset's at three times a base evaluation), for figures no verdict read.
:class:`DiagnosisContext` holds what every model of one diagnosis shares.
"""

from __future__ import annotations

import dataclasses
import multiprocessing
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass

import numpy as np

from catenary.plumbing.errors import ConvergenceError
from catenary.plumbing.workers import map_blocks
from catenary.stages.identification.design import design_dimension, draw_unit_design
from catenary.stages.identification.fit import ParameterBox, messenger_tension_bounds_n
from catenary.stages.identification.likelihood import Likelihood
from catenary.stages.identification.scoring import STEP as _BASE_STEP
from catenary.stages.identification.scoring import expected_information, gaussian_moments
from .candidates import CANDIDATES
from .locate import (Locate, bootstrap_eigenvalues, efficient_information, locate, mixture_sf,
                     required_noncentrality, score_pvalue, secant_noncentrality)
from .model import EffectSampler, ModelSet, design_columns, relative_cost
from .problem import Fit, JointProblem, refit, with_covariance

__all__ = ["CandidateTest", "DiagnosisContext", "base_moments_at", "continue_refit", "moment_steps", "refit_and_test",
           "refit_and_test_all", "sandwich_leaders"]

#: Model spans drawn per block of the eigenvalue bootstrap (:meth:`DiagnosisContext.locate`): its
#: B data sets of ν spans are drawn and reduced to their eigenvalues a block of
#: ``max(1, this // ν)`` data sets at a time, each block from its own random stream
#: (``[seed, first data set]``), so that the look's memory stays at a block's whatever B ν (5 × 10⁶
#: model spans on 5 000 spans: 9.4 GB when drawn at once) and the answer is the same for any
#: number of workers.
BOOTSTRAP_BLOCK_DRAWS = 100_000
# _BASE_STEP (from identification.scoring): the step, in θ, of the base coordinates' finite
# differences for the Fisher information, the same as the scoring's.
#: Step of a shift's finite differences, in units of its scale; a spread's variance step is (this × scale)².
_EFFECT_STEP = 0.25


@dataclass(frozen=True)
class CandidateTest:
    """One candidate added to the model of a step.

    Attributes
    ----------
    effect : str
    n_parameters : int
        The candidate's own parameters.
    j : float
        J of M + E at its maximum.
    delta_loglik : float
        J(M + E) − J(M).
    lr_statistic : float
        2 Δℓ, divided by the sandwich factor when that was computed (``lr_factor``).
    lr_factor : float
        Sandwich factor max(λ, 1) of the candidate's parameters; NaN where not computed: a
        candidate not significant, or not read by the verdict (:func:`sandwich_leaders`).
    p_value, p_adjusted : float
        Under the boundary mixture, and × K (Bonferroni, capped at 1); on the independence
        likelihood where ``lr_factor`` is NaN (a lower bound of the sandwiched one).
    aic, bic : float
        Of M + E (all its free coordinates).
    estimates : dict
        ``{parameter: (value, standard error)}`` [SI]; the error NaN where not computed.
    detectable : dict
        ``{parameter: smallest magnitude detectable}`` [SI] (each parameter alone).
    score_statistic, score_p_value : float
        Score test at the null (before the refit).
    score_z : dict
        ``{parameter: U / √I_eff}``.
    converged : bool
    n_evaluations : int
    time_s : float
    theta : numpy.ndarray or None
        The refit's coordinates (:attr:`.problem.JointProblem.names` of M + E).
    """

    effect: str
    n_parameters: int
    j: float
    delta_loglik: float
    lr_statistic: float
    lr_factor: float
    p_value: float
    p_adjusted: float
    aic: float
    bic: float
    estimates: dict
    detectable: dict
    score_statistic: float
    score_p_value: float
    score_z: dict
    converged: bool
    n_evaluations: int
    time_s: float
    theta: np.ndarray | None = None


class DiagnosisContext:
    """What every model of one diagnosis shares: data, design, model set, box."""

    def __init__(self, span_type, catenary, data, base, settings, force_influence, declared_force_n, effects, pairs,
                 observations=None, workers: int = 1, models: ModelSet | None = None):
        self.span_type, self.data, self.base, self.settings, self.pairs = span_type, data, base, settings, pairs
        self.observations = observations
        self.start = base.start_inputs(span_type, catenary)
        self.box = ParameterBox()
        n = span_type.n_droppers
        self.base_dim = design_dimension(n, base.system_height_mode)
        self.columns = design_columns(self.base_dim, effects)
        dim = self.base_dim + sum(CANDIDATES[e].design_columns for e in effects)
        self.dimension = dim
        self.design = draw_unit_design(settings.n_samples, dim, method=base.design, seed=settings.seed)
        t = span_type.messenger_tension_n
        lo, hi = messenger_tension_bounds_n(self.start, self.box)
        self.models = models if models is not None else ModelSet(
            span_type, catenary, (min(lo, 0.5 * t), max(hi, 1.5 * t)), base.neighbours,
            force_influence_m_n=force_influence)
        self.declared_force_n = declared_force_n
        self.free_means = base.free_mean_names(n)
        self.free_sigmas = base.random_names(n)
        self.rng = np.random.default_rng(settings.seed + 1)
        self.workers = int(workers)
        self.n_evaluations = 0

    def problem(self, effects: tuple[str, ...]) -> JointProblem:
        sampler = EffectSampler(self.models, base_dimension=self.base_dim,
                                system_height_mode=self.base.system_height_mode, columns=self.columns,
                                active=effects, declared_force_n=self.declared_force_n, dimension=self.dimension)
        lik = Likelihood(self.models.model(sampler.needs), self.design, self.data, estimator="gaussian",
                         system_height_mode=self.base.system_height_mode, sampler=sampler,
                         observations=self.observations)
        return JointProblem.for_inputs(lik, self.start, self.free_means, self.free_sigmas, effects)

    def model_draws(self, problem: JointProblem, theta: np.ndarray, count: int, rng: np.random.Generator
                    ) -> np.ndarray:
        """``count`` i.i.d. model spans at θ (taut-weighted acceptance, as J weights them), drawn
        with ``rng``."""
        lik = problem.likelihood
        means, sigmas = problem.laws(theta)
        mags = problem.magnitudes(theta)
        out, n_have = [], 0
        for _ in range(50):
            z = np.clip(rng.standard_normal((max(2 * (count - n_have), 1000), self.dimension)), -6.0, 6.0)
            res = lik.sampler(z, means, sigmas, mags)
            if res is None:
                break
            w, f_min = res
            keep = rng.uniform(size=f_min.size) < lik.taper_weights(f_min)
            out.append(w[keep])
            n_have += int(keep.sum())
            if n_have >= count:
                break
        if n_have < count:
            raise RuntimeError(f"could draw only {n_have} of {count} model spans at the fitted laws")
        return np.concatenate(out)[:count]

    def locate(self, problem: JointProblem, fit: Fit) -> Locate:
        """:func:`.locate.locate` at the fit, its bootstrap drawn block by block (module docs of
        :data:`BOOTSTRAP_BLOCK_DRAWS`) in the context's ``workers``."""
        value = problem.evaluate(fit.theta)
        nu = self.data.shape[0]
        seed = int(self.rng.integers(2**63))       # this look's stream, from the diagnosis' seed

        def block(start: int, stop: int) -> np.ndarray:
            draws = self.model_draws(problem, fit.theta, (stop - start) * nu, np.random.default_rng([seed, start]))
            return bootstrap_eigenvalues(draws, value.fit, nu, stop - start)

        replicates = self.settings.bootstrap_replicates
        boot = np.concatenate(map_blocks(block, replicates, self.workers, max(1, BOOTSTRAP_BLOCK_DRAWS // nu)))
        # the located figures are of W: with measurements besides W, J of W's own law (the free
        # Gaussian it is compared with has no other quantity)
        j = value.j if value.fit is None or self.observations is None else float(
            np.sum(problem.likelihood.data_log_density(value.fit)))
        return locate(self.data, value.fit, j, boot)


def _information(ctx: DiagnosisContext, problem: JointProblem, theta: np.ndarray, base_moments) -> tuple:
    """Fisher information over (M's coordinates, the last candidate's), the score of J along
    the candidate's coordinates at its null, and the coordinate kinds."""
    nu = ctx.data.shape[0]
    ref_value = problem.evaluate(theta)
    if ref_value.fit is None:          # J not finite at M's optimum under this model (its range)
        return None
    reference = gaussian_moments(ref_value)
    n_m = len(base_moments)
    moments, steps = [(up, down) for up, down, _ in base_moments], [h for _, _, h in base_moments]
    score, spread = [], []
    for k, (effect, p) in enumerate(problem.coordinates[-len(CANDIDATES[problem.effects[-1]].parameters):]):
        i = n_m + k
        if p.kind == "shift":
            up, down = theta.copy(), theta.copy()
            up[i] += _EFFECT_STEP
            down[i] -= _EFFECT_STEP
            vu, vd = problem.evaluate(up), problem.evaluate(down)
            h = 2 * _EFFECT_STEP * p.scale                    # in SI
        else:                                                  # variance v = σ², one-sided at 0
            up = theta.copy()
            up[i] += _EFFECT_STEP
            vu, vd = problem.evaluate(up), ref_value
            h = (_EFFECT_STEP * p.scale) ** 2
        if vu.fit is None or vd.fit is None:
            return None
        moments.append((gaussian_moments(vu), gaussian_moments(vd)))
        steps.append(h)
        score.append((vu.j - vd.j) / h)
        spread.append(p.kind == "spread")
    info = expected_information(moments, steps, nu, reference)
    return info, np.array(score), np.array(spread)


def _detectable(ctx: DiagnosisContext, problem: JointProblem, theta0: np.ndarray, base_moments, k: int, p, level: float,
                n_grid: int = 14) -> float:
    """Smallest size of parameter ``p`` (the others at their null) the step's test detects with
    the configured power [SI]; ∞ beyond the allowed range (:func:`.locate.secant_noncentrality`)."""
    nu = ctx.data.shape[0]
    ref = problem.evaluate(theta0)
    if ref.fit is None:                # J not finite at M's optimum under this model: not stated
        return float("nan")
    m0, s0 = gaussian_moments(ref)
    directions = [((up[0] - down[0]) / h, (up[1] - down[1]) / h) for up, down, h in base_moments]
    need = required_noncentrality(p.kind, level, ctx.settings.power)
    i = theta0.size - len(CANDIDATES[problem.effects[-1]].parameters) + k
    top = p.bounds[1] if p.bounds[1] > 0 else -p.bounds[0]
    sizes = np.geomspace(top / 200.0, top, n_grid)
    previous = (0.0, 0.0)
    for size in sizes:
        theta = theta0.copy()
        theta[i] = size / p.scale
        value = problem.evaluate(theta)
        if value.fit is None:
            return float("inf")
        m, cov = gaussian_moments(value)
        lam = secant_noncentrality((m - m0, cov - s0), directions, s0, nu)
        if lam >= need:          # interpolate in log size between the last two sizes
            s_prev, l_prev = previous
            if s_prev <= 0 or lam <= l_prev:
                return float(size)
            t = (np.log(need) - np.log(max(l_prev, 1e-300))) / (np.log(lam) - np.log(max(l_prev, 1e-300)))
            return float(np.exp(np.log(s_prev) + np.clip(t, 0.0, 1.0) * (np.log(size) - np.log(s_prev))))
        previous = (size, lam)
    return float("inf")


def base_moments_at(ctx: DiagnosisContext, problem: JointProblem, theta: np.ndarray):
    """The model's Gaussian moments of W ``_BASE_STEP`` either side of ``theta`` along each base
    coordinate, with the distance between them: ``(up, down, h)`` (:func:`moment_steps`)."""
    def moments(t):
        value = problem.evaluate(t)
        return None if value.fit is None else gaussian_moments(value)
    return moment_steps(moments, theta, problem.names)


def moment_steps(moments, theta: np.ndarray, names) -> list:
    """``(up, down, h)`` along each coordinate of ``theta``: ``moments(θ)`` (a model's mean and
    covariance, or None where it cannot be drawn) ``_BASE_STEP`` either side, and the distance
    between the two. Where the moments are not available on one side (a fit that stopped
    against the edge of what the model can draw, a sample past the fast model's range or half
    the samples slack), the difference is taken on the other side from ``theta`` itself, and
    with half the step again if needed (three times); a coordinate along which they are nowhere
    available near ``theta`` is a :class:`ConvergenceError` of the fit (the model's fit did not
    reach a maximum)."""
    theta = np.asarray(theta, dtype=float)
    centre = moments(theta)
    out = []
    for i in range(theta.size):
        for halving in range(4):
            step = _BASE_STEP / 2 ** halving
            up, down = theta.copy(), theta.copy()
            up[i] += step
            down[i] -= step
            mu, md = moments(up), moments(down)
            if mu is not None and md is not None:
                out.append((mu, md, 2 * step))
                break
            if centre is not None and (mu is not None or md is not None):
                out.append((mu, centre, step) if mu is not None else (centre, md, step))
                break
        else:
            raise ConvergenceError(f"J is not finite anywhere next to the fitted model along {names[i]}: "
                                   "its fit did not reach a maximum of J")
    return out


#: The context a forked worker reads (set by :func:`refit_and_test_all` before the pool forks).
_WORKER: dict = {}


def _worker_test(effect: str) -> tuple[CandidateTest, Fit]:
    w = _WORKER
    return refit_and_test(w["ctx"], w["effects"], w["fit"], w["base_moments"], effect, w["n_tests"])


def refit_and_test_all(ctx, effects, fit, base_moments, names, workers):
    """Test every candidate, in ``workers`` forked processes or in this one; yield
    ``(name, (test, fit))`` as each refit ends.

    The refits are independent and deterministic: the result does not depend on ``workers`` or
    on the order they end in. With several workers the costliest refits start first (their J
    costs :func:`.model.relative_cost` times the base model's), so that the cheap ones fill the
    other workers meanwhile instead of leaving one worker alone with the costliest at the end.
    Each process should use one BLAS thread (``OPENBLAS_NUM_THREADS=1`` before NumPy is
    imported, as the rule script does) so that ``workers`` processes use ``workers`` cores.
    """
    args = dict(ctx=ctx, effects=effects, fit=fit, base_moments=base_moments, n_tests=len(names))
    if workers <= 1 or len(names) <= 1:
        _WORKER.update(args)
        try:
            yield from ((n, _worker_test(n)) for n in names)
        finally:
            _WORKER.clear()
        return
    order = sorted(names, key=lambda n: -relative_cost(CANDIDATES[n].needs))     # stable: config order on ties
    _WORKER.update(args)
    try:
        with ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("fork")) as pool:
            futures = {pool.submit(_worker_test, n): n for n in order}
            for future in as_completed(futures):
                yield futures[future], future.result()
    finally:
        _WORKER.clear()


def refit_and_test(ctx: DiagnosisContext, current_effects: tuple[str, ...], fit: Fit, base_moments, effect: str,
                    n_tests: int) -> tuple[CandidateTest, Fit]:
    s = ctx.settings
    cand = CANDIDATES[effect]
    problem = ctx.problem((*current_effects, effect))
    theta0 = np.r_[fit.theta, np.zeros(len(cand.parameters))]
    level = s.level / n_tests
    score_z = {}
    score_stat, score_p = float("nan"), float("nan")
    info = _information(ctx, problem, theta0, base_moments)
    if info is not None:
        full, score, spread = info
        tested = np.zeros(full.shape[0], dtype=bool)
        tested[-len(cand.parameters):] = True
        eff = efficient_information(full, tested)
        score_stat, score_p = score_pvalue(score, eff, spread)
        for k, p in enumerate(cand.parameters):
            score_z[p.name] = float(score[k] / np.sqrt(eff[k, k])) if eff[k, k] > 0 else float("nan")
    detectable = {p.name: _detectable(ctx, problem, theta0, base_moments, k, p, level)
                  for k, p in enumerate(cand.parameters)}
    new = refit(problem, theta0, ctx.box, base_step=0.1, effect_step=1.0, max_evaluations=s.max_evaluations,
                xtol=s.xtol, ftol=s.ftol, method=s.optimiser)
    return _tested(ctx, problem, fit, new, n_tests, detectable=detectable, score_statistic=float(score_stat),
                   score_p_value=float(score_p), score_z=score_z)


def _tested(ctx: DiagnosisContext, problem: JointProblem, fit: Fit, new: Fit, n_tests: int, *,
            sandwich: bool = False, workers: int = 1, **screen) -> tuple[CandidateTest, Fit]:
    """The likelihood-ratio test of the refit ``new`` of M + E (``problem``) against M's ``fit``;
    ``screen`` carries the fields computed at the null (detectable, score). With ``sandwich``,
    a candidate significant on the independence likelihood is tested again with its LR divided
    by the sandwich factor of its parameters, and gets standard errors (their J evaluations in
    ``workers`` processes: called from the job's own process only, never from a worker)."""
    s = ctx.settings
    effect = problem.effects[-1]
    cand = CANDIDATES[effect]
    delta = new.j - fit.j
    lr = max(2.0 * delta, 0.0)
    p_value = mixture_sf(lr, cand.n_shift, cand.n_spread)
    factor = float("nan")
    estimates = {name: (value, float("nan")) for name, value in new.magnitudes(problem)[effect].items()}
    if sandwich and min(1.0, n_tests * p_value) < s.level:
        # Significant on the independence likelihood: measure how much spans sharing a mast
        # inflate it (never deflate), test again, and give the standard errors.
        new = (with_covariance(new, problem, ctx.box, mast_pairs=ctx.pairs, workers=workers) if new.covariance is None
               else new)
        widen = new.variance_widening[-len(cand.parameters):]
        inside = new.interior[-len(cand.parameters):]
        factor = float(max(1.0, np.max(widen[inside]))) if inside.any() else 1.0
        lr /= factor
        p_value = mixture_sf(lr, cand.n_shift, cand.n_spread)
        estimates = new.effect_estimates(problem)[effect]
    k_total = new.theta.size
    nu = ctx.data.shape[0]
    test = CandidateTest(
        effect=effect, n_parameters=len(cand.parameters), j=new.j, delta_loglik=float(delta), lr_statistic=float(lr),
        lr_factor=factor, p_value=float(p_value), p_adjusted=float(min(1.0, n_tests * p_value)),
        aic=float(-2 * new.j + 2 * k_total), bic=float(-2 * new.j + k_total * np.log(nu)), estimates=estimates,
        converged=new.converged, n_evaluations=new.n_evaluations, time_s=new.time_s, theta=new.theta.copy(), **screen)
    return test, new


def continue_refit(ctx: DiagnosisContext, current_effects: tuple[str, ...], fit: Fit, test: CandidateTest, new: Fit,
               n_tests: int) -> tuple[CandidateTest, Fit]:
    """Restart a refit that spent its evaluation budget: Nelder–Mead again from its best point
    with a smaller simplex (a restart is the usual remedy for a simplex that has collapsed along
    a bound), then the test again. J can only rise; the budgets and times add up."""
    problem = ctx.problem((*current_effects, test.effect))
    more = refit(problem, new.theta, ctx.box, base_step=0.02, effect_step=0.25,
                 max_evaluations=ctx.settings.max_evaluations, xtol=ctx.settings.xtol, ftol=ctx.settings.ftol,
                 workers=ctx.workers)
    more = dataclasses.replace(more, n_evaluations=new.n_evaluations + more.n_evaluations,
                               time_s=new.time_s + more.time_s)
    return _tested(ctx, problem, fit, more, n_tests, detectable=test.detectable, score_statistic=test.score_statistic,
                   score_p_value=test.score_p_value, score_z=test.score_z)


def sandwich_leaders(ctx: DiagnosisContext, current_effects: tuple[str, ...], fit: Fit, results: dict,
                     n_tests: int) -> dict:
    """``results`` (effect → (test, fit)) with the sandwich test (:func:`_tested`) for the
    candidates the verdict reads: the best by BIC among the significant ones and the next by
    BIC, until the best significant one stays significant after its own. The verdict is the one
    every significant candidate's sandwich would give: it ranks by BIC, which the sandwich does
    not change, and reads the significance of the leader only."""
    level = ctx.settings.level
    done: set[str] = set()
    while True:
        ranked = sorted(results.values(), key=lambda r: r[0].bic)
        lead = next((r for r in ranked if r[0].p_adjusted < level), None)
        if lead is None:
            return results
        runner = next((r for r in ranked if r[0].effect != lead[0].effect), None)
        pending = [r for r in (lead, runner) if r is not None and r[0].effect not in done]
        if not pending:
            return results
        for test, new in pending:
            problem = ctx.problem((*current_effects, test.effect))
            results[test.effect] = _tested(ctx, problem, fit, new, n_tests, sandwich=True, workers=ctx.workers,
                                           detectable=test.detectable,
                                           score_statistic=test.score_statistic, score_p_value=test.score_p_value,
                                           score_z=test.score_z)
            done.add(test.effect)
