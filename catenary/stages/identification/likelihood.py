"""Log-likelihood J(s) of measured deflections under the model's law of W (paper §3, eq. 5).

For hyper-parameters s (mean and σ of every random input), the fixed design (common random
numbers, :mod:`.design`) is mapped to N input vectors, the fast static model gives N deflection
vectors W (n droppers), the law of W is estimated from them and

    J(s) = Σ_k ln p_W(W_k^exp; s)

over the K measured spans. Same design ⇒ same J, bit for bit.

It is one concern, over 500 lines: J of the data under the model sample's law — the estimators, the
one chunked pass that accumulates the sample's moments (W's and, with measurements besides W,
the joint ones) and the data's density under them; split apart, the pass and its readers would
be two copies of one loop.

Estimators
----------
``"gaussian"`` (default, the paper's choice): multivariate normal with the sample mean and the
(unbiased, weighted) sample covariance of W; ``ln p`` through its Cholesky factor L,
``ln p(x) = −½‖L⁻¹(x − m)‖² − Σ ln L_ii − (n/2) ln 2π``. The sample is streamed in blocks:
memory does not grow with N.

``"kernel"``: Gaussian kernel smoothing in whitened coordinates ``y = L⁻¹(w − m)`` (L from the
sample covariance), isotropic kernel of bandwidth h — Scott's rule ``h = n_eff^(−1/(n+4))``
(default; the same as ``scipy.stats.gaussian_kde``) or Silverman's
``h = (n_eff (n+2)/4)^(−1/(n+4))`` — i.e. bandwidth matrix ``h² Σ̂`` in W. ``ln p`` is a
logsumexp over the model sample (no underflow far in the tails), accumulated block by block,
plus the log-Jacobian ``−Σ ln L_ii`` of the whitening. It needs the whole W sample in memory
(N × n) and O(K N n) time. J values of the two estimators are different functions: compare J
only within one estimator.

Slack droppers
--------------
The fast model is exact only with every dropper taut; a sample with a dropper in compression
has no valid W. Such samples are removed from the model sample, i.e. the model law is that of W
*given every dropper taut* (synthetic data are drawn the same way). To keep J smooth in s (for
the optimiser and the finite-difference Hessian), the removal is a probit taper in the smallest
dropper force ``F_min``: weight ``Φ(F_min / τ)`` with ``τ = slack_taper_n`` (default 2 N; τ = 0
gives the hard indicator ``F_min > 0``). The mean and covariance are weighted accordingly and the
slack fraction ``1 − Σ weight / N`` is reported; if it exceeds ``max_slack_fraction`` (default
0.5) — the model sample no longer represents the span — J = −inf. J is also −inf when a T_MW
sample falls outside the fast model's tension range or the covariance is not positive definite.

Measurements besides W
----------------------
With ``observations`` (:class:`catenary.measurement.channels.observations.Observations`: a residual
thickness, a tension, a mast's ΔH per span; the measuring force for the line), the model sample
gives each measured quantity beside W (:mod:`catenary.measurement.channels.quantities`, the same functions
the campaign records them with), the Gaussian is fitted to W and the quantities together, and
each span's W and measured quantities enter J jointly, with each quantity's measurement error
(:func:`catenary.measurement.channels.observations.joint_log_density`); a line quantity adds its own term.
W's own fit (``LikelihoodValue.fit``) is computed exactly as without them.
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np
from scipy import special
from scipy.linalg import solve_triangular

from catenary.measurement.channels.observations import Observations, joint_log_density, line_log_density
from catenary.measurement.channels.quantities import model_columns, observe
from catenary.physics.effects import SpanParameters
from catenary.physics.fast import FastSpanModel, row_minimum
from catenary.plumbing.errors import OutOfModelRangeError
from catenary.plumbing.workers import KeptProcesses
from .design import UnitDesign, design_dimension, map_inputs

__all__ = ["BANDWIDTH_RULES", "ESTIMATORS", "GaussianFit", "Likelihood", "LikelihoodValue",
           "MOMENT_BLOCKS", "ModelSample", "SampleMoments", "fit_gaussian", "gaussian_log_density", "kernel_bandwidth",
           "kernel_log_density"]

ESTIMATORS = ("gaussian", "kernel")
BANDWIDTH_RULES = ("scott", "silverman")
_LOG_2PI = float(np.log(2.0 * np.pi))
#: Blocks of the design whose moments are summed apart and then added (:attr:`Likelihood.moment_blocks`):
#: as many processes can share a J (:meth:`Likelihood.parallel`).
MOMENT_BLOCKS = 4
#: Bytes of one block of the data × model-sample distance matrix (kernel estimator).
_KERNEL_BLOCK_BYTES = 16 * 2**20


@dataclass(frozen=True)
class GaussianFit:
    """Mean and Cholesky factor of a (weighted) sample covariance.

    Attributes
    ----------
    mean : numpy.ndarray, shape (n,)
    chol : numpy.ndarray, shape (n, n)
        Lower-triangular L with ``L Lᵀ`` the covariance.
    n_effective : float
        Kish effective sample size ``(Σw)² / Σw²``.
    """

    mean: np.ndarray
    chol: np.ndarray
    n_effective: float

    @property
    def log_det_chol(self) -> float:
        """``Σ ln L_ii`` = ½ ln det Σ̂."""
        return float(np.sum(np.log(np.diag(self.chol))))


def _fit_from_moments(sum_w: float, sum_w2: float, s1: np.ndarray, s2: np.ndarray,
                      shift: np.ndarray) -> GaussianFit:
    """Gaussian fit from shifted weighted moments ``s1 = Σ w (x − c)``, ``s2 = Σ w (x − c)(x − c)ᵀ``.

    The covariance uses the reliability-weight correction ``Σw − Σw²/Σw`` (N − 1 for unit
    weights). Raises ``numpy.linalg.LinAlgError`` if it is not positive definite.
    """
    d = s1 / sum_w
    cov = (s2 - sum_w * np.outer(d, d)) / (sum_w - sum_w2 / sum_w)
    cov = 0.5 * (cov + cov.T)
    return GaussianFit(mean=shift + d, chol=np.linalg.cholesky(cov), n_effective=sum_w**2 / sum_w2)


def _joint_moments(sum_w: float, sum_w2: float, s1: np.ndarray, s2: np.ndarray,
                   shift: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and covariance from shifted weighted moments, as :func:`_fit_from_moments` but not
    factored (a measured quantity the model holds fixed has no variance of its own)."""
    d = s1 / sum_w
    cov = (s2 - sum_w * np.outer(d, d)) / (sum_w - sum_w2 / sum_w)
    return shift + d, 0.5 * (cov + cov.T)


