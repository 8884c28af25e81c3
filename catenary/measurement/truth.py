"""Truth specification of the virtual measurement campaign and its seeded draw.

The truth file (``config/campaign.yaml``) describes a line of tensioning sections of spans,
the random laws of the per-span parameters, the section tensions, the hidden effects of
:mod:`catenary.physics.effects`, and the measurement settings. :func:`draw_line` turns it into a
concrete line: masts (ids, chainages, CW heights, system heights) and per-span parameters.
The pipeline never reads the truth; only validation compares against it.

Laws: ``normal`` or ``gamma`` by (``mean``, ``std``), or ``fixed`` (``mean`` only). Dropper
lengths are drawn per span and dropper, their means default to the span type's nominal
table (``mean: nominal``). ΔH and the CW height are drawn per mast, so adjacent spans share
them; tensions per section.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import yaml

from catenary.physics.config import Catenary
from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.physics.effects import EFFECTS, SpanParameters, load_modules, plant
from catenary.plumbing.errors import ConfigError
from .recording_car import ForceChannel, MastTableErrors, Odometer, RunSpec, StaggerSpec, Variation, WearChannel
from catenary.plumbing.schema import check



@dataclass(frozen=True)
class Law:
    """A scalar law by mean and standard deviation (SI units)."""

    kind: str
    mean: float
    std: float = 0.0

    def sample(self, rng: np.random.Generator, size) -> np.ndarray:
        if self.kind == "fixed" or self.std == 0.0:
            return np.full(size, self.mean)
        if self.kind == "normal":
            return self.mean + self.std * rng.standard_normal(size)
        shape = (self.mean / self.std) ** 2
        return rng.gamma(shape, self.mean / shape, size)


@dataclass(frozen=True)
class SectionSpec:
    section_id: str
    span_type: str
    n_spans: int


@dataclass(frozen=True)
class Measurement:
    """Recording-car settings.

    Attributes: pantograph (name in the pantographs file), speed_kmh [km/h], force_n
    (declared mean force [N]), sampling_step_m [m], noise_std_m [m], quantisation_m [m],
    dropout_rate_per_km, dropout_length_m [m], spike_rate_per_km, spike_height_m [m],
    mode ("dynamic" or "quasi_static"), time_step_s [s], runs (the car's runs,
    :class:`~catenary.measurement.recording_car.RunSpec`; default one run towards increasing chainage with
    an exact odometer), stagger (:class:`~catenary.measurement.recording_car.StaggerSpec` or None: the
    stagger is not recorded), wear_channel and force_channel (the residual thickness and the
    contact force the car records, :class:`~catenary.measurement.recording_car.WearChannel`,
    :class:`~catenary.measurement.recording_car.ForceChannel`; None: not recorded).
    """

    pantograph: str
    speed_kmh: float
    force_n: float
    sampling_step_m: float
    noise_std_m: float
    quantisation_m: float
    dropout_rate_per_km: float
    dropout_length_m: float
    spike_rate_per_km: float
    spike_height_m: float
    mode: str
    time_step_s: float
    runs: tuple[RunSpec, ...] = (RunSpec(),)
    stagger: StaggerSpec | None = None
    wear_channel: WearChannel | None = None
    force_channel: ForceChannel | None = None


@dataclass(frozen=True)
class SurveySpec:
    """What a crew measures: ``quantity`` (:data:`catenary.measurement.channels.quantities.QUANTITIES`) at
    ``count`` places evenly spread along the line (None: all), each with standard uncertainty
    ``std`` and an error ``common_std`` all share [SI]."""

    quantity: str
    count: int | None
    std: float
    common_std: float = 0.0


@dataclass(frozen=True)
class TruthSpec:
    """Parsed truth file."""

    seed: int
    sections: list[SectionSpec]
    section_gap_m: float
    span_length_jitter_m: float
    cw_height: Law
    dropper_laws: dict[str, tuple[np.ndarray | None, np.ndarray, str]]
    system_height: dict[str, Law]
    contact_tension: Law
    messenger_tension: dict[str, Law]
    hidden_effects: list[tuple[str, dict[str, float]]]
    measurement: Measurement
    raw: dict = field(repr=False, default_factory=dict)
    mast_table: MastTableErrors | None = None
    survey: tuple[SurveySpec, ...] = ()


def _law(raw: Mapping[str, Any]) -> Law:
    """A law from its schema-checked mapping."""
    return Law(raw["law"], float(raw["mean"]), float(raw.get("std", 0.0)))


def _variation(raw: Mapping[str, Any] | None) -> Variation:
    return Variation() if raw is None else Variation(float(raw["std"]), float(raw["length_m"]))


def _runs(raw: list | None, where: str) -> tuple[RunSpec, ...]:
    """The car's runs from their schema-checked list (default: one run, exact odometer)."""
    if not raw:
        return (RunSpec(),)
    runs = []
    for r in raw:
        o = r.get("odometer") or {}
        runs.append(RunSpec(run_id=str(r["run_id"]), direction=int(r.get("direction", 1)), seed=int(r["seed"]),
                            odometer=Odometer(float(o.get("offset_m", 0.0)), float(o.get("scale", 1.0)),
                                              _variation(o.get("drift"))),
                            speed_variation=_variation(r.get("speed_variation")),
                            force_variation=_variation(r.get("force_variation")),
                            force_n=None if r.get("force_n") is None else float(r["force_n"])))
    ids = [r.run_id for r in runs]
    if len(set(ids)) != len(ids):
        raise ConfigError(f"{where}.measurement.runs: run ids must be unique, got {ids}")
    return tuple(runs)


