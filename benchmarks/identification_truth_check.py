"""End-to-end check of the identification against a campaign's truth (not run by ``make bench``:
it needs a campaign's ``truth.parquet``, default ``results/campaign/truth.parquet`` from
``snakemake results/campaign/truth.parquet --cores 2``; another path may be given).

Data: the truth's static W (``static_w*_m``, solved on the whole section: wires continuous over
the masts) — what a perfect correction would hand over. For each span type and each span model
of the identification (``neighbours`` 1: the span in the line, the default; 0: the paper's
pinned span) it runs the rule's identification (config defaults otherwise, N = 1e4) and
compares T_MW and ΔH μ and σ with the realized truth of the spans (``z`` = (estimate − realized)
/ standard error). A pinned model puts the continuity lift of W (≈ 1.1 mm) into the ΔH mean.

Standard errors as the rule computes them (``identification.standard_errors: sandwich``: spans
that share a mast read from the truth's sections and chainages); no profile intervals.

Prints a table and writes ``identification_truth_check.json`` beside the truth file.
"""

from record import ROOT  # noqa: I001  (sets one BLAS thread first)

import json
import sys
import time
from pathlib import Path

import pandas as pd

from catenary.measurement.truth_checks import realized_truth
from catenary.physics.config import load_catenary
from catenary.stages.identification.dependence import adjacent_span_pairs
from catenary.stages.identification.runner import run_identification
from catenary.stages.identification.settings import IdentificationSettings


def main(truth_path: Path) -> None:
    catenary = load_catenary(ROOT / "config" / "catenary.yaml")
    truth = pd.read_parquet(truth_path)
    rows = []
    for name in sorted(truth["span_type"].unique()):
        st = catenary.span_type(name)
        spans = truth[truth["span_type"] == name]
        data = spans[[f"static_w{i + 1}_m" for i in range(st.n_droppers)]].to_numpy()
        realized = realized_truth(truth, spans["span_id"])
        pairs = adjacent_span_pairs(spans["section_id"], spans["start_chainage_m"], spans["end_chainage_m"])
        for neighbours in (1, 0):
            settings = IdentificationSettings.from_mapping(
                {"neighbours": neighbours, "estimators_n_samples": [1000], "profile_intervals": {"parameters": []},
                 "band": {"n_samples": 500, "n_points": 31}, "normality": {"n_samples": 200}})
            t0 = time.perf_counter()
            run = run_identification(st, catenary, data, settings, mast_pairs=pairs)
            wall = time.perf_counter() - t0
            e = {x.parameter: x for x in run.result.estimates}
            row = dict(truth=str(truth_path), span_type=name, neighbours=neighbours, n_spans=int(data.shape[0]),
                       status=run.result.status, n_evaluations=run.result.n_evaluations, wall_s=wall)
            for key, label in (("messenger_tension_n", "t_mw"), ("system_height_m", "dh")):
                est, (mean, std) = e[key], realized[key]
                row.update({f"{label}_mu": est.mu, f"{label}_mu_se": est.mu_se, f"{label}_mu_realized": mean,
                            f"{label}_mu_z": (est.mu - mean) / est.mu_se,
                            f"{label}_sigma": est.sigma, f"{label}_sigma_se": est.sigma_se,
                            f"{label}_sigma_realized": std, f"{label}_sigma_z": (est.sigma - std) / est.sigma_se})
            rows.append(row)
            print(f"{name} neighbours {neighbours}: T_MW μ {row['t_mw_mu']:.0f} ± {row['t_mw_mu_se']:.0f} "
                  f"(realized {row['t_mw_mu_realized']:.0f}, z {row['t_mw_mu_z']:+.2f}), σ {row['t_mw_sigma']:.0f} ± "
                  f"{row['t_mw_sigma_se']:.0f} (realized {row['t_mw_sigma_realized']:.0f}, z {row['t_mw_sigma_z']:+.2f}); "
                  f"ΔH μ {1e3 * row['dh_mu']:.2f} ± {1e3 * row['dh_mu_se']:.2f} mm (realized "
                  f"{1e3 * row['dh_mu_realized']:.2f}, z {row['dh_mu_z']:+.2f}), σ {1e3 * row['dh_sigma']:.2f} ± "
                  f"{1e3 * row['dh_sigma_se']:.2f} mm (realized {1e3 * row['dh_sigma_realized']:.2f}, z "
                  f"{row['dh_sigma_z']:+.2f}); {row['status']}, {run.result.n_evaluations} evaluations, {wall:.1f} s",
                  flush=True)
    out = truth_path.parent / "identification_truth_check.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(rows, indent=2) + "\n")
    print(f"written {out}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "results" / "campaign" / "truth.parquet")
