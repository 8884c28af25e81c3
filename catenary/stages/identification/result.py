"""Result of an identification: the s_opt table, the J trace and the intervals."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import special

from .dependence import widened_covariance, widening
from .design import RandomInput

__all__ = ["STATUSES", "IdentificationResult", "ParameterEstimate"]

#: Values of :attr:`IdentificationResult.status`, written to every output a program reads.
STATUSES = ("ok", "not_converged", "singular_information")


@dataclass(frozen=True)
class ParameterEstimate:
    """One row of the s_opt table (units of the parameter name); se = standard error."""

    parameter: str
    mu: float
    sigma: float
    mu_se: float
    sigma_se: float
    mu_fixed: bool


@dataclass(frozen=True)
class IdentificationResult:
    """Outcome of :func:`identify`.

    Attributes
    ----------
    estimates : tuple of ParameterEstimate
        s_opt with standard errors, one row per random input (design order).
    j_opt : float
        J(s_opt).
    n_evaluations : int
        Evaluations of J by the optimiser (the Hessian's are in ``n_hessian_evaluations``).
    trace_means, trace_sigmas : numpy.ndarray, shape (n_evaluations, d)
        s at every optimiser evaluation.
    trace_j : numpy.ndarray, shape (n_evaluations,)
        J at every optimiser evaluation (−inf where infeasible).
    time_s : float
        Wall time of the optimisation and the standard errors [s].
    method : str
    converged : bool
        The optimiser's own convergence flag.
    message : str
    free_parameters : tuple of str
        Names ``"<input>.mu"`` / ``"<input>.sigma"`` of the coordinates θ.
    theta_opt : numpy.ndarray
    theta_covariance : numpy.ndarray
        ``(−H)⁻¹`` in θ (NaN if −H is not positive definite or not computed).
    n_hessian_evaluations : int
    theta_covariance_sandwich : numpy.ndarray
        ``H⁻¹ K H⁻¹`` in θ, robust to spans that share a mast (:mod:`.dependence`); NaN where
        not computed (no span adjacency given).
    covariance : {"observed_information", "sandwich"}
        Where the standard errors of ``estimates`` come from: the observed information alone, or
        the observed information widened by the sandwich (:func:`.dependence.widened_covariance`).
    n_mast_pairs : int
        Pairs of measured spans sharing a mast in the sandwich (0 when not computed).
    at_lower_bound : tuple of str
        Free σ coordinates (``"<input>.sigma"``) whose estimate sits at the lower edge of the
        admissible box (σ0/50): on the boundary, without a standard error (NaN); their profile
        interval reaches 0.
    slack_fraction : float
        Slack fraction of the model sample at s_opt.
    """

    estimates: tuple[ParameterEstimate, ...]
    j_opt: float
    n_evaluations: int
    trace_means: np.ndarray
    trace_sigmas: np.ndarray
    trace_j: np.ndarray
    time_s: float
    method: str
    converged: bool
    message: str
    free_parameters: tuple[str, ...]
    theta_opt: np.ndarray
    theta_covariance: np.ndarray
    n_hessian_evaluations: int
    slack_fraction: float
    theta_covariance_sandwich: np.ndarray | None = None
    covariance: str = "observed_information"
    n_mast_pairs: int = 0
    at_lower_bound: tuple[str, ...] = ()

    @property
    def reported_covariance(self) -> np.ndarray:
        """The covariance in θ that the standard errors come from (``covariance``)."""
        if self.covariance == "sandwich" and self.theta_covariance_sandwich is not None:
            return widened_covariance(self.theta_covariance, self.theta_covariance_sandwich)
        return self.theta_covariance

    @property
    def variance_widening(self) -> np.ndarray:
        """Factor on each θ variance (and on the profile's critical drop): ``max(λ_i, 1)`` for
        ``covariance="sandwich"``, else 1."""
        if self.covariance == "sandwich" and self.sandwich_available:
            return widening(self.theta_covariance, self.theta_covariance_sandwich)
        return np.ones(np.asarray(self.theta_opt).size)

    @property
    def standard_errors_available(self) -> bool:
        """True when the observed information of the interior coordinates (all but those
        ``at_lower_bound``) was positive definite and the reported covariance is finite there."""
        inside = self.interior
        block = np.ix_(inside, inside)
        return bool(np.all(np.isfinite(self.theta_covariance[block]))
                    and np.all(np.isfinite(self.reported_covariance[block])))

    @property
    def interior(self) -> np.ndarray:
        """Mask of the free coordinates that are not ``at_lower_bound``."""
        return np.array([p not in self.at_lower_bound for p in self.free_parameters], dtype=bool)

    @property
    def sandwich_available(self) -> bool:
        """True when the mast-sharing sandwich covariance was computed and is finite (over the
        interior coordinates)."""
        c = self.theta_covariance_sandwich
        inside = self.interior
        return c is not None and bool(np.all(np.isfinite(c[np.ix_(inside, inside)])))

    @property
    def status(self) -> str:
        """``"ok"``; ``"not_converged"`` when the optimiser stopped without converging (its
        s_opt is then only the best point evaluated); else ``"singular_information"`` when −H is
        not positive definite at s_opt (no standard errors: s_opt may sit on a ridge or at the
        edge of the box)."""
        if not self.converged:
            return "not_converged"
        if not self.standard_errors_available:
            return "singular_information"
        return "ok"

    @property
    def means(self) -> np.ndarray:
        return np.array([e.mu for e in self.estimates])

    @property
    def sigmas(self) -> np.ndarray:
        return np.array([e.sigma for e in self.estimates])

    def inputs(self) -> tuple[RandomInput, ...]:
        """s_opt as random inputs."""
        return tuple(RandomInput(e.parameter, e.mu, e.sigma) for e in self.estimates)

    def table_rows(self) -> list[dict]:
        """s_opt table: parameter, mu, sigma, mu_se, sigma_se, mu_fixed, converged, status (the
        last two describe the whole run and repeat on every row, so no reader can miss them)."""
        return [dict(parameter=e.parameter, mu=e.mu, sigma=e.sigma, mu_se=e.mu_se,
                     sigma_se=e.sigma_se, mu_fixed=e.mu_fixed, converged=self.converged, status=self.status)
                for e in self.estimates]

    def intervals(self, level: float = 0.95) -> list[dict]:
        """Wald confidence intervals, built in the optimisation coordinates θ.

        Means: ``μ̂ ± z se(μ)`` (μ is linear in θ); σ: ``σ̂ exp(± z se(σ)/σ̂)`` — the interval of
        ``θ_σ = ln σ``, where the quadratic approximation of J is made. It stays positive and
        follows the skew of the likelihood in σ, which the symmetric ``σ̂ ± z se(σ)`` does not
        (with 117 spans it under-covered T_MW σ: 25 of 30 replicates against 28 of 30 for this
        one). ``z`` is the standard normal quantile of ``(1 + level)/2``; fixed means get a
        zero-width interval.
        """
        z = float(special.ndtri(0.5 * (1.0 + level)))
        return [dict(parameter=e.parameter, mu_low=e.mu - z * e.mu_se, mu_high=e.mu + z * e.mu_se,
                     sigma_low=e.sigma * np.exp(-z * e.sigma_se / e.sigma),
                     sigma_high=e.sigma * np.exp(z * e.sigma_se / e.sigma)) for e in self.estimates]

    def trace_rows(self) -> list[dict]:
        """J trace: evaluation, j and ``<input>_mu``, ``<input>_sigma`` per evaluation."""
        names = [e.parameter for e in self.estimates]
        rows = []
        for i, j in enumerate(self.trace_j):
            row = {"evaluation": i + 1, "j": float(j)}
            for k, name in enumerate(names):
                row[f"{name}_mu"] = float(self.trace_means[i, k])
                row[f"{name}_sigma"] = float(self.trace_sigmas[i, k])
            rows.append(row)
        return rows