def fit_gaussian(sample: np.ndarray, weights: np.ndarray | None = None) -> GaussianFit:
    """Weighted mean and covariance (Cholesky) of ``sample`` (N, n); unit weights by default."""
    x = np.asarray(sample, dtype=float)
    w = np.ones(x.shape[0]) if weights is None else np.asarray(weights, dtype=float)
    shift = x[0].copy()
    c = x - shift
    cw = c * w[:, None]
    return _fit_from_moments(float(w.sum()), float(np.dot(w, w)), cw.sum(axis=0), c.T @ cw, shift)


def gaussian_log_density(x: np.ndarray, fit: GaussianFit) -> np.ndarray:
    """``ln p(x)`` of the normal law ``fit`` at the rows of ``x`` (K, n)."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    r = solve_triangular(fit.chol, (x - fit.mean).T, lower=True, check_finite=False)
    n = x.shape[1]
    return -0.5 * np.einsum("ij,ij->j", r, r) - fit.log_det_chol - 0.5 * n * _LOG_2PI


def kernel_bandwidth(n_effective: float, dimension: int, rule: str = "scott") -> float:
    """Kernel bandwidth in whitened coordinates (Scott or Silverman rule of thumb)."""
    if rule == "scott":
        return float(n_effective ** (-1.0 / (dimension + 4)))
    if rule == "silverman":
        return float((n_effective * (dimension + 2) / 4.0) ** (-1.0 / (dimension + 4)))
    raise ValueError(f"bandwidth: expected one of {BANDWIDTH_RULES}, got {rule!r}")


def kernel_log_density(x: np.ndarray, sample: np.ndarray, weights: np.ndarray | None = None,
                       bandwidth: str = "scott") -> np.ndarray:
    """``ln p(x)`` of the Gaussian kernel smoothing of ``sample`` at the rows of ``x``.

    Parameters
    ----------
    x : numpy.ndarray, shape (K, n)
        Evaluation points.
    sample : numpy.ndarray, shape (N, n)
        Model sample.
    weights : numpy.ndarray, shape (N,), optional
        Non-negative sample weights (default 1).
    bandwidth : {"scott", "silverman"}
        Rule for h in whitened coordinates (see the module docstring).

    Returns
    -------
    numpy.ndarray, shape (K,)
        Computed as a running logsumexp over blocks of the sample (memory O(K × block)).
    """
    x = np.atleast_2d(np.asarray(x, dtype=float))
    sample = np.asarray(sample, dtype=float)
    w = np.ones(sample.shape[0]) if weights is None else np.asarray(weights, dtype=float)
    keep = w > 0
    if not np.all(keep):
        sample, w = sample[keep], w[keep]
    fit = fit_gaussian(sample, w)
    n = sample.shape[1]
    h = kernel_bandwidth(fit.n_effective, n, bandwidth)
    # Whitened and divided by h, so that the kernel is exp(−½‖a − b‖²).
    y = solve_triangular(fit.chol, (sample - fit.mean).T, lower=True, check_finite=False).T / h
    yx = solve_triangular(fit.chol, (x - fit.mean).T, lower=True, check_finite=False).T / h
    log_w = np.log(w)
    sq_x = np.einsum("ij,ij->i", yx, yx)
    running_max = np.full(x.shape[0], -np.inf)
    running_sum = np.zeros(x.shape[0])
    block = max(1024, _KERNEL_BLOCK_BYTES // (8 * x.shape[0]))
    for start in range(0, y.shape[0], block):
        yb = y[start:start + block]
        e = yx @ yb.T
        e -= 0.5 * sq_x[:, None]
        e -= 0.5 * np.einsum("ij,ij->i", yb, yb)[None, :]
        e += log_w[None, start:start + block]
        block_max = e.max(axis=1)
        new_max = np.maximum(running_max, block_max)
        running_sum *= np.exp(running_max - new_max)
        e -= new_max[:, None]
        np.exp(e, out=e)
        running_sum += e.sum(axis=1)
        running_max = new_max
    log_kernel_sum = running_max + np.log(running_sum)
    return (log_kernel_sum - np.log(w.sum()) - n * np.log(h) - 0.5 * n * _LOG_2PI
            - fit.log_det_chol)


@dataclass(frozen=True)
class LikelihoodValue:
    """One evaluation of J.

    Attributes
    ----------
    j : float
        J(s) (−inf when the model sample is unusable, see ``status``).
    slack_fraction : float
        Weighted fraction of the model sample removed for slack droppers.
    n_effective : float
        Kish effective size of the retained model sample (0 if not computed).
    status : str
        ``"ok"``, ``"slack"``, ``"tension_out_of_bounds"`` or ``"singular"``.
    log_density : numpy.ndarray or None
        ``ln p_W(W_k; s)`` per measured span (K,), whose sum is J; None unless ``status == "ok"``.
    fit : GaussianFit or None
        Mean and covariance of the model sample (Gaussian estimator; None otherwise or unless
        ``status == "ok"``).
    joint : (numpy.ndarray, numpy.ndarray) or None
        Mean and covariance of the model sample over W and every quantity the likelihood's
        observations measure, in the order of W then :func:`catenary.measurement.channels.quantities.model_columns`
        of :attr:`~catenary.measurement.channels.observations.Observations.sampled` [SI] (None without
        observations).
    line_log_density : float
        The part of J that belongs to the line, not to a span: the line observations and the
        errors shared by every span's measurement (0 without any).
    """

    j: float
    slack_fraction: float
    n_effective: float
    status: str
    log_density: np.ndarray | None = None
    fit: GaussianFit | None = None
    joint: tuple | None = None
    line_log_density: float = 0.0


@dataclass(frozen=True)
class SampleMoments:
    """Taper-weighted moments of a model sample (or a block of it) about ``shift`` (W) and
    ``shift_y`` (the measured quantities besides W, when there are): ``sum_w = Σ w``,
    ``sum_w2 = Σ w²``, ``s1 = Σ w (W − shift)``, ``s2 = Σ w (W − shift)(W − shift)ᵀ`` and the same
    with the quantities Y (``s1y``, ``s2wy``, ``s2yy``; empty without them) [SI]. Two blocks'
    moments about the same shifts add up (``+``)."""

    sum_w: float
    sum_w2: float
    s1: np.ndarray
    s2: np.ndarray
    shift: np.ndarray
    s1y: np.ndarray = field(default_factory=lambda: np.zeros(0))
    s2wy: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    s2yy: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    shift_y: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __add__(self, other: "SampleMoments") -> "SampleMoments":
        return SampleMoments(self.sum_w + other.sum_w, self.sum_w2 + other.sum_w2, self.s1 + other.s1,
                             self.s2 + other.s2, self.shift, self.s1y + other.s1y, self.s2wy + other.s2wy,
                             self.s2yy + other.s2yy, self.shift_y)


@dataclass(frozen=True)
class ModelSample:
    """Model sample of W under given laws: deflections, taper weights and dropper forces."""

    w_m: np.ndarray
    weight: np.ndarray
    min_dropper_force_n: np.ndarray


class Likelihood:
    """J(s) for one span type, one fixed design and one set of measured deflections.

    Parameters
    ----------
    model : FastSpanModel
        Fast static model of the span type; its T_MW range must cover the T_MW samples of every
        s to be evaluated (else J = −inf).
    design : UnitDesign
        Unit-cube design with ``design_dimension(n, system_height_mode)`` columns.
    data_w_m : array_like, shape (K, n)
        Measured CW deflections from the chord at the droppers [m].
    estimator : {"gaussian", "kernel"}
    system_height_mode : {"shared", "independent"}
        How ΔH_left and ΔH_right follow the ΔH law (see :mod:`.design`).
    slack_taper_n : float
        Width τ of the slack taper [N] (0: hard removal).
    max_slack_fraction : float
        J = −inf above this slack fraction.
    bandwidth : {"scott", "silverman"}
        Kernel bandwidth rule (kernel estimator only).
    chunk_size : int
        Design rows mapped and evaluated at once, at most (J sums them in :attr:`moment_blocks`).
    noise_covariance_m2 : numpy.ndarray, optional
        Covariance R of one run's W error (n × n) [m²]: the law of a measured W is that of the
        model plus ``R / n_runs`` of its span (Gaussian estimator only). Default: none.
    n_runs : array_like of int, shape (K,), optional
        Runs averaged into each measured W (default 1).
    sampler : callable, optional
        Replaces the map from design rows to model W: ``sampler(z, means, sigmas, extra)``
        returns ``(W, F_min)`` for the standard normal scores ``z`` of a block of the design, or
        None when a sample falls outside the model's range (J = −inf); ``extra`` is what
        :meth:`evaluate` was given (the diagnosis's effect magnitudes, :mod:`catenary.stages.diagnosis`).
        It states the design columns it reads as its ``dimension``. Default: the fast model of
        the random inputs alone. With observations it is called with ``observe=`` the quantities
        and returns ``(W, F_min, Y)``, Y their model columns.
    observations : Observations, optional
        Measurements besides W (module docstring; Gaussian estimator only). Without a sampler,
        only quantities of the random inputs and no line quantity.

    Notes
    -----
    ``means`` and ``sigmas`` given to :meth:`evaluate` are arrays over the inputs in design
    order: droppers 1…n, T_MW [N], ΔH [m].
    """

    def __init__(self, model: FastSpanModel, design: UnitDesign, data_w_m: np.ndarray, *,
                 estimator: str = "gaussian", system_height_mode: str = "shared",
                 slack_taper_n: float = 2.0, max_slack_fraction: float = 0.5,
                 bandwidth: str = "scott", chunk_size: int = 16384, sampler=None,
                 noise_covariance_m2: np.ndarray | None = None, n_runs: np.ndarray | None = None,
                 observations: Observations | None = None):
        n = model.n_droppers
        expected = design_dimension(n, system_height_mode) if sampler is None else sampler.dimension
        if design.dimension != expected:
            raise ValueError(f"design: expected {expected} columns (system_height_mode={system_height_mode!r}"
                             f"{', the sampler' if sampler is not None else ''}), got {design.dimension}")
        data = np.atleast_2d(np.asarray(data_w_m, dtype=float))
        if data.ndim != 2 or data.shape[1] != n or not np.all(np.isfinite(data)):
            raise ValueError(f"data_w_m: expected finite values of shape (K, {n}), got {data.shape}")
        if estimator not in ESTIMATORS:
            raise ValueError(f"estimator: expected one of {ESTIMATORS}, got {estimator!r}")
        if bandwidth not in BANDWIDTH_RULES:
            raise ValueError(f"bandwidth: expected one of {BANDWIDTH_RULES}, got {bandwidth!r}")
        if slack_taper_n < 0 or not 0 < max_slack_fraction <= 1:
            raise ValueError("need slack_taper_n ≥ 0 and 0 < max_slack_fraction ≤ 1")
        self.model = model
        self.design = design
        self.data_w_m = data
        self.estimator = estimator
        self.system_height_mode = system_height_mode
        self.slack_taper_n = float(slack_taper_n)
        self.max_slack_fraction = float(max_slack_fraction)
        self.bandwidth = bandwidth
        self.chunk_size = int(chunk_size)
        self.sampler = sampler
        self._processes = None
        self._shift = data.mean(axis=0)
        self.n_runs = np.ones(data.shape[0], dtype=int) if n_runs is None else np.asarray(n_runs, dtype=int)
        if self.n_runs.shape != (data.shape[0],) or np.any(self.n_runs < 1):
            raise ValueError(f"n_runs: expected {data.shape[0]} counts ≥ 1, got {self.n_runs}")
        self.noise_covariance_m2 = None
        if noise_covariance_m2 is not None:
            noise = np.asarray(noise_covariance_m2, dtype=float)
            if noise.shape != (n, n) or not np.allclose(noise, noise.T):
                raise ValueError(f"noise_covariance_m2: expected a symmetric ({n}, {n}) matrix, got shape {noise.shape}")
            if estimator != "gaussian":
                raise ValueError("noise_covariance_m2: a measurement noise needs the gaussian estimator")
            self.noise_covariance_m2 = noise
        self.observations = None
        if observations is not None and not observations.empty:
            if observations.values.shape[0] != data.shape[0]:
                raise ValueError(f"observations: expected {data.shape[0]} rows (one per measured span), got "
                                 f"{observations.values.shape[0]}")
            if estimator != "gaussian":
                raise ValueError("observations: measurements besides W need the gaussian estimator")
            if sampler is None and observations.line:
                raise ValueError("observations: a line quantity needs a model of it (a sampler)")
            self.observations = observations
            values = observations.values
            seen = np.isfinite(values).any(axis=0)
            first = {}
            for o in observations.line:
                first.setdefault(o.quantity, o.value)
            # the moments are accumulated about the data (a quantity the model holds fixed is
            # then no catastrophic cancellation of two large sums)
            span_shift = np.zeros(values.shape[1])
            span_shift[seen] = np.nanmean(values[:, seen], axis=0)
            self._shift_y = np.r_[span_shift, [first[q] for q in model_columns(observations.sampled)[values.shape[1]:]]]

    @property
    def n_samples(self) -> int:
        return self.design.n_samples

    def with_data(self, data_w_m: np.ndarray) -> "Likelihood":
        """The same J (model, design, options) for other measured deflections."""
        same = np.asarray(data_w_m).shape[0] == self.data_w_m.shape[0]
        return Likelihood(self.model, self.design, data_w_m, estimator=self.estimator,
                          system_height_mode=self.system_height_mode, slack_taper_n=self.slack_taper_n,
                          max_slack_fraction=self.max_slack_fraction, bandwidth=self.bandwidth,
                          chunk_size=self.chunk_size, sampler=self.sampler,
                          noise_covariance_m2=self.noise_covariance_m2, n_runs=self.n_runs if same else None,
                          observations=self.observations if same else None)

    def data_log_density(self, fit: GaussianFit) -> np.ndarray:
        """``ln p(W_k)`` of each measured span under the model's Gaussian law ``fit``, with its
        measurement noise ``R / n_runs`` added when the likelihood has one.

        Raises
        ------
        numpy.linalg.LinAlgError
            If a covariance is not positive definite.
        """
        if self.noise_covariance_m2 is None:
            return gaussian_log_density(self.data_w_m, fit)
        covariance = fit.chol @ fit.chol.T
        out = np.empty(self.data_w_m.shape[0])
        for runs in np.unique(self.n_runs):
            rows = self.n_runs == runs
            chol = np.linalg.cholesky(covariance + self.noise_covariance_m2 / runs)
            out[rows] = gaussian_log_density(self.data_w_m[rows], GaussianFit(fit.mean, chol, fit.n_effective))
        return out

    def taper_weights(self, min_force: np.ndarray) -> np.ndarray:
        """Weight of each model sample: Φ(F_min / τ), the slack taper (module docstring)."""
        if self.slack_taper_n == 0.0:
            return (min_force > 0.0).astype(float)
        return special.ndtr(min_force / self.slack_taper_n)

    def _sample(self, z, means, sigmas, extra, names=None):
        """(W, F_min) of the design rows ``z`` — (W, F_min, Y) with observations (or ``names``),
        Y the model columns of the quantities they measure (or of ``names``) — or None if T_MW is
        out of the model's range."""
        if names is None:
            names = self.observations.sampled if self.observations is not None else ()
        if self.sampler is not None:
            return self.sampler(z, means, sigmas, extra, observe=names) if names else self.sampler(z, means, sigmas,
                                                                                                    extra)
        lo, hi = self.model.messenger_tension_bounds_n
        x = map_inputs(z, means, sigmas, self.system_height_mode)
        t = x.messenger_tension_n
        if t.min() < lo or t.max() > hi:
            return None
        res = self.model.evaluate(x.dropper_lengths_m, t, x.system_height_left_m,
                                  x.system_height_right_m, chunk_size=self.chunk_size)
        if not names:
            return res.w_m, row_minimum(res.dropper_force_n)
        st = self.model.span_type
        p = SpanParameters.independent_spans(
            x.dropper_lengths_m, t, x.system_height_left_m, x.system_height_right_m,
            system_height_mean_m=float(means[-1]), contact_tension_n=st.contact_tension_n, measuring_force_n=np.nan)
        return res.w_m, row_minimum(res.dropper_force_n), observe(p, self.model.catenary, names)

    def _chunks(self, means, sigmas, extra=None, with_y: bool = False):
        """Yield (W, weights, F_min) per block of the design — (W, weights, F_min, Y) with
        ``with_y`` — or None if T_MW is out of range."""
        z = self.design.z
        for start in range(0, z.shape[0], self.chunk_size):
            out = self._sample(z[start:start + self.chunk_size], means, sigmas, extra)
            if out is None:
                yield None
                return
            w, f_min = out[:2]
            yield (w, self.taper_weights(f_min), f_min, *out[2:3]) if with_y else (w, self.taper_weights(f_min), f_min)

    def joint_moments(self, means: np.ndarray, sigmas: np.ndarray, extra, quantities) -> tuple | None:
        """Mean and covariance of the (taper-weighted) model sample over W and the model columns
        of ``quantities`` (:func:`catenary.measurement.channels.quantities.model_columns`) [SI], whatever was
        measured; None where the model sample is unusable (as J = −inf)."""
        quantities = tuple(quantities)
        sum_w = sum_w2 = 0.0
        s1 = s2 = shift = None
        z = self.design.z
        for start in range(0, z.shape[0], self.chunk_size):
            out = self._sample(z[start:start + self.chunk_size], np.asarray(means, dtype=float),
                               np.asarray(sigmas, dtype=float), extra, names=quantities)
            if out is None:
                return None
            x = np.column_stack([out[0], *out[2:3]]) if quantities else out[0]
            weight = self.taper_weights(out[1])
            if shift is None:
                shift = x[0].copy()
                s1, s2 = np.zeros(x.shape[1]), np.zeros((x.shape[1], x.shape[1]))
            c = x - shift
            cw = c * weight[:, None]
            sum_w += float(weight.sum())
            sum_w2 += float(np.dot(weight, weight))
            s1 += cw.sum(axis=0)
            s2 += c.T @ cw
        if 1.0 - sum_w / self.n_samples > self.max_slack_fraction:
            return None
        return _joint_moments(sum_w, sum_w2, s1, s2, shift)

    def model_sample(self, means: np.ndarray, sigmas: np.ndarray, extra=None) -> ModelSample:
        """The whole model sample of W under the laws (means, sigmas).

        Raises
        ------
        OutOfModelRangeError
            If a T_MW sample lies outside the fast model's tension range.
        """
        parts = list(self._chunks(means, sigmas, extra))
        if parts and parts[-1] is None:
            raise OutOfModelRangeError("messenger_tension_n: samples outside the fast model's tension bounds "
                             f"{self.model.messenger_tension_bounds_n} N")
        w, weight, f_min = (np.concatenate(p) for p in zip(*parts))
        return ModelSample(w_m=w, weight=weight, min_dropper_force_n=f_min)

    def evaluate(self, means: np.ndarray, sigmas: np.ndarray, extra=None) -> LikelihoodValue:
        """J and diagnostics at the laws (means, sigmas) (arrays in design order); ``extra``
        goes to the sampler."""
        means = np.asarray(means, dtype=float)
        sigmas = np.asarray(sigmas, dtype=float)
        if self.estimator == "kernel":
            try:
                sample = self.model_sample(means, sigmas, extra)
            except OutOfModelRangeError:
                return LikelihoodValue(-np.inf, np.nan, 0.0, "tension_out_of_bounds")
            slack = 1.0 - float(sample.weight.sum()) / self.n_samples
            if slack > self.max_slack_fraction:
                return LikelihoodValue(-np.inf, slack, 0.0, "slack")
            try:
                logp = kernel_log_density(self.data_w_m, sample.w_m, sample.weight, self.bandwidth)
                w = sample.weight
                n_eff = float(w.sum() ** 2 / np.dot(w, w))
            except np.linalg.LinAlgError:
                return LikelihoodValue(-np.inf, slack, 0.0, "singular")
            return LikelihoodValue(float(np.sum(logp)), slack, n_eff, "ok", logp)
        moments = self.moments(means, sigmas, extra)
        if moments is None:
            return LikelihoodValue(-np.inf, np.nan, 0.0, "tension_out_of_bounds")
        return self.value_of(moments)

    def value_of(self, moments: SampleMoments) -> LikelihoodValue:
        """J and diagnostics of this likelihood's data under the model sample whose moments are
        ``moments`` (Gaussian estimator): the data may be other than those the moments were
        accumulated about (the model sample does not depend on them)."""
        slack = 1.0 - moments.sum_w / self.n_samples
        if slack > self.max_slack_fraction:
            return LikelihoodValue(-np.inf, slack, 0.0, "slack")
        m = moments
        try:
            fit = _fit_from_moments(m.sum_w, m.sum_w2, m.s1, m.s2, m.shift)
            if self.observations is None:
                logp = self.data_log_density(fit)
                return LikelihoodValue(float(np.sum(logp)), slack, fit.n_effective, "ok", logp, fit)
            joint = _joint_moments(m.sum_w, m.sum_w2, np.r_[m.s1, m.s1y], np.block([[m.s2, m.s2wy], [m.s2wy.T, m.s2yy]]),
                                   np.r_[m.shift, m.shift_y])
            logp, line = self._joint_log_density(joint)
        except np.linalg.LinAlgError:
            return LikelihoodValue(-np.inf, slack, 0.0, "singular")
        return LikelihoodValue(float(np.sum(logp)) + line, slack, fit.n_effective, "ok", logp, fit, joint, line)

    @property
    def moment_blocks(self) -> list[tuple[int, int]]:
        """Rows of the design summed together, in the order their sums are added: at least
        :data:`MOMENT_BLOCKS` blocks of at most ``chunk_size`` rows, the same for any number
        of processes (:meth:`parallel`)."""
        n = self.n_samples
        rows = max(1, min(self.chunk_size, -(-n // MOMENT_BLOCKS)))
        return [(start, min(start + rows, n)) for start in range(0, n, rows)]

    def _block_moments(self, first: int, stop: int, means: np.ndarray, sigmas: np.ndarray, extra) -> list | None:
        """The moments of blocks ``first``…``stop − 1`` of :attr:`moment_blocks`, one
        :class:`SampleMoments` each, or None if a T_MW sample lies out of the model's range."""
        obs = self.observations
        z = self.design.z
        out = []
        for begin, end in self.moment_blocks[first:stop]:
            part = self._sample(z[begin:end], means, sigmas, extra)
            if part is None:
                return None
            w, weight = part[0], self.taper_weights(part[1])
            c = w - self._shift
            cw = c * weight[:, None]
            moments = dict(sum_w=float(weight.sum()), sum_w2=float(np.dot(weight, weight)), s1=cw.sum(axis=0),
                           s2=c.T @ cw, shift=self._shift)
            if obs is not None:
                cy = part[2] - self._shift_y
                cyw = cy * weight[:, None]
                moments.update(s1y=cyw.sum(axis=0), s2wy=c.T @ cyw, s2yy=cy.T @ cyw, shift_y=self._shift_y)
            out.append(SampleMoments(**moments))
        return out

    def moments(self, means: np.ndarray, sigmas: np.ndarray, extra=None) -> SampleMoments | None:
        """Taper-weighted moments of the model sample of W (and of the measured quantities) at
        the laws (means, sigmas), block by block (:attr:`moment_blocks`) and added in the blocks'
        order — shared among the processes of :meth:`parallel` when it is open; None if a T_MW
        sample lies out of the model's range."""
        means = np.asarray(means, dtype=float)
        sigmas = np.asarray(sigmas, dtype=float)
        n_blocks = len(self.moment_blocks)
        processes = self._processes
        parts = processes.workers if processes is not None else 1
        cuts = [round(k * n_blocks / parts) for k in range(parts + 1)]
        calls = [(a, b, means, sigmas, extra) for a, b in zip(cuts[:-1], cuts[1:]) if b > a]
        found = processes.map(calls) if processes is not None else [self._block_moments(*c) for c in calls]
        if any(f is None for f in found):
            return None
        blocks = [m for f in found for m in f]
        total = blocks[0]
        for m in blocks[1:]:
            total = total + m
        return total

    @contextmanager
    def parallel(self, workers: int):
        """Within the block, each J's model sample is shared among ``workers`` processes (this
        one and ``workers − 1`` forked helpers, :class:`catenary.plumbing.workers.KeptProcesses`):
        the same J, bit for bit, for any number. For J evaluated one after the other (an
        optimiser); J at many points at once is better spread over points (:func:`.fit.evaluate_points`)."""
        if workers <= 1 or self._processes is not None:
            yield self
            return
        self._processes = KeptProcesses(self._block_moments, workers)
        try:
            yield self
        finally:
            self._processes.close()
            self._processes = None

    def _joint_log_density(self, joint) -> tuple[np.ndarray, float]:
        """Per span ``ln p`` of W and its measured quantities, and the line observations' term."""
        obs = self.observations
        mean, cov = joint
        n, c = self.model.n_droppers, obs.values.shape[1]
        span_cols = np.arange(n + c)
        noise = None
        if self.noise_covariance_m2 is not None:
            noise = [(self.n_runs == runs, self.noise_covariance_m2 / runs) for runs in np.unique(self.n_runs)]
        logp, common = joint_log_density(self.data_w_m, obs, mean[span_cols], cov[np.ix_(span_cols, span_cols)],
                                         noise)
        if not obs.line:
            return logp, common
        line_cols = model_columns(obs.sampled)[c:]
        where = {q: n + c + i for i, q in enumerate(line_cols)}
        idx = [where[o.quantity] for o in obs.line]
        return logp, common + line_log_density(obs, mean[idx], np.diag(cov)[idx])

    def __call__(self, means: np.ndarray, sigmas: np.ndarray, extra=None) -> float:
        """J(s) (see :meth:`evaluate`)."""
        return self.evaluate(means, sigmas, extra).j
