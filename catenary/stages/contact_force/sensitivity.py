"""Which geometric spread drives the contact-force spread: Sobol indices on the dynamic model.

Surrogates of the criteria were tried and measured, and fail where the spread comes from:

* least squares of σ_F on static features of each section (RMS deviation, slope and curvature
  of the static CW height in the analysis window, W, T_MW mean and spread, ΔH spread): held-out
  R² ≤ 0.2 on 60 N2 sections at 300 km/h;
* the window's contact-force signal linearised in every random input (one dynamic run per
  input raised by its σ): it predicts the mean force of 12 replicate sections with R² 0.99, but
  σ_F with R² −1.1 and −2.8 (N2, N3; RMS errors 4 N where σ_F spreads by 1–2 N) — the force
  is not linear in the geometry once droppers slacken under the pantograph at high speed.

So the indices are estimated on the dynamic model itself: OpenTURNS' pick-freeze design
(``SobolIndicesExperiment`` with second order: N (2k + 2) sections for k input groups) and its
``MauntzKucherenkoSensitivityAlgorithm`` (first, second and total order, with percentile-bootstrap
intervals over the base samples; better than Saltelli's estimator for indices near 0 or 1: on y = u₁ at N = 500 its
second-order estimates are within 0.03 of 0 where Saltelli's are biased to −0.05 each). Each
input group of :mod:`.draws` is driven by one uniform variable of the design that seeds its
stream; a design row is a section whose groups come from the streams of its uniforms, run
over at the first speed (``sobol`` batches). With the N of a default run the intervals are
wide: they are reported, and first plus second order should sum to ≈ 1 within them.
OpenTURNS is loaded by the two functions that use it, so that the batch jobs of the other cases
do not pay for it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from .draws import groups
from .laws import SectionLaws
from .settings import ContactForceSettings

__all__ = ["SOBOL_COLUMNS", "SobolResult", "sobol_design", "sobol_indices", "sobol_seeds"]


def sobol_design(laws: SectionLaws, settings: ContactForceSettings) -> np.ndarray:
    """The pick-freeze design (rows × groups of uniforms), the same in every job (seeded)."""
    import openturns as ot
    k = len(groups(laws))
    state = ot.RandomGenerator.GetState()
    try:
        ot.RandomGenerator.SetSeed(int(settings.seed) + 1)
        design = ot.SobolIndicesExperiment(ot.JointDistribution([ot.Uniform(0.0, 1.0)] * k),
                                           settings.sensitivity_samples, True).generate()
    finally:
        ot.RandomGenerator.SetState(state)
    return np.array(design)


def sobol_seeds(laws: SectionLaws, settings: ContactForceSettings, row: np.ndarray) -> dict:
    """The group seeds of one design row."""
    return {g: np.random.SeedSequence([int(settings.seed), 7, j, int(row[j] * 2**52)])
            for j, g in enumerate(groups(laws))}


#: Columns of ``sensitivity.csv`` (:meth:`SobolResult.table`).
SOBOL_COLUMNS = ("criterion", "group", "first_order", "first_order_low", "first_order_high", "total_order",
                 "total_order_low", "total_order_high", "sum_first_second_order", "sum_first_second_order_low",
                 "sum_first_second_order_high", "n_base")


@dataclass(frozen=True)
class SobolResult:
    """Sobol indices of one criterion over the input groups."""

    criterion: str
    groups: tuple[str, ...]
    first: np.ndarray
    first_interval: np.ndarray
    total: np.ndarray
    total_interval: np.ndarray
    second: np.ndarray
    sum_first_second: float
    n_base: int
    sum_interval: tuple[float, float] = (float("nan"), float("nan"))

    def table(self) -> pd.DataFrame:
        """One row per group, :data:`SOBOL_COLUMNS`."""
        return pd.DataFrame({"criterion": self.criterion, "group": list(self.groups), "first_order": self.first,
                             "first_order_low": self.first_interval[:, 0], "first_order_high": self.first_interval[:, 1],
                             "total_order": self.total, "total_order_low": self.total_interval[:, 0],
                             "total_order_high": self.total_interval[:, 1],
                             "sum_first_second_order": self.sum_first_second,
                             "sum_first_second_order_low": self.sum_interval[0],
                             "sum_first_second_order_high": self.sum_interval[1], "n_base": self.n_base})


def _mauntz_kucherenko(design: np.ndarray, values: np.ndarray, n_base: int):
    import openturns as ot
    alg = ot.MauntzKucherenkoSensitivityAlgorithm(ot.Sample(design), ot.Sample(values.reshape(-1, 1)), n_base)
    return (np.array(alg.getFirstOrderIndices()), np.array(alg.getTotalOrderIndices()),
            np.array(alg.getSecondOrderIndices()))


def sobol_indices(design: np.ndarray, values: np.ndarray, names: tuple[str, ...], n_base: int,
                  criterion: str, *, n_bootstrap: int = 200, seed: int = 0) -> SobolResult:
    """Mauntz–Kucherenko indices from the design and the criterion of each of its rows, with
    95 % percentile-bootstrap intervals: the N base samples are resampled with replacement
    together with every pick-freeze row built from them (the design's blocks of N rows); the
    same for first plus second order, whose departure from 1 beyond its interval would be
    third-order interactions (or an estimator's bias)."""
    values = np.asarray(values, dtype=float)
    first, total, second = _mauntz_kucherenko(design, values, n_base)
    n_blocks = design.shape[0] // n_base
    rng = np.random.default_rng(seed)
    boot_first, boot_total, boot_sum = [], [], []
    for _ in range(n_bootstrap):
        pick = rng.integers(0, n_base, n_base)
        rows = (np.arange(n_blocks)[:, None] * n_base + pick[None, :]).ravel()
        if np.unique(pick).size < 2:          # one base sample repeated: no variance to share
            continue
        f, t, s2 = _mauntz_kucherenko(design[rows], values[rows], n_base)
        boot_first.append(f)
        boot_total.append(t)
        boot_sum.append(f.sum() + np.triu(s2, 1).sum())
    fi = np.nanquantile(np.array(boot_first), [0.025, 0.975], axis=0).T
    ti = np.nanquantile(np.array(boot_total), [0.025, 0.975], axis=0).T
    return SobolResult(criterion=criterion, groups=tuple(names), first=first, first_interval=fi, total=total,
                       total_interval=ti, second=second, sum_first_second=float(first.sum() + np.triu(second, 1).sum()),
                       n_base=int(n_base), sum_interval=tuple(float(v) for v in np.nanquantile(boot_sum, [0.025, 0.975])))
