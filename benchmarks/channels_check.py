"""``make validate``: issue [17]'s campaigns with measurements besides the height, against their truth.

* ``c_ambiguous`` (a T_MW spread of 400 N and a worn CW, height only): ambiguous, and the
  recommended measurement for the ambiguity is the wear channel;
* ``c_ambiguous_wear`` (the same line with the wear channel): both effects named, each size
  within 3 standard errors of the realized one;
* ``c_null`` (no effect, every channel and a survey of every kind): nothing named;
* ``c_car`` (a car pushing 3 N more than declared, height only): the car's question recommends
  the measuring force;
* ``c_car_calibrated`` (the same, the force calibrated): the force offset named within 3
  standard errors of the planted 3 N.

Reads each campaign's ``validation/diagnosis_check.csv`` and ``N2/diagnosis/recommendations.csv``;
writes ``results/validation/channels.csv`` (one row per campaign: what was asked, what came out,
whether it holds) and exits non-zero on a miss. Usage: ``python benchmarks/channels_check.py``.
"""

from __future__ import annotations

import sys

import pandas as pd

from record import ROOT

CAMPAIGNS = ("c_ambiguous", "c_ambiguous_wear", "c_null", "c_car", "c_car_calibrated")
Z_MAX = 3.0


def _read(name: str):
    folder = ROOT / "results" / "validate" / name
    check = pd.read_csv(folder / "validation" / "diagnosis_check.csv")
    recs = pd.read_csv(folder / "N2" / "diagnosis" / "recommendations.csv")
    return check, recs


def _named(check: pd.DataFrame) -> list[str]:
    return list(dict.fromkeys(check.loc[check["verdict"] == "named", "effect"].dropna()))


def _sizes(check: pd.DataFrame) -> str:
    rows = check[check["verdict"] == "named"].dropna(subset=["parameter"])
    return "; ".join(f"{r.effect} {r.parameter} {r.identified:.4g} ± {r.standard_error:.2g} (realized "
                     f"{r.realized_magnitude:.4g}, z {r.z:+.2f})" for r in rows.itertuples())


def main() -> None:
    rows = []
    for name in CAMPAIGNS:
        check, recs = _read(name)
        named = _named(check)
        verdicts = ", ".join(f"step {r.step} {r.verdict} {r.effect if isinstance(r.effect, str) else ''}"
                             + (f" / {r.runner_up}" if r.verdict == "ambiguous" else "")
                             for r in check.drop_duplicates("step").itertuples())
        chosen = recs[recs["recommended"]]
        if name == "c_ambiguous":
            amb = chosen[chosen["kind"] == "ambiguous"]
            option = amb["option"].iloc[0] if len(amb) else ""
            ok = (check["verdict"] == "ambiguous").any() and option == "wear_channel"
            what = f"{verdicts}; recommended for the ambiguity: {option or 'none'}" + (
                f" (power {amb['power'].iloc[0]:.2f}, {amb['cost_h'].iloc[0]:.3g} h)" if len(amb) else "")
        elif name == "c_ambiguous_wear":
            sized = check[(check["verdict"] == "named") & check["parameter"].notna()]
            want = {"messenger_tension_variability", "contact_wire_wear"}
            ok = want <= set(named) and bool((sized["z"].abs() <= Z_MAX).all())
            what = f"{verdicts}; {_sizes(check)}"
        elif name == "c_null":
            ok = not named
            what = verdicts
        elif name == "c_car":
            car = chosen[chosen["kind"] == "car"]
            option = car["quantity"].iloc[0] if len(car) else ""
            ok = option == "measuring_force_n"
            what = f"{verdicts}; the car's question recommends: {car['option'].iloc[0] if len(car) else 'none'}" + (
                f" (power {car['power_full'].iloc[0]:.2f})" if len(car) else "")
        else:
            force = check[(check["effect"] == "measuring_force_offset") & (check["verdict"] == "named")]
            ok = len(force) > 0 and bool((force["z"].abs() <= Z_MAX).all())
            what = f"{verdicts}; {_sizes(check)}"
        rows.append({"campaign": name, "holds": bool(ok), "named": ", ".join(named), "what": what})
        print(f"{name}: {'holds' if ok else 'MISS'} — {what}")
    out = ROOT / "results" / "validation" / "channels.csv"
    out.parent.mkdir(parents=True, exist_ok=True)
    table = pd.DataFrame(rows)
    table.to_csv(out, index=False)
    if not table["holds"].all():
        sys.exit("channels check: " + ", ".join(table.loc[~table["holds"], "campaign"]) + " missed")


if __name__ == "__main__":
    main()
