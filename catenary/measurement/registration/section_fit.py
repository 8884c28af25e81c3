"""A section's supports found jointly from the height trace, and the mast table's accuracy measured.

Mast by mast, the height places a support to 0.2–0.3 m with tails to almost a metre
(:mod:`.supports`): a span's droppers leave kinks of a few millimetres per metre against 1 mm
of noise. A mast table kept to the decimetre is as good; one kept to the metre is worse. This
module weighs all the evidence of a section at once, in one probability model of its supports'
recorded chainages ``x_0 … x_K``:

* **the table**: a listed mast's chainage ``t_k`` is its true one plus an error of standard
  deviation ``σ_t``, independent from mast to mast: ``x_k ~ N(M(t_k), (M'(t_k) σ_t)²)``, ``M``
  the section's map from table to recorded chainage (:class:`.mapping.ChainageMap`). A mast the
  registration inserted (missing from the table) has no such term;
* **the spans**: a span has its type's length ``L_k`` up to a deviation of standard deviation
  ``σ_L`` (recorded metres), independent from span to span:
  ``x_{k+1} − x_k ~ N(M'(m_k) L_k, σ_L²)``, ``m_k`` the span's middle. This ties each support to
  its neighbours, and so every dropper of the section to every support;
* **the trace**: around each support, the height's misfit by the support's pattern of kinks
  (the mast and the droppers of its two spans at their design places, the dynamic pass's lag
  included; :func:`height_evidence`) at each trial position on a grid of ``GRID_STEP_M``,
  read as a log-likelihood ``−ΔRSS / (2 σ² κ²)``. The windows of neighbouring supports do not
  overlap (each ends between the two droppers nearest to mid-span), so their evidences are
  independent. ``κ`` (:data:`EVIDENCE_TEMPER`) widens the evidence to the fit's real error.

The model is a chain, so the forward–backward algorithm on the grid gives, exactly, every
support's posterior and the marginal likelihood ``p(trace, table | M, σ_t, σ_L)``. ``M``,
``σ_t`` and ``σ_L`` maximise it (Nelder–Mead), with the configured ``mast_table_std_m`` as a
prior on ``σ_t`` worth :data:`PRIOR_MASTS` masts (a scaled inverse-χ² on ``σ_t²``): the table's
accuracy is measured by the run — how far the masts the trace and the spans place lie from where
the table puts them, less what the trace itself cannot tell — and the config value only decides
where the run cannot. A position on the grid stands for a cell of ``GRID_STEP_M``: its
quantisation (``step²/12`` per position, twice that per span) is added to both variances, so a
table more precise than the grid is not penalised for it; there the final positions come from the
Gaussian product of the table's and the rest's evidence (``_place``), which the grid cannot
resolve. The maximum's ``σ_t`` is low by the map's fitted coefficients, as a mean square over
``n`` instead of ``n − p``: it is scaled by ``√(n / (n − p))``.

Measured on the default campaign's line recorded without stagger by a car whose odometer reads
0.3 % long and 7 m ahead, through the registration (``r_height_loose_03`` and ``r_height_loose_1``
of ``make validate``; docs/input_formats.md): the masts lie 0.104 / 0.102 m (RMS) from the truth,
0.30 m at worst, with a table within ±0.3 m / ±1 m, where mast by mast they lay 0.21 / 0.59 m with
tails of 0.9 / 1.7 m; each section's table accuracy within 7 % of what its table's errors
realized. ``κ`` matters only where the evidence would otherwise be trusted too much: 1.5 and 2
give 0.104 / 0.104 m and 0.102 / 0.098 m; κ = 1 (the misfit at face value) put one section of the
±1 m table's run 3.7 m off. Each trial of the map and the two standard deviations costs one
forward pass over the section's 20 spans on a grid of 61 trials per support, compiled
(:mod:`.section_chain`: each span's transitions are one lag density, so no 61 × 61 matrix is
built); the maximum's posteriors take one forward–backward pass with the matrices.

For a trace whose supports each come with a Gaussian error (the stagger's reversals, to a
centimetre) the table's accuracy is the residuals' mean square less the fits' own variances
(:func:`table_std_from_residuals`), with the same prior.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from catenary.physics.config import Catenary
from .mapping import ChainageMap
from .section_chain import SectionChain
from .supports import Trace, pattern_misfit, valley_fit

__all__ = ["EVIDENCE_TEMPER", "GRID_STEP_M", "PRIOR_MASTS", "Evidence", "SectionFit", "fit_section",
           "height_evidence", "table_std_from_residuals"]

#: Step of the grid of trial support positions [m]: finer than the height places a support
#: (0.1–0.3 m), as coarse as keeps a section's fit at a fraction of a second.
GRID_STEP_M = 0.05
#: Widening κ of the height's evidence: the misfit's curvature understates a mast fit's error,
#: by 1.08 (N2) and 1.89 (N3) on the correction's own model of a measuring pass
#: (tests/test_registration_supports.py); 1.5 lies between (module docs: 1.5 and 2 give the
#: same supports; 1 trusts the misfit too much).
EVIDENCE_TEMPER = 1.5
#: Weight of the configured ``mast_table_std_m`` as a prior on the table's accuracy, in masts:
#: a section of 20 masts measures it ten times more than the config says it.
PRIOR_MASTS = 2.0
#: The search stops when its simplex is this small (in metres of the map's nodes and in the
#: standard deviations' logarithms: 5 mm, 0.5 %) and its log-likelihoods this close.
_X_TOLERANCE, _F_TOLERANCE = 5e-3, 1e-2
#: Range of the standard deviations searched [m].
_STD_RANGE_M = (1e-3, 5.0)
#: Node spacing of the map's parametrisation in the search: its values at ``degree + 1`` table
#: chainages spread over the section (metres, like the standard deviations' logarithms' scale).
_SIMPLEX_M, _SIMPLEX_LOG = 0.1, 0.5


@dataclass(frozen=True)
class Evidence:
    """What the height trace says about each support of a section.

    Attributes
    ----------
    grid_m : numpy.ndarray
        ``(n_supports, n_trials)``: recorded chainage of each trial position [m].
    log_likelihood : numpy.ndarray
        ``(n_supports, n_trials)``: log-likelihood of the height around the support at each trial
        position, 0 at the best [-]; all 0 where the trace says nothing (too few samples).
    own_m, own_std_m : numpy.ndarray
        Each support's own best position (the misfit's valley, :func:`.supports.valley_fit`)
        and its standard error [m]; NaN where not found or at the search's edge.
    """

    grid_m: np.ndarray
    log_likelihood: np.ndarray
    own_m: np.ndarray
    own_std_m: np.ndarray


@dataclass(frozen=True)
class SectionFit:
    """A section's supports as the whole section places them.

    Attributes
    ----------
    position_m, std_m : numpy.ndarray
        Posterior mean and standard deviation of each support's recorded chainage [m].
    corr_next : numpy.ndarray
        Posterior correlation of each support's position with the next one's [-] (NaN at the
        last): the spans tie neighbours together, which the error of a span's W depends on.
    chainage_map : ChainageMap
        The map from table to recorded chainage that maximises the marginal likelihood.
    table_std_m : float
        The table's accuracy: standard deviation of a listed mast's chainage error [m of the table].
    length_std_m : float
        Standard deviation of a span's length about its type's [m of the table].
    log_likelihood : float
        Marginal log-likelihood at the optimum (up to a constant of the trace) [-].
    converged : bool
        Whether the search met its tolerances.
    """

    position_m: np.ndarray
    std_m: np.ndarray
    corr_next: np.ndarray
    chainage_map: ChainageMap
    table_std_m: float
    length_std_m: float
    log_likelihood: float
    converged: bool


def _middle_gap(positions_m: np.ndarray, length_m: float) -> float:
    """The midpoint between two neighbouring droppers nearest to mid-span [m from the span's start]."""
    gaps = 0.5 * (positions_m[1:] + positions_m[:-1])
    return float(gaps[np.argmin(np.abs(gaps - 0.5 * length_m))]) if gaps.size else 0.5 * length_m


def height_evidence(trace: Trace, guess_m: np.ndarray, span_types: list, catenary: Catenary, scale: float,
                    lags_m: dict, reach_m: float, step_m: float = GRID_STEP_M) -> Evidence:
    """The height's evidence on each support of a section (module docs).

    Parameters
    ----------
    trace : Trace
    guess_m : numpy.ndarray
        Where the supports are believed to be (recording frame) [m]: the grid's centres.
    span_types : list
        Type of the span starting at each support (None at the last).
    catenary : Catenary
    scale : float
        Recorded metres per metre of the span types' lengths [-].
    lags_m : dict
        Lag of each span type's kinks in the trace, signed along the chainage [m].
    reach_m : float
        Trial positions within ± this of the guess [m].
    step_m : float
        Grid step [m].

    Returns
    -------
    Evidence
    """
    guess = np.asarray(guess_m, dtype=float)
    shifts = np.arange(-reach_m, reach_m + 0.5 * step_m, step_m)
    n = guess.size
    log_l = np.zeros((n, shifts.size))
    own, own_std = np.full(n, np.nan), np.full(n, np.nan)
    for j in range(n):
        right_type = span_types[j] if j + 1 < n else None
        left_type = span_types[j - 1] if j > 0 else None
        kinks, lags = [], [lags_m[t] for t in (left_type, right_type) if t is not None]
        mast_lag = float(np.mean(lags)) if lags else 0.0
        kinks.append(mast_lag)
        outside = reach_m + 1.0 + abs(mast_lag)          # a section's end: the mast's kink never leaves the window
        low, high = guess[j] - outside, guess[j] + outside
        if right_type is not None:
            st = catenary.span_type(right_type)
            kinks += list(scale * st.dropper_positions_m + lags_m[right_type])
            high = guess[j] + scale * _middle_gap(st.dropper_positions_m, st.length_m)
        if left_type is not None:
            st = catenary.span_type(left_type)
            kinks += list(scale * (st.dropper_positions_m - st.length_m) + lags_m[left_type])
            low = guess[j] - scale * (st.length_m - _middle_gap(st.dropper_positions_m, st.length_m))
        rss, dof = pattern_misfit(trace, guess[j] + np.asarray(kinks), low, high, shifts)
        if dof <= 0 or not np.all(np.isfinite(rss)):
            continue
        best = float(np.min(rss))
        sigma2 = max(best / dof, 1e-30)
        log_l[j] = -(rss - best) / (2.0 * sigma2 * EVIDENCE_TEMPER ** 2)
        fit = valley_fit(shifts, rss, dof, 0.0, step_m, dof)
        if fit.found and np.isfinite(fit.std_m):
            own[j], own_std[j] = guess[j] + fit.position_m, fit.std_m
    return Evidence(guess[:, None] + shifts[None, :], log_l, own, own_std)


def _map_from_nodes(values: np.ndarray, nodes: np.ndarray, reference_m: float) -> ChainageMap:
    degree = nodes.size - 1
    coefficients = np.linalg.solve(np.vander(nodes - reference_m, degree + 1, increasing=True), values)
    return ChainageMap(coefficients, reference_m)


def _log_prior(table_std_m: float, prior_std_m: float) -> float:
    """Scaled inverse-χ² prior of σ_t² with :data:`PRIOR_MASTS` degrees of freedom, as a density
    of log σ_t: its mode at the configured value."""
    v = table_std_m ** 2
    return -0.5 * PRIOR_MASTS * (np.log(v) + prior_std_m ** 2 / v)


def fit_section(evidence: Evidence, table_m: np.ndarray, listed: np.ndarray, lengths_m: np.ndarray, *,
                initial: ChainageMap, degree: int, prior_std_m: float,
                fixed_map: ChainageMap | None = None, fixed_table_std_m: float | None = None,
                max_evaluations: int = 1500) -> SectionFit:
    """The supports, the map and the table's accuracy of one section (module docs).

    Parameters
    ----------
    evidence : Evidence
        The trace's evidence on each support (:func:`height_evidence`).
    table_m : numpy.ndarray
        Each support's table chainage (for a mast the registration inserted, where the span
        types put it) [m].
    listed : numpy.ndarray of bool
        Which supports the table lists (the others have no table term).
    lengths_m : numpy.ndarray
        Each span's type's length [m of the table].
    initial : ChainageMap
        Where the search starts (the coarse search's line).
    degree : int
        Degree of the map (lowered to what the listed masts allow, at least 1).
    prior_std_m : float
        The configured accuracy of the table [m]: the prior's mode.
    fixed_map : ChainageMap, optional
        Keep this map; only the standard deviations are searched.
    fixed_table_std_m : float, optional
        Keep this accuracy of the table [m] (a table found from the same trace, whose errors
        are the trace's own and not independent of it); then ``table_std_m`` is this value.
    max_evaluations : int
        Largest number of marginal likelihoods the search evaluates.

    Returns
    -------
    SectionFit

    Raises
    ------
    ValueError
        If fewer than 2 supports are listed.
    """
    t = np.asarray(table_m, dtype=float)
    listed = np.asarray(listed, dtype=bool)
    if listed.sum() < 2:
        raise ValueError("fit_section: fewer than 2 listed masts")
    chain = SectionChain(evidence.grid_m, evidence.log_likelihood, t, listed, lengths_m)
    reference = float(initial.reference_m)
    degree = int(max(1, min(degree, listed.sum() - 2)))
    nodes = np.linspace(t[listed].min(), t[listed].max(), degree + 1)
    lo, hi = np.log(_STD_RANGE_M[0]), np.log(_STD_RANGE_M[1])

    n_std = 1 if fixed_table_std_m is not None else 2

    def unpack(theta):
        if fixed_map is not None:
            chainage_map, rest = fixed_map, theta
        else:
            chainage_map, rest = _map_from_nodes(theta[:-n_std], nodes, reference), theta[-n_std:]
        stds = np.exp(np.clip(rest, lo, hi))
        table_std = float(fixed_table_std_m) if fixed_table_std_m is not None else float(stds[0])
        return chainage_map, table_std, float(stds[-1])

    def cost(theta):
        chainage_map, table_std, length_std = unpack(theta)
        if np.any(chainage_map.slope(t) <= 0):
            return np.inf
        value = chain.run(chainage_map, table_std, length_std)
        prior = _log_prior(table_std, prior_std_m) if fixed_table_std_m is None else 0.0
        return -(value + prior) if np.isfinite(value) else np.inf

    start = ([np.log(prior_std_m)] if fixed_table_std_m is None else []) + [np.log(0.1)]
    steps = [_SIMPLEX_LOG] * n_std
    if fixed_map is None:
        start = list(initial.to_recorded(nodes)) + start
        steps = [_SIMPLEX_M] * nodes.size + steps
    x0 = np.asarray(start, dtype=float)
    simplex = np.vstack([x0] + [x0 + np.eye(x0.size)[i] * steps[i] for i in range(x0.size)])
    result = minimize(cost, x0, method="Nelder-Mead",
                      options={"initial_simplex": simplex, "xatol": _X_TOLERANCE, "fatol": _F_TOLERANCE,
                               "maxfev": max_evaluations})
    chainage_map, table_std, length_std = unpack(result.x)
    # The map's coefficients are fitted to the same masts: the maximum's variance is low by their
    # count, as a residuals' mean square over n instead of n − p (≈ 5 % on σ_t for 21 masts).
    n_fitted = 0 if fixed_map is not None or fixed_table_std_m is not None else degree + 1
    table_std *= float(np.sqrt(listed.sum() / (listed.sum() - n_fitted))) if listed.sum() > n_fitted else 1.0
    log_likelihood, (gamma, cross, table) = chain.run(chainage_map, table_std, length_std, posterior=True)
    position, std = _place(chain, gamma, table, chainage_map, table_std)
    # each position's variance with its cell's quantisation, as _place gives it (independent
    # between supports): a posterior on one node is then uncorrelated with its neighbour's
    mean = (chain.grid * gamma).sum(axis=1, keepdims=True)
    variance = ((chain.grid - mean) ** 2 * gamma).sum(axis=1) + chain.step ** 2 / 12.0
    corr = cross[:-1] / np.sqrt(variance[:-1] * variance[1:])
    corr_next = np.r_[np.clip(corr, -1.0, 1.0), np.nan]
    scale = float(np.mean(chainage_map.slope(t)))
    return SectionFit(position, std, corr_next, chainage_map, table_std, length_std / scale, log_likelihood,
                      bool(result.success))


def _place(chain: SectionChain, gamma: np.ndarray, table: np.ndarray, chainage_map: ChainageMap,
           table_std_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Each support's position and standard error from its posterior on the grid; where the table
    places a listed mast more finely than the grid's step, the Gaussian product of the table's
    term and the rest of the section's evidence (the posterior without its own table term)."""
    grid = chain.grid
    quantisation = chain.step ** 2 / 12.0
    mean = (grid * gamma).sum(axis=1)
    variance = (grid ** 2 * gamma).sum(axis=1) - mean ** 2 + quantisation
    expected = chainage_map.to_recorded(chain.t)
    table_var = (chainage_map.slope(chain.t) * table_std_m) ** 2
    fine = chain.listed & (np.sqrt(table_var) < chain.step)
    for k in np.flatnonzero(fine):
        with np.errstate(divide="ignore"):
            log_rest = np.log(gamma[k]) - table[k]
        if not np.isfinite(log_rest).any():
            continue
        rest = np.exp(log_rest - np.max(log_rest[np.isfinite(log_rest)]))
        rest = np.where(np.isfinite(rest), rest, 0.0)
        rest /= rest.sum()
        rest_mean = float(grid[k] @ rest)
        rest_var = float(grid[k] ** 2 @ rest) - rest_mean ** 2 + quantisation
        weight = 1.0 / rest_var + 1.0 / max(table_var[k], 1e-12)
        mean[k] = (rest_mean / rest_var + expected[k] / max(table_var[k], 1e-12)) / weight
        variance[k] = 1.0 / weight
    return mean, np.sqrt(np.maximum(variance, 0.0))


def table_std_from_residuals(residual_m: np.ndarray, trace_std_m: np.ndarray, n_parameters: int,
                             prior_std_m: float) -> float:
    """The table's accuracy from masts placed by a Gaussian trace (the stagger's reversals).

    The residuals' mean square, less the trace's own variances, estimates the table's variance
    (the map's ``n_parameters`` fitted to the same residuals taken into account); it is pooled
    with the configured value weighted as :data:`PRIOR_MASTS` masts.

    Parameters
    ----------
    residual_m : numpy.ndarray
        Trace position minus the map of each matched mast, in table metres [m].
    trace_std_m : numpy.ndarray
        Each trace position's standard error, in table metres [m].
    n_parameters : int
        Coefficients of the map fitted to these masts.
    prior_std_m : float
        The configured accuracy [m].

    Returns
    -------
    float
        The table's accuracy [m].
    """
    r = np.asarray(residual_m, dtype=float)
    v = np.asarray(trace_std_m, dtype=float) ** 2
    ok = np.isfinite(r) & np.isfinite(v)
    n = int(ok.sum())
    if n <= n_parameters:
        return float(prior_std_m)
    variance = max(float(np.sum(r[ok] ** 2)) / (n - n_parameters) - float(np.mean(v[ok])), 0.0)
    return float(np.sqrt((PRIOR_MASTS * prior_std_m ** 2 + n * variance) / (PRIOR_MASTS + n)))
