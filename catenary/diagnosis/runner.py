"""One span type's diagnosis: locate, name, add, show the gap shrink (forward selection).

From the starting model M (``diagnosis.start``), each step

1. **locates** the disagreement without a refit (:mod:`.locate`): residuals, whitened
   eigenvalues against their bootstrap band, Mahalanobis distances, the catch-all gains, and a
   score screen with the smallest detectable magnitude of every candidate;
2. **names**: refits M + E for every candidate E not in M (warm start from M's optimum with E
   at its null, same design, N and likelihood), takes ``Δℓ = J(M+E) − J(M)`` and
   ``LR = 2Δℓ`` with the boundary-mixture null law (:func:`.locate.mixture_sf`), Bonferroni
   over the K candidates of the step. A significant candidate's LR is divided by the
   sandwich factor of its parameters (spans that share a mast, Chandler & Bate 2007) before it
   is tested again. The candidates are ranked by BIC (equal parameter counts: by J). The
   leader is **named** if it is significant and the runner-up's BIC is at least
   ``bic_margin`` higher; **ambiguous** if it is significant but the runner-up is within the
   margin; **none_detected** if no candidate is significant;
3. a named effect is added: M ← M + E, and the next step starts from its fit, until nothing
   is significant, the verdict is ambiguous, or ``max_steps`` is reached.

The located quantities of M + E after a step are those the next step starts from; the report
shows them before and after.
"""

from __future__ import annotations

import dataclasses
import logging
import multiprocessing
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field

import numpy as np

from ..config import Catenary, SpanType
from ..identification.design import MESSENGER_TENSION, design_dimension, draw_unit_design
from ..identification.fit import ParameterBox, messenger_tension_bounds_n
from ..identification.likelihood import Likelihood
from ..identification.report import check_span_count
from ..identification.settings import IdentificationSettings
from ..normality import henze_zirkler
from ..progress import Progress
from .candidates import CANDIDATES
from .locate import (Locate, efficient_information, expected_information, locate, mixture_sf,
                     required_noncentrality, score_pvalue, secant_noncentrality)
from .model import EffectSampler, ModelSet, design_columns, relative_cost
from .problem import Fit, JointProblem, refit, with_covariance
from .settings import DiagnosisSettings

__all__ = ["CandidateTest", "DiagnosisRun", "Step", "VERDICTS", "applicable_candidates", "diagnose", "make_sampler"]

VERDICTS = ("named", "ambiguous", "none_detected")
_LOG = logging.getLogger(__name__)
#: Step, in θ, of the finite differences of the base coordinates for the Fisher information.
_BASE_STEP = 0.02
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
        Sandwich factor max(λ, 1) of the candidate's parameters (1 when not computed).
    p_value, p_adjusted : float
        Under the boundary mixture, and × K (Bonferroni, capped at 1).
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


@dataclass(frozen=True)
class Step:
    """One step of the forward selection.

    Attributes
    ----------
    step : int
        1, 2, …
    model_effects : tuple of str
        Effects of M at the start of the step.
    before : Locate
        M against the data.
    candidates : list of CandidateTest
    verdict : str
        One of :data:`VERDICTS`.
    effect, runner_up : str or None
        The named (or, when ambiguous, the leading) candidate and the next by BIC.
    after : Locate or None
        M + E against the data, when an effect was named.
    """

    step: int
    model_effects: tuple[str, ...]
    before: Locate
    candidates: list[CandidateTest]
    verdict: str
    effect: str | None
    runner_up: str | None
    after: Locate | None = None

    @property
    def leading(self) -> CandidateTest | None:
        return next((c for c in self.candidates if c.effect == self.effect), None)

    @property
    def gap_closed_fraction(self) -> float:
        """Δℓ of the named effect over the free Gaussian's gain (NaN when none was named)."""
        c = self.leading
        if c is None or self.verdict != "named" or self.before.free_gaussian_gain <= 0:
            return float("nan")
        return float(c.delta_loglik / self.before.free_gaussian_gain)


@dataclass
class DiagnosisRun:
    """Everything the diagnosis rule writes for one span type."""

    span_type: str
    settings: DiagnosisSettings
    base: IdentificationSettings
    n_spans: int
    skipped: dict[str, str]
    start: Fit
    steps: list[Step]
    final: Fit
    final_names: list[str]
    final_problem: JointProblem
    data_normality: dict
    time_s: float
    n_evaluations: int = 0
    notes: list[str] = field(default_factory=list)

    @property
    def named(self) -> list[str]:
        return [s.effect for s in self.steps if s.verdict == "named"]

    @property
    def converged(self) -> bool:
        return self.start.converged and all(c.converged for s in self.steps for c in s.candidates
                                            if c.effect == s.effect) and self.final.converged


