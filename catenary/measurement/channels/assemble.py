"""One span type's measurements besides W, from the recording's channels and the survey file.

:func:`observations_for` puts, on the rows of the W data (one per span, its runs averaged):

- the **residual thickness** of each span's CW: the mean of the wear channel over the span's
  samples in each run (``results/{span_type}/spans.parquet``, column ``cw_residual_thickness_m``),
  the runs averaged; its standard uncertainty the accuracy's ``std`` (the channel's error in one
  span of one run) and the samples' standard error, over the square root of the runs; a survey's
  calliper value of the span is combined with it by inverse variance. The error every value
  shares (the channel's calibration, the new wire's diameter) is the accuracy's ``common_std``;
- a **tension** measured in a span (``messenger_tension_n``) on that span; a section's **CW
  tension** (``contact_tension_n``, at its tensioning device) on the section's first span the
  data holds: the model gives every span of a section the same CW tension, so one span carries
  the section's one measurement;
- a mast's **system height** on the span it starts (its left mast), else the span it ends;
- the **measuring force** of the line: each survey value (a calibration at standstill), and
  each run's mean contact force from the car's contact-force channel (its calibration error the
  accuracy of ``contact_force_n``, one per run), referred to the base run's declared force: a run
  declared at another force measures the same offset of the car from its declaration.

Survey rows of places the data does not hold (another span type, a span left out) are returned
apart, with why, for the log.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from .observations import LineObservation, Observations
from .quantities import QUANTITIES, model_columns
from .settings import MeasurementSettings
from .survey import ID_COLUMN

__all__ = ["IDENTIFIED_QUANTITIES", "observations_for", "read_observations"]

#: What the identification's model gives besides W: its random inputs measured directly (the
#: diagnosis reads every quantity; its effects give the others).
IDENTIFIED_QUANTITIES = ("messenger_tension_n", "system_height_m")


def observations_for(span_ids, spans: pd.DataFrame, survey: pd.DataFrame | None, settings: MeasurementSettings,
                     declared_force_n: float, quantities=None) -> tuple[Observations, pd.DataFrame]:
    """The measurements besides W on the rows ``span_ids`` of a span type's data.

    Parameters
    ----------
    span_ids : array of str
        The W data's rows, in order.
    spans : pandas.DataFrame
        The span type's projected spans (``spans.parquet``): ``span_id``, ``run_id``, ``force_n``,
        ``section_id``, ``left_mast_id``, ``right_mast_id`` and the channels'
        columns (:data:`catenary.measurement.projection.CHANNEL_COLUMNS`), one row per span and run.
    survey : pandas.DataFrame or None
        :func:`catenary.measurement.channels.survey.read_survey`'s table.
    settings : MeasurementSettings
        The accuracies where the survey gives none, and of the channels.
    declared_force_n : float
        The force the correction models [N] (the base of the measuring-force offset).
    quantities : iterable of str, optional
        Keep only these quantities (the identification keeps those of its random inputs).

    Returns
    -------
    observations : Observations
    unused : pandas.DataFrame
        Survey rows not placed on the data, with a column ``reason``.
    """
    span_ids = np.asarray(span_ids, dtype=str)
    row_of = {s: i for i, s in enumerate(span_ids)}
    places = (spans.groupby("span_id", sort=False)[["section_id", "left_mast_id", "right_mast_id"]].first()
              .reindex(span_ids))
    survey = survey if survey is not None else pd.DataFrame(columns=["quantity", "span_id", "section_id", "mast_id",
                                                                     "value", "std"])
    keep = set(QUANTITIES) if quantities is None else set(quantities)
    cells: dict[tuple[int, str], list[tuple[float, float]]] = {}
    unused = []

    def put(row: int, column: str, value: float, std: float):
        cells.setdefault((row, column), []).append((float(value), float(std)))

    thickness = _thickness_per_span(spans, settings)
    if "cw_residual_thickness_m" in keep:
        for span, (value, std) in thickness.items():
            if span in row_of:
                put(row_of[span], "cw_residual_thickness_m", value, std)
    first_of_section = {}
    for i, section in enumerate(places["section_id"]):
        first_of_section.setdefault(section, i)
    left_of = {m: i for i, m in enumerate(places["left_mast_id"]) if isinstance(m, str)}
    right_of = {m: i for i, m in enumerate(places["right_mast_id"]) if isinstance(m, str)}
    line = []
    for r in survey.itertuples(index=False):
        q = QUANTITIES[r.quantity]
        std = r.std if np.isfinite(r.std) else settings.accuracy[r.quantity].std
        if r.quantity not in keep:
            unused.append((*r, "not a quantity of this stage's model"))
            continue
        if q.place == "line":
            line.append(LineObservation(r.quantity, float(r.value), float(std)))
            continue
        place = getattr(r, ID_COLUMN[q.place])
        if q.place == "span" and place in row_of:
            put(row_of[place], r.quantity, r.value, std)
        elif q.place == "section" and place in first_of_section:
            put(first_of_section[place], r.quantity, r.value, std)
        elif q.place == "mast" and (place in left_of or place in right_of):
            if place in left_of:
                put(left_of[place], f"{r.quantity}_left", r.value, std)
            else:
                put(right_of[place], f"{r.quantity}_right", r.value, std)
        else:
            unused.append((*r, f"{ID_COLUMN[q.place].removesuffix('_id')} {place} not among this type's used spans"))
    if "measuring_force_n" in keep:
        line += _force_from_channel(spans, settings, declared_force_n)
    measured = [name for name in QUANTITIES if QUANTITIES[name].place != "line"
                and any(c == name or c.startswith(f"{name}_") for (_, c) in cells)]
    columns = model_columns(measured)
    values = np.full((span_ids.size, len(columns)), np.nan)
    stds = np.full_like(values, np.nan)
    for (row, column), items in cells.items():
        v, s = np.array(items).T
        weight = 1.0 / s ** 2
        values[row, columns.index(column)] = float(np.sum(weight * v) / weight.sum())
        stds[row, columns.index(column)] = float(1.0 / np.sqrt(weight.sum()))
    common = np.array([settings.accuracy[_quantity_of(c)].common_std for c in columns])
    observations = Observations(tuple(measured), values, stds, tuple(line), common)
    table = pd.DataFrame(unused, columns=[*survey.columns, "reason"])
    return observations, table


def _quantity_of(column: str) -> str:
    return column if column in QUANTITIES else column.rsplit("_", 1)[0]


def _thickness_per_span(spans: pd.DataFrame, settings: MeasurementSettings) -> dict[str, tuple[float, float]]:
    """Each span's residual thickness from the wear channel, its runs averaged, and its standard
    uncertainty [m] (module docstring)."""
    if "cw_residual_thickness_m" not in spans.columns:
        return {}
    t = spans[["span_id", "cw_residual_thickness_m", "cw_residual_thickness_se_m"]].dropna(
        subset=["cw_residual_thickness_m"])
    if t.empty:
        return {}
    acc = settings.accuracy["cw_residual_thickness_m"].std
    var = acc ** 2 + t["cw_residual_thickness_se_m"].fillna(0.0).to_numpy() ** 2
    t = t.assign(var=var)
    g = t.groupby("span_id", sort=False)
    value = g["cw_residual_thickness_m"].mean()
    std = np.sqrt(g["var"].mean() / g.size())
    return {s: (float(value[s]), float(std[s])) for s in value.index}


def _force_from_channel(spans: pd.DataFrame, settings: MeasurementSettings,
                        declared_force_n: float) -> list[LineObservation]:
    """One observation of the measuring force per run with a contact-force channel: the mean of
    its spans' mean contact forces, less the run's declared force's difference from the base one."""
    if "contact_force_n" not in spans.columns:
        return []
    acc = settings.accuracy["contact_force_n"]
    out = []
    for run_id, rows in spans.dropna(subset=["contact_force_n"]).groupby("run_id", sort=True):
        force = rows["contact_force_n"].to_numpy(dtype=float)
        declared = rows["force_n"].to_numpy(dtype=float) if "force_n" in rows else np.full(force.size, np.nan)
        shift = np.nanmean(declared) - declared_force_n if np.isfinite(declared).any() else 0.0
        se = force.std(ddof=1) / np.sqrt(force.size) if force.size > 1 else acc.std
        out.append(LineObservation("measuring_force_n", float(force.mean() - shift),
                                   float(np.hypot(acc.std, se))))
    return out


def read_observations(span_ids, spans_path, survey_path, settings: MeasurementSettings, declared_force_n: float,
                      quantities=None) -> tuple[Observations, pd.DataFrame]:
    """:func:`observations_for` from the files: the span type's ``spans.parquet`` and the survey
    file (None: no survey), read and checked (:func:`catenary.measurement.channels.survey.read_survey`)."""
    from catenary.plumbing.parquet import read_table
    from .survey import read_survey
    survey = read_survey(survey_path) if survey_path else None
    return observations_for(span_ids, read_table(spans_path), survey, settings, declared_force_n, quantities)
