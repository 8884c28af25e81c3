"""The virtual measurement campaign: simulate the recording car over a drawn line.

For each section of a :class:`~catenary.measurement.truth.Line`, the section model (its true dropper
lengths, support heights, system heights and per-span tensions) is solved statically (the
true static W) and run over by the measuring pantograph at the true measuring force, once per
run of the car (:mod:`catenary.measurement.recording_car`: its direction, its speed along the run, its
force): the true dynamic W of that run and its clean recording. The car then adds what it
adds (:mod:`catenary.measurement.recording_car`): the sensor's noise, quantisation, drop-outs and spikes,
its odometer's chainage and, when it records it, the stagger. Each section and run draws from
its own seeded streams, so sections can be simulated in parallel and the result does not
depend on the order.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pyarrow as pa

from catenary.measurement.channels.quantities import QUANTITIES, observe
from catenary.measurement.channels.survey import SURVEY_COLUMNS
from catenary.physics.config import Catenary
from catenary.physics.measuring import measuring_pass
from catenary.physics.pantograph import Pantograph
from .recording_car import MastTableErrors, RunSpec, mast_stagger, mast_table_with_errors, sensor as car_sensor, smooth_profile, stagger_at
from catenary.physics.section import Section
from catenary.physics.static import solve_static
from .truth import Line, Measurement, TruthSpec

#: Spacing of the knots of a run's speed profile [m] (its correlation length is hundreds of m).
SPEED_KNOT_SPACING_M = 2.0
#: Spacing of the knots of a run's force profile [m] (a regulated force fluctuates over metres).
FORCE_KNOT_SPACING_M = 0.25


def section_model(line: Line, k: int, catenary: Catenary) -> tuple[Section, np.ndarray]:
    """The true model of section ``k`` of ``line`` and the indices of its spans in the line."""
    spans = np.flatnonzero(line.params.section_index == k)
    left = line.spans["left_mast"][spans]
    masts = np.concatenate([left, [left[-1] + 1]])
    x = line.masts["chainage_m"][masts]
    span_type = line.spans["span_type"][spans[0]]
    lengths = line.params.dropper_lengths_m[spans]
    n_d = int(np.sum(~np.isnan(lengths[0])))
    starts = np.repeat((x - x[0])[:-1, None], line.params.cw_point_mass_kg.shape[1], axis=1)
    carried = line.params.cw_point_mass_kg[spans] > 0
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
        cw_point_mass_x_m=(starts + line.params.cw_point_mass_x_m[spans])[carried],
        cw_point_mass_kg=line.params.cw_point_mass_kg[spans][carried],
    ), spans


def _positions(catenary: Catenary, span_type: str) -> np.ndarray:
    return catenary.span_type(span_type).dropper_positions_m


def deflections_from_heights(section: Section, heights_at_droppers: np.ndarray, heights_at_masts: np.ndarray) -> np.ndarray:
    """W per span: heights at droppers minus the chord through the heights at the masts,
    shape (n_spans, n_droppers_per_span) [m]."""
    return (heights_at_droppers - section.chord_at_droppers(heights_at_masts)).reshape(section.n_spans, -1)


def simulate_section(line: Line, k: int, catenary: Catenary, pantograph: Pantograph, measurement: Measurement,
                     seed: int) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """Recording samples and truth rows of section ``k``, for every run of the car.

    Returns
    -------
    recording : DataFrame
        Per run, in time order: ``chainage_m`` (as the run's odometer records it), ``height_m``
        (with sensor effects), ``speed_kmh`` (the run's speed there), ``force_n`` (the declared
        force), ``stagger_m`` (NaN unless recorded; seen from the car, so its sign flips with the
        direction), ``run_id``, ``direction``.
    truth : DataFrame
        One row per span: ids, type, every true parameter, ``static_w*_m`` and the first run's
        ``dynamic_w*_m``.
    truth_runs : DataFrame
        One row per span and run: ``span_id``, ``run_id``, ``direction``, ``speed_kmh`` (mean over
        the span), ``dynamic_w*_m``, ``recorded_start_chainage_m`` and ``recorded_end_chainage_m``
        (the run's odometer at the span's masts).
    """
    section, spans = section_model(line, k, catenary)
    offset = line.masts["chainage_m"][line.spans["left_mast"][spans[0]]]
    static_w = solve_static(section, catenary).dropper_deflection_m().reshape(section.n_spans, -1)
    masts_x = section.mast_chainage_m
    grid = np.arange(masts_x[0], masts_x[-1] + 1e-9, measurement.sampling_step_m)
    exact = np.concatenate([section.dropper_chainage_m, masts_x])
    force = line.params.measuring_force_n
    n_d = section.dropper_x_m.size
    line_x = line.masts["chainage_m"]
    mast_index = np.concatenate([line.spans["left_mast"][spans], [line.spans["left_mast"][spans[-1]] + 1]])
    base = [line_seed(line), seed, k]
    parts, runs_rows, first_dynamic = [], [], None
    wear = _thickness_of_spans(line, spans, catenary) if measurement.wear_channel is not None else None
    for run in measurement.runs:
        extra = {}
        declared = measurement.force_n if run.force_n is None else run.force_n
        run_force = force + (declared - measurement.force_n)      # the car's error holds at every setting
        speed_kmh = np.full(grid.size, measurement.speed_kmh)
        if run.direction != 1:
            extra["direction"] = run.direction
        if run.speed_variation.std > 0:
            knots = np.arange(masts_x[0], masts_x[-1] + SPEED_KNOT_SPACING_M, SPEED_KNOT_SPACING_M)
            v = _run_speed_kmh(knots + offset, measurement, run, base)
            extra["speed_profile"] = (knots, v / 3.6)
            speed_kmh = np.interp(grid, knots, v)
        if run.force_variation.std > 0:
            knots = np.arange(masts_x[0], masts_x[-1] + FORCE_KNOT_SPACING_M, FORCE_KNOT_SPACING_M)
            extra["force_profile"] = (knots, smooth_profile(knots + offset, run.force_variation.std,
                                                            run.force_variation.length_m, run.stream(base[0], seed, 2)))
        passed = measuring_pass(section, catenary, pantograph.with_static_force(run_force),
                                speed_m_s=measurement.speed_kmh / 3.6, mode=measurement.mode,
                                time_step_s=measurement.time_step_s, chainage_m=np.concatenate([grid, exact]),
                                **extra)
        heights = passed.height_m
        clean, at_exact = heights[:grid.size], heights[grid.size:]
        dynamic_w = deflections_from_heights(section, at_exact[:n_d], at_exact[n_d:])
        first_dynamic = dynamic_w if first_dynamic is None else first_dynamic
        rng = np.random.default_rng(run.stream(*base))
        recorded = car_sensor(grid, clean, measurement.noise_std_m, measurement.quantisation_m,
                              measurement.dropout_rate_per_km, measurement.dropout_length_m,
                              measurement.spike_rate_per_km, measurement.spike_height_m, rng)
        stagger = np.full(grid.size, np.nan)
        if measurement.stagger is not None:
            at_masts = mast_stagger(line_x.size, measurement.stagger, [base[0], seed, 4])[mast_index]
            stagger = run.direction * (stagger_at(grid, masts_x, at_masts)
                                       + measurement.stagger.noise_std_m * rng.standard_normal(grid.size))
        start = line_x.min() if run.direction == 1 else line_x.max()
        drift_seed = run.stream(base[0], seed, 3)
        chainage = run.odometer.recorded(grid + offset, start, drift_seed) if not run.odometer.exact else grid + offset
        thickness, contact = _channels(measurement, run, grid, masts_x, wear, passed.contact_force_n[:grid.size],
                                       base, seed, k)
        part = pd.DataFrame({"chainage_m": chainage, "height_m": recorded, "speed_kmh": speed_kmh,
                             "force_n": np.full(grid.size, declared), "stagger_m": stagger,
                             "cw_residual_thickness_m": thickness, "contact_force_n": contact,
                             "run_id": np.full(grid.size, run.run_id), "direction": np.full(grid.size, run.direction)})
        parts.append(part.iloc[::run.direction].reset_index(drop=True))
        ends = run.odometer.recorded(masts_x + offset, start, drift_seed)
        mean_speed = [float(np.mean(speed_kmh[(grid >= a) & (grid <= b)])) for a, b in zip(masts_x[:-1], masts_x[1:])]
        rows = {"span_id": line.spans["span_id"][spans], "run_id": np.full(spans.size, run.run_id),
                "direction": np.full(spans.size, run.direction), "speed_kmh": mean_speed,
                "recorded_start_chainage_m": ends[:-1], "recorded_end_chainage_m": ends[1:]}
        rows.update({f"dynamic_w{i + 1}_m": dynamic_w[:, i] for i in range(dynamic_w.shape[1])})
        runs_rows.append(pd.DataFrame(rows))
    truth = _truth_rows(line, spans, section, offset, static_w, first_dynamic, force)
    return pd.concat(parts, ignore_index=True), truth, pd.concat(runs_rows, ignore_index=True)


def _thickness_of_spans(line: Line, spans: np.ndarray, catenary: Catenary) -> np.ndarray:
    """True residual thickness of each span's CW [m] (:mod:`catenary.measurement.channels.quantities`)."""
    return observe(line.params, catenary, ("cw_residual_thickness_m",))[spans, 0]


def _channels(measurement: Measurement, run: RunSpec, grid: np.ndarray, masts_x: np.ndarray,
              thickness_m: np.ndarray | None, contact_force_n: np.ndarray, base: list[int], seed: int, k: int):
    """The wear and contact-force channels of one run over one section (NaN where not recorded):
    each span's true thickness with its error in this run, the run's calibration bias (one draw
    per run, shared by every section) and each sample's noise; the simulated contact force with
    the run's bias and each sample's noise."""
    nan = np.full(grid.size, np.nan)
    thickness, contact = nan, nan.copy()
    bias = np.random.default_rng(run.stream(base[0], 11)).standard_normal(2)        # the run's calibrations
    rng = np.random.default_rng(run.stream(base[0], seed, k, 12))
    if measurement.wear_channel is not None:
        c = measurement.wear_channel
        span = np.clip(np.searchsorted(masts_x, grid, side="right") - 1, 0, masts_x.size - 2)
        per_span = thickness_m + c.span_std_m * rng.standard_normal(thickness_m.size)
        thickness = (per_span[span] + c.run_bias_std_m * bias[0] + c.noise_std_m * rng.standard_normal(grid.size))
        if c.quantisation_m > 0:
            thickness = np.round(thickness / c.quantisation_m) * c.quantisation_m
    if measurement.force_channel is not None:
        c = measurement.force_channel
        contact = contact_force_n + c.run_bias_std_n * bias[1] + c.noise_std_n * rng.standard_normal(grid.size)
    return thickness, contact


def campaign_survey(line: Line, spec: TruthSpec, catenary: Catenary) -> pd.DataFrame:
    """What the campaign's crew measures (``spec.survey``), in the survey file's format
    (:data:`catenary.measurement.channels.survey.SURVEY_COLUMNS`): each quantity's true value
    (:mod:`catenary.measurement.channels.quantities`) at ``count`` places evenly spread along the line, plus
    its error and the instrument's calibration error (one draw per item), seeded by the truth."""
    rows = []
    rng = np.random.default_rng([spec.seed, 31])
    first_of_section = np.r_[True, line.params.section_index[1:] != line.params.section_index[:-1]]
    for item in spec.survey:
        place = QUANTITIES[item.quantity].place
        values = observe(line.params, catenary, (item.quantity,))
        if place == "span":
            where = pd.DataFrame({"span_id": line.spans["span_id"], "value": values[:, 0]})
        elif place == "section":
            where = pd.DataFrame({"section_id": line.spans["section_id"][first_of_section],
                                  "value": values[first_of_section, 0]})
        elif place == "mast":
            last = np.r_[first_of_section[1:], True]                     # a section's last span: its right mast
            masts = np.r_[line.spans["left_mast"], line.spans["left_mast"][last] + 1]
            value = np.r_[values[:, 0], values[last, 1]]
            order = np.argsort(masts, kind="stable")
            where = pd.DataFrame({"mast_id": line.masts["mast_id"][masts[order]], "value": value[order]})
        else:
            where = pd.DataFrame({"value": values[:1, 0]})
        n = len(where) if item.count is None else min(item.count, len(where))
        pick = np.unique(np.round(np.linspace(0, len(where) - 1, n)).astype(int)) if n < len(where) else np.arange(n)
        where = where.iloc[pick].reset_index(drop=True)
        bias = item.common_std * rng.standard_normal()
        where["value"] = where["value"] + bias + item.std * rng.standard_normal(len(where))
        where["quantity"] = item.quantity
        where["std"] = item.std
        rows.append(where)
    table = pd.concat(rows, ignore_index=True) if rows else pd.DataFrame()
    return table.reindex(columns=list(SURVEY_COLUMNS))


def _run_speed_kmh(x_m: np.ndarray, measurement: Measurement, run: RunSpec, base: list[int]) -> np.ndarray:
    """A run's speed at line chainages ``x_m`` [km/h]: the measurement's mean plus the run's smooth
    variation, kept within half and one and a half times the mean."""
    v = measurement.speed_kmh + smooth_profile(x_m, run.speed_variation.std, run.speed_variation.length_m,
                                               run.stream(base[0], base[1], 1))
    return np.clip(v, 0.5 * measurement.speed_kmh, 1.5 * measurement.speed_kmh)


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
    """Recorded heights of the measurement ``m``'s sensor (:func:`catenary.measurement.recording_car.sensor`)."""
    return car_sensor(chainage_m, height_m, m.noise_std_m, m.quantisation_m, m.dropout_rate_per_km,
                      m.dropout_length_m, m.spike_rate_per_km, m.spike_height_m, rng)


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
    if p.cw_point_mass_kg.shape[1]:
        # Concentrated masses on the CW (an effect of one's own): each span's total and where its
        # largest one is (NaN without any).
        masses = p.cw_point_mass_kg[spans]
        rows["cw_point_mass_kg"] = masses.sum(axis=1)
        rows["cw_point_mass_x_m"] = np.where(masses.max(axis=1) > 0, p.cw_point_mass_x_m[spans][
            np.arange(spans.size), masses.argmax(axis=1)], np.nan)
    n_d = static_w.shape[1]
    for i in range(n_d):
        rows[f"dropper_{i + 1}_length_m"] = p.dropper_lengths_m[spans, i]
    for i in range(n_d):
        rows[f"static_w{i + 1}_m"] = static_w[:, i]
    for i in range(n_d if dynamic_w is not None else 0):
        rows[f"dynamic_w{i + 1}_m"] = dynamic_w[:, i]
    return pd.DataFrame(rows)


def masts_table(line: Line) -> pd.DataFrame:
    """The true masts file that catenary.measurement.recording reads (with span types)."""
    m = line.masts
    span_type = np.empty(m["mast_id"].size, dtype=object)
    span_type[line.spans["left_mast"]] = line.spans["span_type"]
    # the last mast of each section starts no span: give it its section's type
    last = np.flatnonzero(span_type == None)  # noqa: E711
    span_type[last] = span_type[last - 1]
    return pd.DataFrame({"mast_id": m["mast_id"], "chainage_m": m["chainage_m"], "section_id": m["section_id"],
                         "span_type": span_type.astype(str)})


def campaign_masts(line: Line, spec: TruthSpec) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The masts file the campaign writes (with the mast-table errors it plants, ``mast_table``)
    and what it did to each mast (:func:`catenary.measurement.recording_car.mast_table_with_errors`)."""
    return mast_table_with_errors(masts_table(line), spec.mast_table or MastTableErrors())


def gather_recording(parts: list[pd.DataFrame], spec: TruthSpec) -> pd.DataFrame:
    """The sections' recordings as the car writes them: the runs one after the other (in the
    campaign's order), each in time order (its chainage increasing or decreasing)."""
    recording = pd.concat(parts, ignore_index=True)
    order = {run.run_id: i for i, run in enumerate(spec.measurement.runs)}
    key = recording["run_id"].map(order) * 1e9 + recording["direction"] * recording["chainage_m"]
    return recording.iloc[np.argsort(key.to_numpy(), kind="stable")].reset_index(drop=True)


def truth_schema(columns) -> pa.Schema:
    """Arrow schema of the truth tables: identifiers as strings, ``direction`` int64, every other
    column float64 (``cw_point_mass_x_m`` null on a span without a concentrated mass)."""
    text = {"span_id", "section_id", "span_type", "run_id"}
    return pa.schema([pa.field(c, pa.string() if c in text else pa.int64() if c == "direction" else pa.float64(),
                               nullable=c == "cw_point_mass_x_m") for c in columns])


def write_recording_csv(recording: pd.DataFrame, path) -> None:
    """The recording as CSV (4 decimals: 0.1 mm), beside its Parquet file, for those who read
    CSV; the stagger column only when the car recorded it."""
    columns = [c for c in recording.columns if c != "stagger_m" or recording["stagger_m"].notna().any()]
    recording[columns].to_csv(path, index=False, float_format="%.4f")