def applicable_candidates(settings: DiagnosisSettings, base: IdentificationSettings, n_droppers: int,
                          has_force_influence: bool) -> tuple[tuple[str, ...], dict[str, str]]:
    """Candidates to try and why the others are skipped."""
    skipped = {}
    random = set(base.random_names(n_droppers))
    out = []
    for name in settings.candidates:
        if name in settings.start_effects:
            skipped[name] = "in the starting model already"
        elif name == "messenger_tension_variability" and MESSENGER_TENSION in random:
            skipped[name] = "T_MW is a random input of the starting model already"
        elif name == "wire_continuity" and base.neighbours != 0:
            skipped[name] = "the span model is the span in the line already (neighbours > 0)"
        elif "force_influence" in CANDIDATES[name].needs and not has_force_influence:
            skipped[name] = "no measuring-pass influence given"
        else:
            out.append(name)
    return tuple(out), skipped


class _Context:
    """What every model of one diagnosis shares: data, design, model set, box."""

    def __init__(self, span_type, catenary, data, base, settings, force_influence, declared_force_n, effects, pairs):
        self.span_type, self.data, self.base, self.settings, self.pairs = span_type, data, base, settings, pairs
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
        self.models = ModelSet(span_type, catenary, (min(lo, 0.5 * t), max(hi, 1.5 * t)), base.neighbours,
                               force_influence_m_n=force_influence)
        self.declared_force_n = declared_force_n
        self.free_means = base.free_mean_names(n)
        self.free_sigmas = base.random_names(n)
        self.rng = np.random.default_rng(settings.seed + 1)
        self.n_evaluations = 0

    def problem(self, effects: tuple[str, ...]) -> JointProblem:
        sampler = EffectSampler(self.models, base_dimension=self.base_dim,
                                system_height_mode=self.base.system_height_mode, columns=self.columns,
                                active=effects, declared_force_n=self.declared_force_n, dimension=self.dimension)
        lik = Likelihood(self.models.model(sampler.needs), self.design, self.data, estimator="gaussian",
                         system_height_mode=self.base.system_height_mode, sampler=sampler)
        return JointProblem.for_inputs(lik, self.start, self.free_means, self.free_sigmas, effects)

    def model_draws(self, problem: JointProblem, theta: np.ndarray, count: int) -> np.ndarray:
        """``count`` i.i.d. model spans at θ (taut-weighted acceptance, as J weights them)."""
        lik = problem.likelihood
        means, sigmas = problem.laws(theta)
        mags = problem.magnitudes(theta)
        out, n_have = [], 0
        for _ in range(50):
            z = np.clip(self.rng.standard_normal((max(2 * (count - n_have), 1000), self.dimension)), -6.0, 6.0)
            res = lik.sampler(z, means, sigmas, mags)
            if res is None:
                break
            w, f_min = res
            keep = self.rng.uniform(size=f_min.size) < lik.taper_weights(f_min)
            out.append(w[keep])
            n_have += int(keep.sum())
            if n_have >= count:
                break
        if n_have < count:
            raise RuntimeError(f"could draw only {n_have} of {count} model spans at the fitted laws")
        return np.concatenate(out)[:count]

    def locate(self, problem: JointProblem, fit: Fit) -> Locate:
        value = problem.evaluate(fit.theta)
        draws = self.model_draws(problem, fit.theta, self.settings.bootstrap_replicates * self.data.shape[0])
        return locate(self.data, value.fit, value.j, draws, n_replicates=self.settings.bootstrap_replicates)


def _moments(value):
    f = value.fit
    return f.mean, f.chol @ f.chol.T


def _information(ctx: _Context, problem: JointProblem, theta: np.ndarray, base_moments) -> tuple:
    """Fisher information over (M's coordinates, the last candidate's), the score of J along
    the candidate's coordinates at its null, and the coordinate kinds."""
    nu = ctx.data.shape[0]
    ref_value = problem.evaluate(theta)
    reference = _moments(ref_value)
    n_m = len(base_moments)
    moments, steps = list(base_moments), [2 * _BASE_STEP] * n_m
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
        moments.append((_moments(vu), _moments(vd)))
        steps.append(h)
        score.append((vu.j - vd.j) / h)
        spread.append(p.kind == "spread")
    info = expected_information(moments, steps, nu, reference)
    return info, np.array(score), np.array(spread)


