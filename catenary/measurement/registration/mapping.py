"""The map from the mast table's chainage to a run's recorded chainage, one per section.

Over a section (≈ 1.2 km) the odometer's error is an offset, a scale (``recorded = c₀ + c₁ (t −
t_ref)``, ``c₁`` = 1 + the scale error) and, where the data ask for it, a smooth drift: a
polynomial of higher degree in ``t − t_ref``. The map is fitted by weighted least squares to the
masts whose support the trace shows, each weighted by ``1 / (σ_trace² + (c₁ σ_table)²)``,
and robustly: a mast further than ``max(4 σ, bound)`` from the fit leaves it and the fit is
repeated until the set of masts settles (the first fit unweighted, so that one mast placed
confidently in the wrong place does not tilt the map that judges it).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

__all__ = ["ChainageMap", "fit_map"]


@dataclass(frozen=True)
class ChainageMap:
    """``recorded = Σ_k coefficients[k] (t − reference_m)^k`` for table chainages ``t`` [m].

    Attributes
    ----------
    coefficients : numpy.ndarray
        Polynomial coefficients, lowest degree first: offset at ``reference_m`` [m], scale [-],
        drift terms [m^(1−k)].
    reference_m : float
        Table chainage the polynomial is centred on [m].
    """

    coefficients: np.ndarray
    reference_m: float

    @classmethod
    def identity(cls, reference_m: float = 0.0) -> "ChainageMap":
        return cls(np.array([reference_m, 1.0]), reference_m)

    @property
    def degree(self) -> int:
        return int(self.coefficients.size - 1)

    @property
    def scale(self) -> float:
        """d(recorded)/d(table) at the reference [-]."""
        return float(self.coefficients[1])

    @property
    def offset_m(self) -> float:
        """Recorded minus table chainage at the reference [m]."""
        return float(self.coefficients[0] - self.reference_m)

    def to_recorded(self, table_m) -> np.ndarray:
        """Recorded chainage of table chainages [m]."""
        u = np.asarray(table_m, dtype=float) - self.reference_m
        return np.polynomial.polynomial.polyval(u, self.coefficients)

    def slope(self, table_m) -> np.ndarray:
        """d(recorded)/d(table) at table chainages [-]."""
        u = np.asarray(table_m, dtype=float) - self.reference_m
        return np.polynomial.polynomial.polyval(u, self._slope_coefficients)

    @cached_property
    def _slope_coefficients(self) -> np.ndarray:
        """The derivative's coefficients, lowest degree first (kept: a section's fit asks for the
        slope of one map many times)."""
        return np.polynomial.polynomial.polyder(self.coefficients)

    def to_table(self, recorded_m) -> np.ndarray:
        """Table chainage of recorded chainages [m] (Newton's method on the monotonic map)."""
        y = np.asarray(recorded_m, dtype=float)
        t = self.reference_m + (y - self.coefficients[0]) / self.coefficients[1]
        if self.degree > 1:
            for _ in range(20):
                step = (self.to_recorded(t) - y) / self.slope(t)
                t = t - step
                if np.all(np.abs(step) < 1e-9):
                    break
        return t


def fit_map(table_m: np.ndarray, recorded_m: np.ndarray, std_m: np.ndarray, *, degree: int, reference_m: float,
            table_std_m, bound_m: float, max_iterations: int = 20) -> tuple[ChainageMap, np.ndarray]:
    """Robust weighted least-squares map from table to recorded chainage (module docs).

    Parameters
    ----------
    table_m, recorded_m : numpy.ndarray
        Table chainage of each mast and where the trace puts its support [m] (NaN: not found).
    std_m : numpy.ndarray
        Standard error of each trace position [m].
    degree : int
        1: offset and scale; 2, 3: a smooth drift as well. Lowered to what the inliers allow
        (at least degree + 2 of them).
    reference_m : float
        Centre of the polynomial [m].
    table_std_m : float or numpy.ndarray
        Standard error of each mast's chainage in the mast table [m].
    bound_m : float
        A mast within this of the fit is never an outlier [m].

    Returns
    -------
    ChainageMap, numpy.ndarray of bool
        The map and which masts it was fitted on (the inliers).

    Raises
    ------
    ValueError
        If fewer than 2 masts have a trace position.
    """
    t = np.asarray(table_m, dtype=float)
    y = np.asarray(recorded_m, dtype=float)
    s = np.asarray(std_m, dtype=float)
    usable = np.isfinite(y) & np.isfinite(s)
    if usable.sum() < 2:
        raise ValueError("fit_map: fewer than 2 masts with a trace position")
    inlier = usable.copy()
    coefficients = np.array([reference_m, 1.0])
    for iteration in range(max_iterations):
        d = int(min(degree, max(1, inlier.sum() - 2)))
        u = t - reference_m
        variance = s ** 2 + (coefficients[1] * np.asarray(table_std_m, dtype=float)) ** 2
        # the first pass unweighted: a mast placed confidently in the wrong place (a comb slipped
        # by a metre, its standard error a few centimetres) must not tilt the map that judges it
        w = 1.0 / np.sqrt(variance) if iteration else np.ones_like(variance)
        a = np.vander(u, d + 1, increasing=True)
        coefficients = np.linalg.lstsq(a[inlier] * w[inlier, None], y[inlier] * w[inlier], rcond=None)[0]
        residual = y - a @ coefficients
        limit = np.maximum(4.0 * np.sqrt(variance), bound_m)
        new = usable & (np.abs(residual) <= limit)
        if new.sum() < 2 or np.array_equal(new, inlier):
            break
        inlier = new
    return ChainageMap(np.asarray(coefficients, dtype=float), float(reference_m)), inlier
