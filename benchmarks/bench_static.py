"""Static model speed: FE solve of one span and of a 20-span section, fast-model
throughput. Targets: < 20 ms, < 0.5 s, ≥ 1e6 samples/s on one core. Also the evaluation of
10⁴ samples by the sampling models of the identification and the diagnosis (the span in the
line, degree SAMPLING_DEGREE in 1/T_MW, with and without a per-sample CW clamp offset): the
fast model's share of one evaluation of J."""

from record import ROOT, best_time_s, record  # noqa: I001  (sets one BLAS thread first)

import numpy as np

from catenary.physics.config import load_catenary
from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.physics.fast import SAMPLING_DEGREE, FastSpanModel
from catenary.physics.section import single_span, uniform_section
from catenary.physics.static import solve_static
from catenary.stages.diagnosis.model import OFFSET_BOUNDS_M, OFFSET_DEGREE


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
    k = 10_000                                    # the design size of J (identification, diagnosis)
    wide = (8.5e3, 37.5e3)                        # the widest T_MW range they serve [N]
    line = FastSpanModel(n2, catenary, messenger_tension_bounds_n=wide, degree=SAMPLING_DEGREE, neighbours=1)
    offset = FastSpanModel(n2, catenary, messenger_tension_bounds_n=wide, degree=SAMPLING_DEGREE, neighbours=1,
                           cw_clamp_offset_bounds_m=OFFSET_BOUNDS_M, offset_degree=OFFSET_DEGREE)
    delta = np.clip(-0.1 + 0.1 * rng.standard_normal(k), *OFFSET_BOUNDS_M)
    t_line = best_time_s(lambda: line.evaluate(x[:k], t_mw[:k], dh[:k, 0], dh[:k, 1]), repeat=20)
    t_offset = best_time_s(lambda: offset.evaluate(x[:k], t_mw[:k], dh[:k, 0], dh[:k, 1], cw_offset_m=delta),
                           repeat=10)
    figures = record({
        "fe_solve_one_span_ms": 1e3 * t_one,
        "fe_solve_20_span_section_ms": 1e3 * t_section,
        "fast_model_samples_per_s": n / t_fast,
        "fast_model_build_ms": 1e3 * t_build,
        "fast_model_sampling_10k_samples_ms": 1e3 * t_line,
        "fast_model_sampling_cw_offset_10k_samples_ms": 1e3 * t_offset,
    })
    for key in ("fe_solve_one_span_ms", "fe_solve_20_span_section_ms", "fast_model_samples_per_s",
                "fast_model_build_ms", "fast_model_sampling_10k_samples_ms",
                "fast_model_sampling_cw_offset_10k_samples_ms"):
        print(f"{key}: {figures[key]:.4g}")


if __name__ == "__main__":
    main()