def _detectable(ctx: _Context, problem: JointProblem, theta0: np.ndarray, base_moments, k: int, p, level: float,
                n_grid: int = 14) -> float:
    """Smallest size of parameter ``p`` (the others at their null) the step's test detects with
    the configured power [SI]; ∞ beyond the allowed range (:func:`.locate.secant_noncentrality`)."""
    nu = ctx.data.shape[0]
    ref = problem.evaluate(theta0)
    m0, s0 = _moments(ref)
    directions = [((up[0] - down[0]) / (2 * _BASE_STEP), (up[1] - down[1]) / (2 * _BASE_STEP))
                  for up, down in base_moments]
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
        m, cov = _moments(value)
        lam = secant_noncentrality((m - m0, cov - s0), directions, s0, nu)
        if lam >= need:          # interpolate in log size between the last two sizes
            s_prev, l_prev = previous
            if s_prev <= 0 or lam <= l_prev:
                return float(size)
            t = (np.log(need) - np.log(max(l_prev, 1e-300))) / (np.log(lam) - np.log(max(l_prev, 1e-300)))
            return float(np.exp(np.log(s_prev) + np.clip(t, 0.0, 1.0) * (np.log(size) - np.log(s_prev))))
        previous = (size, lam)
    return float("inf")


def _base_moments(ctx: _Context, problem: JointProblem, theta: np.ndarray):
    out = []
    for i in range(theta.size):
        up, down = theta.copy(), theta.copy()
        up[i] += _BASE_STEP
        down[i] -= _BASE_STEP
        vu, vd = problem.evaluate(up), problem.evaluate(down)
        if vu.fit is None or vd.fit is None:
            raise RuntimeError(f"J is not finite next to the fitted model along {problem.names[i]}")
        out.append((_moments(vu), _moments(vd)))
    return out


#: The context a forked worker reads (set by :func:`_map_candidates` before the pool forks).
_WORKER: dict = {}


def _worker_test(effect: str) -> tuple[CandidateTest, Fit]:
    w = _WORKER
    return _test_candidate(w["ctx"], w["effects"], w["fit"], w["base_moments"], effect, w["n_tests"])


def _map_candidates(ctx, effects, fit, base_moments, names, workers):
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


def _test_candidate(ctx: _Context, current_effects: tuple[str, ...], fit: Fit, base_moments, effect: str,
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
    new = refit(problem, theta0, ctx.box, base_step=0.1, effect_step=1.0, max_evaluations=s.max_evaluations)
    return _tested(ctx, problem, fit, new, n_tests, detectable=detectable, score_statistic=float(score_stat),
                   score_p_value=float(score_p), score_z=score_z)


def _tested(ctx: _Context, problem: JointProblem, fit: Fit, new: Fit, n_tests: int, **screen) -> tuple[CandidateTest, Fit]:
    """The likelihood-ratio test of the refit ``new`` of M + E (``problem``) against M's ``fit``;
    ``screen`` carries the fields computed at the null (detectable, score)."""
    s = ctx.settings
    effect = problem.effects[-1]
    cand = CANDIDATES[effect]
    delta = new.j - fit.j
    lr = max(2.0 * delta, 0.0)
    p_value = mixture_sf(lr, cand.n_shift, cand.n_spread)
    factor = 1.0
    estimates = {name: (value, float("nan")) for name, value in new.magnitudes(problem)[effect].items()}
    if min(1.0, n_tests * p_value) < s.level:
        # Significant on the independence likelihood: measure how much spans sharing a mast
        # inflate it (never deflate), test again, and give the standard errors.
        new = with_covariance(new, problem, ctx.box, mast_pairs=ctx.pairs)
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
        converged=new.converged, n_evaluations=new.n_evaluations, time_s=new.time_s, **screen)
    return test, new


