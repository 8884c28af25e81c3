"""Diagnosis speed: one span type, every candidate, the default settings, 2 processes.

Data: 117 synthetic N2 spans of the paper's Table 2 laws with its 818 N per-span T_MW spread
(drawn through the diagnosis's own sampler, plus 0.6 mm of noise: the correction's residual),
diagnosed from the paper's first model as the default run does (design N = 10⁴; the named
spread, then a step that finds nothing). Target: < 5 min on 2 cores.
"""

from record import ROOT, record  # noqa: I001  (sets one BLAS thread first)

import time

import numpy as np
import yaml

from catenary.physics.config import load_catenary
from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.physics.measuring import force_influence
from catenary.physics.pantograph import load_pantographs
from catenary.stages.diagnosis.model import simulate_spans
from catenary.stages.diagnosis.runner import diagnose, make_sampler
from catenary.stages.diagnosis.settings import DiagnosisSettings
from catenary.stages.identification.settings import IdentificationSettings

TABLE2_SIGMA = [0.0067, 0.0050, 0.0045, 0.0045, 0.0038, 0.0044, 0.0035, 0.0034, 0.0070]


def main() -> None:
    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    catenary = load_catenary(ROOT / "config" / "catenary.yaml")
    st = catenary.span_type("N2")
    ident = IdentificationSettings.from_mapping(config["identification"])
    settings = DiagnosisSettings.from_mapping(config["diagnosis"])
    t0 = time.perf_counter()
    pantograph = load_pantographs(ROOT / "config" / "pantographs.yaml")["measuring"].with_static_force(36.0)
    g = force_influence(st, catenary, pantograph, speed_m_s=40 / 3.6, mode="dynamic", time_step_s=0.004)
    t_influence = time.perf_counter() - t0
    sampler = make_sampler(st, catenary, ident, settings, ("messenger_tension_variability",), force_influence_m_n=g)
    means = np.r_[nominal_dropper_lengths(st, catenary).dropper_lengths_m, 20575.0, 1.388]
    sigmas = np.r_[TABLE2_SIGMA, 20575e-9, 0.0065]
    data = simulate_spans(sampler, means, sigmas, {"messenger_tension_variability": {"std_n": 818.0}}, 117, seed=5,
                          noise_std_m=0.0006)
    t0 = time.perf_counter()
    run = diagnose(st, catenary, data, ident, settings, force_influence_m_n=g, workers=2)
    wall = time.perf_counter() - t0
    n_eval = sum(c.n_evaluations for s in run.steps for c in s.candidates)
    print(f"diagnosis: {[s.verdict + ' ' + (s.effect or '') for s in run.steps]} in {wall:.1f} s "
          f"(+{t_influence:.1f} s for the force influence), {n_eval} refit evaluations")
    record({"diagnosis_one_span_type_2_cores_s": wall + t_influence, "diagnosis_force_influence_s": t_influence,
            "diagnosis_refit_evaluations": n_eval, "diagnosis_steps": len(run.steps)})


if __name__ == "__main__":
    main()