def truth_from_dict(raw: Mapping[str, Any], catenary: Catenary, where: str = "campaign") -> TruthSpec:
    """Check and parse a truth mapping; errors name the key.

    The campaign schema (:mod:`catenary.plumbing.schema`) checks every key and value; this function
    adds what depends on the catenary data and the effects' physics: known span types, unique
    section ids, one dropper law per dropper of the type, the effects' names and magnitudes.
    """
    check(raw, "campaign", where=where)
    line = raw["line"]
    sections = []
    for i, s in enumerate(line["sections"]):
        if s["span_type"] not in catenary.span_types:
            raise ConfigError(f"{where}.line.sections[{i}].span_type: unknown span type {s['span_type']!r}; "
                              f"known: {', '.join(catenary.span_types)}")
        sections.append(SectionSpec(s["section_id"], s["span_type"], int(s["n_spans"])))
    ids = [s.section_id for s in sections]
    if len(set(ids)) != len(ids):
        raise ConfigError(f"{where}.line.sections: section ids must be unique, got {ids}")
    used_types = sorted({s.span_type for s in sections})
    params = raw["span_parameters"]
    dropper_laws, system_height, messenger = {}, {}, {}
    for t in used_types:
        w = f"{where}.span_parameters.{t}"
        if t not in params:
            raise ConfigError(f"{w}: missing key (the line has sections of span type {t})")
        p = params[t]
        d = p["dropper_lengths_m"]
        n_d = catenary.span_type(t).n_droppers
        std = np.asarray(d["std"], dtype=float)
        if std.shape != (n_d,):
            raise ConfigError(f"{w}.dropper_lengths_m.std: expected {n_d} values ≥ 0 [m] (one per dropper of {t}), "
                              f"got {std.size}")
        mean = d.get("mean", "nominal")
        if mean != "nominal":
            mean = np.asarray(mean, dtype=float)
            if mean.shape != (n_d,):
                raise ConfigError(f"{w}.dropper_lengths_m.mean: expected 'nominal' or {n_d} positive lengths [m], "
                                  f"got {mean.size}")
        else:
            mean = None
        dropper_laws[t] = (mean, std, d.get("law", "gamma"))
        system_height[t] = _law(p["system_height_m"])
        messenger[t] = _law(p["messenger_tension_n"])
    load_modules(raw.get("effects_modules") or [], where=f"{where}.effects_modules")
    effects = []
    for i, e in enumerate(raw.get("hidden_effects") or []):
        w = f"{where}.hidden_effects[{i}]"
        name = e["name"]
        if name not in EFFECTS:
            raise ConfigError(f"{w}.name: unknown effect {name!r}; known: {', '.join(EFFECTS)}")
        magnitude = {k: float(v) for k, v in e.items() if k != "name"}
        keys, required = list(EFFECTS[name].magnitudes), list(EFFECTS[name].required)
        unknown = sorted(set(magnitude) - set(keys))
        missing = sorted(set(required) - set(magnitude))
        if unknown or missing:
            raise ConfigError(f"{w}: effect {name!r} takes magnitudes {keys} (required {required}); "
                              f"unknown {unknown}, missing {missing}")
        effects.append((name, magnitude))
    m = raw["measurement"]
    measurement = Measurement(
        pantograph=str(m["pantograph"]), speed_kmh=float(m["speed_kmh"]), force_n=float(m["force_n"]),
        sampling_step_m=float(m["sampling_step_m"]), noise_std_m=float(m["noise_std_m"]),
        quantisation_m=float(m["quantisation_m"]), dropout_rate_per_km=float(m["dropout_rate_per_km"]),
        dropout_length_m=float(m["dropout_length_m"]), spike_rate_per_km=float(m["spike_rate_per_km"]),
        spike_height_m=float(m["spike_height_m"]), mode=str(m["mode"]), time_step_s=float(m["time_step_s"]),
        runs=_runs(m.get("runs"), where),
        stagger=StaggerSpec(**{k: float(v) for k, v in m["stagger"].items()}) if m.get("stagger") else None,
        wear_channel=WearChannel(**{k: float(v) for k, v in m["wear_channel"].items()})
        if m.get("wear_channel") is not None else None,
        force_channel=ForceChannel(**{k: float(v) for k, v in m["force_channel"].items()})
        if m.get("force_channel") is not None else None)
    table = raw.get("mast_table")
    mast_table = (MastTableErrors(float(table.get("position_error_m", 0.0)), int(table.get("missing", 0)),
                                  int(table.get("extra", 0)), int(table.get("seed", raw["seed"])))
                  if table else None)
    survey = tuple(SurveySpec(str(item["quantity"]), None if item.get("count", "all") == "all" else int(item["count"]),
                              float(item["std"]), float(item.get("common_std", 0.0)))
                   for item in raw.get("survey") or [])
    return TruthSpec(
        seed=int(raw["seed"]), sections=sections, section_gap_m=float(line.get("section_gap_m", 50.0)),
        span_length_jitter_m=float(line.get("span_length_jitter_m", 0.0)), cw_height=_law(line["cw_height_m"]),
        dropper_laws=dropper_laws, system_height=system_height, contact_tension=_law(raw["contact_tension_n"]),
        messenger_tension=messenger, hidden_effects=effects, measurement=measurement, raw=dict(raw),
        mast_table=mast_table, survey=survey)