def _continued(ctx: _Context, current_effects: tuple[str, ...], fit: Fit, test: CandidateTest, new: Fit,
               n_tests: int) -> tuple[CandidateTest, Fit]:
    """Restart a refit that spent its evaluation budget: Nelder–Mead again from its best point
    with a smaller simplex (a restart is the usual remedy for a simplex that has collapsed along
    a bound), then the test again. J can only rise; the budgets and times add up."""
    problem = ctx.problem((*current_effects, test.effect))
    more = refit(problem, new.theta, ctx.box, base_step=0.02, effect_step=0.25,
                 max_evaluations=ctx.settings.max_evaluations)
    more = dataclasses.replace(more, n_evaluations=new.n_evaluations + more.n_evaluations,
                               time_s=new.time_s + more.time_s)
    return _tested(ctx, problem, fit, more, n_tests, detectable=test.detectable, score_statistic=test.score_statistic,
                   score_p_value=test.score_p_value, score_z=test.score_z)


def _verdict(tests: list[CandidateTest], level: float, margin: float) -> tuple[str, str | None, str | None]:
    if not tests:
        return "none_detected", None, None
    ranked = sorted(tests, key=lambda t: t.bic)
    significant = [t for t in ranked if t.p_adjusted < level]
    if not significant:
        best = max(tests, key=lambda t: t.delta_loglik)
        return "none_detected", None, best.effect
    lead = significant[0]
    runner = next((t for t in ranked if t.effect != lead.effect), None)
    if runner is None or runner.bic - lead.bic >= margin:
        return "named", lead.effect, runner.effect if runner else None
    return "ambiguous", lead.effect, runner.effect


