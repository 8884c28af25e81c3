"""The per-span check's validation table (issue [16], ``make validate``): what the campaigns with
an effect no catalogue lists, and the null ones, give against their truth.

For every campaign run: its ``validation/spans_check.csv`` rows (affected spans flagged, others
flagged, KS p-value of the unaffected spans' p-values, position errors, adjustments sent to
affected spans, device rows); for ``o_local`` and ``o_section`` the laws identified without the
flagged spans against the laws of the default campaign's same line without the effect (z =
difference / the default's standard error, the 2-standard-error criterion); for ``o_plugin`` the
concentrated masses its user's effect found on the spans it explains against the truth of
``o_local`` (z = (fitted − planted) / se). Written to ``results/validation/open_world.csv`` and
``results/validation/open_world_plugin.csv``.
Usage: ``python benchmarks/open_world_check.py``.
"""

from record import ROOT  # noqa: I001  (sets one BLAS thread first)

import json

import numpy as np
import pandas as pd

from catenary.plumbing.parquet import read_table


def folder(name: str):
    return ROOT / ("results" if name == "default" else f"results/validate/{name}")


def laws_against_default(name: str, span_type: str = "N2") -> pd.DataFrame:
    """Laws without the flagged spans against the default campaign's (the same line without the effect)."""
    ours = pd.read_csv(folder(name) / span_type / "identification" / "s_opt_explained.csv").set_index("parameter")
    base = pd.read_csv(folder("default") / span_type / "identification" / "s_opt.csv").set_index("parameter")
    rows = []
    for p in base.index:
        for stat in ("mu", "sigma"):
            se = float(base.loc[p, f"{stat}_se"])
            if not se > 0:
                continue
            d = float(ours.loc[p, stat]) - float(base.loc[p, stat])
            rows.append({"campaign": name, "parameter": p, "statistic": stat, "without_effect": base.loc[p, stat],
                         "flagged_left_out": ours.loc[p, stat], "standard_error": se, "z": d / se})
    return pd.DataFrame(rows)


def plugin_against_truth() -> pd.DataFrame:
    fits = pd.read_csv(folder("o_plugin") / "N2" / "diagnosis" / "span_effects.csv")
    truth = read_table(folder("o_local") / "campaign" / "truth.parquet").set_index("span_id")
    rows = []
    for r in fits.itertuples():
        est = json.loads(r.parameters)
        mass, mass_se = est["mass_kg"]
        x, x_se = est["x_m"]
        true_mass = float(truth.loc[r.span_id, "cw_point_mass_kg"])
        true_x = float(truth.loc[r.span_id, "cw_point_mass_x_m"]) if true_mass > 0 else np.nan
        rows.append({"span_id": r.span_id, "explained": r.explained, "mass_kg": mass, "mass_se_kg": mass_se,
                     "planted_mass_kg": true_mass, "z_mass": (mass - true_mass) / mass_se if mass_se > 0 else np.nan,
                     "x_m": x, "planted_x_m": true_x, "position_error_m": x - true_x})
    return pd.DataFrame(rows)


def main() -> None:
    out = ROOT / "results" / "validation"
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for name in ("default", "v2_null", "o_local", "o_section"):
        path = folder(name) / "validation" / "spans_check.csv"
        if path.exists():
            rows.append(pd.read_csv(path))
    table = pd.concat(rows, ignore_index=True) if rows else pd.DataFrame()
    table.to_csv(out / "open_world.csv", index=False, float_format="%.6g")
    print(table.to_string(index=False))
    laws = [laws_against_default(n) for n in ("o_local", "o_section")
            if (folder(n) / "N2" / "identification" / "s_opt_explained.csv").exists()]
    if laws:
        laws = pd.concat(laws, ignore_index=True)
        laws.to_csv(out / "open_world_laws.csv", index=False, float_format="%.6g")
        print(laws.to_string(index=False))
        print("largest |z| per campaign:", laws.groupby("campaign")["z"].apply(lambda z: float(np.abs(z).max())).to_dict())
    if (folder("o_plugin") / "N2" / "diagnosis" / "span_effects.csv").exists():
        plugin = plugin_against_truth()
        plugin.to_csv(out / "open_world_plugin.csv", index=False, float_format="%.6g")
        print(plugin.to_string(index=False))


if __name__ == "__main__":
    main()
