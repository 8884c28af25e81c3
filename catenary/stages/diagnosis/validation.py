"""What a diagnosis named against the hidden effects its campaign planted (validation only).

One row per span type and step: the verdict, the effect named, whether it was planted, and for
each of its parameters the planted magnitude, the magnitude realized in the spans of that type
(the sample spread of the drawn values, where the truth table records them), the identified
value ± standard error and z = (identified − realized) / se. And the per-span check against the
spans an effect no catalogue lists touched (:func:`span_check_validation`).
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd

from catenary.measurement.truth import TruthSpec

__all__ = ["affected_spans", "diagnosis_check", "realized_magnitudes", "span_check_validation"]

#: Truth-table column whose spread over the spans realizes a spread parameter.
_REALIZED = {("messenger_tension_variability", "std_n"): "messenger_tension_n",
             ("contact_tension_variability", "std_n"): "contact_tension_n",
             ("dropper_creep", "std_m"): "creep_offset_m",
             ("cw_longitudinal_offset", "std_m"): "cw_offset_m",
             ("contact_wire_wear", "std_fraction"): "cw_wear_fraction"}
_REALIZED_MEAN = {("dropper_creep", "mean_m"): "creep_offset_m",
                  ("cw_longitudinal_offset", "mean_m"): "cw_offset_m",
                  ("contact_wire_wear", "mean_fraction"): "cw_wear_fraction"}


def realized_magnitudes(spec: TruthSpec, truth: pd.DataFrame, span_type: str) -> dict[str, dict[str, float]]:
    """Planted effects of ``spec`` with their magnitudes as realized in the spans of ``span_type``."""
    spans = truth[truth["span_type"] == span_type]
    out = {}
    for name, magnitudes in spec.hidden_effects:
        realized = {}
        for key, value in magnitudes.items():
            column = _REALIZED.get((name, key)) or _REALIZED_MEAN.get((name, key))
            if column is None or column not in spans:
                realized[key] = float(value)
            elif (name, key) in _REALIZED:
                realized[key] = float(spans[column].std(ddof=1))
            else:
                realized[key] = float(spans[column].mean())
        out[name] = realized
    return out


def diagnosis_check(findings: dict[str, pd.DataFrame], spec: TruthSpec, truth: pd.DataFrame,
                    campaign: str) -> pd.DataFrame:
    """The table of the module docstring from each span type's ``findings.csv``."""
    rows = []
    planted = [name for name, _ in spec.hidden_effects]
    for span_type, table in findings.items():
        realized = realized_magnitudes(spec, truth, span_type)
        named = [e for e, v in zip(table["effect"].fillna(""), table["verdict"]) if v == "named"]
        for _, step in table.iterrows():
            effect = step["effect"] if isinstance(step["effect"], str) else ""
            base = dict(campaign=campaign, span_type=span_type, step=int(step["step"]), verdict=step["verdict"],
                        effect=effect, runner_up=step["runner_up"] if isinstance(step["runner_up"], str) else "",
                        planted=";".join(planted), effect_planted=effect in planted if effect else False,
                        all_planted_named=all(p in named for p in planted), p_value=step["p_value"])
            params = json.loads(step["parameters"]) if isinstance(step["parameters"], str) else {}
            if not params:
                rows.append({**base, "parameter": "", "planted_magnitude": np.nan, "realized_magnitude": np.nan,
                             "identified": np.nan, "standard_error": np.nan, "z": np.nan})
            for key, (value, se) in params.items():
                value = np.nan if value is None else value
                se = np.nan if se is None else se
                truth_value = dict(spec.hidden_effects).get(effect, {}).get(key, 0.0)
                real = realized.get(effect, {}).get(key, 0.0)
                rows.append({**base, "parameter": key, "planted_magnitude": truth_value, "realized_magnitude": real,
                             "identified": value, "standard_error": se,
                             "z": (value - real) / se if se and np.isfinite(se) and se > 0 else np.nan})
    return pd.DataFrame(rows)