def diagnose(span_type: SpanType, catenary: Catenary, data_w_m: np.ndarray, identification: IdentificationSettings,
             settings: DiagnosisSettings, *, mast_pairs: np.ndarray | None = None,
             force_influence_m_n: np.ndarray | None = None, declared_force_n: float = 36.0, workers: int = 1,
             n_left_out: int = 0, log: logging.Logger | None = None) -> DiagnosisRun:
    """Run the forward selection of the module docstring on the measured W of one span type.

    Parameters
    ----------
    span_type, catenary
    data_w_m : numpy.ndarray, shape (ν, n)
        Measured (corrected) deflections [m].
    identification : IdentificationSettings
        Base laws, ΔH mode and design method.
    settings : DiagnosisSettings
    mast_pairs : numpy.ndarray, optional
        Rows that share a mast (:func:`catenary.identification.dependence.adjacent_span_pairs`).
    force_influence_m_n : numpy.ndarray, optional
        Measuring pass's ∂W/∂F [m/N] (:func:`catenary.measuring.force_influence`); without it
        ``measuring_force_offset`` is skipped.
    declared_force_n : float
        The measuring force the correction assumed [N].
    workers : int
        Processes testing the candidates of a step side by side (the result is the same).
    n_left_out : int
        Spans of the type left out upstream (correction not converged), for the refusal message
        when too few spans remain (:func:`catenary.identification.report.check_span_count`).
    """
    log = log or _LOG
    t0 = time.perf_counter()
    data = np.asarray(data_w_m, dtype=float)
    base = settings.base(identification)
    n = span_type.n_droppers
    candidates, skipped = applicable_candidates(settings, base, n, force_influence_m_n is not None)
    ctx = _Context(span_type, catenary, data, base, settings, force_influence_m_n, declared_force_n,
                   (*settings.start_effects, *candidates), mast_pairs)
    problem = ctx.problem(tuple(settings.start_effects))
    check_span_count(span_type.name, data.shape[0], len(problem.names), log, n_left_out=n_left_out)
    fit = refit(problem, np.zeros(len(problem.names)), ctx.box, base_step=base.initial_step, effect_step=1.0,
                max_evaluations=base.max_evaluations)
    start_fit = fit
    log.info("%s: starting model (%s) fitted: J = %.3f after %d evaluations in %.1f s (%s)", span_type.name,
             ", ".join(settings.start_effects) or "no effect", fit.j, fit.n_evaluations, fit.time_s, fit.message)
    steps: list[Step] = []
    before = ctx.locate(problem, fit)
    for k in range(1, settings.max_steps + 1):
        remaining = [c for c in candidates if c not in problem.effects]
        effects_before = problem.effects
        if not remaining:
            break
        log.info("%s step %d: model %s; J = %.2f; λ₁ = %.2f (bootstrap 95 %% [%.2f, %.2f]); free Gaussian gain "
                 "%.1f; testing %d candidates", span_type.name, k, list(problem.effects) or "base", fit.j,
                 before.eigenvalues[0], before.eigen_low[0], before.eigen_high[0], before.free_gaussian_gain,
                 len(remaining))
        base_moments = _base_moments(ctx, problem, fit.theta)
        results = {}
        progress = Progress(log, f"{span_type.name} step {k}", len(remaining), "candidates", every_s=0.0)
        for name, (test, new_fit) in _map_candidates(ctx, problem.effects, fit, base_moments, remaining, workers):
            results[name] = (test, new_fit)
            progress.update(len(results), f"{name}: Δℓ = {test.delta_loglik:.2f}, LR = {test.lr_statistic:.2f} "
                            f"(sandwich factor {test.lr_factor:.2f}), p = {test.p_value:.3g} (adjusted "
                            f"{test.p_adjusted:.3g}), BIC {test.bic:.1f}; "
                            + ", ".join(f"{key} = {v[0]:.4g}" for key, v in test.estimates.items())
                            + f"; {test.n_evaluations} evaluations, {test.time_s:.1f} s")
        results = {name: results[name] for name in remaining}             # config order, whatever ended first
        restarted: set[str] = set()
        while True:
            # The verdict rests on the two best by BIC: a refit of theirs that spent its budget
            # is restarted once, so that neither the leader nor the margin to the runner-up
            # comes from an optimiser stopped half-way.
            top = sorted(results.values(), key=lambda r: r[0].bic)[:2]
            pending = [r[0].effect for r in top if not r[0].converged and r[0].effect not in restarted]
            if not pending:
                break
            for name in pending:
                old_test, old_fit = results[name]
                log.info("%s step %d: %s's refit spent its %d evaluations without converging: restarted",
                         span_type.name, k, name, old_test.n_evaluations)
                results[name] = _continued(ctx, problem.effects, fit, old_test, old_fit, len(remaining))
                restarted.add(name)
                log.info("%s step %d: %s after the restart: Δℓ = %.2f, p adjusted %.3g, BIC %.1f, %s", span_type.name,
                         k, name, results[name][0].delta_loglik, results[name][0].p_adjusted, results[name][0].bic,
                         "converged" if results[name][0].converged else "still not converged")
        tests = [r[0] for r in results.values()]
        verdict, effect, runner = _verdict(tests, settings.level, settings.bic_margin)
        after = None
        if verdict == "named":
            fit = results[effect][1]
            problem = ctx.problem((*problem.effects, effect))
            fit = with_covariance(fit, problem, ctx.box, mast_pairs=mast_pairs) if fit.covariance is None else fit
            after = ctx.locate(problem, fit)
        steps.append(Step(step=k, model_effects=effects_before, before=before, candidates=tests, verdict=verdict, effect=effect,
                          runner_up=runner, after=after))
        log.info("%s step %d: %s%s", span_type.name, k, verdict,
                 f" {effect}" + (f" (runner-up {runner})" if runner else "") if effect else "")
        if verdict != "named":
            break
        before = after
    final = fit if fit.covariance is not None else with_covariance(fit, problem, ctx.box, mast_pairs=mast_pairs)
    hz = henze_zirkler(data)
    run = DiagnosisRun(span_type=span_type.name, settings=settings, base=base, n_spans=int(data.shape[0]),
                       skipped=skipped, start=start_fit, steps=steps, final=final, final_names=final.names,
                       final_problem=problem, data_normality={"statistic": hz.statistic, "p_value": hz.p_value},
                       time_s=time.perf_counter() - t0)
    return run


def make_sampler(span_type: SpanType, catenary: Catenary, identification: IdentificationSettings,
                 settings: DiagnosisSettings, effects: tuple[str, ...], *, force_influence_m_n: np.ndarray | None = None,
                 declared_force_n: float = 36.0) -> EffectSampler:
    """The sampler of the model with ``effects`` exactly as :func:`diagnose` builds it (same
    fast models and design columns), e.g. to simulate spans with :func:`.model.simulate_spans`."""
    base = settings.base(identification)
    candidates, _ = applicable_candidates(settings, base, span_type.n_droppers, force_influence_m_n is not None)
    order = tuple(dict.fromkeys((*settings.start_effects, *candidates, *effects)))
    ctx = _Context(span_type, catenary, np.zeros((2, span_type.n_droppers)), base,
                   dataclasses.replace(settings, n_samples=max(settings.n_samples, 500)), force_influence_m_n,
                   declared_force_n, order, None)
    return ctx.problem(tuple(effects)).likelihood.sampler
