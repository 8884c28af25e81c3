"""Cost of the per-span answers (issue [14]).

* the posteriors: on 117 spans drawn from the paper's Table 2 laws (N2, ΔH per mast, 0.6 mm of
  noise), with the default maintenance settings (4000 importance draws per span, 1 % fault
  component): the wall time of the modes (Gauss–Newton from the prior's centre and the
  single-fault starts) and of the whole posterior, its peak memory, and the effective sample size
  (median and minimum);
* the population's posterior band: the same spans' posteriors with 200 draws kept per span, the
  prior and posterior bands along the span (235 abscissae, 4000 prior samples) and the
  leave-one-out coverage;
* what fixing buys: the default run's N2 list (made with Snakemake when missing), its windows
  run as measured and repaired at the operating speeds.
"""

from record import ROOT, record  # noqa: I001  (sets one BLAS thread first)

import dataclasses
import subprocess
import sys
import time
import tracemalloc

import numpy as np
import pandas as pd
import yaml

from catenary.physics.config import load_catenary
from catenary.physics.fast import FastSpanModel
from catenary.physics.pantograph import load_pantographs
from catenary.plumbing.parquet import read_table
from catenary.stages.contact_force.settings import ContactForceSettings
from catenary.stages.identification.band import band_abscissae
from catenary.stages.identification.design import default_inputs
from catenary.stages.maintenance.population import population_bands
from catenary.stages.maintenance.posterior import global_modes, span_posteriors
from catenary.stages.maintenance.prior import SpanPrior, messenger_tension_range_n
from catenary.stages.maintenance.repair import fixing_buys
from catenary.stages.maintenance.settings import MaintenanceSettings

CONFIG = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
N_SPANS = 117


def main() -> None:
    catenary = load_catenary(ROOT / CONFIG["catenary"])
    n2 = catenary.span_type("N2")
    settings = MaintenanceSettings.from_mapping(CONFIG["maintenance"])
    means = np.array([r.mean for r in default_inputs(n2, catenary)])
    means[-2:] = 20575.0, 1.388
    sigmas = np.r_[0.0067, 0.0050, 0.0045, 0.0045, 0.0038, 0.0044, 0.0035, 0.0034, 0.0070, 818.0, 0.0065]
    model = FastSpanModel(n2, catenary, messenger_tension_bounds_n=messenger_tension_range_n(means[-2], sigmas[-2]),
                          degree=14, neighbours=1)
    prior = SpanPrior(model, means, sigmas, "independent", settings.fault_probability, settings.fault_std_m)
    rng = np.random.default_rng(1)
    z = rng.standard_normal((N_SPANS, prior.dimension))
    w = prior.deflections(z)[0] + settings.measurement_noise_m * rng.standard_normal((N_SPANS, 9))
    noise = settings.measurement_noise_m**2 * np.eye(9)
    l_inv = np.broadcast_to(np.eye(9) / settings.measurement_noise_m, (N_SPANS, 9, 9))
    start = time.perf_counter()
    global_modes(prior, w, l_inv)
    modes_s = time.perf_counter() - start
    tracemalloc.start()
    start = time.perf_counter()
    post = span_posteriors(prior, w, noise, n_samples=settings.n_samples, seed=settings.seed)
    total_s = time.perf_counter() - start
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    no_fault = dataclasses.replace(prior, fault_probability=0.0)
    start = time.perf_counter()
    span_posteriors(no_fault, w, noise, n_samples=settings.n_samples, seed=settings.seed)
    plain_s = time.perf_counter() - start
    drawn = span_posteriors(prior, w, noise, n_samples=settings.n_samples, seed=settings.seed,
                            n_draws=settings.band_draws_per_span)
    start = time.perf_counter()
    population_bands(prior, drawn.draws_z, w, np.broadcast_to(noise, (N_SPANS, 9, 9)), x_m=band_abscissae(n2, 235),
                     level=0.98, n_prior_samples=4000, design_method="sobol", seed=2)
    band_s = time.perf_counter() - start
    folder = ROOT / CONFIG["results"] / "N2" / "maintenance"
    if not (folder / "maintenance.csv").exists():
        subprocess.run([sys.executable, "-m", "snakemake", "--cores", "2", "--",
                        str((folder / "maintenance.csv").relative_to(ROOT))], cwd=ROOT, check=True)
    cf = ContactForceSettings.from_mapping(CONFIG["contact_force"])
    pantograph = load_pantographs(ROOT / CONFIG["pantographs"])[cf.pantograph]
    start = time.perf_counter()
    table, _ = fixing_buys(read_table(folder / "posterior.parquet"), pd.read_csv(folder / "maintenance.csv"), n2,
                           catenary, pantograph, cf)
    repair_s = time.perf_counter() - start
    figures = record({
        "maintenance_repair_default_n2_s": repair_s,
        "maintenance_repair_runs": float(len(table)),
        "maintenance_modes_117_spans_s": modes_s,
        "maintenance_posterior_117_spans_s": total_s,
        "maintenance_posterior_no_fault_component_117_spans_s": plain_s,
        "maintenance_posterior_peak_memory_mb": peak / 2**20,
        "maintenance_population_band_117_spans_s": band_s,
        "maintenance_effective_samples_median": float(np.median(post.effective_samples)),
        "maintenance_effective_samples_min": float(np.min(post.effective_samples)),
    })
    for key in sorted(k for k in figures if k.startswith("maintenance_")):
        print(f"{key}: {figures[key]:.4g}")


if __name__ == "__main__":
    main()
