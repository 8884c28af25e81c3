"""Dynamic runs over random sections: the criteria of each replicate at each speed.

For every replicate of a batch, the section of :func:`.draws.draw_section` is assembled once
(:class:`~catenary.physics.dynamics.CatenaryDynamics`) and run over at every speed by the pantograph
(:func:`~catenary.physics.dynamics.run_pantograph`, run-in before the first analysis mast and run-out
after the last, simulated until one span after the window:
:func:`~catenary.physics.contact_statistics.analysis_stop_m`); the statistics over the central spans are
those of the dynamics rule (:func:`~catenary.physics.contact_statistics.contact_statistics`), and the limits of
:class:`.settings.Limits` say which criteria the section violates. Each row also carries a
summary of what was drawn: the static geometry in the analysis window
(:func:`static_features`).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from catenary.physics.config import Catenary, SpanType
from catenary.physics.contact_statistics import analysis_stop_m, contact_statistics
from catenary.physics.dynamics import CatenaryDynamics, run_pantograph
from catenary.physics.pantograph import Pantograph
from catenary.physics.section import Section
from catenary.plumbing.progress import Progress
from .draws import draw_section, replicate_seeds
from .sensitivity import sobol_seeds
from .laws import SectionLaws
from .settings import ContactForceSettings, Limits, tolerance_replicates

__all__ = ["CRITERIA", "FEATURES", "VIOLATIONS", "run_batch", "run_case_batch", "run_section", "run_sobol_batch",
           "section_state", "static_features", "violations"]

#: Criteria of a run (EN 50318 / EN 50367), in the units of their names.
CRITERIA = ("mean_force_n", "std_force_n", "statistical_max_n", "statistical_min_n", "max_force_n", "min_force_n",
            "max_support_uplift_m", "contact_loss_percent")
#: Limit violations of a run (:func:`violations`).
VIOLATIONS = ("mean_force_above_target", "std_above_limit", "statistical_min_below_limit", "uplift_above_limit",
              "contact_lost")
#: Static features of a section in its analysis window (:func:`static_features`).
FEATURES = ("height_rms_mm", "slope_rms_mrad", "w_rms_mm", "messenger_tension_mean_n", "messenger_tension_std_n",
            "system_height_std_mm", "dropper_length_rms_mm")


def violations(row: dict, speed_kmh: float, limits: Limits) -> dict[str, bool]:
    """Which limits a run's criteria violate."""
    fm, sd = row["mean_force_n"], row["std_force_n"]
    return {"mean_force_above_target": bool(fm > limits.mean_force_target_n(speed_kmh)),
            "std_above_limit": bool(sd > limits.max_std_fraction * fm),
            "statistical_min_below_limit": bool(fm - 3.0 * sd <= limits.min_statistical_n),
            "uplift_above_limit": bool(row["max_support_uplift_m"] > limits.max_uplift_m),
            "contact_lost": bool(row["contact_loss_percent"] > 0.0)}


def static_features(section: Section, height_m: np.ndarray, nominal_height_m: np.ndarray, w_m: np.ndarray,
                    nominal_w_m: np.ndarray, window: tuple[float, float], nominal_lengths_m: np.ndarray) -> dict[str, float]:
    """Summary of a section's static geometry in the analysis window.

    ``height_m``, ``w_m`` and their ``nominal_`` twins are the static CW heights and W at the
    droppers of the section and of the nominal section [m]. Heights are what the pantograph
    rides on: their deviation from the nominal section (RMS), its slope between consecutive
    droppers (RMS), W's deviation (RMS), and summaries of the drawn inputs.
    """
    x = section.dropper_chainage_m
    inside = (x >= window[0]) & (x <= window[1])
    dev = (height_m - nominal_height_m)[inside]
    slope = np.diff(dev) / np.diff(x[inside])
    w_dev = (w_m - nominal_w_m)[inside]
    spans = np.unique(section.dropper_span[inside])
    masts = (section.mast_chainage_m >= window[0]) & (section.mast_chainage_m <= window[1])
    t = section.messenger_tension_by_span_n[spans]
    n_d = nominal_lengths_m.size
    lengths = section.dropper_lengths_m.reshape(section.n_spans, n_d)[spans] - nominal_lengths_m
    return {"height_rms_mm": 1e3 * float(np.sqrt(np.mean(dev**2))),
            "slope_rms_mrad": 1e3 * float(np.sqrt(np.mean(slope**2))),
            "w_rms_mm": 1e3 * float(np.sqrt(np.mean(w_dev**2))),
            "messenger_tension_mean_n": float(t.mean()), "messenger_tension_std_n": float(t.std()),
            "system_height_std_mm": 1e3 * float(section.system_heights_m[masts].std()),
            "dropper_length_rms_mm": 1e3 * float(np.sqrt(np.mean(lengths**2)))}


