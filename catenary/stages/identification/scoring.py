"""Fisher scoring of J: its own Gaussian law gives the curvature.

Two re-optimisations from a warm start use it: the diagnosis's refit of a candidate effect
(:func:`catenary.stages.diagnosis.problem.refit`) and each point of a profile likelihood
(:mod:`.profile`: the other coordinates re-optimised with one held).

J is the log-likelihood of ν measured spans under the Gaussian law N(m(θ), Σ(θ)) of the model's
W (:class:`~catenary.stages.identification.likelihood.Likelihood`, Gaussian estimator). Its expected
(Fisher) information

    I(θ) = ν [ ∂mᵀ Σ⁻¹ ∂m + ½ tr(Σ⁻¹ ∂Σ Σ⁻¹ ∂Σ) ]

needs only the first derivatives of m and Σ, which the central differences of J's gradient
evaluate anyway (2p + 1 evaluations for p coordinates). Each iteration steps by
``(I + λ diag I)⁻¹ ∇J`` (Levenberg–Marquardt: λ = 0 is the scoring step; λ grows by 10 while a
step does not raise J, and shrinks again after one that does), scaled so that no coordinate
moves more than r times its cap (1 in θ, 4 for a variance), inside the box. A spread enters as
its variance v = t² (t = σ/scale is the optimiser's coordinate): J is flat in t at the null,
where its gradient in v is not, so the step can leave the null; its difference is one-sided
there.

The radius r (1 at the start) is a trust region: it doubles, up to 16, after a step that was cut
by it and gained more than ¾ of what the quadratic model predicted, halves (down to 1/64)
after one that gained less than ¼, and shrinks by 4 where a trial step leaves the model's
domain (J not finite: a T_CW spread beyond the tensions the model was built for, CW offsets
beyond the tabulated ones), where more damping would not shorten a move held at its cap. On the
default campaign (2026-11-26) the doubling let the CW wear's refit walk its mean fraction 8 caps
from the null, to its bound, and its spread's variance 4 caps: N2's refit was certified after 10
iterations (277 evaluations, J 0.03 above Nelder–Mead's after 1 973), where the fixed cap
crawled and handed over. Where r stays 1, the iterations are those of the fixed cap.

A coordinate whose difference step leaves the domain in the direction its gradient points is at
the domain's edge and is held there, as one on its bound whose gradient points out of the box:
the others then climb at full steps instead of every step shrinking against the edge, and the
maximum along the edge is certified within a difference step of it (J within ``STEP`` × the
gradient there). On the default campaign (2026-11-27) the CW offset's refit at step 1, whose
spread runs to its bound and whose mean to where the design's lowest score reaches the
tabulated −0.5 m, crawled with the radius shrinking by 4 then doubling at every iteration (J
4 510 after 12, Nelder–Mead after it reaching 4 566.37 in 1 536 evaluations in all); holding
the mean at the edge it reached J 4 566.00 at iteration 12 (742 evaluations in all, Δℓ 0.016
higher).

Where the model fits the data the scoring step is nearly Newton's and converges in a few
iterations: on the default campaign's N2 (117 spans, N = 10⁴) the named T_MW spread's refit
took 162 evaluations to J within 10⁻⁴ of Nelder–Mead's after 1 409. Where it does not (an
effect standing in for another, J's maximum far from the null along a poorly modelled
direction), the expected information is not J's curvature and the iterations crawl (two
steps in a row gaining less than ``ftol`` end the scoring), or stop at a point they cannot
improve. The result is therefore **certified** only where a full
scoring step (λ = 0, uncapped) predicts a gain below ``ftol`` — the quadratic model, accurate
there, says the maximum is reached; otherwise :func:`fisher_scoring` says why it stopped and the
caller goes on by Nelder–Mead from the better point.

In a profile the start (the quadratic approximation's profile path) is close to the maximum:
on the default campaign's N3 (in-process, 2026-11-26) every one of the 62 profile points was
certified, after 1–3 iterations (26–76 evaluations, against 150–250 by Nelder–Mead), the 26
interval ends within 0.05 % of Nelder–Mead's. A start far from the maximum gains nothing: the
diagnosis's start fit, from s0 and without the T_MW spread the data show, did not certify in
12 iterations and, with Nelder–Mead after it, cost about as much as Nelder–Mead alone (N2 1 086
evaluations against 1 168, N3 963 against 779; tried, not used).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ScoringResult", "expected_information", "fisher_scoring", "gaussian_moments"]

#: Central-difference step of a coordinate in θ (the diagnosis's refits take their base coordinates'
#: step from here).
STEP = 0.02
#: Step of a spread's variance v = t² (t = 0.25: a quarter of the spread's typical size).
VARIANCE_STEP = 0.0625
#: Largest move of a coordinate in one step (θ; a variance: 4, i.e. t from 0 to 2).
MAX_MOVE = 1.0
MAX_VARIANCE_MOVE = 4.0
#: Trials of the damping λ in one iteration before the scoring gives up.
MAX_DAMPING_TRIALS = 6
#: The trust radius r multiplies the caps: its largest value, its smallest after a poor step.
MAX_RADIUS = 16.0
MIN_RADIUS = 1.0 / 64


@dataclass(frozen=True)
class ScoringResult:
    """The end of a Fisher-scoring run.

    Attributes
    ----------
    theta : numpy.ndarray
        The best point reached (θ, spreads as t).
    j : float
        J there (−inf if J was not finite at the start).
    certified : bool
        Converged on a full scoring step (module docstring).
    message : str
        Why it stopped.
    n_evaluations : int
        J evaluations spent.
    """

    theta: np.ndarray
    j: float
    certified: bool
    message: str
    n_evaluations: int


def gaussian_moments(value) -> tuple[np.ndarray, np.ndarray]:
    """Mean and covariance of the Gaussian law of W behind a J evaluation (``value.fit``)."""
    f = value.fit
    return f.mean, f.chol @ f.chol.T


def expected_information(moments: list[tuple[np.ndarray, np.ndarray]], derivative_steps: list, n_spans: int,
                         reference: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """Fisher information of ν Gaussian spans from finite-difference moments.

    Parameters
    ----------
    moments : list of ((m₊, Σ₊), (m₋, Σ₋)) per coordinate
        The model's mean and covariance at the coordinate moved up and down (for a one-sided
        difference, ``(m₋, Σ₋)`` is the reference itself).
    derivative_steps : list of float
        The step of each coordinate's difference (``+h − (−h) = 2h`` central, ``h`` one-sided).
    n_spans : int
        ν.
    reference : (m, Σ)
        Mean and covariance at the point.
    """
    sigma = reference[1]
    inv = np.linalg.inv(sigma)
    dm = [(up[0] - down[0]) / h for (up, down), h in zip(moments, derivative_steps)]
    ds = [(up[1] - down[1]) / h for (up, down), h in zip(moments, derivative_steps)]
    p = len(dm)
    info = np.empty((p, p))
    a = [inv @ x for x in ds]
    for i in range(p):
        for k in range(i + 1):
            info[i, k] = info[k, i] = dm[i] @ inv @ dm[k] + 0.5 * np.trace(a[i] @ a[k])
    return n_spans * info


def fisher_scoring(problem, theta0: np.ndarray, lo: np.ndarray, hi: np.ndarray, spread: np.ndarray, *, ftol: float,
                   max_iterations: int = 12, max_evaluations: int = 4000) -> ScoringResult:
    """Maximise ``problem``'s J from ``theta0`` by damped Fisher scoring (module docstring).

    Parameters
    ----------
    problem : JointProblem or ScaledProblem
        Its ``evaluate(θ)`` returns a :class:`~catenary.stages.identification.likelihood.LikelihoodValue`
        whose ``fit`` holds the Gaussian law of W (None where J is not finite).
    theta0 : numpy.ndarray
        Start, inside ``[lo, hi]`` after clipping.
    lo, hi : numpy.ndarray
        The box in θ.
    spread : numpy.ndarray of bool
        Coordinates that are spreads (t ≥ 0, handled in t²).
    ftol : float
        Certified when a full scoring step predicts a gain below this.
    max_iterations, max_evaluations : int
        Limits; reaching either leaves the result uncertified.
    """
    spread = np.asarray(spread, dtype=bool)
    n_spans = problem.likelihood.data_w_m.shape[0]
    n0 = problem.n_evaluations
    xlo, xhi = np.asarray(lo, dtype=float).copy(), np.asarray(hi, dtype=float).copy()
    xlo[spread], xhi[spread] = np.maximum(xlo[spread], 0.0) ** 2, xhi[spread] ** 2
    steps = np.where(spread, VARIANCE_STEP, STEP)
    cap = np.where(spread, MAX_VARIANCE_MOVE, MAX_MOVE)

    def theta_of(x):
        theta = x.copy()
        theta[spread] = np.sqrt(np.maximum(x[spread], 0.0))
        return theta

    x = np.clip(np.asarray(theta0, dtype=float), lo, hi)
    x[spread] = x[spread] ** 2
    current = problem.evaluate(theta_of(x))

    def result(certified, message):
        return ScoringResult(theta_of(x), float(current.j), certified, message, problem.n_evaluations - n0)

    if current.fit is None:
        return result(False, f"J not finite at the start ({current.status})")
    damping, small_gains, radius = 0.0, 0, 1.0
    for iteration in range(1, max_iterations + 1):
        if problem.n_evaluations - n0 + 2 * x.size + MAX_DAMPING_TRIALS > max_evaluations:
            return result(False, f"evaluation budget reached after {iteration - 1} iterations")
        moments, widths, gradient = [], [], np.zeros(x.size)
        usable = np.ones(x.size, dtype=bool)
        edge_up, edge_down = np.zeros(x.size, dtype=bool), np.zeros(x.size, dtype=bool)
        for i in range(x.size):
            up, down = x.copy(), x.copy()
            up[i] = min(x[i] + steps[i], xhi[i])
            down[i] = max(x[i] - steps[i], xlo[i])
            v_up = problem.evaluate(theta_of(up)) if up[i] > x[i] else current
            v_down = problem.evaluate(theta_of(down)) if down[i] < x[i] else current
            if v_up.fit is None:                 # J not finite on one side: one-sided on the other
                v_up, up = current, x
                edge_up[i] = True
            if v_down.fit is None:
                v_down, down = current, x
                edge_down[i] = True
            width = up[i] - down[i]
            if width <= 0.0:                     # neither side finite: this coordinate stays put
                usable[i] = False
                moments.append((gaussian_moments(current), gaussian_moments(current)))
                widths.append(1.0)
                continue
            moments.append((gaussian_moments(v_up), gaussian_moments(v_down)))
            widths.append(width)
            gradient[i] = (v_up.j - v_down.j) / width
        info = expected_information(moments, widths, n_spans, gaussian_moments(current))
        # A coordinate on its bound whose gradient points out of the box stays there; so does one
        # within a difference step of the model's domain edge, its gradient pointing beyond it.
        free = usable & ~((x <= xlo) & (gradient < 0.0)) & ~((x >= xhi) & (gradient > 0.0))
        free &= ~(edge_down & (gradient < 0.0)) & ~(edge_up & (gradient > 0.0))
        seen = usable & (np.diag(info) > 0.0)
        free &= seen
        if not free.any():
            if seen.all():               # every coordinate on a bound it is pushed against
                return result(True, f"converged after {iteration - 1} iterations (every coordinate on its bound)")
            return result(False, f"no coordinate left to move at iteration {iteration}")
        a = info[np.ix_(free, free)]
        g = gradient[free]
        for _ in range(MAX_DAMPING_TRIALS):
            move = np.zeros(x.size)
            move[free] = np.linalg.lstsq(a + damping * np.diag(np.diag(a)), g, rcond=1e-12)[0]
            largest = float(np.max(np.abs(move) / (radius * cap)))
            if largest > 1.0:
                move /= largest
            predicted = float(g @ move[free] - 0.5 * move[free] @ a @ move[free])
            trial_x = np.clip(x + move, xlo, xhi)
            trial = problem.evaluate(theta_of(trial_x))
            if damping == 0.0 and largest <= 1.0 and largest * radius <= 1.0 and predicted < ftol:
                # A full scoring step that can gain less than ftol: at the maximum, whether or
                # not J's rounding lets this last step raise it.
                if trial.j > current.j:
                    x, current = trial_x, trial
                return result(True, f"converged after {iteration} iterations (predicted gain {predicted:.2g})")
            if trial.j > current.j:
                break
            if trial.fit is None:        # out of the model's domain: a shorter move, not more damping
                radius /= 4.0
            else:
                damping = max(1e-3, 10.0 * damping)
        else:
            return result(False, f"no step raised J at iteration {iteration} (damping {damping:g}, radius {radius:g})")
        gain = float(trial.j - current.j)
        agreement = gain / predicted if predicted > 0.0 else 0.0
        if agreement > 0.75 and largest >= 1.0:
            radius = min(2.0 * radius, MAX_RADIUS)
        elif agreement < 0.25 and radius > MIN_RADIUS:
            radius = max(0.5 * radius, MIN_RADIUS)
        x, current = trial_x, trial
        damping = damping / 10.0 if damping > 1e-3 else 0.0
        small_gains = small_gains + 1 if gain < ftol else 0
        if small_gains == 2:             # crawling where the quadratic model is wrong: hand over
            return result(False, f"crawling at iteration {iteration} (two gains below {ftol:g})")
    return result(False, f"not converged in {max_iterations} iterations")
