"""Statistical identification speed: J(s) at N = 1e3…1e6, the whole identification
at N = 1e4 (Nelder–Mead and BOBYQA), peak memory of J at N = 1e6, and the Monte Carlo spread of
J at s_opt over 20 design seeds for the LHS and Sobol designs.

Targets: J < 2 ms at N = 1e3, < 0.2 s at N = 1e5; identification < 1 min at N = 1e4. Also the
rule's identification on the default campaign's N2 line (span in the line, sandwich standard
errors) and the cost of its profile intervals of T_MW and ΔH (μ and σ) at N = 1e4.
Data: 117 synthetic N2 spans under the paper's Table 2 laws (data seed 123, design seed 1).

Memory (N = 1e6) is measured in a fresh subprocess: ``identification_peak_memory_n1e6_mb`` is
its peak resident set size (``resource.getrusage(RUSAGE_SELF).ru_maxrss``: interpreter and
libraries ≈ 220 MB, fast model, the stored design u and z of 2 × 88 MB (default Sobol design),
and one J evaluation);
``identification_j_traced_peak_n1e6_mb`` is the tracemalloc peak of one J call alone (the
temporaries J allocates on top of the design).
"""

from record import ROOT, best_time_s, record  # noqa: I001  (sets one BLAS thread first)

import json
import subprocess
import sys
import time

import numpy as np

from catenary.measurement.truth import load_truth
from catenary.physics.config import load_catenary
from catenary.stages.identification.design import default_inputs
from catenary.stages.identification.fit import identify, make_likelihood
from catenary.stages.identification.profile import profile_intervals
from catenary.stages.identification.settings import IdentificationSettings
from catenary.stages.identification.synthetic import line_deflections, simulate_deflections

TABLE2_DROPPER_SIGMA_M = [0.0067, 0.0050, 0.0045, 0.0045, 0.0038, 0.0044, 0.0035, 0.0034, 0.0070]

MEMORY_PROBE = r"""
import json, resource, tracemalloc
import numpy as np
from catenary.physics.config import load_catenary
from catenary.stages.identification.design import default_inputs
from catenary.stages.identification.fit import make_likelihood
catenary = load_catenary({config!r})
n2 = catenary.span_type("N2")
start = default_inputs(n2, catenary)
data = np.asarray({data!r})
lik = make_likelihood(n2, catenary, data, start=start, n_samples=1_000_000, seed=1)
means = np.array([s.mean for s in start]); sigmas = np.array([s.sigma for s in start])
tracemalloc.start()
j = lik(means, sigmas)
_, traced = tracemalloc.get_traced_memory()
tracemalloc.stop()
print(json.dumps({{"rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                   "traced_mb": traced / 2**20, "j": j}}))
"""


def table2_truth(start):
    means = np.array([s.mean for s in start])
    means[9], means[10] = 20575.0, 1.388
    return means, np.r_[TABLE2_DROPPER_SIGMA_M, 818.0, 0.0065]


def main() -> None:
    catenary = load_catenary(ROOT / "config" / "catenary.yaml")
    n2 = catenary.span_type("N2")
    start = default_inputs(n2, catenary, messenger_tension_mean_n=20_000.0, system_height_mean_m=1.40)
    truth = table2_truth(start)
    model = make_likelihood(n2, catenary, np.zeros((1, 9)), start=start, n_samples=2).model
    data = simulate_deflections(model, *truth, 117, seed=123)
    figures = {}

    for n, tag, repeat in ((1_000, "1e3", 200), (10_000, "1e4", 50), (100_000, "1e5", 10),
                           (1_000_000, "1e6", 3)):
        lik = make_likelihood(n2, catenary, data, start=start, n_samples=n, seed=1)
        figures[f"identification_j_eval_n{tag}_ms"] = 1e3 * best_time_s(lambda: lik(*truth), repeat=repeat)
        if n <= 10_000:
            kern = make_likelihood(n2, catenary, data, start=start, n_samples=n, seed=1, estimator="kernel")
            figures[f"identification_j_eval_kernel_n{tag}_ms"] = 1e3 * best_time_s(lambda: kern(*truth), repeat=5)

    lik = make_likelihood(n2, catenary, data, start=start, n_samples=10_000, seed=1)
    results = {}
    for method, key in (("nelder-mead", ""), ("bobyqa", "_bobyqa")):
        t0 = time.perf_counter()
        r = identify(lik, start, method=method)
        figures[f"identification_total{key}_n1e4_s"] = time.perf_counter() - t0
        figures[f"identification_evaluations{key}_n1e4"] = r.n_evaluations
        figures[f"identification_hessian_evaluations{key}_n1e4"] = r.n_hessian_evaluations
        figures[f"identification_j_opt{key}_n1e4"] = r.j_opt
        results[method] = r
    figures["identification_j_opt_bobyqa_minus_nelder_mead"] = results["bobyqa"].j_opt - results["nelder-mead"].j_opt

    # Monte Carlo spread of J(s_opt) over 20 design seeds, LHS vs scrambled Sobol (N = 1e4).
    s_opt = (results["nelder-mead"].means, results["nelder-mead"].sigmas)
    for method in ("lhs", "sobol"):
        js = [make_likelihood(n2, catenary, data, start=start, n_samples=10_000, seed=100 + k,
                              design_method=method)(*s_opt) for k in range(20)]
        figures[f"identification_j_spread_{method}_n1e4"] = float(np.std(js, ddof=1))
        figures[f"identification_j_mean_{method}_n1e4"] = float(np.mean(js))

    # As the rule runs it on a line: 117 N2 spans of the default campaign (static section W, wires
    # continuous, masts shared), the span in the line, sandwich over the spans sharing a mast,
    # then the profile intervals of T_MW and ΔH (4 coordinates) at N = 1e4.
    spec = load_truth(ROOT / "config" / "campaign.yaml", catenary)
    line = line_deflections(spec, catenary, "N2", seed=spec.seed)
    settings = IdentificationSettings()
    s0 = settings.start_inputs(n2, catenary)
    lik = make_likelihood(n2, catenary, line.w_m, start=s0, n_samples=10_000, seed=1, neighbours=1,
                          system_height_mode=settings.system_height_mode)
    t0 = time.perf_counter()
    r = identify(lik, s0, free_sigmas=settings.random_names(9), mast_pairs=line.mast_pairs, covariance="sandwich")
    figures["identification_line_sandwich_n1e4_s"] = time.perf_counter() - t0
    figures["identification_line_evaluations_n1e4"] = r.n_evaluations + r.n_hessian_evaluations
    t0 = time.perf_counter()
    profiles = profile_intervals(lik, s0, r, parameters=("messenger_tension_n", "system_height_m"),
                                 max_evaluations=settings.profile_max_evaluations)
    figures["identification_profile_intervals_4_parameters_n1e4_s"] = time.perf_counter() - t0
    figures["identification_profile_intervals_evaluations_n1e4"] = sum(p.n_evaluations for p in profiles)

    probe = MEMORY_PROBE.format(config=str(ROOT / "config" / "catenary.yaml"), data=data.tolist())
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    mem = json.loads(out.stdout.strip().splitlines()[-1])
    figures["identification_peak_memory_n1e6_mb"] = mem["rss_mb"]
    figures["identification_j_traced_peak_n1e6_mb"] = mem["traced_mb"]

    record(figures)
    for k, v in figures.items():
        print(f"{k}: {v:.4g}")


if __name__ == "__main__":
    main()
