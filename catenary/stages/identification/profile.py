"""Profile-likelihood intervals of the identified hyper-parameters, and "no spread detected".

The observed-information standard errors (:mod:`.fit`) come from a quadratic approximation of J
at s_opt; in the log-σ coordinates a Wald interval can never reach σ = 0, so a data set with
no spread in some input still reports a positive σ with a tight-looking interval. The profile
likelihood does not make that approximation: for one coordinate θ_i of the optimiser,

    P(t) = max over the other coordinates of J(θ) with θ_i = t,

and the interval at level 1 − α is ``{t : 2 (J(s_opt) − P(t)) ≤ χ²₁(1 − α)}`` (Wilks). Each
P(t) re-optimises the other parameters under the same design (common random numbers: J is
deterministic), warm-started on the profile path of the quadratic approximation
``θ_−i(t) = θ̂_−i + C_−i,i / C_ii (t − θ̂_i)``, by Fisher scoring (:mod:`.scoring`; Gaussian
estimator) and by bounded Nelder–Mead from the scoring's end where it does not certify its
maximum (and always with the kernel estimator, which has no Gaussian law to score). From that
start the scoring certifies in 1–3 iterations: in the default run the 13 intervals took 2 456
and 3 036 evaluations of J (N2, N3) against 6 861 and 8 133 by Nelder–Mead alone, every end
within 0.05 % of Nelder–Mead's (``tests/test_identification_profile.py`` holds the two to each other). The two
ends are found by a secant iteration on the signed root ``r(t) = ±√(2 (J(s_opt) − P(t)))``,
nearly linear in t, from the Wald end.

Spans that share a mast: when the identification reports the sandwich-widened covariance
(:mod:`.dependence`), the critical drop of coordinate i is ``max(λ_i, 1) χ²₁(1 − α)/2`` — the
profile likelihood ratio of a composite likelihood is ``λ_i χ²₁``, not χ²₁.

Boundary: σ cannot go below the box's lower edge (σ0/50, a spread that moves W by far less than
the data resolve). If the profile is still inside the interval there, the σ interval reaches 0:
the report says "consistent with no spread", with lower end 0. The interval then uses χ²₁ as
everywhere (a test of σ = 0 on its boundary has the null law ½χ²₀ + ½χ²₁ and is the diagnosis'
business); a mean interval that reaches the box edge is reported at the edge and flagged.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np
from scipy import stats
from scipy.optimize import minimize

from catenary.plumbing.workers import map_each

from .design import RandomInput
from .fit import ParameterBox, ScaledProblem
from .likelihood import Likelihood, LikelihoodValue
from .result import IdentificationResult
from .scoring import fisher_scoring

__all__ = ["INNER_FTOL", "ProfileInterval", "ProfileSearch", "profile_intervals", "profile_search"]

#: Accuracy of J in each inner re-optimisation: 0.005 against the 1.92 drop that defines an end
#: moves the signed root by ≈ 0.003, the end by ≈ 0.1 % of its distance from s_opt.
INNER_FTOL = 5e-3


@dataclass(frozen=True)
class ProfileInterval:
    """One parameter's profile-likelihood interval (units of the parameter name).

    Attributes
    ----------
    parameter : str
        Input name.
    statistic : {"mu", "sigma"}
    estimate, low, high : float
        s_opt's value and the interval's ends (``low`` = 0 when a σ reaches its boundary).
    low_at_boundary, high_at_boundary : bool
        The profile stayed inside the interval up to the box edge on that side.
    n_evaluations : int
        J evaluations spent on this parameter.
    """

    parameter: str
    statistic: str
    estimate: float
    low: float
    high: float
    low_at_boundary: bool
    high_at_boundary: bool
    n_evaluations: int

    @property
    def no_spread_detected(self) -> bool:
        """A σ whose interval reaches 0: the data are consistent with no spread of this input."""
        return self.statistic == "sigma" and self.low_at_boundary


@dataclass
class _Held:
    """``problem`` with coordinate ``i`` held at ``theta[i]``: J over the other coordinates."""

    problem: ScaledProblem
    theta: np.ndarray
    others: np.ndarray

    @property
    def likelihood(self) -> Likelihood:
        return self.problem.likelihood

    @property
    def n_evaluations(self) -> int:
        return self.problem.n_evaluations

    def full(self, x: np.ndarray) -> np.ndarray:
        theta = self.theta.copy()
        theta[self.others] = x
        return theta

    def evaluate(self, x: np.ndarray) -> LikelihoodValue:
        return self.problem.evaluate(self.full(x))

    def objective(self, x: np.ndarray) -> float:
        return self.problem.objective(self.full(x))



@dataclass(frozen=True)
class ProfileSearch:
    """The searches of a set of profile intervals' ends (:func:`profile_search`).

    Attributes
    ----------
    ends : list of callable
        One per end, low then high of each parameter: called with nothing, each returns
        (θ_i at the end, whether it is the box's edge, J evaluations).
    intervals : callable
        From the ends' results, in the order of ``ends``, the list of :class:`ProfileInterval`.
    """

    ends: list[Callable[[], tuple[float, bool, int]]]
    intervals: Callable[[list], list[ProfileInterval]]

def _profile(problem: ScaledProblem, theta_opt, cov, i, t, lo, hi, max_evaluations, method):
    """P(t) and the maximising θ: the other coordinates re-optimised from the quadratic
    approximation's profile path, by Fisher scoring (Gaussian estimator) and by bounded
    Nelder–Mead from its end where the scoring does not certify its maximum."""
    others = np.flatnonzero(np.arange(theta_opt.size) != i)
    guess = theta_opt.copy()
    if np.isfinite(cov[i, i]) and cov[i, i] > 0:
        guess = theta_opt + np.nan_to_num(cov[:, i] / cov[i, i]) * (t - theta_opt[i])
    guess[i] = t
    guess = np.clip(guess, lo, hi)
    if others.size == 0:
        return problem.j(guess), guess
    held = _Held(problem, guess, others)
    x0 = guess[others]
    if method == "fisher-scoring" and problem.likelihood.estimator == "gaussian":
        scored = fisher_scoring(held, x0, lo[others], hi[others], np.zeros(others.size, dtype=bool), ftol=INNER_FTOL,
                                max_evaluations=max_evaluations)
        if scored.certified:
            return scored.j, held.full(scored.theta)
        if np.isfinite(scored.j):
            x0 = scored.theta
        max_evaluations = max(max_evaluations - scored.n_evaluations, 1)
    scale = np.sqrt(np.diag(cov))[others]
    scale = np.where(np.isfinite(scale) & (scale > 0), scale, 0.3)       # 0.3: no curvature known
    step = np.clip(0.3 * scale, 1e-3, 0.5)
    step = np.where(x0 + step <= hi[others], step, -step)
    simplex = np.vstack([x0, x0 + np.diag(step)])
    res = minimize(held.objective, x0, method="Nelder-Mead", bounds=list(zip(lo[others], hi[others])),
                   options=dict(initial_simplex=simplex, xatol=1e-2, fatol=INNER_FTOL, maxfev=max_evaluations,
                                adaptive=True))
    return -float(res.fun), held.full(res.x)


def profile_search(likelihood: Likelihood, start: tuple[RandomInput, ...], result: IdentificationResult, *,
                   parameters: tuple[str, ...] | None = None, box: ParameterBox = ParameterBox(),
                   level: float = 0.95, max_evaluations: int = 400, tolerance: float = 0.05,
                   max_steps: int = 8, method: str = "fisher-scoring") -> ProfileSearch:
    """The searches of the profile-likelihood intervals' ends of every free mean and σ of
    ``result`` (module docstring), to be run where the caller likes (:func:`profile_intervals`
    runs them in worker processes).

    Parameters
    ----------
    likelihood : Likelihood
        The J that ``result`` maximised (same design).
    start : tuple of RandomInput
        s0 of that identification.
    result : IdentificationResult
    parameters : tuple of str, optional
        Input names whose free mean and σ are profiled (default: every free coordinate). Each
        costs a few hundred J evaluations per end (measured: 900–2 400 per parameter).
    box : ParameterBox
        The admissible region of that identification.
    level : float
        Confidence level (0.95: the profile drops by χ²₁(0.95)/2 = 1.92 at the ends).
    max_evaluations : int
        Budget of J evaluations of each inner re-optimisation.
    tolerance : float
        Accuracy of each end in units of the parameter's standard error.
    max_steps : int
        Widening or secant steps per end, at most.
    method : {"fisher-scoring", "nelder-mead"}
        Each re-optimisation of the other coordinates: Fisher scoring, then Nelder–Mead where it
        does not certify its maximum (module docstring), or Nelder–Mead alone.

    Returns
    -------
    ProfileSearch
        One search per end, each from s_opt alone: the same intervals whatever runs them.
    """
    if not 0.0 < level < 1.0:
        raise ValueError(f"level: expected a probability in (0, 1), got {level!r}")
    if method not in ("fisher-scoring", "nelder-mead"):
        raise ValueError(f"method: expected 'fisher-scoring' or 'nelder-mead', got {method!r}")
    free_means = tuple(p[:-3] for p in result.free_parameters if p.endswith(".mu"))
    free_sigmas = tuple(p[:-6] for p in result.free_parameters if p.endswith(".sigma"))
    problem = ScaledProblem.for_inputs(likelihood, start, free_means, free_sigmas)
    problem.recording = False
    lo, hi = problem.bounds(box)
    theta_opt = np.asarray(result.theta_opt, dtype=float)
    cov = np.asarray(result.theta_covariance, dtype=float)
    j_opt = float(result.j_opt)
    # 1.96 on the signed-root scale; × √max(λ_i, 1) for spans sharing masts (.dependence).
    critical_base = float(np.sqrt(stats.chi2.ppf(level, 1)))
    inflation = result.variance_widening
    nm = problem.free_mean_idx.size
    chosen = [i for i, coordinate in enumerate(result.free_parameters)
              if parameters is None or coordinate.rsplit(".", 1)[0] in parameters]

    def end(i: int, side: float) -> tuple[float, bool, int]:
        """One end of coordinate i's interval: (θ_i there, at the box's edge, J evaluations)."""
        first_evaluation = problem.n_evaluations

        def root(t):
            """Signed-root distance of the profile at θ_i = t below J(s_opt) (≥ 0)."""
            value, _ = _profile(problem, theta_opt, cov, i, t, lo, hi, max_evaluations, method)
            return np.sqrt(2.0 * max(j_opt - value, 0.0))

        critical = critical_base * float(np.sqrt(inflation[i]))
        se = float(np.sqrt(cov[i, i])) if np.isfinite(cov[i, i]) and cov[i, i] > 0 else 0.5
        edge = lo[i] if side < 0 else hi[i]
        t_in, r_in = theta_opt[i], 0.0
        t_out = float(np.clip(theta_opt[i] + side * critical * se, lo[i], hi[i]))
        r_out = root(t_out)
        steps = 0
        while r_out < critical and t_out != edge and steps < max_steps:
            t_in, r_in = t_out, r_out
            t_out = float(np.clip(theta_opt[i] + 1.6 * (t_out - theta_opt[i]), lo[i], hi[i]))
            r_out = root(t_out)
            steps += 1
        if r_out < critical:                 # still inside at the box edge (or out of steps)
            return t_out, t_out == edge, problem.n_evaluations - first_evaluation
        for _ in range(max_steps):           # secant on r(t) − critical, kept in the bracket
            t_new = t_in + (critical - r_in) * (t_out - t_in) / (r_out - r_in)
            if abs(t_new - t_in) < tolerance * se or abs(t_out - t_new) < tolerance * se:
                t_in = t_new
                break
            r_new = root(t_new)
            if r_new < critical:
                t_in, r_in = t_new, r_new
            else:
                t_out, r_out = t_new, r_new
        return t_in, False, problem.n_evaluations - first_evaluation

    # Every end is its own search from s_opt: in any process, in any order.
    tasks = [(i, side) for i in chosen for side in (-1.0, 1.0)]

    def intervals(found: list) -> list[ProfileInterval]:
        out = []
        for n_chosen, i in enumerate(chosen):
            (low, low_edge, n_low), (high, high_edge, n_high) = found[2 * n_chosen], found[2 * n_chosen + 1]
            ends, at_edge = [low, high], [low_edge, high_edge]
            if i < nm:
                k = problem.free_mean_idx[i]
                values = [problem.mu0[k] + problem.mean_scale[k] * t for t in (theta_opt[i], *ends)]
                statistic = "mu"
            else:
                k = problem.free_sigma_idx[i - nm]
                values = [problem.sd0[k] * np.exp(t) for t in (theta_opt[i], *ends)]
                statistic = "sigma"
                if at_edge[0]:
                    values[1] = 0.0                  # the interval reaches σ = 0: no spread detected
            out.append(ProfileInterval(parameter=start[k].name, statistic=statistic, estimate=float(values[0]),
                                       low=float(values[1]), high=float(values[2]), low_at_boundary=at_edge[0],
                                       high_at_boundary=at_edge[1], n_evaluations=n_low + n_high))
        return out

    return ProfileSearch(ends=[partial(end, i, side) for i, side in tasks], intervals=intervals)


def profile_intervals(likelihood: Likelihood, start: tuple[RandomInput, ...], result: IdentificationResult, *,
                      workers: int = 1, **options) -> list[ProfileInterval]:
    """Profile-likelihood intervals of every free mean and σ of ``result`` (module docstring).

    Parameters
    ----------
    likelihood, start, result, **options
        As :func:`profile_search`.
    workers : int
        Processes over the intervals' ends (:func:`catenary.plumbing.workers.map_each`): each
        end is searched from s_opt alone, so the intervals are the same for any number.

    Returns
    -------
    list of ProfileInterval
        In the order of ``result.free_parameters`` (those of ``parameters``).
    """
    search = profile_search(likelihood, start, result, **options)
    return search.intervals(map_each(lambda k: search.ends[k](), len(search.ends), workers, 1))
