"""Dynamic model speed: real-time factor (simulated / wall time) of the 10-span run
at 300 km/h (target ≥ 1 on one core) and wall time of a 20-span measuring pass at 40 km/h."""

from record import ROOT, record  # noqa: I001  (sets one BLAS thread first)

import time

from catenary.config import load_catenary
from catenary.dropper_table import nominal_dropper_lengths
from catenary.dynamics import CatenaryDynamics, run_pantograph
from catenary.measuring import measuring_pass
from catenary.pantograph import load_pantographs
from catenary.section import uniform_section


def main() -> None:
    catenary = load_catenary(ROOT / "config" / "catenary.yaml")
    pantographs = load_pantographs(ROOT / "config" / "pantographs.yaml")
    n2 = catenary.span_type("N2")
    lengths = nominal_dropper_lengths(n2, catenary).dropper_lengths_m

    section = uniform_section(n2, 10, lengths)
    start = time.perf_counter()
    run = run_pantograph(CatenaryDynamics(section, catenary), pantographs["reference_2mass"], 300 / 3.6)
    wall = time.perf_counter() - start
    simulated = run.time_s[-1]

    long_section = uniform_section(n2, 20, lengths)
    start = time.perf_counter()
    measuring_pass(long_section, catenary, pantographs["measuring"], speed_m_s=40 / 3.6, sampling_step_m=0.1)
    measuring_wall = time.perf_counter() - start
    start = time.perf_counter()
    measuring_pass(long_section, catenary, pantographs["measuring"], speed_m_s=40 / 3.6, sampling_step_m=0.1,
                   mode="quasi_static")
    quasi_static_wall = time.perf_counter() - start
    figures = record({
        "dynamics_10_spans_300kmh_real_time_factor": simulated / wall,
        "dynamics_10_spans_300kmh_wall_s": wall,
        "measuring_pass_20_spans_40kmh_wall_s": measuring_wall,
        "measuring_pass_20_spans_quasi_static_wall_s": quasi_static_wall,
    })
    for k in ("dynamics_10_spans_300kmh_real_time_factor", "dynamics_10_spans_300kmh_wall_s",
              "measuring_pass_20_spans_40kmh_wall_s", "measuring_pass_20_spans_quasi_static_wall_s"):
        print(f"{k}: {figures[k]:.4g}")


if __name__ == "__main__":
    main()
