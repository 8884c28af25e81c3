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

from catenary.physics.config import Catenary, SpanType
from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.physics.fast import SAMPLING_DEGREE, FastSpanModel
from catenary.plumbing.errors import InputError
from catenary.stages.identification.band import band_abscissae
from catenary.stages.identification.data import CorrectedData, span_places
from catenary.stages.identification.design import default_inputs
from catenary.stages.identification.propagation import SpanShifts
from catenary.stages.identification.settings import IdentificationSettings
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
                    one_run_m2: np.ndarray | None = None, w_shifts: SpanShifts | None = None,
                    spans_check: pd.DataFrame | None = None,
                    sections_check: pd.DataFrame | None = None, workers: int = 1) -> MaintenanceRun:
    """Posterior per span and input, and the maintenance list, for one span type.

    Parameters
    ----------
    data : CorrectedData
        The identification's spans (:func:`~catenary.stages.identification.data.read_corrected`).
    corrected : pandas.DataFrame
        The correction's table (where each span lies: ``section_id``, ``start_chainage_m``,
        ``end_chainage_m``).
    s_opt : pandas.DataFrame
        The identified laws.
    one_run_m2 : numpy.ndarray, optional
        Covariance of one run's W error that the identification used (None: it used none).
    w_shifts : SpanShifts, optional
        The correction's model-error budget per span.
    spans_check, sections_check : pandas.DataFrame, optional
        The diagnosis' per-span check (``diagnosis/spans.csv``, ``sections.csv``): a section
        whose spans share a T_MW offset has its spans' posteriors drawn from the laws with that
        offset (its device, not their droppers, is what is wrong), and the list acts on what the
        model does not explain (:func:`maintenance_list`).
    workers : int
        Processes over blocks of spans (the posteriors and the band's coverages); the result does
        not depend on them.
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
                           seed=settings.seed, n_draws=settings.band_draws_per_span, workers=workers)
    for section, offset in tension_offsets(sections_check).items():
        rows = np.flatnonzero(span_places(corrected, data.span_id)["section_id"].to_numpy() == section)
        if rows.size == 0:
            continue
        shifted = s_opt.copy()
        shifted.loc[shifted["parameter"] == "messenger_tension_n", "mu"] += offset
        group = span_posteriors(prior_from_s_opt(span_type, catenary, shifted, identification,
                                                 fault_probability=settings.fault_probability,
                                                 fault_std_m=settings.fault_std_m,
                                                 law_uncertainty=settings.law_uncertainty),
                                data.w_m[rows], cov[rows], lower=lower, upper=upper, n_samples=settings.n_samples,
                                seed=settings.seed, n_draws=settings.band_draws_per_span, workers=workers)
        post = post.with_rows(rows, group)
    bands = None
    if settings.band_draws_per_span > 0:
        bands = population_bands(prior, post.draws_z, data.w_m, cov,
                                 x_m=band_abscissae(span_type, identification.band_n_points),
                                 level=identification.band_level, n_prior_samples=identification.band_n_samples,
                                 design_method=identification.design, seed=identification.seed + 1,
                                 workers=workers)
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
    listed = maintenance_list(table, settings.threshold, spans_check, sections_check)
    return MaintenanceRun(table, listed, what, time.perf_counter() - t0, bands)


def _action(row) -> str:
    if row.input.endswith("_force_n"):
        return "unloaded dropper (slack or nearly): check it, shorten"
    if row.input.startswith("dropper_"):
        # A dropper longer than nominal lowers the CW: shorten it (and lengthen a short one).
        return "shorten" if row.deviation > 0 else "lengthen"
    if row.input == "messenger_tension_n":
        return "inspect tensioning device (T_MW " + ("high" if row.deviation > 0 else "low") + ")"
    return "check system height (" + ("high" if row.deviation > 0 else "low") + ")"


def tension_offsets(sections_check: pd.DataFrame | None) -> dict[str, float]:
    """The sections whose spans depart together as a T_MW offset (``sections.csv``), with the
    offset [N]."""
    if sections_check is None or sections_check.empty:
        return {}
    rows = sections_check[sections_check["unexplained"].astype(str).str.lower().isin(["true", "1"])
                          & sections_check["tension_offset"].astype(str).str.lower().isin(["true", "1"])]
    return {str(r.section_id): float(r.messenger_tension_offset_n) for r in rows.itertuples()}


def _inspections(spans_check: pd.DataFrame, sections_check: pd.DataFrame | None, places: pd.DataFrame) -> pd.DataFrame:
    """One row per span the model does not explain alone (inspect the span where its profile
    departs, or what an effect of one's own found there) and per section whose spans depart
    together (its tensioning device with its T_MW offset, or the section)."""
    rows = []
    flag = spans_check["unexplained"].astype(str).str.lower().isin(["true", "1"])
    by = spans_check["explained_by"].fillna("").astype(str) if "explained_by" in spans_check else ""
    alone = spans_check[(flag | (by != "")) & (spans_check["group"].fillna("").astype(str) == "")]
    for r in alone.itertuples():
        where = (f"at chainage {r.peak_chainage_m:.1f} m ({r.peak_size_mm:+.1f} mm; a point load of "
                 f"{r.peak_load_n:.0f} N would bend the CW so)" if np.isfinite(r.peak_chainage_m)
                 else "at its droppers")
        own = getattr(r, "explained_by", "")
        if own:
            rows.append({"span_id": r.span_id, "section_id": r.section_id, "start_chainage_m": r.start_chainage_m,
                         "end_chainage_m": r.end_chainage_m, "input": "span", "p_out_of_tolerance": np.nan,
                         "action": f"inspect span: {own} explains its profile", "status": "explained by an effect"})
            continue
        what = "its profile departs from the model"
        rows.append({"span_id": r.span_id, "section_id": r.section_id, "start_chainage_m": r.start_chainage_m,
                     "end_chainage_m": r.end_chainage_m, "input": "span", "p_out_of_tolerance": np.nan,
                     "action": f"inspect span: {what} {where}", "status": "unexplained"})
    offsets = tension_offsets(sections_check)
    if sections_check is not None and not sections_check.empty:
        groups = sections_check[sections_check["unexplained"].astype(str).str.lower().isin(["true", "1"])]
        for g in groups.itertuples():
            inside = places[places["section_id"].astype(str) == str(g.section_id)]
            start, end = inside["start_chainage_m"].min(), inside["end_chainage_m"].max()
            if str(g.section_id) in offsets:
                action = (f"inspect the tensioning device of section {g.section_id}: its {g.n_spans} spans share a "
                          f"T_MW offset of {g.messenger_tension_offset_n:+.0f} ± {g.messenger_tension_offset_se_n:.0f} "
                          "N from the line's")
                extra = {"input": "messenger_tension_n", "deviation": g.messenger_tension_offset_n}
            else:
                action = f"inspect section {g.section_id}: its {g.n_spans} spans depart from the model together"
                extra = {"input": "section"}
            rows.append({"span_id": f"section {g.section_id}", "section_id": g.section_id, "start_chainage_m": start,
                         "end_chainage_m": end, "p_out_of_tolerance": np.nan, "action": action, "status": "unexplained",
                         **extra})
    return pd.DataFrame(rows, columns=list(LIST_COLUMNS))


def maintenance_list(posterior: pd.DataFrame, threshold: float, spans_check: pd.DataFrame | None = None,
                     sections_check: pd.DataFrame | None = None) -> pd.DataFrame:
    """The spans' inputs whose probability of lying outside tolerance exceeds ``threshold``,
    most likely first (ties by chainage), with the deviation of the posterior mean from nominal
    and the action it calls for.

    With the diagnosis' per-span check, no crew is sent to adjust a dropper or a tension the model
    cannot vouch for: a span the final model does not explain alone (or explains only with a local
    effect of one's own) gets one row, ``inspect span``, with where its profile departs, instead of
    its inputs' rows; a section whose spans depart together gets one row for its tensioning device
    (with the T_MW offset its spans share; their tension rows dropped, their dropper rows drawn
    from the laws with that offset) or for the section (its spans' rows dropped). These rows come
    first, their ``p_out_of_tolerance`` empty and ``status`` ``unexplained``."""
    rows = posterior[posterior["p_out_of_tolerance"] > threshold].copy()
    rows["deviation"] = rows["mean"] - rows["nominal"]
    rows["action"] = [_action(r) for r in rows.itertuples()] if len(rows) else []
    rows = rows.sort_values(["p_out_of_tolerance", "start_chainage_m"], ascending=[False, True], kind="stable")
    rows = rows.reindex(columns=list(LIST_COLUMNS)).reset_index(drop=True)
    if spans_check is None:
        return rows
    flag = spans_check["unexplained"].astype(str).str.lower().isin(["true", "1"])
    by = spans_check["explained_by"].fillna("").astype(str) if "explained_by" in spans_check else ""
    group = spans_check["group"].fillna("").astype(str)
    offsets = tension_offsets(sections_check)
    drop_all = set(spans_check.loc[(flag | (by != "")) & ((group == "") | ~group.isin(list(offsets))), "span_id"])
    drop_tension = set(spans_check.loc[group.isin(list(offsets)), "span_id"])
    keep = ~rows["span_id"].isin(drop_all) & ~(rows["span_id"].isin(drop_tension)
                                              & (rows["input"] == "messenger_tension_n"))
    places = posterior.drop_duplicates("span_id")[["span_id", "section_id", "start_chainage_m", "end_chainage_m"]]
    inspections = _inspections(spans_check, sections_check, places).sort_values("start_chainage_m", kind="stable")
    return pd.concat([inspections, rows[keep]], ignore_index=True).reindex(columns=list(LIST_COLUMNS))
