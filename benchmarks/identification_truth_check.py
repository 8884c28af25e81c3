"""End-to-end check of the identification against the default campaign's truth (not run by
``make bench``: it needs ``results/campaign/truth.parquet`` from a default run).

Data: the truth's static W (``static_w*_m``, solved on the whole section: wires continuous over
the masts) of the 117 N2 and 60 N3 spans — what a perfect correction would hand over. The
truth (``config/campaign.yaml``): per-span T_MW normal with σ = 818 N (hidden effect
``messenger_tension_variability``), ΔH Gamma with σ = 6.5 mm drawn per mast (adjacent spans
share it), dropper lengths Gamma with the Table 2 σ. Issue targets: T_MW σ within 25 %, ΔH σ
within 50 % of the truth.

For each span type and each ΔH mode (``independent``: ΔH_left, ΔH_right independent draws of
the ΔH law, the config default; ``shared``: one ΔH per span, the paper's model) it runs the
rule's identification (config defaults, N = 1e4, Nelder–Mead) on

* the section W of the truth (the pipeline's case), and
* the single-span W of the same true parameters (fast model: no model error), which separates
  the statistical error from the effect of wire continuity over the masts.

Prints a table and writes ``results/identification_truth_check.json``.
"""

from record import ROOT  # noqa: I001  (sets one BLAS thread first)

import json
import time

import numpy as np
import pandas as pd

from catenary.config import load_catenary
from catenary.identification.fit import make_likelihood
from catenary.identification.report import run_identification
from catenary.identification.settings import IdentificationSettings

TRUTH_T_MW_SIGMA_N = 818.0
TRUTH_DH_SIGMA_M = 0.0065


def main() -> None:
    catenary = load_catenary(ROOT / "config" / "catenary.yaml")
    truth = pd.read_parquet(ROOT / "results" / "campaign" / "truth.parquet")
    rows = []
    for name in ("N2", "N3"):
        st = catenary.span_type(name)
        spans = truth[truth["span_type"] == name]
        n = st.n_droppers
        section_w = spans[[f"static_w{i + 1}_m" for i in range(n)]].to_numpy()
        masts_dh = np.unique(np.r_[spans["system_height_left_m"], spans["system_height_right_m"]])
        # Single-span W of the true parameters (fast model: no continuity over the masts).
        model = make_likelihood(st, catenary, section_w, n_samples=2).model
        single_w = model.evaluate(spans[[f"dropper_{i + 1}_length_m" for i in range(n)]].to_numpy(),
                                  spans["messenger_tension_n"].to_numpy(), spans["system_height_left_m"].to_numpy(),
                                  spans["system_height_right_m"].to_numpy(), spans["contact_tension_n"].to_numpy()).w_m
        lift = section_w - single_w
        for mode in ("independent", "shared"):
            settings = IdentificationSettings.from_mapping(
                {"system_height_mode": mode, "estimators_n_samples": [1000], "band": {"n_samples": 500,
                                                                                     "n_points": 31},
                 "normality": {"n_samples": 200}})
            for data_name, data in (("section", section_w), ("single_span", single_w)):
                t0 = time.perf_counter()
                run = run_identification(st, catenary, data, settings)
                wall = time.perf_counter() - t0
                e = {x.parameter: x for x in run.result.estimates}
                t, h = e["messenger_tension_n"], e["system_height_m"]
                row = dict(span_type=name, system_height_mode=mode, data=data_name, n_spans=int(data.shape[0]),
                           t_mw_mu_n=t.mu, t_mw_mu_se_n=t.mu_se, t_mw_sigma_n=t.sigma, t_mw_sigma_se_n=t.sigma_se,
                           t_mw_sigma_error=t.sigma / TRUTH_T_MW_SIGMA_N - 1.0,
                           dh_mu_m=h.mu, dh_sigma_m=h.sigma, dh_sigma_se_m=h.sigma_se,
                           dh_sigma_error=h.sigma / TRUTH_DH_SIGMA_M - 1.0,
                           truth_sample_t_mw_sigma_n=float(spans["messenger_tension_n"].std(ddof=1)),
                           truth_sample_t_mw_mean_n=float(spans["messenger_tension_n"].mean()),
                           truth_sample_dh_sigma_m=float(np.std(masts_dh, ddof=1)),
                           dropper_sigma_m=[e[f"dropper_{i + 1}_length_m"].sigma for i in range(n)],
                           j_opt=run.result.j_opt, n_evaluations=run.result.n_evaluations,
                           n_hessian_evaluations=run.result.n_hessian_evaluations,
                           identification_s=run.identification_time_s, wall_s=wall)
                if data_name == "single_span":
                    row["continuity_lift_mean_mm"] = (1e3 * lift.mean(axis=0)).round(3).tolist()
                    row["continuity_lift_std_mm"] = (1e3 * lift.std(axis=0, ddof=1)).round(3).tolist()
                rows.append(row)
                print(f"{name} {mode:11s} {data_name:11s}: T_MW μ {t.mu:7.0f} σ {t.sigma:5.0f} ± {t.sigma_se:3.0f} N "
                      f"({100 * row['t_mw_sigma_error']:+.0f} %), ΔH μ {h.mu:.4f} σ {1e3 * h.sigma:.2f} ± "
                      f"{1e3 * h.sigma_se:.2f} mm ({100 * row['dh_sigma_error']:+.0f} %), J {run.result.j_opt:.2f}, "
                      f"{run.result.n_evaluations}+{run.result.n_hessian_evaluations} evaluations, {wall:.1f} s",
                      flush=True)
    out = ROOT / "results" / "identification_truth_check.json"
    out.write_text(json.dumps(rows, indent=2) + "\n")
    print(f"written {out}")


if __name__ == "__main__":
    main()
