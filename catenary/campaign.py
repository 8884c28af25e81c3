"""The virtual measurement campaign: simulate the recording car over a drawn line.

For each section of a :class:`~catenary.truth.Line`, the section model (its true dropper
lengths, support heights, system heights and per-span tensions) is solved statically (the
true static W) and run over by the measuring pantograph at the true measuring force (the true
dynamic W and the clean recording). The sensor then adds Gaussian noise, quantisation,
drop-outs (NaN runs) and spikes. Each section draws its sensor noise from its own seeded
stream, so sections can be simulated in parallel and the result does not depend on the order.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pyarrow as pa

from .config import Catenary
from .measuring import measuring_pass
from .pantograph import Pantograph
from .section import Section
from .static import solve_static
from .truth import Line, Measurement


def section_model(line: Line, k: int, catenary: Catenary) -> tuple[Section, np.ndarray]:
    """The true model of section ``k`` of ``line`` and the indices of its spans in the line."""
    spans = np.flatnonzero(line.params.section_index == k)
    left = line.spans["left_mast"][spans]
    masts = np.concatenate([left, [left[-1] + 1]])
    x = line.masts["chainage_m"][masts]
    span_type = line.spans["span_type"][spans[0]]
    lengths = line.params.dropper_lengths_m[spans]
    n_d = int(np.sum(~np.isnan(lengths[0])))
    return Section(
        span_lengths_m=np.diff(x),
        dropper_span=np.repeat(np.arange(spans.size), n_d),
        dropper_x_m=np.tile(_positions(catenary, span_type), spans.size),
        dropper_lengths_m=lengths[:, :n_d].ravel(),
        cw_support_heights_m=line.masts["cw_height_m"][masts],
        system_heights_m=line.masts["system_height_m"][masts],
        contact_tension_n=line.params.contact_tension_n[spans],
        messenger_tension_n=line.params.messenger_tension_n[spans],
        dropper_offset_m=np.repeat(line.params.cw_offset_m[spans], n_d),
        cw_mass_factor=1.0 - line.params.cw_wear_fraction[spans],
    ), spans


def _positions(catenary: Catenary, span_type: str) -> np.ndarray:
    return catenary.span_type(span_type).dropper_positions_m


def deflections_from_heights(section: Section, heights_at_droppers: np.ndarray, heights_at_masts: np.ndarray) -> np.ndarray:
    """W per span: heights at droppers minus the chord through the heights at the masts,
    shape (n_spans, n_droppers_per_span) [m]."""
    return (heights_at_droppers - section.chord_at_droppers(heights_at_masts)).reshape(section.n_spans, -1)


def simulate_section(line: Line, k: int, catenary: Catenary, pantograph: Pantograph, measurement: Measurement,
                     seed: int) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Recording samples and truth rows of section ``k``.

    Returns
    -------
    recording : DataFrame
        ``chainage_m`` (line chainage), ``height_m`` (with sensor effects), ``speed_kmh``,
        ``force_n`` (the declared force), ``run_id``.
    truth : DataFrame
        One row per span: ids, type, every true parameter, ``static_w*_m`` and ``dynamic_w*_m``.
    """
    section, spans = section_model(line, k, catenary)
    offset = line.masts["chainage_m"][line.spans["left_mast"][spans[0]]]
    static_w = solve_static(section, catenary).dropper_deflection_m().reshape(section.n_spans, -1)

    masts_x = section.mast_chainage_m
    grid = np.arange(masts_x[0], masts_x[-1] + 1e-9, measurement.sampling_step_m)
    exact = np.concatenate([section.dropper_chainage_m, masts_x])
    force = line.params.measuring_force_n
    heights = measuring_pass(section, catenary, pantograph.with_static_force(force),
                             speed_m_s=measurement.speed_kmh / 3.6, mode=measurement.mode,
                             time_step_s=measurement.time_step_s, chainage_m=np.concatenate([grid, exact])).height_m
    clean, at_exact = heights[:grid.size], heights[grid.size:]
    n_d = section.dropper_x_m.size
    dynamic_w = deflections_from_heights(section, at_exact[:n_d], at_exact[n_d:])

    rng = np.random.default_rng([line_seed(line), seed, k])
    recorded = sensor(grid, clean, measurement, rng)
    recording = pd.DataFrame({"chainage_m": grid + offset, "height_m": recorded,
                              "speed_kmh": np.full(grid.size, measurement.speed_kmh),
                              "force_n": np.full(grid.size, measurement.force_n),
                              "run_id": np.full(grid.size, "campaign")})
    truth = _truth_rows(line, spans, section, offset, static_w, dynamic_w, force)
    return recording, truth


