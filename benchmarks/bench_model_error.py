"""Cost of the correction's model-error budget (issue [13]).

* the shifts of the corrected W: the default campaign's sections the budget measures
  (``model_error.sections_per_span_type``), each corrected dynamically and then measured for every
  declared source, one section per process on 2 processes (as the workflow runs them): the wall
  time of the correction alone, with the budget, and the budget's time per source and section;
* the propagation to the identified parameters: every source carried to the 13 μ and σ of a
  117-span Table 2 data set at the default design size (N = 10⁴).

Needs the projected spans of the default run; they are made with Snakemake when missing.
"""

from record import ROOT, record  # noqa: I001  (sets one BLAS thread first)

import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pandas as pd
import yaml

from catenary.physics.config import load_catenary
from catenary.physics.pantograph import load_pantographs
from catenary.plumbing.parquet import read_table
from catenary.stages.correction import CorrectionSettings, correct_spans
from catenary.stages.identification.design import default_inputs
from catenary.stages.identification.fit import ScaledProblem, identify, make_likelihood
from catenary.stages.identification.propagation import parameter_shifts
from catenary.stages.identification.synthetic import simulate_deflections
from catenary.stages.model_error.correction import run_shifts
from catenary.stages.model_error.sources import ModelErrorSettings

CONFIG = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
RESULTS = ROOT / CONFIG["results"]
INPUTS = [RESULTS / t / "spans.parquet" for t in CONFIG["span_types"]]


def _spans() -> pd.DataFrame:
    return pd.concat([read_table(p).assign(span_type=t) for t, p in zip(CONFIG["span_types"], INPUTS)],
                     ignore_index=True)


def _section(job: tuple[str, bool]) -> tuple[float, float]:
    """(wall time of the correction, of the budget) of one section [s]."""
    section_id, with_budget = job
    catenary = load_catenary(ROOT / CONFIG["catenary"])
    settings = CorrectionSettings.from_mapping(CONFIG["correction"])
    pantograph = load_pantographs(ROOT / CONFIG["pantographs"])[settings.pantograph]
    budget = ModelErrorSettings.from_mapping(CONFIG["model_error"])
    spans = _spans()
    spent = [0.0]

    def measure(rows, result, panto, speed, direction, profile):
        start = time.perf_counter()
        run_shifts(rows, result, catenary, panto, speed, budget.sources, mode=settings.mode,
                   time_step_s=settings.time_step_s, direction=direction, speed_profile=profile)
        spent[0] += time.perf_counter() - start

    start = time.perf_counter()
    correct_spans(spans[spans["section_id"] == section_id], catenary, pantograph, settings,
                  after_run=measure if with_budget else None)
    return time.perf_counter() - start - spent[0], spent[0]


def _propagation_s(n_sources: int) -> float:
    catenary = load_catenary(ROOT / CONFIG["catenary"])
    n2 = catenary.span_type("N2")
    start_laws = default_inputs(n2, catenary)
    model = make_likelihood(n2, catenary, np.zeros((1, 9)), start=start_laws, n_samples=2).model
    means = np.array([s.mean for s in start_laws])
    sigmas = np.r_[np.full(9, 0.005), 818.0, 0.0065]
    data = simulate_deflections(model, means, sigmas, 117, seed=1)
    lik = make_likelihood(n2, catenary, data, start=start_laws, n_samples=10_000, seed=0)
    result = identify(lik, start_laws)
    names = tuple(s.name for s in start_laws)
    problem = ScaledProblem.for_inputs(lik, start_laws, ("messenger_tension_n", "system_height_m"), names)
    rng = np.random.default_rng(0)
    shifts = {f"s{k}": np.broadcast_to(rng.normal(0.0, 1e-4, 9), data.shape) for k in range(n_sources)}
    start = time.perf_counter()
    parameter_shifts(problem, result.theta_opt, result.theta_covariance, shifts, 0.01)
    return time.perf_counter() - start


def main() -> None:
    if not all(p.exists() for p in INPUTS):
        subprocess.run([sys.executable, "-m", "snakemake", "--cores", "2", "--"]
                       + [str(p.relative_to(ROOT)) for p in INPUTS], cwd=ROOT, check=True)
    budget = ModelErrorSettings.from_mapping(CONFIG["model_error"])
    sections = sorted(budget.measured_sections(_spans()))
    start = time.perf_counter()
    with ProcessPoolExecutor(2) as pool:
        times = list(pool.map(_section, [(s, True) for s in sections]))
    wall = time.perf_counter() - start
    per_source = [b / len(budget.sources) for _, b in times]
    figures = {
        "model_error_sections_measured": float(len(sections)),
        "model_error_sources": float(len(budget.sources)),
        "model_error_correction_and_budget_2_processes_s": wall,
        "model_error_budget_per_source_per_section_s": float(np.mean(per_source)),
        "model_error_correction_alone_per_section_s": float(np.mean([c for c, _ in times])),
        "model_error_propagation_4_sources_117_spans_s": _propagation_s(4),
    }
    figures = record(figures)
    for key in sorted(k for k in figures if k.startswith("model_error_")):
        print(f"{key}: {figures[key]:.4g}")


if __name__ == "__main__":
    main()
