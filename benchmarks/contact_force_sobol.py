"""Sobol indices of the contact force at a larger N than the default run's, on the dynamic model.

The default run's sensitivity (``contact_force.sensitivity.n_samples: 8``, 96 runs per span
type) has intervals too wide to check that first plus second order sum to ≈ 1. This script
takes the identified laws of a finished default run (``results/<type>/identification/s_opt.csv``
and ``diagnosis/findings.csv``), runs the same pick-freeze design (OpenTURNS'
``SobolIndicesExperiment``, seeded as the rule seeds it) at ``--n-samples`` on ``--workers``
processes through the rule's own functions, and writes the Mauntz–Kucherenko indices of σ_F and
Fm − 3σ with their bootstrap intervals (and the sum's) to
``results/validation/contact_force_sobol_<type>.csv`` and the sums into
``results/benchmarks.json``.

Usage: ``python benchmarks/contact_force_sobol.py [--span-type N2] [--n-samples 64] [--workers 2]``
(N (2·5 + 2) dynamic runs: 768 at N = 64, ≈ 4 min on 2 cores).
"""

from record import ROOT, record  # noqa: I001  (sets one BLAS thread first)

import argparse
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace

import numpy as np
import pandas as pd
import yaml

from catenary.physics.config import load_catenary
from catenary.physics.pantograph import load_pantographs
from catenary.stages.contact_force.draws import groups
from catenary.stages.contact_force.laws import read_laws
from catenary.stages.contact_force.runs import run_sobol_batch
from catenary.stages.contact_force.sensitivity import sobol_design, sobol_indices
from catenary.stages.contact_force.settings import ContactForceSettings

CONFIG = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())


def _context(span_type_name: str, n_samples: int):
    catenary = load_catenary(ROOT / CONFIG["catenary"])
    span_type = catenary.span_type(span_type_name)
    settings = replace(ContactForceSettings.from_mapping(CONFIG["contact_force"]), sensitivity_samples=n_samples)
    pantograph = load_pantographs(ROOT / CONFIG["pantographs"])[settings.pantograph]
    folder = ROOT / CONFIG["results"] / span_type_name
    laws = read_laws(folder / "identification" / "s_opt.csv", folder / "diagnosis" / "findings.csv", span_type,
                     settings.cw_height)
    return catenary, span_type, settings, pantograph, laws


def _rows(job: tuple[str, int, list[int]]) -> pd.DataFrame:
    span_type_name, n_samples, rows = job
    catenary, span_type, settings, pantograph, laws = _context(span_type_name, n_samples)
    design = sobol_design(laws, settings)
    return run_sobol_batch(laws, span_type, catenary, pantograph, settings, rows, design, settings.speeds_kmh[0])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--span-type", default="N2")
    parser.add_argument("--n-samples", type=int, default=64)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    _, _, settings, _, laws = _context(args.span_type, args.n_samples)
    design = sobol_design(laws, settings)
    chunks = [c.tolist() for c in np.array_split(np.arange(design.shape[0]), 4 * args.workers)]
    start = time.perf_counter()
    with ProcessPoolExecutor(args.workers) as pool:
        runs = pd.concat(pool.map(_rows, [(args.span_type, args.n_samples, c) for c in chunks]), ignore_index=True)
    wall = time.perf_counter() - start
    runs = runs.sort_values("replicate")
    tables, figures = [], {}
    speed = settings.speeds_kmh[0]
    for criterion in ("std_force_n", "statistical_min_n"):
        r = sobol_indices(design, runs[criterion].to_numpy(float), groups(laws), args.n_samples,
                          f"{criterion} at {speed:g} km/h")
        tables.append(r.table())
        key = f"contact_force_sobol_{args.span_type}_{criterion}_n{args.n_samples}"
        figures[f"{key}_sum_first_second"] = r.sum_first_second
        figures[f"{key}_sum_first_second_low"] = r.sum_interval[0]
        figures[f"{key}_sum_first_second_high"] = r.sum_interval[1]
    figures[f"contact_force_sobol_{args.span_type}_n{args.n_samples}_wall_s"] = wall
    out = ROOT / "results" / "validation" / f"contact_force_sobol_{args.span_type}.csv"
    out.parent.mkdir(parents=True, exist_ok=True)
    table = pd.concat(tables, ignore_index=True)
    table.to_csv(out, index=False, float_format="%.4g")
    record(figures)
    print(table.to_string(index=False))
    for key, value in figures.items():
        print(f"{key}: {value:.4g}")


if __name__ == "__main__":
    main()