def static_truth(line: Line, catenary: Catenary) -> pd.DataFrame:
    """Truth rows of every span of ``line`` with its static W only (no measuring pass).

    Each section is solved statically as the campaign does (wires continuous over the masts,
    a mast's ΔH shared by its two spans); the rows are those of :func:`simulate_section`'s
    truth without the ``dynamic_w*_m`` columns. This is what a perfect correction would hand
    over: W-level replicates of a campaign for statistical checks of the identification.
    """
    parts = []
    for k in range(len(line.sections)):
        section, spans = section_model(line, k, catenary)
        offset = line.masts["chainage_m"][line.spans["left_mast"][spans[0]]]
        static_w = solve_static(section, catenary).dropper_deflection_m().reshape(section.n_spans, -1)
        parts.append(_truth_rows(line, spans, section, offset, static_w, None, line.params.measuring_force_n))
    return pd.concat(parts, ignore_index=True)


def line_seed(line: Line) -> int:
    """A stable integer identifying the drawn line (for the sensor streams)."""
    return int(np.round(line.masts["chainage_m"].sum() * 1e3)) % (2**31)


def sensor(chainage_m: np.ndarray, height_m: np.ndarray, m: Measurement, rng: np.random.Generator) -> np.ndarray:
    """Recorded heights: noise, quantisation, drop-outs (NaN runs) and single-sample spikes."""
    h = height_m + m.noise_std_m * rng.standard_normal(height_m.size)
    if m.quantisation_m > 0:
        h = m.quantisation_m * np.round(h / m.quantisation_m)
    length_km = (chainage_m[-1] - chainage_m[0]) / 1e3
    for start in rng.uniform(chainage_m[0], chainage_m[-1], rng.poisson(m.dropout_rate_per_km * length_km)):
        h[(chainage_m >= start) & (chainage_m < start + m.dropout_length_m)] = np.nan
    n_spikes = rng.poisson(m.spike_rate_per_km * length_km)
    where = rng.integers(0, h.size, n_spikes)
    h[where] += m.spike_height_m * rng.choice([-1.0, 1.0], n_spikes)
    return h


def _truth_rows(line, spans, section, offset, static_w, dynamic_w, force) -> pd.DataFrame:
    p = line.params
    left = line.spans["left_mast"][spans]
    rows = {
        "span_id": line.spans["span_id"][spans],
        "section_id": line.spans["section_id"][spans],
        "span_type": line.spans["span_type"][spans],
        "start_chainage_m": section.mast_chainage_m[:-1] + offset,
        "end_chainage_m": section.mast_chainage_m[1:] + offset,
        "length_m": section.span_lengths_m,
        "messenger_tension_n": p.messenger_tension_n[spans],
        "contact_tension_n": p.contact_tension_n[spans],
        "system_height_left_m": p.system_height_left_m[spans],
        "system_height_right_m": p.system_height_right_m[spans],
        "cw_height_left_m": line.masts["cw_height_m"][left],
        "cw_height_right_m": line.masts["cw_height_m"][left + 1],
        "creep_offset_m": p.creep_offset_m[spans],
        "cw_offset_m": p.cw_offset_m[spans],
        "cw_wear_fraction": p.cw_wear_fraction[spans],
        "measuring_force_n": np.full(spans.size, force),
    }
    n_d = static_w.shape[1]
    for i in range(n_d):
        rows[f"dropper_{i + 1}_length_m"] = p.dropper_lengths_m[spans, i]
    for i in range(n_d):
        rows[f"static_w{i + 1}_m"] = static_w[:, i]
    for i in range(n_d if dynamic_w is not None else 0):
        rows[f"dynamic_w{i + 1}_m"] = dynamic_w[:, i]
    return pd.DataFrame(rows)


