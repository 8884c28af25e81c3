"""The maintenance stage of one span type: prior from s_opt, noise, posterior per span, the list.

Inputs are the identification's: its corrected W (averaged over the runs of each span), its
identified laws (``s_opt.csv``) and the noise its likelihood used; the correction's model-error
budget, when measured, widens each span's noise by its systematic (a shift shared by the spans
of a run is, for one span's posterior, an error like any other).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..config import Catenary, SpanType
from ..dropper_table import nominal_dropper_lengths
from ..errors import InputError
from ..fast import SAMPLING_DEGREE, FastSpanModel
from ..identification.band import band_abscissae
from ..identification.design import default_inputs
from ..identification.data import CorrectedData, span_places
from ..identification.settings import IdentificationSettings
from ..model_error.propagation import SpanShifts
from .population import PopulationBands, population_bands
from .posterior import span_posteriors
from .prior import SpanPrior, messenger_tension_range_n, output_names
from .settings import MaintenanceSettings, tolerance_limits

__all__ = ["LIST_COLUMNS", "MaintenanceRun", "POSTERIOR_COLUMNS", "maintenance_list", "noise_covariances",
           "prior_from_s_opt", "run_maintenance"]

#: Columns of ``posterior.parquet``, one row per span and input (and dropper force).
POSTERIOR_COLUMNS = ("span_id", "input", "mean", "q05", "q95", "p_out_of_tolerance", "nominal", "lower", "upper",
                     "section_id", "start_chainage_m", "end_chainage_m", "effective_samples", "status")
#: Columns of ``maintenance.csv``: the listed spans and inputs, most likely out first.
LIST_COLUMNS = ("span_id", "section_id", "start_chainage_m", "end_chainage_m", "input", "p_out_of_tolerance",
                "nominal", "mean", "q05", "q95", "deviation", "action", "status")


def prior_from_s_opt(span_type: SpanType, catenary: Catenary, s_opt: pd.DataFrame,
                     identification: IdentificationSettings, *, fault_probability: float = 0.0,
                     fault_std_m: float = 0.03, law_uncertainty: bool = False,
                     source: str = "s_opt.csv") -> SpanPrior:
    """The identified laws (``parameter``, ``mu``, ``sigma`` rows of s_opt) with the droppers'
    fault component, and the identification's fast model (same neighbours, T_MW range over the
    law's ±8 normal scores). With ``law_uncertainty``, each μ and σ carries its total standard
    uncertainty: the standard error and the model-error budget's systematic in quadrature
    (``mu_se``, ``mu_systematic``, ``sigma_se``, ``sigma_systematic``; a blank one counts 0 — a
    σ on the boundary, or a singular information, has no standard error to carry).

    Raises
    ------
    InputError
        A parameter of the span type missing from ``s_opt`` or a non-positive μ or σ.
    """
    names = [r.name for r in default_inputs(span_type, catenary)]
    table = s_opt.set_index("parameter")
    missing = [n for n in names if n not in table.index]
    if missing:
        raise InputError(f"{source}: parameter(s) {', '.join(missing)} missing; expected one row per input of "
                         f"span type {span_type.name} ({names[0]} … {names[-1]})")
    means = table.loc[names, "mu"].to_numpy(dtype=float)
    sigmas = table.loc[names, "sigma"].to_numpy(dtype=float)
    bad = [n for n, m, s in zip(names, means, sigmas) if not (np.isfinite(m) and np.isfinite(s) and m > 0 and s > 0)]
    if bad:
        raise InputError(f"{source}: parameter(s) {', '.join(bad)}: expected a positive finite mu and sigma")
    model = FastSpanModel(span_type, catenary, messenger_tension_bounds_n=messenger_tension_range_n(means[-2],
                                                                                                     sigmas[-2]),
                          degree=SAMPLING_DEGREE, neighbours=identification.neighbours)
    u_mu = u_sigma = None
    if law_uncertainty:
        def total(kind):
            parts = [table.loc[names, c].to_numpy(dtype=float) for c in (f"{kind}_se", f"{kind}_systematic")
                     if c in table.columns]
            return np.sqrt(sum(np.nan_to_num(p) ** 2 for p in parts)) if parts else np.zeros(len(names))
        u_mu, u_sigma = total("mu"), total("sigma")
    return SpanPrior(model, means, sigmas, identification.system_height_mode, fault_probability, fault_std_m,
                     u_mu, u_sigma)


def noise_covariances(n_droppers: int, n_runs: np.ndarray, one_run_m2: np.ndarray | None, settings: MaintenanceSettings,
                      w_shifts: SpanShifts | None = None) -> tuple[np.ndarray, str]:
    """Covariance of each span's W error (K, n, n) [m²] and what it holds, in words.

    One run's error is the identification's (the repeatability's R, or its assumed σ² I), else
    ``settings.measurement_noise_m``² I; a span averaged over k runs carries 1/k of it. The
    budget's sources add ``Σ_j b_j b_jᵀ`` (``b_j`` the span's shift per standard uncertainty).
    """
    runs = np.asarray(n_runs, dtype=float)
    if one_run_m2 is None:
        base = settings.measurement_noise_m**2 * np.eye(n_droppers)
        what = f"{1e3 * settings.measurement_noise_m:.2f} mm per dropper (maintenance.measurement_noise_m)"
    else:
        base = np.asarray(one_run_m2, dtype=float)
        what = f"{1e3 * np.sqrt(np.mean(np.diag(base))):.2f} mm RMS per run (the identification's)"
    cov = base[None] / runs[:, None, None]
    if w_shifts is not None and w_shifts.w_m:
        for b in w_shifts.w_m.values():
            b = np.asarray(b, dtype=float)
            cov = cov + b[:, :, None] * b[:, None, :]
        what += f" + the model-error budget ({', '.join(w_shifts.w_m)})"
    return cov, what


@dataclass
class MaintenanceRun:
    """Outputs of :func:`run_maintenance`: ``posterior`` (:data:`POSTERIOR_COLUMNS`), ``listed``
    (:data:`LIST_COLUMNS`), the noise in words, the wall time [s] and the population's bands
    (None when ``band_draws_per_span`` is 0)."""

    posterior: pd.DataFrame
    listed: pd.DataFrame
    noise: str
    time_s: float
    bands: PopulationBands | None = None


def run_maintenance(span_type: SpanType, catenary: Catenary, data: CorrectedData, corrected: pd.DataFrame,
                    s_opt: pd.DataFrame, identification: IdentificationSettings, settings: MaintenanceSettings, *,
                    one_run_m2: np.ndarray | None = None, w_shifts: SpanShifts | None = None) -> MaintenanceRun:
    """Posterior per span and input, and the maintenance list, for one span type.

    Parameters
    ----------
    data : CorrectedData
        The identification's spans (:func:`~catenary.identification.data.read_corrected`).
    corrected : pandas.DataFrame
        The correction's table (where each span lies: ``section_id``, ``start_chainage_m``,
        ``end_chainage_m``).
    s_opt : pandas.DataFrame
        The identified laws.
    one_run_m2 : numpy.ndarray, optional
        Covariance of one run's W error that the identification used (None: it used none).
    w_shifts : SpanShifts, optional
        The correction's model-error budget per span.
    """
    t0 = time.perf_counter()
    prior = prior_from_s_opt(span_type, catenary, s_opt, identification,
                             fault_probability=settings.fault_probability, fault_std_m=settings.fault_std_m,
                             law_uncertainty=settings.law_uncertainty)
    n = span_type.n_droppers
    n_runs = np.ones(data.w_m.shape[0]) if data.n_runs is None else data.n_runs
    cov, what = noise_covariances(n, n_runs, one_run_m2, settings, w_shifts)
    nominal_inputs = np.array([r.mean for r in default_inputs(span_type, catenary)])
    if prior.system_height_mode == "independent":
        nominal_inputs = np.append(nominal_inputs, nominal_inputs[-1])
    nominal_inputs = np.r_[nominal_inputs, nominal_dropper_lengths(span_type, catenary).dropper_force_n]
    lower, upper = tolerance_limits(output_names(n, prior.system_height_mode), nominal_inputs, settings)
    post = span_posteriors(prior, data.w_m, cov, lower=lower, upper=upper, n_samples=settings.n_samples,
                           seed=settings.seed, n_draws=settings.band_draws_per_span)
    bands = None
    if settings.band_draws_per_span > 0:
        bands = population_bands(prior, post.draws_z, data.w_m, cov,
                                 x_m=band_abscissae(span_type, identification.band_n_points),
                                 level=identification.band_level, n_prior_samples=identification.band_n_samples,
                                 design_method=identification.design, seed=identification.seed + 1)
    places = span_places(corrected, data.span_id)
    k, d = post.mean.shape
    table = pd.DataFrame({
        "span_id": np.repeat(data.span_id.astype(str), d),
        "input": np.tile(post.names, k),
        "mean": post.mean.ravel(), "q05": post.q05.ravel(), "q95": post.q95.ravel(),
        "p_out_of_tolerance": post.p_outside.ravel(),
        "nominal": np.tile(nominal_inputs, k), "lower": np.tile(lower, k), "upper": np.tile(upper, k),
        "section_id": np.repeat(places["section_id"].to_numpy(), d),
        "start_chainage_m": np.repeat(places["start_chainage_m"].to_numpy(dtype=float), d),
        "end_chainage_m": np.repeat(places["end_chainage_m"].to_numpy(dtype=float), d),
        "effective_samples": np.repeat(post.effective_samples, d),
        "status": np.repeat(post.status, d),
    }, columns=list(POSTERIOR_COLUMNS))
    return MaintenanceRun(table, maintenance_list(table, settings.threshold), what, time.perf_counter() - t0, bands)


def _action(row) -> str:
    if row.input.endswith("_force_n"):
        return "unloaded dropper (slack or nearly): check it, shorten"
    if row.input.startswith("dropper_"):
        # A dropper longer than nominal lowers the CW: shorten it (and lengthen a short one).
        return "shorten" if row.deviation > 0 else "lengthen"
    if row.input == "messenger_tension_n":
        return "inspect tensioning device (T_MW " + ("high" if row.deviation > 0 else "low") + ")"
    return "check system height (" + ("high" if row.deviation > 0 else "low") + ")"


def maintenance_list(posterior: pd.DataFrame, threshold: float) -> pd.DataFrame:
    """The spans' inputs whose probability of lying outside tolerance exceeds ``threshold``,
    most likely first (ties by chainage), with the deviation of the posterior mean from nominal
    and the action it calls for."""
    rows = posterior[posterior["p_out_of_tolerance"] > threshold].copy()
    rows["deviation"] = rows["mean"] - rows["nominal"]
    rows["action"] = [_action(r) for r in rows.itertuples()] if len(rows) else []
    rows = rows.sort_values(["p_out_of_tolerance", "start_chainage_m"], ascending=[False, True], kind="stable")
    return rows.reindex(columns=list(LIST_COLUMNS)).reset_index(drop=True)
