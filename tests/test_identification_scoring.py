"""Fisher scoring (catenary.stages.identification.scoring) on a Gaussian likelihood whose maximum is
known in closed form."""

from types import SimpleNamespace

import numpy as np
import pytest

from catenary.stages.identification.likelihood import GaussianFit, LikelihoodValue
from catenary.stages.identification.scoring import MAX_MOVE, STEP, fisher_scoring


class MeanShift:
    """J of ν spans under N(A θ, s² I): θ moves the model's mean along the columns of A. The
    maximum is the least-squares θ̂ = A⁺ w̄, and the Fisher information ν AᵀA / s² is J's exact
    curvature, so a scoring step that its cap does not cut lands on θ̂."""

    def __init__(self, a: np.ndarray, data: np.ndarray, s: float):
        self.a, self.s = a, s
        self.likelihood = SimpleNamespace(data_w_m=data)
        self.n_evaluations = 0

    def evaluate(self, theta):
        self.n_evaluations += 1
        mean = self.a @ np.asarray(theta, dtype=float)
        r = (self.likelihood.data_w_m - mean) / self.s
        logp = -0.5 * np.sum(r * r, axis=1) - r.shape[1] * np.log(self.s * np.sqrt(2 * np.pi))
        fit = GaussianFit(mean=mean, chol=self.s * np.eye(mean.size), n_effective=1e4)
        return LikelihoodValue(float(logp.sum()), 0.0, 1e4, "ok", logp, fit)


def with_edge(problem: MeanShift, edge: float) -> None:
    """Make ``problem``'s J not finite beyond θ₁ = ``edge`` (a model without a law there, as T_CW
    spreads beyond the built tension range or CW offsets beyond the tabulated ones)."""
    inner = problem.evaluate

    def evaluate(theta):
        if theta[0] > edge:
            problem.n_evaluations += 1
            return LikelihoodValue(-np.inf, np.nan, 0.0, "out_of_domain")
        return inner(theta)

    problem.evaluate = evaluate


@pytest.fixture
def far_maximum():
    rng = np.random.default_rng(3)
    a = np.array([[1.0, 0.2], [0.3, 1.0], [0.5, -0.4]]) * 1e-3            # [m] per unit of θ
    theta_true = np.array([10.0, -3.0])                                  # 10 caps from the start
    data = a @ theta_true + 2e-4 * rng.standard_normal((40, 3))
    problem = MeanShift(a, data, 2e-4)
    theta_hat = np.linalg.lstsq(a, data.mean(axis=0), rcond=None)[0]
    return problem, theta_hat


def test_the_trust_radius_reaches_a_maximum_many_caps_away_in_few_iterations(far_maximum):
    # A fixed cap of 1 moves θ̂ ≈ 10 away by at most 1 per iteration: ≥ 10 iterations before the
    # certifying step. The radius doubles after each step that its cap cut and the exact
    # quadratic model predicted (1, 2, 4, 8: 1 + 2 + 4 caps, then the full step), so scoring
    # certifies after 5. θ̂ to 1e-6 (J is quadratic: the central differences are exact up to
    # rounding); J at least J(θ̂) − ftol.
    problem, theta_hat = far_maximum
    assert np.max(np.abs(theta_hat)) > 9 * MAX_MOVE
    lo, hi = np.full(2, -50.0), np.full(2, 50.0)
    r = fisher_scoring(problem, np.zeros(2), lo, hi, np.zeros(2, dtype=bool), ftol=1e-3, max_iterations=6)
    assert r.certified, r.message
    assert r.message.startswith("converged after 5 iterations"), r.message
    np.testing.assert_allclose(r.theta, theta_hat, atol=1e-6)
    assert r.j >= problem.evaluate(theta_hat).j - 1e-3


def test_a_scoring_whose_steps_leave_the_models_domain_climbs_to_its_edge_inside_it(far_maximum):
    # Beyond θ₁ = 7.5 the model has no law (as T_CW spreads beyond the built tension range: J
    # not finite). The maximum over the domain is on its edge; once the growing radius carries
    # a trial beyond it (a trial out of the domain divides the radius by 4), the scoring must
    # still climb towards the edge and never report a point outside. (A fixed cap of 1, which
    # never overshoots here, passes too: this guards the radius, it does not tell it apart.)
    problem, theta_hat = far_maximum
    with_edge(problem, 7.5)
    lo, hi = np.full(2, -50.0), np.full(2, 50.0)
    start = problem.evaluate(np.zeros(2)).j
    r = fisher_scoring(problem, np.zeros(2), lo, hi, np.zeros(2, dtype=bool), ftol=1e-3, max_iterations=12)
    assert r.theta[0] <= 7.5 and np.isfinite(r.j)
    assert r.theta[0] > 6.5, (r.theta, r.message)                  # climbed most of the way to the edge
    assert r.j > start


def test_a_coordinate_at_the_domains_edge_is_held_and_the_maximum_along_it_certified(far_maximum):
    # The same edge θ₁ = 7.5. Once θ₁'s difference step crosses it against a gradient pointing
    # beyond, θ₁ is held (as on a bound) and θ₂ climbs at full steps: the scoring certifies the
    # maximum along the edge — θ₂ the least-squares optimum with θ₁ where it was held, θ₁ within
    # a difference step (STEP) of the edge. Without the hold every step shrinks against the edge
    # and twelve iterations do not certify (checked).
    problem, _ = far_maximum
    with_edge(problem, 7.5)
    lo, hi = np.full(2, -50.0), np.full(2, 50.0)
    r = fisher_scoring(problem, np.zeros(2), lo, hi, np.zeros(2, dtype=bool), ftol=1e-3, max_iterations=12)
    assert r.certified, r.message
    assert 7.5 - STEP <= r.theta[0] <= 7.5
    a, w = problem.a, problem.likelihood.data_w_m.mean(axis=0)
    theta2 = np.linalg.lstsq(a[:, 1:], w - a[:, 0] * r.theta[0], rcond=None)[0][0]
    assert r.theta[1] == pytest.approx(theta2, abs=1e-6)          # J quadratic: exact up to rounding