def masts_table(line: Line) -> pd.DataFrame:
    """The masts file that catenary.recording reads (with span types and design CW heights)."""
    m = line.masts
    span_type = np.empty(m["mast_id"].size, dtype=object)
    span_type[line.spans["left_mast"]] = line.spans["span_type"]
    # the last mast of each section starts no span: give it its section's type
    last = np.flatnonzero(span_type == None)  # noqa: E711
    span_type[last] = span_type[last - 1]
    return pd.DataFrame({"mast_id": m["mast_id"], "chainage_m": m["chainage_m"], "section_id": m["section_id"],
                         "span_type": span_type.astype(str)})


def truth_schema(columns) -> pa.Schema:
    """Arrow schema of the truth table: identifiers as strings, every other column float64."""
    text = {"span_id", "section_id", "span_type"}
    return pa.schema([pa.field(c, pa.string() if c in text else pa.float64(), nullable=False) for c in columns])


def projection_round_trip(spans: pd.DataFrame, truth: pd.DataFrame) -> dict[str, float]:
    """Compare projected W with the truth's dynamic and static W of the same spans [m]."""
    merged = spans.merge(truth, on="span_id", suffixes=("", "_truth"))
    n_d = len([c for c in spans.columns if c.startswith("w") and c.endswith("_m")])
    w = merged[[f"w{i}_m" for i in range(1, n_d + 1)]].to_numpy()
    dyn = merged[[f"dynamic_w{i}_m" for i in range(1, n_d + 1)]].to_numpy()
    sta = merged[[f"static_w{i}_m" for i in range(1, n_d + 1)]].to_numpy()
    return {
        "n_spans": float(len(merged)),
        "rms_vs_dynamic_m": float(np.sqrt(np.mean((w - dyn) ** 2))),
        "max_abs_vs_dynamic_m": float(np.max(np.abs(w - dyn))) if len(merged) else float("nan"),
        "rms_vs_static_m": float(np.sqrt(np.mean((w - sta) ** 2))),
    }


def correction_round_trip(corrected: pd.DataFrame, spans: pd.DataFrame, truth: pd.DataFrame) -> dict[str, float]:
    """Corrected static W (converged spans) and the uncorrected projected W against the truth's
    static W of the same spans [m]: the correction's accuracy and the size of the correction.

    ``max_abs_mean_error_m`` and ``max_abs_mean_error_z`` look for a bias the RMS would hide: at
    each dropper the mean error over the spans, and that mean in units of its standard error
    (sample standard deviation / √n); the largest over the droppers. A correction with the
    wrong measuring force, for example, leaves a mid-span-heavy mean error.
    """
    ok = corrected[corrected["converged"]]
    n_d = len([c for c in ok.columns if c.startswith("w") and c.endswith("_m")])
    cols = [f"w{i}_m" for i in range(1, n_d + 1)]
    static = [f"static_w{i}_m" for i in range(1, n_d + 1)]
    merged = ok[["span_id"] + cols].merge(truth[["span_id"] + static], on="span_id")
    raw = spans[["span_id"] + cols].merge(truth[["span_id"] + static], on="span_id")
    error = merged[cols].to_numpy() - merged[static].to_numpy()
    raw_error = raw[cols].to_numpy() - raw[static].to_numpy()
    per_span = np.sqrt(np.mean(error ** 2, axis=1)) if len(merged) else np.zeros(0)
    if len(merged) > 1:
        mean_error = error.mean(axis=0)
        z = np.abs(mean_error) / (error.std(axis=0, ddof=1) / np.sqrt(len(merged)))
        bias_m, bias_z = float(np.max(np.abs(mean_error))), float(np.max(z))
    else:
        bias_m = bias_z = float("nan")
    return {
        "n_spans": float(len(corrected)),
        "n_converged": float(len(ok)),
        "rms_corrected_vs_static_m": float(np.sqrt(np.mean(error ** 2))) if len(merged) else float("nan"),
        "max_abs_corrected_vs_static_m": float(np.max(np.abs(error))) if len(merged) else float("nan"),
        "max_span_rms_corrected_vs_static_m": float(np.max(per_span)) if per_span.size else float("nan"),
        "max_abs_mean_error_m": bias_m,
        "max_abs_mean_error_z": bias_z,
        "rms_uncorrected_vs_static_m": float(np.sqrt(np.mean(raw_error ** 2))) if len(raw) else float("nan"),
    }


