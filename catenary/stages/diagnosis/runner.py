"""One span type's diagnosis: locate, name, add, show the gap shrink (forward selection).

From the starting model M (``diagnosis.start``), each step

1. **locates** the disagreement without a refit (:mod:`.locate`): residuals, whitened
   eigenvalues against their bootstrap band, Mahalanobis distances, the catch-all gains, and a
   score screen with the smallest detectable magnitude of every candidate;
2. **names**: refits M + E for every candidate E not in M (warm start from M's optimum with E
   at its null, same design, N and likelihood), takes ``Δℓ = J(M+E) − J(M)`` and
   ``LR = 2Δℓ`` with the boundary-mixture null law (:func:`.locate.mixture_sf`), Bonferroni
   over the K candidates of the step. The LR of the significant leader by BIC and of its
   runner-up is divided by the sandwich factor of their parameters (spans that share a mast,
   Chandler & Bate 2007) before they are tested again (:func:`.refits.sandwich_leaders`;
   the next significant one leads if the leader does not stay significant). The candidates
   are ranked by BIC (equal parameter counts: by J). The
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
import json
import logging
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from catenary.physics.config import Catenary, SpanType
from catenary.plumbing.errors import InputError
from catenary.plumbing.progress import Progress
from catenary.stages.identification.design import MESSENGER_TENSION
from catenary.stages.identification.normality import henze_zirkler
from catenary.stages.identification.runner import check_span_count
from catenary.stages.identification.settings import IdentificationSettings
from .candidates import CANDIDATES
from .locate import Locate
from .model import EffectSampler, ModelSet
from .problem import Fit, JointProblem, refit, with_covariance
from .settings import DiagnosisSettings
from .span_check import SpanCheck, WLaw, check_spans, w_law
from .refits import (CandidateTest, DiagnosisContext, base_moments_at, continue_refit, refit_and_test_all,
                     sandwich_leaders)

__all__ = ["DiagnosisRun", "LineDiagnosis", "Step", "VERDICTS", "applicable_candidates", "diagnose", "diagnose_line",
           "final_w_law", "make_sampler"]

VERDICTS = ("named", "ambiguous", "none_detected")
_LOG = logging.getLogger(__name__)


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
        """The share of the gap to a free Gaussian law of W that the named effect closed: the
        rise of W's own J from the located model before to the one after, over the free
        Gaussian's gain (NaN when none was named). Of W's J, not the J the tests compare: with
        measurements besides W that J also rises by what they say, which no law of W can match."""
        c = self.leading
        if c is None or self.verdict != "named" or self.before.free_gaussian_gain <= 0:
            return float("nan")
        gain = c.delta_loglik if self.after is None else self.after.j - self.before.j
        return float(gain / self.before.free_gaussian_gain)


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
    context: DiagnosisContext | None = field(default=None, repr=False)

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
        if name not in CANDIDATES:
            skipped[name] = "acts span by span: fitted on the spans the final model does not explain"
        elif name in settings.start_effects:
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
             n_left_out: int = 0, observations=None, log: logging.Logger | None = None,
             models: ModelSet | None = None) -> DiagnosisRun:
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
        Rows that share a mast (:func:`catenary.stages.identification.dependence.adjacent_span_pairs`).
    force_influence_m_n : numpy.ndarray, optional
        Measuring pass's ∂W/∂F [m/N] (:func:`catenary.physics.measuring.force_influence`); without it
        ``measuring_force_offset`` is skipped.
    declared_force_n : float
        The measuring force the correction assumed [N].
    workers : int
        Processes testing the candidates of a step side by side and drawing the eigenvalue
        bootstrap's blocks (the result is the same).
    n_left_out : int
        Spans of the type left out upstream (correction not converged), for the refusal message
        when too few spans remain (:func:`catenary.stages.identification.runner.check_span_count`).
    observations : Observations, optional
        Measurements besides W, row by row with ``data_w_m``
        (:class:`catenary.measurement.channels.observations.Observations`): every model's J reads them
        jointly with W.
    models : ModelSet, optional
        The fast models of an earlier diagnosis of the same span type (built once for both).
    """
    log = log or _LOG
    t0 = time.perf_counter()
    data = np.asarray(data_w_m, dtype=float)
    base = settings.base(identification)
    n = span_type.n_droppers
    candidates, skipped = applicable_candidates(settings, base, n, force_influence_m_n is not None)
    ctx = DiagnosisContext(span_type, catenary, data, base, settings, force_influence_m_n, declared_force_n,
                           (*settings.start_effects, *candidates), mast_pairs, observations, workers=workers,
                           models=models)
    # The fast models of the starting model and of each candidate added to it, built side by
    # side before the candidates' processes fork (they inherit them).
    needs = []
    for active in (tuple(settings.start_effects), *((*settings.start_effects, c) for c in candidates)):
        need = frozenset().union(*(CANDIDATES[a].needs for a in active))
        needs += [(need, None)] + ([(need, 1)] if "continuity" in need else [])
    ctx.models.prepare(needs, workers)
    problem = ctx.problem(tuple(settings.start_effects))
    check_span_count(span_type.name, data.shape[0], len(problem.names), log, n_left_out=n_left_out)
    fit = refit(problem, np.zeros(len(problem.names)), ctx.box, base_step=base.initial_step, effect_step=1.0,
                max_evaluations=base.max_evaluations, workers=workers)
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
        base_moments = base_moments_at(ctx, problem, fit.theta)
        results = {}
        progress = Progress(log, f"{span_type.name} step {k}", len(remaining), "candidates", every_s=0.0)
        for name, (test, new_fit) in refit_and_test_all(ctx, problem.effects, fit, base_moments, remaining, workers):
            results[name] = (test, new_fit)
            progress.update(len(results), f"{name}: Δℓ = {test.delta_loglik:.2f}, LR = {test.lr_statistic:.2f}, "
                            f"p = {test.p_value:.3g} (adjusted {test.p_adjusted:.3g}), BIC {test.bic:.1f}; "
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
                results[name] = continue_refit(ctx, problem.effects, fit, old_test, old_fit, len(remaining))
                restarted.add(name)
                log.info("%s step %d: %s after the restart: Δℓ = %.2f, p adjusted %.3g, BIC %.1f, %s", span_type.name,
                         k, name, results[name][0].delta_loglik, results[name][0].p_adjusted, results[name][0].bic,
                         "converged" if results[name][0].converged else "still not converged")
        results = sandwich_leaders(ctx, problem.effects, fit, results, len(remaining))
        for test, _ in results.values():
            if np.isfinite(test.lr_factor):
                log.info("%s step %d: %s with spans sharing a mast: sandwich factor %.2f, LR %.2f, adjusted p %.3g",
                         span_type.name, k, test.effect, test.lr_factor, test.lr_statistic, test.p_adjusted)
        tests = [r[0] for r in results.values()]
        verdict, effect, runner = _verdict(tests, settings.level, settings.bic_margin)
        after = None
        if verdict == "named":
            fit = results[effect][1]
            problem = ctx.problem((*problem.effects, effect))
            fit = (with_covariance(fit, problem, ctx.box, mast_pairs=mast_pairs, workers=workers)
                   if fit.covariance is None else fit)
            after = ctx.locate(problem, fit)
        steps.append(Step(step=k, model_effects=effects_before, before=before, candidates=tests, verdict=verdict, effect=effect,
                          runner_up=runner, after=after))
        log.info("%s step %d: %s%s", span_type.name, k, verdict,
                 f" {effect}" + (f" (runner-up {runner})" if runner else "") if effect else "")
        if verdict != "named":
            break
        before = after
    final = (fit if fit.covariance is not None
             else with_covariance(fit, problem, ctx.box, mast_pairs=mast_pairs, workers=workers))
    hz = henze_zirkler(data)
    run = DiagnosisRun(span_type=span_type.name, settings=settings, base=base, n_spans=int(data.shape[0]),
                       skipped=skipped, start=start_fit, steps=steps, final=final, final_names=final.names,
                       final_problem=problem, data_normality={"statistic": hz.statistic, "p_value": hz.p_value},
                       time_s=time.perf_counter() - t0, context=ctx)
    return run


def make_sampler(span_type: SpanType, catenary: Catenary, identification: IdentificationSettings,
                 settings: DiagnosisSettings, effects: tuple[str, ...], *, force_influence_m_n: np.ndarray | None = None,
                 declared_force_n: float = 36.0) -> EffectSampler:
    """The sampler of the model with ``effects`` exactly as :func:`diagnose` builds it (same
    fast models and design columns), e.g. to simulate spans with :func:`.model.simulate_spans`."""
    base = settings.base(identification)
    candidates, _ = applicable_candidates(settings, base, span_type.n_droppers, force_influence_m_n is not None)
    order = tuple(dict.fromkeys((*settings.start_effects, *candidates, *effects)))
    ctx = DiagnosisContext(span_type, catenary, np.zeros((2, span_type.n_droppers)), base,
                   dataclasses.replace(settings, n_samples=max(settings.n_samples, 500)), force_influence_m_n,
                   declared_force_n, order, None)
    return ctx.problem(tuple(effects)).likelihood.sampler


def final_w_law(run: DiagnosisRun, catenary: Catenary, span_type: SpanType,
                extra_covariance_m2: np.ndarray | None = None) -> WLaw:
    """The law of W of a diagnosis' final model (its model sample's Gaussian, plus
    ``extra_covariance_m2``: the data's measurement error the likelihood does not carry) and its
    sensitivities at the fitted means (:func:`.span_check.w_law`)."""
    problem, theta = run.final_problem, run.final.theta
    value = problem.evaluate(theta)
    if value.fit is None:
        raise RuntimeError(f"{span_type.name}: the final model's J is not finite at its optimum ({value.status})")
    means, sigmas = problem.laws(theta)
    covariance = value.fit.chol @ value.fit.chol.T
    if extra_covariance_m2 is not None:
        covariance = covariance + np.asarray(extra_covariance_m2, dtype=float)
    model = problem.likelihood.sampler.models.model(frozenset())
    return w_law(model, means, sigmas, value.fit.mean, covariance)


@dataclass
class LineDiagnosis:
    """A span type's diagnosis with its per-span check.

    Attributes
    ----------
    run : DiagnosisRun
        The verdicts that stand: those of the spans the final model explains when some are not.
    check : SpanCheck
        Every span against the final model of ``run`` (:mod:`.span_check`).
    with_unexplained : DiagnosisRun or None
        The diagnosis of every span, when unexplained spans were left out of ``run``.
    first_check : SpanCheck or None
        The check against the final model of ``with_unexplained``, which chose the spans left out.
    span_effects : pandas.DataFrame or None
        The user's span-scope effects fitted on the spans unexplained alone
        (:func:`.span_effects.test_span_effects`); ``check`` then says which each explains.
    """

    run: DiagnosisRun
    check: SpanCheck
    with_unexplained: DiagnosisRun | None = None
    first_check: SpanCheck | None = None

    span_effects: pd.DataFrame | None = None

    @property
    def depends_on_unexplained(self) -> bool:
        """Whether leaving the unexplained spans out changed the named effects."""
        return self.with_unexplained is not None and self.with_unexplained.named != self.run.named


def diagnose_line(span_type: SpanType, catenary: Catenary, data, places, identification: IdentificationSettings,
                  settings: DiagnosisSettings, *, profile=None, extra_covariance_m2: np.ndarray | None = None,
                  span_effects=None, log: logging.Logger | None = None, **kwargs) -> LineDiagnosis:
    """:func:`diagnose` every span of ``data``, then check each span against the final model; if
    some are unexplained, diagnose again without them (a named effect must be carried by the
    bulk of the spans) and check every span against that final model (docs/diagnosis.md).

    Parameters
    ----------
    data : CorrectedData
        The spans (:func:`catenary.stages.identification.data.read_corrected`).
    places : pandas.DataFrame
        ``section_id``, ``start_chainage_m``, ``end_chainage_m`` of each row of ``data``
        (:func:`catenary.stages.identification.data.span_places`).
    profile : pandas.DataFrame, optional
        The spans' profile tests (:func:`.profile_check.profile_tests`).
    extra_covariance_m2 : numpy.ndarray, optional
        Measurement error of W the diagnosis' likelihood does not carry, added to the final law.
    span_effects : callable, optional
        ``span_effects(span_ids) -> DataFrame``: the user's span-scope effects fitted on the spans
        unexplained alone (:func:`.span_effects.test_span_effects` with the profiles bound); the
        spans an effect explains are explained by it.
    **kwargs
        Passed to :func:`diagnose` (force influence, declared force, workers, spans left out).
    """
    log = log or _LOG
    check_settings = settings.span_check()
    spans = places.reset_index(drop=True).assign(span_id=np.asarray(data.span_id, dtype=str))
    pairs = np.zeros((0, 2), dtype=int) if data.mast_pairs is None else data.mast_pairs

    def checked(run: DiagnosisRun) -> SpanCheck:
        law = final_w_law(run, catenary, span_type, extra_covariance_m2)
        return check_spans(spans, data.w_m, law, profile, pairs, check_settings)

    first = diagnose(span_type, catenary, data.w_m, identification, settings, mast_pairs=data.mast_pairs, log=log,
                     observations=data.observations, **kwargs)
    check = checked(first)
    log.info("%s: %d of %d spans unexplained by the final model (FDR %.0f %%)%s", span_type.name,
             check.n_unexplained, data.w_m.shape[0], 100 * settings.fdr,
             ": " + ", ".join(check.spans.loc[check.unexplained, "span_id"]) if check.n_unexplained else "")
    if check.n_unexplained == 0:
        return LineDiagnosis(first, check)
    fitted, check = _span_effects(check, span_effects, log, span_type.name)
    departing = check.departing
    bulk = data.without(departing, "unexplained by the final model (or only with a local effect)")
    log.info("%s: diagnosed again without the %d unexplained spans", span_type.name, int(departing.sum()))
    n_left_out = kwargs.pop("n_left_out", 0) + int(departing.sum())
    try:
        run = diagnose(span_type, catenary, bulk.w_m, identification, settings, mast_pairs=bulk.mast_pairs,
                       log=log, n_left_out=n_left_out, observations=bulk.observations, models=first.context.models,
                       **kwargs)
    except InputError as exc:          # too few spans left for the model's parameters
        log.warning("%s: the explained spans alone cannot be diagnosed (%s): the verdicts are those of every "
                    "span, the unexplained ones included", span_type.name, exc)
        first.notes.append(f"{int(departing.sum())} spans are unexplained, and the {bulk.w_m.shape[0]} others are too "
                           "few to diagnose alone: the verdicts are those of every span, the unexplained ones "
                           "included")
        return LineDiagnosis(first, check, span_effects=fitted)
    final = checked(run)
    if fitted is not None:
        final = explained_by(final, fitted)
    log.info("%s: against the bulk's final model, %d spans unexplained; named %s (with every span: %s)",
             span_type.name, final.n_unexplained, run.named or "nothing", first.named or "nothing")
    return LineDiagnosis(run, final, first, check, span_effects=fitted)


def explained_by(check: SpanCheck, fitted: pd.DataFrame) -> SpanCheck:
    """``check`` with every unexplained span that a fitted span-scope effect explains marked
    explained by it (``explained_by``: the effect with the largest LR and its magnitudes, SI)."""
    best = (fitted[fitted["explained"].astype(bool)].sort_values("lr_statistic", ascending=False)
            .drop_duplicates("span_id").set_index("span_id"))
    text = {span: f"{r.effect} (" + ", ".join(f"{k} {v[0]:.4g}" for k, v in json.loads(r.parameters).items()) + ")"
            for span, r in best.iterrows()}
    spans = check.spans.copy()
    by = spans["span_id"].map(text).fillna("")
    spans["explained_by"] = np.where(spans["unexplained"].astype(bool), by, "")
    spans["unexplained"] = spans["unexplained"].astype(bool) & (spans["explained_by"] == "")
    return SpanCheck(spans, check.sections, check.noise)


def _span_effects(check: SpanCheck, span_effects, log, name: str):
    """Fit the user's span-scope effects on the spans unexplained alone (not as a section)."""
    if span_effects is None:
        return None, check
    alone = check.spans.loc[check.unexplained & (check.spans["group"] == ""), "span_id"].tolist()
    if not alone:
        return None, check
    fitted = span_effects(alone)
    check = explained_by(check, fitted)
    log.info("%s: the span-scope effects explain %d of the %d spans unexplained alone", name,
             int((check.spans["explained_by"] != "").sum()), len(alone))
    return fitted, check
