"""J of a model with effects, in the optimiser's coordinates, its maximum and its curvature.

Coordinates θ: the base's free means and log-σ exactly as the identification scales them
(:class:`~catenary.stages.identification.fit.ScaledProblem`), then every parameter of every active
effect divided by its typical size (:attr:`~.candidates.CandidateParameter.scale`), in the
effect's allowed range. A spread's null 0 is the lower edge of its range, so the optimiser can
reach it (a log scale could not).

A model is refitted from a warm start — the current optimum with the new effect at its null —
under the same design, N and likelihood as the model without it: by Fisher scoring where it
certifies its maximum (:mod:`catenary.stages.identification.scoring`), by Nelder–Mead otherwise or on
request.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from catenary.stages.identification.dependence import robust_covariance, widening
from catenary.stages.identification.design import RandomInput
from catenary.stages.identification.fit import (ParameterBox, ScaledProblem, evaluate_points, observed_covariance,
                                                run_nelder_mead)
from catenary.stages.identification.likelihood import Likelihood, LikelihoodValue
from catenary.stages.identification.scoring import fisher_scoring
from .candidates import CANDIDATES, CandidateParameter

__all__ = ["Fit", "JointProblem", "refit", "with_covariance"]

#: Objective given to the optimiser where J = −inf.
_PENALTY = 1e10


@dataclass
class JointProblem:
    """J over the base laws and the magnitudes of the active effects.

    Attributes
    ----------
    likelihood : Likelihood
        J with the sampler of the model (:class:`.model.EffectSampler`).
    base : ScaledProblem
        The base's coordinates (its likelihood is not called).
    effects : tuple of str
        Active effects, in the sampler's order.
    """

    likelihood: Likelihood
    base: ScaledProblem
    effects: tuple[str, ...]
    n_evaluations: int = 0
    best: tuple = field(default=(None, -np.inf))

    @property
    def coordinates(self) -> list[tuple[str, CandidateParameter]]:
        """(effect, parameter) of every effect coordinate, in θ order."""
        return [(e, p) for e in self.effects for p in CANDIDATES[e].parameters]

    @property
    def n_base(self) -> int:
        return self.base.free_mean_idx.size + self.base.free_sigma_idx.size

    @property
    def names(self) -> list[str]:
        """Names of the coordinates: ``<input>.mu`` / ``<input>.sigma``, then ``<effect>.<parameter>``."""
        start = self.base.start
        return ([f"{start[i].name}.mu" for i in self.base.free_mean_idx]
                + [f"{start[i].name}.sigma" for i in self.base.free_sigma_idx]
                + [f"{e}.{p.name}" for e, p in self.coordinates])

    def magnitudes(self, theta: np.ndarray) -> dict[str, dict[str, float]]:
        out: dict[str, dict[str, float]] = {e: {} for e in self.effects}
        for (e, p), t in zip(self.coordinates, np.asarray(theta, dtype=float)[self.n_base:]):
            out[e][p.name] = float(p.scale * t)
        return out

    def laws(self, theta: np.ndarray):
        return self.base.laws(np.asarray(theta, dtype=float)[:self.n_base])

    def evaluate(self, theta: np.ndarray) -> LikelihoodValue:
        theta = np.asarray(theta, dtype=float)
        return self._record(theta, self._value(theta))

    def _value(self, theta: np.ndarray) -> LikelihoodValue:
        return self.likelihood.evaluate(*self.laws(theta), self.magnitudes(theta))

    def _record(self, theta: np.ndarray, value: LikelihoodValue) -> LikelihoodValue:
        """Count an evaluation at θ and keep the best."""
        self.n_evaluations += 1
        if value.j > self.best[1]:
            self.best = (theta.copy(), value.j)
        return value

    def evaluate_many(self, thetas, workers: int = 1) -> list[LikelihoodValue]:
        """:meth:`evaluate` at each θ of ``thetas`` in ``workers`` processes
        (:func:`catenary.stages.identification.fit.evaluate_points`), counted and the best kept
        here in their order, as one after the other."""
        thetas = [np.asarray(t, dtype=float) for t in thetas]
        return [self._record(t, v) for t, v in zip(thetas, evaluate_points(self._value, thetas, workers))]

    def j(self, theta: np.ndarray) -> float:
        return self.evaluate(theta).j

    def log_densities(self, theta: np.ndarray):
        """``ln p`` of each span's data at θ and, with observations besides W, the line's term
        (line quantities, errors shared by every span) as one more independent unit (what the
        sandwich sums over); None where J is not finite."""
        return self._log_densities(self.evaluate(theta))

    def log_densities_many(self, thetas, workers: int = 1) -> list:
        """:meth:`log_densities` at each θ of ``thetas`` in ``workers`` processes."""
        return [self._log_densities(v) for v in self.evaluate_many(thetas, workers)]

    def _log_densities(self, value: LikelihoodValue):
        if value.log_density is None or self.likelihood.observations is None:
            return value.log_density
        return np.r_[value.log_density, value.line_log_density]

    def objective(self, theta) -> float:
        value = self.j(theta)
        return -value if np.isfinite(value) else _PENALTY

    def bounds(self, box: ParameterBox) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = self.base.bounds(box)
        lo_e = [p.bounds[0] / p.scale for _, p in self.coordinates]
        hi_e = [p.bounds[1] / p.scale for _, p in self.coordinates]
        return np.concatenate([lo, lo_e]), np.concatenate([hi, hi_e])

    def with_effects(self, likelihood: Likelihood, effects: tuple[str, ...]) -> "JointProblem":
        """The same base coordinates for another model (likelihood and effects)."""
        return JointProblem(likelihood, self.base, tuple(effects))

    @classmethod
    def for_inputs(cls, likelihood: Likelihood, start: tuple[RandomInput, ...], free_means, free_sigmas,
                   effects: tuple[str, ...]) -> "JointProblem":
        return cls(likelihood, ScaledProblem.for_inputs(likelihood, start, free_means, free_sigmas), tuple(effects))


@dataclass(frozen=True)
class Fit:
    """A model fitted by maximum likelihood.

    Attributes
    ----------
    effects : tuple of str
    theta : numpy.ndarray
        θ at the maximum.
    j : float
        J there.
    names : list of str
        Coordinate names (:attr:`JointProblem.names`).
    converged : bool
    message : str
    n_evaluations : int
        J evaluations of the optimiser.
    time_s : float
    covariance : numpy.ndarray or None
        (−H)⁻¹ in θ over the interior coordinates (NaN elsewhere), widened by the sandwich over
        spans that share a mast where that is wider; None when not computed.
    variance_widening : numpy.ndarray or None
        The sandwich factor max(λ, 1) per coordinate (1 without mast pairs).
    interior : numpy.ndarray of bool or None
        Coordinates away from a lower bound (a spread at 0, a base σ on the box edge).
    """

    effects: tuple[str, ...]
    theta: np.ndarray
    j: float
    names: list[str]
    converged: bool
    message: str
    n_evaluations: int
    time_s: float
    covariance: np.ndarray | None = None
    variance_widening: np.ndarray | None = None
    interior: np.ndarray | None = None

    def magnitudes(self, problem: JointProblem) -> dict[str, dict[str, float]]:
        return problem.magnitudes(self.theta)

    def effect_estimates(self, problem: JointProblem) -> dict[str, dict[str, tuple[float, float]]]:
        """``{effect: {parameter: (value, standard error)}}`` [SI]; the error is NaN where not
        computed or on the boundary."""
        out: dict[str, dict[str, tuple[float, float]]] = {e: {} for e in self.effects}
        for k, (e, p) in enumerate(problem.coordinates):
            i = problem.n_base + k
            se = np.nan
            if self.covariance is not None and np.isfinite(self.covariance[i, i]):
                se = p.scale * float(np.sqrt(self.covariance[i, i]))
            out[e][p.name] = (p.scale * float(self.theta[i]), se)
        return out


def refit(problem: JointProblem, theta0: np.ndarray, box: ParameterBox, *, base_step: float = 0.2,
          effect_step: float = 1.0, max_evaluations: int = 4000, xtol: float = 1e-3, ftol: float = 1e-4,
          method: str = "nelder-mead", workers: int = 1) -> Fit:
    """Maximise J from ``theta0``; each J's model sample shared by ``workers`` processes
    (:meth:`catenary.stages.identification.likelihood.Likelihood.parallel`: the same fit for any number).

    ``method="nelder-mead"``: Nelder–Mead, simplex steps ``base_step`` on the base coordinates and
    ``effect_step`` on the effects', stopped at ``xtol`` in θ and ``ftol`` in J.
    ``"fisher-scoring"``: Fisher scoring first (:mod:`catenary.stages.identification.scoring`); if it does
    not certify its maximum, Nelder–Mead as above from the better of its end and ``theta0``, with
    what is left of the budget. The fit's message says which ended it.
    """
    with problem.likelihood.parallel(workers):
        return _refit(problem, theta0, box, base_step, effect_step, max_evaluations, xtol, ftol, method)


def _refit(problem, theta0, box, base_step, effect_step, max_evaluations, xtol, ftol, method) -> Fit:
    lo, hi = problem.bounds(box)
    theta0 = np.clip(np.asarray(theta0, dtype=float), lo, hi)
    problem.best = (None, -np.inf)
    n0 = problem.n_evaluations
    t0 = time.perf_counter()
    prefix = ""
    if method == "fisher-scoring":
        spread = np.zeros(lo.size, dtype=bool)
        spread[problem.n_base:] = [p.kind == "spread" for _, p in problem.coordinates]
        scored = fisher_scoring(problem, theta0, lo, hi, spread, ftol=ftol, max_evaluations=max_evaluations)
        if scored.certified:
            return Fit(effects=problem.effects, theta=scored.theta, j=scored.j, names=problem.names, converged=True,
                       message="Fisher scoring " + scored.message, n_evaluations=problem.n_evaluations - n0,
                       time_s=time.perf_counter() - t0)
        prefix = f"Fisher scoring {scored.message}; Nelder–Mead: "
        if np.isfinite(scored.j):
            theta0 = scored.theta
        max_evaluations = max(max_evaluations - scored.n_evaluations, 1)
        problem.best = (None, -np.inf)
    elif method != "nelder-mead":
        raise ValueError(f"method: expected 'nelder-mead' or 'fisher-scoring', got {method!r}")
    steps = np.r_[np.full(problem.n_base, base_step), np.full(lo.size - problem.n_base, effect_step)]
    converged, message = run_nelder_mead(problem, theta0, lo, hi, steps, max_evaluations, xtol, ftol)
    theta, j = problem.best
    if theta is None:                    # no finite J anywhere: report the start as not converged
        theta, j, converged, message = theta0, -np.inf, False, "no finite J: " + message
    return Fit(effects=problem.effects, theta=theta, j=float(j), names=problem.names, converged=converged,
               message=prefix + message, n_evaluations=problem.n_evaluations - n0, time_s=time.perf_counter() - t0)


def with_covariance(fit: Fit, problem: JointProblem, box: ParameterBox, *, step: float = 0.01,
                    mast_pairs: np.ndarray | None = None, workers: int = 1) -> Fit:
    """``fit`` with the observed-information covariance (interior coordinates), widened by the
    sandwich over spans sharing a mast where that is wider (as the identification does); the
    J evaluations of both in ``workers`` processes (the same covariance for any number)."""
    lo, _ = problem.bounds(box)
    nm = problem.base.free_mean_idx.size
    interior = np.ones(fit.theta.size, dtype=bool)
    interior[nm:] = fit.theta[nm:] > lo[nm:] + step          # σ and spreads away from their lower edge
    for k, (_, p) in enumerate(problem.coordinates):
        if p.kind == "shift":
            interior[problem.n_base + k] = True
    cov, _ = observed_covariance(problem, fit.theta, step, interior, workers)
    factor = np.ones(fit.theta.size)
    if mast_pairs is not None and np.all(np.isfinite(cov[np.ix_(interior, interior)])):
        robust = robust_covariance(problem.log_densities, fit.theta, step, cov, interior, mast_pairs,
                                   log_density_many=lambda x: problem.log_densities_many(x, workers))
        factor = widening(cov, robust)
    d = np.sqrt(factor)
    return Fit(**{**fit.__dict__, "covariance": cov * np.outer(d, d), "variance_widening": factor,
                  "interior": interior})
