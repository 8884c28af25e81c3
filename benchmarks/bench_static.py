"""Static model speed: FE solve of one span and of a 20-span section, fast-model
throughput. Targets: < 20 ms, < 0.5 s, ≥ 1e6 samples/s on one core."""

from record import ROOT, best_time_s, record  # noqa: I001  (sets one BLAS thread first)

import numpy as np

from catenary.config import load_catenary
from catenary.dropper_table import nominal_dropper_lengths
from catenary.fast import FastSpanModel
from catenary.section import single_span, uniform_section
from catenary.static import solve_static


def main() -> None:
    catenary = load_catenary(ROOT / "config" / "catenary.yaml")
    n2 = catenary.span_type("N2")
    lengths = nominal_dropper_lengths(n2, catenary).dropper_lengths_m
    one = single_span(n2, lengths)
    section = uniform_section(n2, 20, lengths)
    t_one = best_time_s(lambda: solve_static(one, catenary), repeat=20)
    t_section = best_time_s(lambda: solve_static(section, catenary), repeat=5)

    model = FastSpanModel(n2, catenary)
    rng = np.random.default_rng(0)
    n = 1_000_000
    x = lengths + 0.005 * rng.standard_normal((n, 9))
    t_mw = 20575.0 + 818.0 * rng.standard_normal(n)
    dh = 1.388 + 0.0065 * rng.standard_normal((n, 2))
    t_fast = best_time_s(lambda: model.evaluate(x, t_mw, dh[:, 0], dh[:, 1]), repeat=3)
    t_build = best_time_s(lambda: FastSpanModel(n2, catenary), repeat=3)
    figures = record({
        "fe_solve_one_span_ms": 1e3 * t_one,
        "fe_solve_20_span_section_ms": 1e3 * t_section,
        "fast_model_samples_per_s": n / t_fast,
        "fast_model_build_ms": 1e3 * t_build,
    })
    for k in ("fe_solve_one_span_ms", "fe_solve_20_span_section_ms", "fast_model_samples_per_s",
              "fast_model_build_ms"):
        print(f"{k}: {figures[k]:.4g}")


if __name__ == "__main__":
    main()
