"""Measurements besides W, span by span, and their log-density jointly with W.

A span type's spans carry W (n droppers) and, for some of them, measured quantities
(:mod:`.quantities`): a residual thickness, a tension, a mast's ΔH. The model gives the joint
law of W and the quantities by its sample (mean ``m``, covariance ``C`` over the columns W then
the quantities, :func:`.quantities.model_columns`); a span's measured vector is that law
restricted to the columns it has, plus its measurement errors:

    x_k ~ N(m_k, C_kk + R_k),

``R_k`` the W block's noise (the runs' repeatability over their number, when the likelihood has
one) and each quantity's variance ``std²`` from the survey or the config. Rows are grouped by
the columns they have; the covariances of a group are factored together.

A measurement error shared by every span — a channel's calibration, the new wire's own diameter
for a residual thickness, a tension meter's bias — is a common offset ``o_j ~ N(0, s_j²)`` of
column ``j`` (``common_std``). It ties the spans together; integrated out exactly (a rank-q
update of the independent spans' law), it adds to J

    −½ ln det(I + S A) + ½ bᵀ (A + S⁻¹)⁻¹ b,   A = Σ_k E_kᵀ Σ_k⁻¹ E_k,  b = Σ_k E_kᵀ Σ_k⁻¹ r_k,

``S = diag(s_j²)``, ``E_k`` the columns of span k's vector that the offsets move and ``r_k`` its
residual: the spread of a quantity is then read in full, its mean only to within its common
error.

A line quantity (the measuring force) is one observation of the line:
``y ~ N(m_y, C_yy + std²)``, its model variance over the sample (0 for a force that is the same
for every span) plus the measurement's.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .quantities import QUANTITIES, model_columns

__all__ = ["LineObservation", "Observations", "joint_log_density", "line_log_density"]

_LOG_2PI = float(np.log(2.0 * np.pi))


@dataclass(frozen=True)
class LineObservation:
    """One measurement of a line quantity: its value and standard uncertainty [SI]."""

    quantity: str
    value: float
    std: float


@dataclass(frozen=True)
class Observations:
    """What was measured besides W for one span type.

    Attributes
    ----------
    quantities : tuple of str
        Span, section and mast quantities measured on some span (:data:`.quantities.QUANTITIES`).
    values, std : numpy.ndarray, shape (K, c)
        Per span (rows in the order of the W data) and model column
        (:func:`.quantities.model_columns` of ``quantities``): the measured value and its standard
        uncertainty [SI]; NaN where not measured.
    line : tuple of LineObservation
        Line quantities.
    common_std : numpy.ndarray, shape (c,), optional
        Standard uncertainty of an error shared by every span's value of each column [SI]
        (module docstring); 0 (default): none.
    """

    quantities: tuple[str, ...] = ()
    values: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    std: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    line: tuple[LineObservation, ...] = ()
    common_std: np.ndarray | None = None

    def __post_init__(self):
        unknown = [q for q in (*self.quantities, *(o.quantity for o in self.line)) if q not in QUANTITIES]
        if unknown:
            raise ValueError(f"observations: unknown quantities {unknown}; known: {', '.join(QUANTITIES)}")
        if any(QUANTITIES[q].place == "line" for q in self.quantities):
            raise ValueError("observations: a line quantity is a LineObservation, not a span column")
        if any(QUANTITIES[o.quantity].place != "line" for o in self.line):
            raise ValueError("observations: a LineObservation must be of a line quantity")
        values, std = np.asarray(self.values, dtype=float), np.asarray(self.std, dtype=float)
        c = len(self.columns)
        if values.ndim != 2 or values.shape[1] != c or std.shape != values.shape:
            raise ValueError(f"observations: values and std must be (K, {c}) arrays, got {values.shape} and {std.shape}")
        measured = np.isfinite(values)
        if np.any(measured & ~(np.isfinite(std) & (std > 0))):
            raise ValueError("observations: every measured value needs a standard uncertainty > 0")
        if any(not (np.isfinite(o.value) and np.isfinite(o.std) and o.std > 0) for o in self.line):
            raise ValueError("observations: a line observation needs a finite value and a standard uncertainty > 0")
        common = np.zeros(c) if self.common_std is None else np.asarray(self.common_std, dtype=float)
        if common.shape != (c,) or np.any(~np.isfinite(common)) or np.any(common < 0):
            raise ValueError(f"observations: common_std must be {c} finite values ≥ 0")
        object.__setattr__(self, "common_std", common)

    @property
    def columns(self) -> list[str]:
        """The model columns of the span quantities."""
        return model_columns(self.quantities)

    @property
    def sampled(self) -> tuple[str, ...]:
        """Every quantity the model must give: the span quantities, then the line ones."""
        return (*self.quantities, *dict.fromkeys(o.quantity for o in self.line))

    @property
    def empty(self) -> bool:
        return not self.quantities and not self.line

    def rows(self, keep: np.ndarray) -> "Observations":
        """The same observations for the rows ``keep`` (a boolean mask or indices) of the data."""
        return Observations(self.quantities, self.values[keep], self.std[keep], self.line, self.common_std)

    @classmethod
    def none(cls, n_rows: int) -> "Observations":
        """No measurement besides W, for ``n_rows`` spans."""
        return cls((), np.zeros((n_rows, 0)), np.zeros((n_rows, 0)), ())


def joint_log_density(w: np.ndarray, obs: Observations, mean: np.ndarray, covariance: np.ndarray,
                      w_noise: list[tuple[np.ndarray, np.ndarray]] | None = None) -> tuple[np.ndarray, float]:
    """``ln p`` of each span's W and measured quantities under the model's joint Gaussian.

    Parameters
    ----------
    w : numpy.ndarray, shape (K, n)
        Measured W [m].
    obs : Observations
        The span quantities (K rows); their columns follow W's in ``mean`` and ``covariance``.
    mean, covariance : numpy.ndarray
        The model sample's joint mean (n + c,) and covariance ((n + c)²) [SI].
    w_noise : list of (rows, R), optional
        W's measurement noise covariance ``R`` (n × n) [m²] of the rows ``rows`` (a boolean mask).

    Returns
    -------
    log_density : numpy.ndarray, shape (K,)
        Each span's ``ln p`` at the shared errors' estimate ô (its residual less ô's share).
    common : float
        The shared errors' term, ``−½ ôᵀS⁻¹ô − ½ ln det(I + S A)``: with the spans' terms, the
        exact marginal of the module docstring (0 without any shared error).

    Raises
    ------
    numpy.linalg.LinAlgError
        A covariance that is not positive definite.
    """
    k, n = w.shape
    shared = np.flatnonzero(obs.common_std > 0)
    a_sum = np.zeros((shared.size, shared.size))
    b_sum = np.zeros(shared.size)
    measured = np.isfinite(obs.values)
    noise_of = np.zeros(k, dtype=int)
    noises = [np.zeros((n, n))]
    for rows, r in (w_noise or []):
        noises.append(np.asarray(r, dtype=float))
        noise_of[np.asarray(rows, dtype=bool)] = len(noises) - 1
    out = np.empty(k)
    carried = []
    keys = np.column_stack([measured, noise_of])
    for key in np.unique(keys, axis=0):
        rows = np.all(keys == key, axis=1)
        cols = np.r_[np.arange(n), n + np.flatnonzero(key[:-1])]
        x = np.column_stack([w[rows], obs.values[rows][:, key[:-1].astype(bool)]])
        base = covariance[np.ix_(cols, cols)].copy()
        base[:n, :n] += noises[int(key[-1])]
        cov = np.broadcast_to(base, (int(rows.sum()), cols.size, cols.size)).copy()
        extra = obs.std[rows][:, key[:-1].astype(bool)] ** 2
        idx = np.arange(n, cols.size)
        cov[:, idx, idx] += extra
        chol = np.linalg.cholesky(cov)
        r = np.linalg.solve(chol, (x - mean[cols])[..., None])[..., 0]
        out[rows] = (-0.5 * np.einsum("ki,ki->k", r, r) - np.log(np.diagonal(chol, axis1=1, axis2=2)).sum(axis=1)
                     - 0.5 * cols.size * _LOG_2PI)
        moved = [j for j, c in enumerate(shared) if key[c]]          # shared offsets this group's rows carry
        if moved:
            e = np.zeros((cols.size, len(moved)))
            for i, j in enumerate(moved):
                e[n + int(np.flatnonzero(np.flatnonzero(key[:-1]) == shared[j])[0]), i] = 1.0
            ew = np.linalg.solve(chol, np.broadcast_to(e, (r.shape[0], *e.shape)))
            a_sum[np.ix_(moved, moved)] += np.einsum("kia,kib->ab", ew, ew)
            b_sum[moved] += np.einsum("kia,ki->a", ew, r)
            carried.append((rows, moved, ew, r))
    if not shared.size:
        return out, 0.0
    s2 = obs.common_std[shared] ** 2
    sign, logdet = np.linalg.slogdet(np.eye(shared.size) + s2[:, None] * a_sum)
    # Each span's term at the shared offsets' estimate ô = (A + S⁻¹)⁻¹ b (its residual less what
    # the common error explains), the rest the offsets' prior: Σ_k ℓ_k(r_k − E_k ô) − ½ ôᵀS⁻¹ô
    # − ½ ln det(I + S A) is the exact marginal of the module docstring, and the spans' terms
    # no longer share the offset (their scores are what a sandwich over spans may read).
    o_hat = np.linalg.solve(a_sum + np.diag(1.0 / s2), b_sum)
    for rows, moved, ew, r in carried:
        shift = np.einsum("kia,a->ki", ew, o_hat[moved])              # whitened E_k ô
        out[rows] += np.einsum("ki,ki->k", shift, r) - 0.5 * np.einsum("ki,ki->k", shift, shift)
    return out, float(-0.5 * logdet - 0.5 * o_hat @ (o_hat / s2))


def line_log_density(obs: Observations, mean: np.ndarray, variance: np.ndarray) -> float:
    """``Σ ln p`` of the line observations under the model: ``mean`` and ``variance`` of each of
    :attr:`Observations.line`'s quantities over the model sample [SI]."""
    total = 0.0
    for o, m, v in zip(obs.line, mean, variance):
        s2 = float(v) + o.std ** 2
        total += -0.5 * ((o.value - float(m)) ** 2 / s2 + np.log(s2) + _LOG_2PI)
    return total