def load_truth(path: str | Path, catenary: Catenary) -> TruthSpec:
    """Read and check the truth file ``path``."""
    path = Path(path)
    try:
        raw = yaml.safe_load(path.read_text())
    except FileNotFoundError:
        raise ConfigError(f"{path}: truth file not found") from None
    if not isinstance(raw, Mapping):
        raise ConfigError(f"{path}: expected a mapping")
    return truth_from_dict(raw, catenary, where=str(path))


@dataclass(frozen=True)
class Line:
    """A drawn line: one row per mast and per span.

    Attributes
    ----------
    masts : dict of arrays
        ``mast_id``, ``section_id``, ``chainage_m``, ``cw_height_m``, ``system_height_m``.
    spans : dict of arrays
        ``span_id``, ``section_id``, ``span_type``, ``left``/``right`` mast indices, and the
        true parameters (dropper lengths as (n_spans, n_droppers) arrays per span type).
    params : SpanParameters
    """

    masts: dict
    spans: dict
    params: SpanParameters
    sections: list[SectionSpec]


def draw_line(spec: TruthSpec, catenary: Catenary) -> Line:
    """Draw every true parameter of the line, seeded by ``spec.seed``."""
    rng = np.random.default_rng(spec.seed)
    mast_ids, mast_section, mast_x, span_left, span_type, span_section = [], [], [], [], [], []
    mast_dh_type = []
    x = 0.0
    for k, s in enumerate(spec.sections):
        st = catenary.span_type(s.span_type)
        lengths = st.length_m + spec.span_length_jitter_m * rng.standard_normal(s.n_spans)
        chain = x + np.concatenate([[0.0], np.cumsum(lengths)])
        first = len(mast_ids)
        for c in chain:
            mast_ids.append(f"M{len(mast_ids) + 1:04d}")
            mast_section.append(s.section_id)
            mast_x.append(float(c))
            mast_dh_type.append(s.span_type)
        for j in range(s.n_spans):
            span_left.append(first + j)
            span_type.append(s.span_type)
            span_section.append(k)
        x = chain[-1] + spec.section_gap_m
    n_masts, n_spans = len(mast_ids), len(span_left)
    cw_height = spec.cw_height.sample(rng, n_masts)
    dh = np.empty(n_masts)
    for t in sorted(set(mast_dh_type)):
        sel = np.array(mast_dh_type) == t
        dh[sel] = spec.system_height[t].sample(rng, int(sel.sum()))
    left = np.array(span_left)
    span_type = np.array(span_type)
    n_d = max(catenary.span_type(t).n_droppers for t in set(span_type))
    lengths = np.full((n_spans, n_d), np.nan)
    dh_mean = np.empty(n_spans)
    section_index = np.array(span_section)
    for t in sorted(set(span_type)):
        sel = span_type == t
        mean, std, law = spec.dropper_laws[t]
        if mean is None:
            mean = nominal_dropper_lengths(catenary.span_type(t), catenary).dropper_lengths_m
        draws = np.column_stack([Law(law, m, s).sample(rng, int(sel.sum())) for m, s in zip(mean, std)])
        lengths[sel, :mean.size] = draws
        dh_mean[sel] = spec.system_height[t].mean
    section_t_mw = np.array([spec.messenger_tension[s.span_type].sample(rng, 1)[0] for s in spec.sections])
    t_mw = section_t_mw[section_index]
    t_cw = spec.contact_tension.sample(rng, len(spec.sections))[section_index]
    params = SpanParameters(
        dropper_lengths_m=lengths, system_height_left_m=dh[left], system_height_right_m=dh[left + 1],
        system_height_mean_m=dh_mean, messenger_tension_n=t_mw, contact_tension_n=t_cw,
        section_index=section_index, measuring_force_n=spec.measurement.force_n, creep_offset_m=np.zeros(n_spans),
        cw_offset_m=np.zeros(n_spans), left_mast=left, mast_cw_height_offset_m=np.zeros(n_masts),
        cw_wear_fraction=np.zeros(n_spans), span_length_m=np.diff(np.array(mast_x))[left],
        dropper_x_m=np.array([np.pad(catenary.span_type(t).dropper_positions_m,
                                     (0, n_d - catenary.span_type(t).n_droppers), constant_values=np.nan)
                              for t in span_type]))
    for name, magnitude in spec.hidden_effects:
        plant(name, params, rng, magnitude)
    if np.any(params.cw_wear_fraction < 0) or np.any(params.cw_wear_fraction >= 1):
        raise ConfigError("campaign: drawn contact-wire wear fractions must lie in [0, 1); check contact_wire_wear")
    cw_height = cw_height + params.mast_cw_height_offset_m
    if np.any(params.dropper_lengths_m[~np.isnan(params.dropper_lengths_m)] <= 0):
        raise ConfigError("campaign: drawn dropper lengths must be positive; check the laws and effects")
    mast_ids = np.array(mast_ids)
    masts = {"mast_id": mast_ids, "section_id": np.array(mast_section), "chainage_m": np.array(mast_x),
             "cw_height_m": cw_height, "system_height_m": dh}
    spans = {"span_id": np.array([f"{mast_ids[i]}-{mast_ids[i + 1]}" for i in left]),
             "section_id": np.array([spec.sections[k].section_id for k in section_index]),
             "span_type": span_type, "left_mast": left}
    return Line(masts=masts, spans=spans, params=params, sections=spec.sections)
