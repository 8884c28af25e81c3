"""The validation table of docs/identification.md: campaigns of known truth through the whole pipeline.

For each results folder given (default: the default run's ``results`` and the three campaigns
of ``make validate`` under ``results/validate/``), reads the identification check
(``validation/identification_check.csv``: estimate, standard error, realized truth, z) and the
profile intervals of ``{span_type}/identification/s_opt.csv``, and the correction check
(``validation/correction_check.csv``: corrected minus true static W). Prints a Markdown table of
T_MW and ΔH μ and σ (truth realized, estimate ± se, 95 % profile interval, z) and writes it to
``results/validate/validation_table.md`` with a JSON twin.
"""

from record import ROOT  # noqa: I001  (sets one BLAS thread first)

import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd

DEFAULT_FOLDERS = ("results", "results/validate/v1_wide", "results/validate/v2_null", "results/validate/v3_n3")
ROWS = (("messenger_tension_n", "mu", "T_MW μ", "N", 1.0), ("messenger_tension_n", "sigma", "T_MW σ", "N", 1.0),
        ("system_height_m", "mu", "ΔH μ", "mm", 1e3), ("system_height_m", "sigma", "ΔH σ", "mm", 1e3))


def _fmt(value: float, unit: str) -> str:
    return f"{value:,.0f}".replace(",", " ") if unit == "N" else f"{value:.2f}"


def folder_rows(folder: Path) -> list[dict]:
    check = pd.read_csv(folder / "validation" / "identification_check.csv")
    correction = pd.read_csv(folder / "validation" / "correction_check.csv")
    out = []
    for span_type, group in check.groupby("span_type"):
        s_opt = pd.read_csv(folder / span_type / "identification" / "s_opt.csv").set_index("parameter")
        rms = float(correction.loc[correction["span_type"] == span_type, "rms_corrected_vs_static_m"].iloc[0])
        for parameter, statistic, label, unit, scale in ROWS:
            row = group[(group["parameter"] == parameter) & (group["statistic"] == statistic)].iloc[0]
            low, high = (s_opt.loc[parameter, f"{statistic}_profile_low"],
                         s_opt.loc[parameter, f"{statistic}_profile_high"])
            out.append(dict(campaign=folder.name if folder.name != "results" else "default", span_type=span_type,
                            n_spans=int(row["n_spans"]), quantity=label, unit=unit,
                            realized=float(row["realized"]) * scale, estimate=float(row["estimate"]) * scale,
                            standard_error=float(row["standard_error"]) * scale,
                            profile_low=float(low) * scale, profile_high=float(high) * scale,
                            z=float(row["z"]), status=str(row["status"]),
                            no_spread=bool(s_opt.loc[parameter, "no_spread_detected"]) if statistic == "sigma" else False,
                            correction_rms_mm=1e3 * rms))
    return out


def main(folders: list[Path]) -> None:
    rows = [r for f in folders for r in folder_rows(f)]
    rms = {(r["campaign"], r["span_type"]): r["correction_rms_mm"] for r in rows}
    lines = ["Correction, RMS of corrected minus true static W: "
             + ", ".join(f"{c} {t} {v:.2f} mm" for (c, t), v in rms.items()) + ".", "",
             "| campaign | type, spans | quantity | truth (realized) | estimate ± se | 95 % profile interval | z |",
             "|---|---|---|---:|---:|---|---:|"]
    for r in rows:
        u = r["unit"]
        interval = f"[{_fmt(r['profile_low'], u)}, {_fmt(r['profile_high'], u)}] {u}"
        if r["no_spread"]:
            interval += " (no spread)"
        if np.isfinite(r["standard_error"]):
            estimate, z = f"{_fmt(r['estimate'], u)} ± {_fmt(r['standard_error'], u)}", f"{r['z']:+.2f}"
        else:                        # a σ on the box edge: no standard error (the profile interval holds)
            estimate, z = f"{_fmt(r['estimate'], u)} (boundary, no se)", "—"
        lines.append(f"| {r['campaign']} | {r['span_type']}, {r['n_spans']} | {r['quantity']} | "
                     f"{_fmt(r['realized'], u)} {u} | {estimate} | {interval} | {z} |")
    text = "\n".join(lines) + "\n"
    print(text)
    out = ROOT / "results" / "validate" / "validation_table.md"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    out.with_suffix(".json").write_text(json.dumps(rows, indent=2) + "\n")
    print(f"written {out}")


if __name__ == "__main__":
    main([ROOT / f for f in (sys.argv[1:] or DEFAULT_FOLDERS)])
