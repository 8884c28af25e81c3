"""The prior of one span's inputs: the identified laws, the static model that maps them to W.

The identification gives the laws of a span type's inputs ``X = [L_1 … L_n, T_MW, ΔH]`` (one ΔH
per mast in ``independent`` mode); :mod:`.posterior` updates them by each span's W.

Faulty droppers
---------------
The identified law of a dropper describes how droppers are made and fitted; a dropper made or
fitted wrong (a few centimetres) is a draw it all but excludes (6 σ), and a posterior with that
law alone shrinks it back towards nominal. Each dropper's prior is therefore contaminated,
``(1 − ε) law + ε fault``, the fault component the law widened by ``fault_std_m``
(``maintenance.fault_probability``, ``fault_std_m``).

The laws' uncertainty
---------------------
The laws are estimates: a σ is known to 7–10 % on the default run's 117 N2 spans, 11–19 % on its
60 N3 spans. A posterior that takes them as exact values (empirical Bayes) is too sure of what
W tells little about:
measured on 8 replicate lines of 60 N3 spans drawn from known laws (W from this fast model,
0.5 mm of noise), the 90 % intervals held the truth for 90.5 % of the inputs with the true laws
as the prior, 87.8 % with the laws identified from the same spans — one input-line in five
below 85 %, against one in thirty. With ``mean_uncertainties`` and ``sigma_uncertainties`` (each
μ's and σ's total standard uncertainty, :func:`~catenary.stages.maintenance.runner.prior_from_s_opt`)
each law is averaged over its own uncertainty — log σ normal with standard deviation ``u_σ/σ``
(the delta method), by a 12-node Gauss–Hermite rule, the mean's variance added — the laws
independent of each other; the importance weights carry the ratio of that prior to the
point-value one (:meth:`SpanPrior.log_law_uncertainty_ratio`), the mode and the proposal staying
the point-value posterior's. On the same replicates: 88.6 %, the intervals 1 % wider, one
input-line in 5.5 below 85 %. The rest is each line's own draw of its laws' error, which no
average over it can undo: the identification's σ were 0.63–1.47 of the truth.

Coordinates
-----------
Every input is written ``x_j = F_j⁻¹(Φ(z_j))`` (the design's Gamma transform,
:func:`~catenary.stages.identification.design.map_inputs`), so the prior is exactly ``N(0, I)`` in ``z``
and the negative log posterior is a least-squares sum, ``½ |z|² + ½ |L⁻¹ (W − f(x(z)))|²``
(``Σ = L Lᵀ``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import special

from catenary.physics.fast import FastSpanModel
from catenary.stages.identification.design import design_dimension, map_inputs

__all__ = ["Z_MAX", "SpanPrior", "input_names", "messenger_tension_range_n", "output_names"]

#: T_MW's normal scores beyond which the prior's mass (< 1e-15) is not sampled: the fast model's
#: T_MW range covers the law out to there.
Z_MAX = 8.0
#: Gauss–Hermite rule over a law's log σ (probabilists' nodes, weights summing to one): 12 nodes
#: give the scale mixture's density within ±4 σ to 2e-7 where σ is known to 20 % (the default
#: run's σ: 7–19 %), 2e-5 at 30 %, 2e-3 at 50 % (against a 4 001-point trapezoid rule).
_HERMITE_NODES, _HERMITE_WEIGHTS = np.polynomial.hermite_e.hermegauss(12)
_HERMITE_WEIGHTS = _HERMITE_WEIGHTS / _HERMITE_WEIGHTS.sum()


def input_names(n_droppers: int, system_height_mode: str) -> tuple[str, ...]:
    """Names of the posterior's inputs in design order, as the campaign's truth names them."""
    heights = (("system_height_left_m", "system_height_right_m") if system_height_mode == "independent"
               else ("system_height_m",))
    return (*(f"dropper_{i + 1}_length_m" for i in range(n_droppers)), "messenger_tension_n", *heights)


def output_names(n_droppers: int, system_height_mode: str) -> tuple[str, ...]:
    """What a posterior describes: the inputs, then each dropper's static force
    (``dropper_i_force_n``, 0 when slack), which W tells better than a length near slackness."""
    return (*input_names(n_droppers, system_height_mode), *(f"dropper_{i + 1}_force_n" for i in range(n_droppers)))


def messenger_tension_range_n(mean_n: float, sigma_n: float) -> tuple[float, float]:
    """T_MW at normal scores ∓ (:data:`Z_MAX` + 0.01) of its Gamma law [N] (the fast model's
    range): a draw clipped at ``Z_MAX`` maps inside it whichever quantile function maps it (the
    design's approximation of the Gamma quantile differs from the exact inverse by ≈ 1e-7 of
    T_MW at 8 normal scores, which put the clipped draws of a proposal as wide as the prior just
    outside a range built at ``Z_MAX`` exactly)."""
    k = (mean_n / sigma_n) ** 2
    scale = sigma_n**2 / mean_n
    lo = special.gammaincinv(k, special.ndtr(-Z_MAX - 0.01)) * scale
    hi = special.gammainccinv(k, special.ndtr(-Z_MAX - 0.01)) * scale
    return float(lo), float(hi)


@dataclass(frozen=True)
class SpanPrior:
    """The identified laws of one span type and the static model that maps them to W.

    Attributes
    ----------
    model : FastSpanModel
        Built over at least :func:`messenger_tension_range_n` of the T_MW law.
    means, sigmas : numpy.ndarray, shape (n + 2,)
        Gamma laws of droppers 1…n [m], T_MW [N] and ΔH [m] (s_opt).
    system_height_mode : {"shared", "independent"}
    """

    model: FastSpanModel
    means: np.ndarray
    sigmas: np.ndarray
    system_height_mode: str = "shared"
    fault_probability: float = 0.0
    fault_std_m: float = 0.03
    mean_uncertainties: np.ndarray | None = None
    sigma_uncertainties: np.ndarray | None = None

    @property
    def has_law_uncertainty(self) -> bool:
        """The laws carry their identification's standard uncertainties (module docs)."""
        u = [a for a in (self.mean_uncertainties, self.sigma_uncertainties) if a is not None]
        return any(np.any(np.asarray(a) > 0) for a in u)

    def _design_laws(self, values: np.ndarray | None) -> np.ndarray:
        """Per design column (ΔH repeated in ``independent`` mode); zeros for None."""
        v = np.zeros(self.means.size) if values is None else np.nan_to_num(np.asarray(values, dtype=float))
        return np.append(v, v[-1]) if self.system_height_mode == "independent" else v

    def log_law_uncertainty_ratio(self, z: np.ndarray, x: np.ndarray) -> np.ndarray:
        """log of the prior averaged over the laws' uncertainty over the prior at the identified
        laws, at normal scores ``z`` (M, d) and inputs ``x`` (M, d) (module docs, *The laws'
        uncertainty*); zeros when the laws carry none. Each column's law is averaged over its
        log σ, normal with standard deviation ``u_σ / σ`` (the delta method), by the
        Gauss–Hermite rule, its mean's uncertainty added to its variance; a dropper's fault
        component is left as it is."""
        if not self.has_law_uncertainty:
            return np.zeros(z.shape[0])
        mu = self._design_laws(self.means)
        sigma = self._design_laws(self.sigmas)
        u_mu = self._design_laws(self.mean_uncertainties)
        s_log = self._design_laws(self.sigma_uncertainties) / sigma          # sd of log σ (delta method)
        log_x = np.log(x)
        base = _gamma_logpdf(x, log_x, mu, sigma)
        log_mix = np.full(x.shape, -np.inf)
        for node, weight in zip(_HERMITE_NODES, _HERMITE_WEIGHTS):
            sd = np.sqrt((sigma * np.exp(s_log * node)) ** 2 + u_mu ** 2)
            log_mix = np.logaddexp(log_mix, np.log(weight) + _gamma_logpdf(x, log_x, mu, sd))
        ratio = log_mix - base                                                   # (M, d)
        if self.fault_probability > 0:
            narrow, wide, faulty = self._components(z)
            changed = np.logaddexp(narrow + ratio, wide) - np.logaddexp(narrow, wide)
            ratio = np.where(faulty, changed, ratio)
        return np.sum(ratio, axis=1)

    def _components(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """log of the law's and of the fault's share of a score's prior density (up to the same
        constant), and which columns have a fault component."""
        eps = self.fault_probability
        kappa = self.fault_scale
        narrow = np.log1p(-eps) - 0.5 * z * z
        wide = np.log(eps) - np.log(kappa) - 0.5 * (z / kappa) ** 2
        return narrow, wide, kappa > 1

    @property
    def fault_scale(self) -> np.ndarray:
        """κ per design column: a faulty dropper's normal score has standard deviation κ
        (``κ² = 1 + (fault_std / σ)²``, the dropper's law widened by the fault's); 1 elsewhere."""
        kappa = np.ones(self.dimension)
        if self.fault_probability > 0:
            kappa[:self.n_droppers] = np.sqrt(1.0 + (self.fault_std_m / self.sigmas[:self.n_droppers]) ** 2)
        return kappa

    def neg_log_prior(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """−log prior (M,) up to a constant, and its curvature weights λ (M, d) at ``z`` (M, d).

        Each dropper's score has the contaminated law ``(1 − ε) φ(z) + ε φ(z/κ)/κ``; every other
        input ``φ(z)``. The gradient of −log prior is exactly ``λ z`` with ``λ = ρ + (1 − ρ)/κ²``
        (``ρ`` the narrow component's responsibility): the Gauss–Newton step's prior precision.
        """
        if self.fault_probability <= 0:
            return 0.5 * np.sum(z * z, axis=-1), np.ones_like(z)
        narrow, wide, faulty = self._components(z)
        log_mix = np.where(faulty, np.logaddexp(narrow, wide), -0.5 * z * z)
        rho = np.where(faulty, np.exp(narrow - log_mix), 1.0)
        return -np.sum(log_mix, axis=-1), rho + (1.0 - rho) / self.fault_scale**2

    @property
    def n_droppers(self) -> int:
        return self.means.size - 2

    @property
    def dimension(self) -> int:
        return design_dimension(self.n_droppers, self.system_height_mode)

    def inputs(self, z: np.ndarray) -> np.ndarray:
        """Physical inputs (M, d) at normal scores ``z`` (M, d), in :func:`input_names` order."""
        x = map_inputs(z, self.means, self.sigmas, self.system_height_mode)
        cols = [x.dropper_lengths_m, x.messenger_tension_n[:, None], x.system_height_left_m[:, None]]
        if self.system_height_mode == "independent":
            cols.append(x.system_height_right_m[:, None])
        return np.hstack(cols)

    def deflections(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """W (M, n) [m], slack droppers solved, and a flag (M,) of the points whose T_MW lies
        beyond :data:`Z_MAX` (no weight there)."""
        w, _, outside = self.evaluate(z)
        return w, outside

    def evaluate(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """W (M, n) [m], the dropper forces (M, n) [N] and the out-of-range flag (M,) at ``z``."""
        z = np.asarray(z, dtype=float)
        t = self.n_droppers                                  # T_MW's column: the model's range
        outside = np.abs(z[:, t]) > Z_MAX
        z = z.copy()
        z[:, t] = np.clip(z[:, t], -Z_MAX, Z_MAX)
        x = map_inputs(z, self.means, self.sigmas, self.system_height_mode)
        res = self.model.evaluate(x.dropper_lengths_m, x.messenger_tension_n, x.system_height_left_m,
                                  x.system_height_right_m, slack="solve")
        return res.w_m, res.dropper_force_n, outside


def _gamma_logpdf(x: np.ndarray, log_x: np.ndarray, mean: np.ndarray, sd: np.ndarray) -> np.ndarray:
    """log density of the Gamma law of mean ``mean`` and standard deviation ``sd`` (per column)
    at ``x`` (M, d), ``log_x = log x`` given (shape ``k = (μ/σ)²``, scale ``σ²/μ``)."""
    k = (mean / sd) ** 2
    scale = sd ** 2 / mean
    return (k - 1.0) * log_x - x / scale - k * np.log(scale) - special.gammaln(k)
