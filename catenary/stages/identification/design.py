"""Random inputs of the statistical identification, their laws and the sampling design.

Random inputs
-------------
``X = [L_drop,1 … L_drop,n, T_MW, ΔH]`` (paper eq. 1), each a Gamma law (maximum entropy for a
positive quantity, paper eq. 2) parameterised by its mean μ and standard deviation σ (eq. 4):
shape ``k = (μ/σ)²`` and rate ``λ = μ/σ²``, i.e. ``ot.Gamma(k, λ, 0)`` in OpenTURNS (whose
density is ``λ^k x^(k−1) e^(−λx) / Γ(k)``) or ``scipy.stats.gamma(a=k, scale=1/λ)``.

System height ΔH
----------------
The paper identifies a single parameter ΔH. By default (``system_height_mode="shared"``) one ΔH
is drawn per span and used at both masts, ``ΔH_left = ΔH_right``. With
``system_height_mode="independent"`` the two masts get independent draws of the same law (the
design then has one more column, the last, for ΔH_right). The shared mode is the paper's model;
the independent mode halves the ΔH-driven covariance of W and makes it asymmetric.

Design (common random numbers)
-------------------------------
A unit-cube design ``u`` (N × d) is drawn once — a scrambled Sobol sequence (SciPy, the default)
or a Latin hypercube (OpenTURNS ``LHSExperiment``, random position in each cell) — and kept.
Every hyper-parameter vector s maps the *same* ``u`` through the inverse CDFs, so J(s) is a
deterministic, smooth function of s. ``u`` is clipped to ``[eps, 1 − eps]`` (default
``eps = 1e-9``, |z| ≤ 6.0) and its standard normal scores ``z = Φ⁻¹(u)`` are stored with it.

Default design: Sobol, from a measurement (benchmarks/bench_identification.py; N2, 117 synthetic
Table 2 spans, J at s_opt over 20 design seeds). The standard deviation of J across seeds is
0.70–0.79 for LHS and 0.10 for Sobol at N = 1e4 (LHS 1.46 / 0.79 / 0.39 and Sobol
0.26 / 0.11 / 0.036 at N = 2048 / 8192 / 32768 over 40 seeds: LHS converges as N^(−1/2), Sobol
faster), and the spread of s_opt over 10 seeds is about 3× smaller (T_MW σ: 0.9 N against 3.3 N,
for a standard error of ≈ 50 N). The paper uses LHS: ``method="lhs"`` keeps it.

Inverse CDF (fast path)
-----------------------
The Gamma quantile of standardised form ``x = μ + σ q(z, c)`` depends on ``u`` through
``z = Φ⁻¹(u)`` and on the law only through the coefficient of variation ``c = σ/μ = 1/√k``. For
``c ≤ CORNISH_FISHER_MAX_CV`` (0.1) ``q`` is the Cornish–Fisher expansion of the Gamma law to
order c⁴ (cumulants ``κ_r = (r−1)! k``; Abramowitz & Stegun 26.2.49):

    q = z + c (z²−1)/3 + c² (z³−7z)/36 − c³ (3z⁴+7z²−16)/810 + c⁴ (9z⁵+256z³−433z)/38880,

whose error is below 5e-6 σ for c ≤ 0.1 and below 3e-8 σ for c ≤ 0.04 over |z| ≤ 5.2, and below
2e-5 σ (c ≤ 0.1) and 2e-7 σ (c ≤ 0.04) out to |z| = 6 (measured against
``scipy.special.gammaincinv``; checked in the tests). Above
that coefficient of variation the exact inverse (``gammaincinv`` / ``gammainccinv`` in the upper
tail) is used. The fast path is a degree-5 polynomial in the stored ``z``: no special functions per
evaluation.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numba import njit
from scipy import special
from scipy.stats import qmc

from catenary.physics.config import Catenary, SpanType
from catenary.physics.dropper_table import nominal_dropper_lengths

if TYPE_CHECKING:                      # OpenTURNS is loaded where it is used: the LHS design and the
    import openturns as ot             # Gamma law as its object (0.4 s of a job's imports otherwise)

__all__ = [
    "CORNISH_FISHER_MAX_CV", "DEFAULT_DESIGN", "DESIGN_METHODS", "MESSENGER_TENSION", "SYSTEM_HEIGHT",
    "SYSTEM_HEIGHT_MODES", "RandomInput", "SpanInputs", "UnitDesign", "default_inputs",
    "design_dimension", "draw_unit_design", "dropper_names", "gamma_quantiles", "map_inputs",
]

MESSENGER_TENSION = "messenger_tension_n"
SYSTEM_HEIGHT = "system_height_m"
SYSTEM_HEIGHT_MODES = ("shared", "independent")
DESIGN_METHODS = ("sobol", "lhs")
DEFAULT_DESIGN = "sobol"
#: Largest coefficient of variation σ/μ served by the Cornish–Fisher fast path.
CORNISH_FISHER_MAX_CV = 0.1


def dropper_names(n_droppers: int) -> tuple[str, ...]:
    """``("dropper_1_length_m", …, "dropper_n_length_m")``."""
    return tuple(f"dropper_{i + 1}_length_m" for i in range(n_droppers))


@dataclass(frozen=True)
class RandomInput:
    """A positive random input with a Gamma law given by its mean and standard deviation.

    Attributes
    ----------
    name : str
        Input name with its unit (``messenger_tension_n``, ``dropper_3_length_m``…).
    mean : float
        Mean μ, in the unit of the name.
    sigma : float
        Standard deviation σ > 0, same unit.
    """

    name: str
    mean: float
    sigma: float

    def __post_init__(self):
        if not (np.isfinite(self.mean) and self.mean > 0):
            raise ValueError(f"{self.name}: mean must be a positive finite number, got {self.mean!r}")
        if not (np.isfinite(self.sigma) and self.sigma > 0):
            raise ValueError(f"{self.name}: sigma must be a positive finite number, got {self.sigma!r}")

    @property
    def shape(self) -> float:
        """Gamma shape k = (μ/σ)²."""
        return (self.mean / self.sigma) ** 2

    @property
    def rate(self) -> float:
        """Gamma rate λ = μ/σ², in the inverse unit of the name."""
        return self.mean / self.sigma**2

    def distribution(self) -> ot.Gamma:
        """The law as an OpenTURNS ``Gamma(k, λ, γ=0)``."""
        import openturns as ot
        return ot.Gamma(self.shape, self.rate, 0.0)

    def quantile(self, u: np.ndarray) -> np.ndarray:
        """Exact inverse CDF at probabilities ``u`` (vectorised, SciPy)."""
        return _exact_quantile(np.asarray(u, dtype=float), self.shape) / self.rate


def _exact_quantile(u: np.ndarray, k: float) -> np.ndarray:
    """Standard Gamma(k, 1) quantile, using the complementary inverse in the upper half."""
    return np.where(u <= 0.5, special.gammaincinv(k, np.minimum(u, 0.5)),
                    special.gammainccinv(k, np.minimum(1.0 - u, 0.5)))


def gamma_quantiles(z: np.ndarray, means: np.ndarray, sigmas: np.ndarray) -> np.ndarray:
    """Gamma quantiles at standard normal scores ``z`` for one law per column.

    Parameters
    ----------
    z : numpy.ndarray, shape (N, d)
        Normal scores Φ⁻¹(u) of the design.
    means, sigmas : array_like, shape (d,)
        Mean and standard deviation of each column's Gamma law.

    Returns
    -------
    numpy.ndarray, shape (N, d)
        ``F⁻¹(Φ(z))`` per column: Cornish–Fisher to order c⁴ where ``σ/μ ≤ 0.1``, exact
        (``gammaincinv``) elsewhere; see the module docstring for the accuracy.
    """
    z = np.asarray(z, dtype=float)
    mu = np.asarray(means, dtype=float)
    sd = np.asarray(sigmas, dtype=float)
    c = sd / mu
    # x = μ + σ Σ_j a_j z^j with the Cornish–Fisher coefficients collected per power of z.
    c2, c3, c4 = c * c, c**3, c**4
    a = [
        mu / sd - c / 3.0 + 16.0 * c3 / 810.0,           # z⁰ (μ/σ folded in)
        1.0 - 7.0 * c2 / 36.0 - 433.0 * c4 / 38880.0,     # z¹
        c / 3.0 - 7.0 * c3 / 810.0,                       # z²
        c2 / 36.0 + 256.0 * c4 / 38880.0,                 # z³
        -3.0 * c3 / 810.0,                                # z⁴
        9.0 * c4 / 38880.0,                               # z⁵
    ]
    out = np.empty_like(z)                  # z's memory order, as NumPy's passes kept it
    _horner(z, np.array([a[j] * sd for j in range(6)]), out)
    for j in np.flatnonzero(c > CORNISH_FISHER_MAX_CV):
        k = 1.0 / c[j] ** 2
        zj = z[:, j]
        # Lower half from Φ(z), upper half from Φ(−z) = 1 − u: full relative accuracy in both tails.
        standard = np.where(zj <= 0.0, special.gammaincinv(k, special.ndtr(np.minimum(zj, 0.0))),
                            special.gammainccinv(k, special.ndtr(-np.maximum(zj, 0.0))))
        out[:, j] = standard * (sd[j] ** 2 / mu[j])
    return out


@dataclass(frozen=True)
class UnitDesign:
    """A unit-cube design drawn once and reused for every s (common random numbers).

    Attributes
    ----------
    u : numpy.ndarray, shape (N, d)
        Points in [eps, 1 − eps]^d (read-only).
    z : numpy.ndarray, shape (N, d)
        Their standard normal scores Φ⁻¹(u) (read-only).
    method : str
        ``"lhs"`` or ``"sobol"``.
    seed : int
        Seed the design was drawn with.
    """

    u: np.ndarray
    z: np.ndarray
    method: str
    seed: int

    @property
    def n_samples(self) -> int:
        return int(self.u.shape[0])

    @property
    def dimension(self) -> int:
        return int(self.u.shape[1])


def draw_unit_design(n_samples: int, dimension: int, *, method: str = DEFAULT_DESIGN, seed: int = 0,
                     eps: float = 1e-9) -> UnitDesign:
    """Draw a unit-cube design once.

    Parameters
    ----------
    n_samples, dimension : int
        N points in [0, 1]^d.
    method : {"sobol", "lhs"}
        ``"lhs"``: OpenTURNS ``LHSExperiment`` on U(0, 1), one column after the other (random
        permutation and random position in each cell), seeded by
        ``ot.RandomGenerator.SetSeed(seed)`` (the global OpenTURNS generator state is restored
        afterwards). ``"sobol"``: SciPy's scrambled Sobol
        sequence (``qmc.Sobol(scramble=True, rng=seed)``), its first ``n_samples`` points (the
        balance properties are exact only for powers of two).
    seed : int
        Seed of the design.
    eps : float
        Clipping of ``u`` to ``[eps, 1 − eps]`` before the inverse CDFs.
    """
    if n_samples < 2 or dimension < 1:
        raise ValueError(f"need n_samples ≥ 2 and dimension ≥ 1, got {n_samples}, {dimension}")
    if not 0.0 < eps < 0.5:
        raise ValueError(f"eps: expected a value in (0, 0.5), got {eps!r}")
    if method == "lhs":
        # One OpenTURNS LHSExperiment per column (independent random permutations and random
        # positions in the cells: a Latin hypercube); column-wise keeps the transient memory of
        # OpenTURNS' samples to one column (≈ 60 MB at N = 1e6 instead of ≈ 600 MB).
        import openturns as ot
        state = ot.RandomGenerator.GetState()
        u = np.empty((int(n_samples), int(dimension)))
        try:
            ot.RandomGenerator.SetSeed(int(seed))
            for j in range(dimension):
                column = ot.LHSExperiment(ot.Uniform(0.0, 1.0), int(n_samples)).generate()
                u[:, j] = np.asarray(column, dtype=float)[:, 0]
        finally:
            ot.RandomGenerator.SetState(state)
    elif method == "sobol":
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "balance properties" for N ≠ 2^m
            u = qmc.Sobol(dimension, scramble=True, rng=int(seed)).random(int(n_samples))
    else:
        raise ValueError(f"method: expected one of {DESIGN_METHODS}, got {method!r}")
    np.clip(u, eps, 1.0 - eps, out=u)
    z = special.ndtri(u)
    u.flags.writeable = False
    z.flags.writeable = False
    return UnitDesign(u=u, z=z, method=method, seed=int(seed))


def design_dimension(n_droppers: int, system_height_mode: str = "shared") -> int:
    """Number of design columns: n droppers, T_MW, ΔH (and ΔH_right if independent)."""
    if system_height_mode not in SYSTEM_HEIGHT_MODES:
        raise ValueError(f"system_height_mode: expected one of {SYSTEM_HEIGHT_MODES}, got {system_height_mode!r}")
    return n_droppers + 2 + (system_height_mode == "independent")


def default_inputs(span_type: SpanType, catenary: Catenary, *, dropper_sigma_m: float = 0.005,
                   messenger_tension_mean_n: float | None = None, messenger_tension_sigma_n: float | None = None,
                   system_height_mean_m: float | None = None,
                   system_height_sigma_m: float = 0.005) -> tuple[RandomInput, ...]:
    """Starting laws s0: dropper means at the nominal table, T_MW and ΔH at the design values.

    Parameters
    ----------
    span_type, catenary
        Span type and catenary data (nominal dropper table, design T_MW and ΔH).
    dropper_sigma_m : float
        σ of every dropper length [m] (default 5 mm, the order of the manufacturing accuracy).
    messenger_tension_mean_n, messenger_tension_sigma_n : float, optional
        T_MW mean (default: design tension) and σ (default: 3 % of the mean) [N].
    system_height_mean_m, system_height_sigma_m : float
        ΔH mean (default: design system height) and σ (default 5 mm) [m].

    Returns
    -------
    tuple of RandomInput
        In design-column order: droppers 1…n, ``messenger_tension_n``, ``system_height_m``.
    """
    lengths = nominal_dropper_lengths(span_type, catenary).dropper_lengths_m
    t_mean = span_type.messenger_tension_n if messenger_tension_mean_n is None else messenger_tension_mean_n
    t_sigma = 0.03 * t_mean if messenger_tension_sigma_n is None else messenger_tension_sigma_n
    h_mean = span_type.system_height_m if system_height_mean_m is None else system_height_mean_m
    droppers = [RandomInput(name, float(m), dropper_sigma_m)
                for name, m in zip(dropper_names(lengths.size), lengths)]
    return (*droppers, RandomInput(MESSENGER_TENSION, t_mean, t_sigma),
            RandomInput(SYSTEM_HEIGHT, h_mean, system_height_sigma_m))


@dataclass(frozen=True)
class SpanInputs:
    """Input arrays of :meth:`catenary.physics.fast.FastSpanModel.evaluate` for N spans."""

    dropper_lengths_m: np.ndarray
    messenger_tension_n: np.ndarray
    system_height_left_m: np.ndarray
    system_height_right_m: np.ndarray


@njit(cache=True, nogil=True)
def _horner(z, coefficients, out):       # pragma: no cover - compiled; tested through gamma_quantiles
    """``out[i, j] = Σ_p coefficients[p, j] z[i, j]^p`` by Horner's rule, one pass over z: the
    operations and their order of NumPy's whole-array passes (z·c₅, +c₄, ·z, …, +c₀), so the
    same numbers, at a fifth of their time (ten passes over 10⁵ values were 1 ms of each J)."""
    for i in range(z.shape[0]):
        for j in range(z.shape[1]):
            x = z[i, j]
            o = x * coefficients[5, j]
            for p in range(4, 0, -1):
                o += coefficients[p, j]
                o *= x
            out[i, j] = o + coefficients[0, j]


def map_inputs(z: np.ndarray, means: np.ndarray, sigmas: np.ndarray,
               system_height_mode: str = "shared") -> SpanInputs:
    """Map design normal scores to physical inputs.

    Parameters
    ----------
    z : numpy.ndarray, shape (N, d)
        Normal scores of the design rows (all of them or a block).
    means, sigmas : array_like, shape (n + 2,)
        Laws of droppers 1…n, T_MW and ΔH, in that order.
    system_height_mode : {"shared", "independent"}
        ``"shared"``: ``d = n + 2``, ΔH_left = ΔH_right. ``"independent"``: ``d = n + 3``, the
        last column drives ΔH_right through the same law as ΔH_left.
    """
    means = np.asarray(means, dtype=float)
    sigmas = np.asarray(sigmas, dtype=float)
    n = means.size - 2
    if z.shape[1] != design_dimension(n, system_height_mode):
        raise ValueError(f"z: expected {design_dimension(n, system_height_mode)} columns for "
                         f"{n} droppers and system_height_mode={system_height_mode!r}, got {z.shape[1]}")
    if system_height_mode == "independent":
        means = np.append(means, means[-1])
        sigmas = np.append(sigmas, sigmas[-1])
    x = gamma_quantiles(z, means, sigmas)
    right = x[:, n + 2] if system_height_mode == "independent" else x[:, n + 1]
    return SpanInputs(dropper_lengths_m=x[:, :n], messenger_tension_n=x[:, n],
                      system_height_left_m=x[:, n + 1], system_height_right_m=right)