def section_state(ops: CatenaryDynamics) -> tuple[np.ndarray, np.ndarray]:
    """Static CW heights and W at the droppers of an assembled section [m]."""
    state = ops.gravity_state
    return state.cw_height_m[ops.mesh.dropper_nodes], state.dropper_deflection_m()


def run_section(section: Section, catenary: Catenary, pantograph: Pantograph, settings: ContactForceSettings,
                speeds_kmh) -> tuple[CatenaryDynamics, list[dict]]:
    """Criteria of ``section`` at each speed (and the assembled operators)."""
    ops = CatenaryDynamics(section, catenary)
    masts = section.mast_chainage_m
    first, last = settings.analysis_masts
    rows = []
    stop = analysis_stop_m(masts, last)             # no step after the window's last span is analysed
    for speed in speeds_kmh:
        run = run_pantograph(ops, pantograph, speed / 3.6, stop_m=stop)
        stats = contact_statistics(run, masts[first], masts[last], masts, cutoff_hz=settings.filter_cutoff_hz)
        row = {"speed_kmh": float(speed), **stats.as_dict()}
        row.update(violations(row, speed, settings.limits))
        rows.append(row)
    return ops, rows


def run_batch(laws: SectionLaws, nominal: Section, span_type: SpanType, catenary: Catenary, pantograph: Pantograph,
              settings: ContactForceSettings, replicates, *, case: str, speeds_kmh, log=None) -> pd.DataFrame:
    """One row per replicate of ``replicates`` (indices) and speed: criteria, violations, features."""
    nominal_height, nominal_w = section_state(CatenaryDynamics(nominal, catenary))
    nominal_lengths = nominal.dropper_lengths_m[:span_type.n_droppers]
    masts = nominal.mast_chainage_m
    window = (masts[settings.analysis_masts[0]], masts[settings.analysis_masts[1]])
    rows = []
    replicates = list(replicates)
    progress = Progress(log, f"{case} replicates", len(replicates), "replicates", every_s=0.0)
    for k, r in enumerate(replicates):
        section, _ = draw_section(laws, span_type, catenary, settings.n_spans, replicate_seeds(settings.seed, r, laws))
        ops, runs = run_section(section, catenary, pantograph, settings, speeds_kmh)
        height, w = section_state(ops)
        features = static_features(section, height, nominal_height, w, nominal_w, window, nominal_lengths)
        slack = int(ops.gravity_state.dropper_slack.sum())
        for row in runs:
            rows.append({"case": case, "replicate": int(r), **row, **features, "static_slack_droppers": slack})
        progress.update(k + 1, f"replicate {r}: σ_F " + ", ".join(f"{x['std_force_n']:.1f}" for x in runs) + " N")
    return pd.DataFrame(rows)


def run_case_batch(laws: SectionLaws, nominal: Section, span_type: SpanType, catenary: Catenary,
                   pantograph: Pantograph, settings: ContactForceSettings, replicates, *, case: str, speeds_kmh,
                   log=None) -> pd.DataFrame:
    """:func:`run_batch` for a batch of the ``identified`` case (the identified laws) or of the
    ``tolerance`` case, whose indices run each combination's laws (:meth:`SectionLaws.with_spreads`
    at the combination's dropper and T_MW σ) and keep its name as their ``case``."""
    if case == "identified":
        runs = [(case, laws, list(replicates))]
    elif case == "tolerance":
        runs = [(name, laws.with_spreads(dropper_sigma_m=dropper_sigma_m, messenger_tension_sigma_n=sigma_n), indices)
                for (name, dropper_sigma_m, sigma_n), indices in tolerance_replicates(settings, replicates)]
    else:
        raise ValueError(f"case: expected 'identified' or 'tolerance', got {case!r}")
    tables = []
    for name, case_laws, indices in runs:
        if log is not None:
            log.info("%s: replicates %s; laws %s", name, indices, case_laws.summary())
        tables.append(run_batch(case_laws, nominal, span_type, catenary, pantograph, settings, indices, case=name,
                                speeds_kmh=speeds_kmh, log=log))
    return pd.concat(tables, ignore_index=True)


def run_sobol_batch(laws: SectionLaws, span_type: SpanType, catenary: Catenary, pantograph: Pantograph,
                    settings: ContactForceSettings, rows, design: np.ndarray, speed_kmh: float,
                    log=None) -> pd.DataFrame:
    """Criteria of the sections of the pick-freeze design's ``rows`` (:mod:`.sensitivity`)."""
    out = []
    rows = list(rows)
    progress = Progress(log, "Sobol design rows", len(rows), "rows", every_s=0.0)
    for n, k in enumerate(rows):
        section, _ = draw_section(laws, span_type, catenary, settings.n_spans, sobol_seeds(laws, settings, design[k]))
        _, runs = run_section(section, catenary, pantograph, settings, (speed_kmh,))
        out.append({"case": "sobol", "replicate": int(k), **runs[0]})
        progress.update(n + 1, f"design row {k}: σ_F {runs[0]['std_force_n']:.2f} N")
    return pd.DataFrame(out)