#: Effects of the validation's own code (``config/validation/effects/planted.py``) and how the
#: truth says which spans they touch: a concentrated mass on the CW (the truth's
#: ``cw_point_mass_kg``), a section's tension offset (the section at the planted index).
_LOCAL_EFFECTS = ("in_span_equipment",)
_SECTION_EFFECTS = ("section_tension_offset",)
#: Actions that adjust a dropper or a tension (the maintenance list's ``_action`` words).
_ADJUSTMENTS = ("shorten", "lengthen", "inspect tensioning device (", "check system height")


def affected_spans(spec: TruthSpec, truth: pd.DataFrame) -> pd.Series:
    """Per span of the truth, which out-of-catalogue effect touches it ("" for none)."""
    out = pd.Series("", index=truth["span_id"].astype(str).to_numpy())
    if "cw_point_mass_kg" in truth:
        carried = truth["cw_point_mass_kg"].to_numpy(dtype=float) > 0
        out[carried] = next((n for n, _ in spec.hidden_effects if n in _LOCAL_EFFECTS), "concentrated mass")
    sections = list(dict.fromkeys(truth["section_id"].astype(str)))
    for name, magnitudes in spec.hidden_effects:
        if name in _SECTION_EFFECTS:
            inside = truth["section_id"].astype(str).to_numpy() == sections[int(magnitudes["section"])]
            out[inside] = name
    return out


def span_check_validation(spans: pd.DataFrame, sections: pd.DataFrame, listed: pd.DataFrame, spec: TruthSpec,
                          truth: pd.DataFrame, span_type: str, campaign: str) -> dict:
    """The per-span check against the truth, one row: spans affected by an effect no catalogue
    lists and how many the check flagged, the others flagged, the KS p-value of the unaffected
    spans' p-values against uniform, the largest error of a flagged local anomaly's position [m],
    the maintenance rows that adjust a dropper or a tension in an affected span, and the rows
    that name a section's tensioning device."""
    from scipy import stats
    affected = affected_spans(spec, truth[truth["span_type"] == span_type])
    table = spans.assign(affected=spans["span_id"].astype(str).map(affected).fillna(""))
    hit = table["affected"] != ""
    flagged = table["unexplained"].astype(str).str.lower().eq("true") | (
        table["explained_by"].fillna("").astype(str) != "")
    error = np.nan
    if "cw_point_mass_x_m" in truth:
        true_x = truth.set_index("span_id")["cw_point_mass_x_m"]
        local = table[hit & flagged & (table["group"].fillna("").astype(str) == "")]
        if len(local):
            found = local["peak_chainage_m"] - local["start_chainage_m"]
            error = float(np.nanmax(np.abs(found.to_numpy() - local["span_id"].map(true_x).to_numpy(dtype=float))))
    rows = listed[listed["span_id"].isin(table.loc[hit, "span_id"])]
    adjusts = sum(a.startswith(_ADJUSTMENTS) for a in rows["action"].astype(str))
    devices = sum(a.startswith("inspect the tensioning device of section") for a in listed["action"].astype(str))
    unaffected = table.loc[~hit, "p_value"].to_numpy(dtype=float)
    return {"campaign": campaign, "span_type": span_type, "n_spans": len(table), "n_affected": int(hit.sum()),
            "n_affected_flagged": int((hit & flagged).sum()), "n_others": int((~hit).sum()),
            "n_others_flagged": int((~hit & flagged).sum()),
            "ks_p_value_unaffected": float(stats.kstest(unaffected, "uniform").pvalue) if unaffected.size else np.nan,
            "max_position_error_m": error, "adjustments_in_affected_spans": int(adjusts),
            "device_rows": int(devices), "sections_flagged": ";".join(
                sections.loc[sections["unexplained"].astype(str).str.lower().eq("true"), "section_id"].astype(str))}
