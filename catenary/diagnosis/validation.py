"""What a diagnosis named against the hidden effects its campaign planted (validation only).

One row per span type and step: the verdict, the effect named, whether it was planted, and for
each of its parameters the planted magnitude, the magnitude realized in the spans of that type
(the sample spread of the drawn values, where the truth table records them), the identified
value ± standard error and z = (identified − realized) / se.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd

from ..truth import TruthSpec

__all__ = ["diagnosis_check", "realized_magnitudes"]

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
