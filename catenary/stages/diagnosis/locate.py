"""Where the fitted model and the data disagree, before any refit.

For ν measured spans W_k (9 deflections each) and a fitted model M, whose law of W is the
Gaussian of its model sample (mean m, covariance Σ; :mod:`catenary.stages.identification.likelihood`):

* **per-dropper mean residuals** ``r̄ = mean_k W_k − m`` with the Student-t 95 % interval from
  the data's own scatter (``se_i = s_i / √ν``);
* **whitened covariance**: the eigenvalues λ₁ ≥ … ≥ λ₉ of ``L⁻¹ S L⁻ᵀ`` (``Σ = L Lᵀ``, S the
  data covariance), all 1 when the model's covariance is the data's. Each is compared with its
  distribution over data sets of ν spans drawn i.i.d. from M (a parametric bootstrap with M
  held at its estimate: the data's eigenvalues along fitted directions are pulled towards 1
  by the fit, so the band is conservative for a too-large eigenvalue);
* **Mahalanobis distances** ``d_k² = (W_k − m)ᵀ Σ⁻¹ (W_k − m)``, χ²₉ under M: a QQ plot and a
  Cramér–von Mises test against χ²₉ (the Henze–Zirkler test is affine invariant, so it says
  whether W is Gaussian at all but cannot see a wrong mean or covariance);
* **catch-all references**: the J gain of a free mean shift (``ν/2 r̄ᵀ Σ⁻¹ r̄``, profiled
  analytically) and of a free Gaussian law of W (the largest gain a Gaussian J can show);
* **score screen** from the expected (Fisher) information of the Gaussian law of W,
  ``I = ν [∂mᵀ Σ⁻¹ ∂m + ½ tr(Σ⁻¹ ∂Σ Σ⁻¹ ∂Σ)]`` with the derivatives taken by finite
  differences of the model sample under the common design. A candidate's efficient
  information is the Schur complement of the base's block; its score is the derivative of J
  at the null. A spread parameter enters through its variance v = σ² (one-sided differences at
  0), where its score is not identically zero;
* **detectable magnitudes** from the same metric applied to the finite change an effect of a
  given size makes (:func:`secant_noncentrality`): the smallest size whose LR non-centrality
  reaches what the test at the step's level needs for the stated power. For an effect linear
  in its size this is the Fisher information at the null; unlike it, it stays right for an
  effect that enters W at second order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize, special, stats
from scipy.linalg import solve_triangular

from catenary.stages.identification.likelihood import GaussianFit

__all__ = ["Locate", "bootstrap_eigenvalues", "detectable_magnitude", "efficient_information",
           "locate", "mixture_sf", "required_noncentrality", "score_pvalue",
           "lr_power", "secant_noncentrality"]


@dataclass(frozen=True)
class Locate:
    """The cheap look at model M against the data (module docstring).

    Attributes
    ----------
    j : float
        J of M.
    residual_mean_m, residual_low_m, residual_high_m : numpy.ndarray, shape (n,)
        Mean residual per dropper and its 95 % interval [m].
    eigenvalues : numpy.ndarray, shape (n,)
        Whitened-covariance eigenvalues, descending.
    eigen_low, eigen_high : numpy.ndarray, shape (n,)
        2.5 % and 97.5 % bootstrap quantiles of each (rank-wise).
    mahalanobis_sq : numpy.ndarray, shape (ν,)
    cvm_p_value : float
        Cramér–von Mises test of the distances against χ²ₙ.
    free_shift_gain, free_gaussian_gain : float
        J gain of the catch-all references.
    residual_covariance_m2 : numpy.ndarray, shape (n, n), optional
        Covariance of the mean residual, S/ν [m²] (S the data covariance).
    """

    j: float
    residual_mean_m: np.ndarray
    residual_low_m: np.ndarray
    residual_high_m: np.ndarray
    eigenvalues: np.ndarray
    eigen_low: np.ndarray
    eigen_high: np.ndarray
    mahalanobis_sq: np.ndarray
    cvm_p_value: float
    free_shift_gain: float
    free_gaussian_gain: float
    residual_covariance_m2: np.ndarray | None = None

    @property
    def top_eigenvalue_inside(self) -> bool:
        """True when λ₁ lies inside its bootstrap 95 % range."""
        return bool(self.eigen_low[0] <= self.eigenvalues[0] <= self.eigen_high[0])

    def as_dict(self) -> dict:
        return {"j": self.j, "residual_mean_mm": (1e3 * self.residual_mean_m).tolist(),
                "residual_low_mm": (1e3 * self.residual_low_m).tolist(),
                "residual_high_mm": (1e3 * self.residual_high_m).tolist(),
                "eigenvalues": self.eigenvalues.tolist(), "eigen_low": self.eigen_low.tolist(),
                "eigen_high": self.eigen_high.tolist(), "top_eigenvalue_inside": self.top_eigenvalue_inside,
                "cvm_p_value": self.cvm_p_value, "free_shift_gain": self.free_shift_gain,
                "free_gaussian_gain": self.free_gaussian_gain}


def _covariance(fit: GaussianFit) -> np.ndarray:
    return fit.chol @ fit.chol.T


def bootstrap_eigenvalues(model_w_m: np.ndarray, fit: GaussianFit, n_spans: int, n_replicates: int) -> np.ndarray:
    """Whitened-covariance eigenvalues (descending) of ``n_replicates`` data sets of
    ``n_spans`` rows taken in turn from the i.i.d. model draws ``model_w_m``, shape (B, n)."""
    w = np.asarray(model_w_m, dtype=float)[:n_replicates * n_spans].reshape(n_replicates, n_spans, -1)
    c = w - w.mean(axis=1, keepdims=True)
    s = np.einsum("bki,bkj->bij", c, c) / (n_spans - 1)
    l_inv = solve_triangular(fit.chol, np.eye(fit.chol.shape[0]), lower=True)
    a = l_inv @ s @ l_inv.T
    return np.linalg.eigvalsh(0.5 * (a + np.swapaxes(a, 1, 2)))[:, ::-1]


def locate(data_w_m: np.ndarray, fit: GaussianFit, j: float, bootstrap: np.ndarray) -> Locate:
    """Residuals, whitened eigenvalues with their bootstrap band, distances, references.

    Parameters
    ----------
    data_w_m : numpy.ndarray, shape (ν, n)
    fit : GaussianFit
        Mean and covariance of M's model sample.
    j : float
        J of M.
    bootstrap : numpy.ndarray, shape (B, n)
        The whitened eigenvalues of B data sets of ν spans drawn i.i.d. from M
        (:func:`bootstrap_eigenvalues`, block by block: :meth:`.refits.DiagnosisContext.locate`).
    """
    data = np.asarray(data_w_m, dtype=float)
    nu, n = data.shape
    mean = data.mean(axis=0)
    r = mean - fit.mean
    s = np.cov(data, rowvar=False)
    se = np.sqrt(np.diag(s) / nu)
    t = stats.t.ppf(0.975, nu - 1)
    l_inv = solve_triangular(fit.chol, np.eye(n), lower=True)
    a = l_inv @ s @ l_inv.T
    eig = np.linalg.eigvalsh(0.5 * (a + a.T))[::-1]
    boot = np.asarray(bootstrap, dtype=float)
    if boot.ndim != 2 or boot.shape[1] != n or boot.shape[0] < 1:
        raise ValueError(f"bootstrap: expected eigenvalues of shape (B ≥ 1, {n}), got {boot.shape}")
    y = solve_triangular(fit.chol, (data - fit.mean).T, lower=True)
    d2 = np.einsum("ij,ij->j", y, y)
    cvm = stats.cramervonmises(d2, stats.chi2(n).cdf)
    whitened_r = l_inv @ r
    s_ml = s * (nu - 1) / nu
    j_free = -0.5 * nu * (n * np.log(2 * np.pi) + np.linalg.slogdet(s_ml)[1] + n)
    return Locate(j=float(j), residual_mean_m=r, residual_low_m=r - t * se, residual_high_m=r + t * se,
                  eigenvalues=eig, eigen_low=np.quantile(boot, 0.025, axis=0),
                  eigen_high=np.quantile(boot, 0.975, axis=0), mahalanobis_sq=d2, cvm_p_value=float(cvm.pvalue),
                  free_shift_gain=float(0.5 * nu * whitened_r @ whitened_r), free_gaussian_gain=float(j_free - j),
                  residual_covariance_m2=s / nu)


def efficient_information(info: np.ndarray, tested: np.ndarray) -> np.ndarray:
    """``I_tt − I_tb I_bb⁺ I_bt``: the information on the ``tested`` coordinates left once the
    others are re-estimated (pseudo-inverse: a base coordinate the data cannot see adds nothing)."""
    tested = np.asarray(tested, dtype=bool)
    base = ~tested
    i_tt = info[np.ix_(tested, tested)]
    if not base.any():
        return i_tt
    i_tb = info[np.ix_(tested, base)]
    return i_tt - i_tb @ np.linalg.pinv(info[np.ix_(base, base)], rcond=1e-10) @ i_tb.T


def mixture_sf(statistic: float, n_shift: int, n_spread: int) -> float:
    """P(LR > statistic) under the null of ``n_shift`` interior and ``n_spread`` boundary
    parameters: the binomial mixture Σ_j C(n_spread, j) 2^−n_spread χ²_(n_shift + j)
    (Self & Liang 1987, for parameters whose estimates are asymptotically independent;
    χ²₀ is the point mass at 0)."""
    statistic = max(float(statistic), 0.0)
    p = 0.0
    for j in range(n_spread + 1):
        weight = special.comb(n_spread, j) / 2.0 ** n_spread
        dof = n_shift + j
        p += weight * (float(statistic <= 0.0) if dof == 0 else float(stats.chi2.sf(statistic, dof)))
    return min(1.0, p)


def score_pvalue(score: np.ndarray, info: np.ndarray, spread: np.ndarray) -> tuple[float, float]:
    """Score statistic ``Uᵀ I⁻¹ U`` (a spread's negative score counts as 0: the null is its
    boundary) and its p-value under the boundary mixture."""
    u = np.where(np.asarray(spread, dtype=bool) & (score < 0), 0.0, score)
    statistic = float(u @ np.linalg.pinv(info) @ u)
    return statistic, mixture_sf(statistic, int((~np.asarray(spread)).sum()), int(np.sum(spread)))


def required_noncentrality(kind: str, level: float, power: float) -> float:
    """Non-centrality of the likelihood ratio that a test at ``level`` detects with ``power``:
    a shift's LR is non-central χ²₁ (two-sided); a spread's √LR ≈ N(√λ, 1) tested one-sided on
    its boundary (½χ²₀ + ½χ²₁)."""
    if kind == "spread":
        return float((stats.norm.isf(level) + stats.norm.ppf(power)) ** 2)
    critical = stats.chi2.isf(level, 1)
    return float(optimize.brentq(lambda nc: stats.ncx2.sf(critical, 1, nc) - power, 1e-6, 1e3))


def lr_power(noncentrality: float, n_shift: int, n_spread: int, level: float) -> float:
    """Power of the LR test of ``n_shift`` interior and ``n_spread`` boundary parameters at
    ``level`` for an effect of non-centrality λ: one spread alone is tested one-sided on its
    boundary (√LR ≈ N(√λ, 1): ``Φ(√λ − z₁₋α)``, as :func:`required_noncentrality`); otherwise
    ``P(χ²_k(λ) > c)`` with k the parameters and c the boundary mixture's critical value
    (:func:`mixture_sf`)."""
    lam = max(float(noncentrality), 0.0)
    if n_spread == 1 and n_shift == 0:
        return float(stats.norm.cdf(np.sqrt(lam) - stats.norm.isf(level)))
    k = n_shift + n_spread
    critical = optimize.brentq(lambda c: mixture_sf(c, n_shift, n_spread) - level, 1e-9, 1e3)
    return float(stats.ncx2.sf(critical, k, lam)) if lam > 0 else float(stats.chi2.sf(critical, k))


def secant_noncentrality(change: tuple[np.ndarray, np.ndarray], base: list[tuple[np.ndarray, np.ndarray]],
                         reference_covariance: np.ndarray, n_spans: int) -> float:
    """Non-centrality of the LR of an effect of finite size: the Fisher norm of the change of
    the model's (mean, covariance) it causes, minus what the base's coordinates can absorb.

    With the metric ``⟨a, b⟩ = ν [a_mᵀ Σ⁻¹ b_m + ½ tr(Σ⁻¹ a_Σ Σ⁻¹ b_Σ)]`` and the base's
    derivative directions B_j: ``λ = ⟨Δ, Δ⟩ − gᵀ G⁺ g`` with ``G_jk = ⟨B_j, B_k⟩``,
    ``g_j = ⟨B_j, Δ⟩``. For an effect linear in its size φ this is φ² times the efficient
    Fisher information at the null; for one that enters at second order (a CW shift, whose
    droppers shorten by δ²/2L) the information at the null vanishes but λ does not.
    """
    inv = np.linalg.inv(reference_covariance)

    def inner(a, b):
        return n_spans * (a[0] @ inv @ b[0] + 0.5 * np.trace(inv @ a[1] @ inv @ b[1]))

    g = np.array([inner(b, change) for b in base])
    gram = np.array([[inner(a, b) for b in base] for a in base])
    return float(inner(change, change) - g @ np.linalg.pinv(gram, rcond=1e-10) @ g) if base else float(inner(change, change))


def detectable_magnitude(efficient_info: float, kind: str, level: float, power: float) -> float:
    """Smallest magnitude detected at ``level`` with probability ``power`` [SI].

    A shift's likelihood ratio is non-central χ²₁ with non-centrality ``φ² I``: the magnitude
    solves P(χ²₁(φ² I) > χ²₁,₁₋α) = power. A spread is tested in its variance v on the boundary
    (½χ²₀ + ½χ²₁, i.e. a one-sided test of √LR ≈ N(v √I, 1)): ``v = (z₁₋α + z_power)/√I`` and
    the magnitude is σ = √v. Infinite when the information is not positive.
    """
    if not np.isfinite(efficient_info) or efficient_info <= 0:
        return float("inf")
    if kind == "spread":
        return float(np.sqrt((stats.norm.isf(level) + stats.norm.ppf(power)) / np.sqrt(efficient_info)))
    critical = stats.chi2.isf(level, 1)
    lam = optimize.brentq(lambda nc: stats.ncx2.sf(critical, 1, nc) - power, 1e-6, 1e3)
    return float(np.sqrt(lam / efficient_info))
