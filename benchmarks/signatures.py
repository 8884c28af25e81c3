"""Signatures of the candidate effects on W at realistic sizes (docs/diagnosis.md).

Not run by ``make bench`` (``make validate`` runs it). For the N2 span in the line at the paper's
Table 2 laws (T_MW not random), the model sample of W (N = 2e4, the diagnosis's sampler) with
each candidate at its realistic size, against the sample without it:

* the mean shift of W per dropper [mm] and its largest value;
* the covariance change: the largest eigenvalue of ΔΣ and its eigenvector (the direction the
  effect spreads W along) as a standard deviation [mm], and the cosine of that direction with
  the T_MW spread's (1: the same signature);
* the paper's Fig. 9 comparison: the CW shift δ whose mid-span W change equals that of
  +500 N of T_MW (the paper: 2 cm), from deterministic single spans at the nominal table.

Writes ``results/signatures.json`` and prints a table.
"""

from record import ROOT  # noqa: I001  (sets one BLAS thread first)

import json

import numpy as np
from scipy import optimize

from catenary.physics.config import load_catenary
from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.physics.fast import FastSpanModel
from catenary.physics.measuring import force_influence
from catenary.physics.pantograph import load_pantographs
from catenary.stages.diagnosis.candidates import CANDIDATES
from catenary.stages.diagnosis.runner import make_sampler
from catenary.stages.diagnosis.settings import DiagnosisSettings
from catenary.stages.identification.design import draw_unit_design
from catenary.stages.identification.settings import IdentificationSettings

TABLE2_SIGMA = [0.0067, 0.0050, 0.0045, 0.0045, 0.0038, 0.0044, 0.0035, 0.0034, 0.0070]


def main() -> None:
    catenary = load_catenary(ROOT / "config" / "catenary.yaml")
    st = catenary.span_type("N2")
    ident = IdentificationSettings.from_mapping({})
    settings = DiagnosisSettings.from_mapping({"n_samples": 20000})
    pantograph = load_pantographs(ROOT / "config" / "pantographs.yaml")["measuring"].with_static_force(36.0)
    g = force_influence(st, catenary, pantograph, speed_m_s=40 / 3.6, mode="dynamic", time_step_s=0.004)
    nominal = nominal_dropper_lengths(st, catenary).dropper_lengths_m
    means = np.r_[nominal, 20575.0, 1.388]
    sigmas = np.r_[TABLE2_SIGMA, 20575e-9, 0.0065]
    names = [c for c in CANDIDATES if c != "wire_continuity"]
    out = {}
    directions = {}
    for name in names:
        sampler = make_sampler(st, catenary, ident, settings, (name,), force_influence_m_n=g)
        z = draw_unit_design(20000, sampler.dimension, seed=3).z
        mags = {name: {p.name: p.realistic for p in CANDIDATES[name].parameters}}
        w0, _ = sampler(z, means, sigmas, {name: CANDIDATES[name].null()})
        w1, _ = sampler(z, means, sigmas, mags)
        shift = 1e3 * (w1.mean(axis=0) - w0.mean(axis=0))
        d_cov = np.cov(1e3 * w1, rowvar=False) - np.cov(1e3 * w0, rowvar=False)
        vals, vecs = np.linalg.eigh(d_cov)
        k = int(np.argmax(np.abs(vals)))
        v = vecs[:, k] * np.sign(vecs[4, k] or 1.0)
        directions[name] = v
        out[name] = {"magnitudes": mags[name], "mean_shift_mm": shift.round(4).tolist(),
                     "largest_mean_shift_mm": float(np.abs(shift).max()),
                     "spread_std_mm": float(np.sign(vals[k]) * np.sqrt(abs(vals[k]))),
                     "spread_direction": v.round(3).tolist()}
    ref = directions["messenger_tension_variability"]
    for name in names:
        out[name]["cosine_with_tension_spread"] = float(abs(directions[name] @ ref))
    # Paper Fig. 9: mid-span W change of +500 N T_MW, and the CW shift that matches it.
    base = FastSpanModel(st, catenary, neighbours=1, degree=14)
    dw_tension = 1e3 * (base.evaluate(nominal[None], 21075.0, 1.4, 1.4).w_m[0, 4]
                        - base.evaluate(nominal[None], 20575.0, 1.4, 1.4).w_m[0, 4])
    shifted = FastSpanModel(st, catenary, neighbours=1, degree=14, cw_clamp_offset_bounds_m=(0.0, 0.3))

    def dw_shift(delta):
        return 1e3 * (shifted.evaluate(nominal[None], 20575.0, 1.4, 1.4, cw_offset_m=delta).w_m[0, 4]
                      - shifted.evaluate(nominal[None], 20575.0, 1.4, 1.4, cw_offset_m=0.0).w_m[0, 4])

    delta = optimize.brentq(lambda d: dw_shift(d) - dw_tension, 1e-3, 0.3)
    out["paper_fig9"] = {"tension_500n_midspan_mm": dw_tension, "equivalent_cw_shift_m": delta,
                         "cw_shift_2cm_midspan_mm": dw_shift(0.02)}
    print("| candidate (realistic size) | largest mean shift [mm] | spread σ [mm] | cos with T_MW spread |")
    print("|---|---:|---:|---:|")
    for name in names:
        r = out[name]
        size = ", ".join(f"{k} {v:g}" for k, v in r["magnitudes"].items())
        print(f"| {name} ({size}) | {r['largest_mean_shift_mm']:.3f} | {r['spread_std_mm']:.3f} | "
              f"{r['cosine_with_tension_spread']:.3f} |")
    print(f"paper Fig. 9: +500 N T_MW moves mid-span W by {dw_tension:+.2f} mm; a CW shift of "
          f"{100 * delta:.1f} cm does the same; a 2 cm shift moves it {out['paper_fig9']['cw_shift_2cm_midspan_mm']:+.3f} mm")
    path = ROOT / "results" / "signatures.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(out, indent=2) + "\n")
    print(f"written {path}")


if __name__ == "__main__":
    main()