def realized_truth(truth: pd.DataFrame, span_ids) -> dict[str, tuple[float, float]]:
    """Sample mean and standard deviation (ddof 1) of the true inputs over the spans ``span_ids``.

    T_MW and every dropper length are per span; ΔH is per mast, so its figures are over the
    distinct masts of those spans (a mast shared by two spans counts once, identified by its
    chainage). Keys are the identification's input names (``messenger_tension_n``,
    ``system_height_m``, ``dropper_<i>_length_m``); values ``(mean, std)`` in SI units.
    """
    spans = truth[truth["span_id"].isin(list(span_ids))]
    masts = pd.concat([spans[["start_chainage_m", "system_height_left_m"]].set_axis(["chainage_m", "dh_m"], axis=1),
                       spans[["end_chainage_m", "system_height_right_m"]].set_axis(["chainage_m", "dh_m"], axis=1)])
    masts = masts.assign(chainage_m=masts["chainage_m"].round(6)).drop_duplicates("chainage_m")
    out = {"messenger_tension_n": (float(spans["messenger_tension_n"].mean()),
                                   float(spans["messenger_tension_n"].std(ddof=1))),
           "system_height_m": (float(masts["dh_m"].mean()), float(masts["dh_m"].std(ddof=1)))}
    for column in [c for c in truth.columns if c.startswith("dropper_") and c.endswith("_length_m")]:
        out[column] = (float(spans[column].mean()), float(spans[column].std(ddof=1)))
    return out


def identification_round_trip(s_opt: pd.DataFrame, corrected: pd.DataFrame, truth: pd.DataFrame) -> pd.DataFrame:
    """Identified laws against the realized truth of the spans they were identified from.

    Parameters
    ----------
    s_opt : pandas.DataFrame
        The identification's ``s_opt.csv`` (``parameter``, ``mu``, ``sigma``, ``mu_se``,
        ``sigma_se``, ``mu_fixed``, ``status``).
    corrected : pandas.DataFrame
        The span type's ``corrected.parquet``: its converged spans are those identified from.
    truth : pandas.DataFrame
        The campaign's truth table.

    Returns
    -------
    pandas.DataFrame
        One row per identified quantity (free means and σ): ``parameter``, ``statistic``
        (``mu`` or ``sigma``), ``estimate``, ``standard_error``, ``realized`` (sample mean or
        standard deviation over the spans used, :func:`realized_truth`), ``z`` =
        (estimate − realized) / standard_error, ``n_spans`` and the run's ``status``.
    """
    used = corrected.loc[corrected["converged"], "span_id"]
    realized = realized_truth(truth, used)
    rows = []
    for r in s_opt.itertuples(index=False):
        if r.parameter not in realized:
            continue
        stats = ([] if r.mu_fixed else [("mu", r.mu, r.mu_se, realized[r.parameter][0])])
        stats.append(("sigma", r.sigma, r.sigma_se, realized[r.parameter][1]))
        for statistic, estimate, se, true in stats:
            rows.append({"parameter": r.parameter, "statistic": statistic, "estimate": float(estimate),
                         "standard_error": float(se), "realized": true,
                         "z": (float(estimate) - true) / float(se) if se > 0 else float("nan"),
                         "n_spans": int(len(used)), "status": r.status})
    return pd.DataFrame(rows, columns=["parameter", "statistic", "estimate", "standard_error", "realized", "z",
                                       "n_spans", "status"])
