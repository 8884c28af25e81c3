"""Write the reference runs of the dynamic model kept as a test fixture (tests/fixtures/).

Run once with the solver whose answers the fixture pins (it was written with the pure-Python
time loop that preceded the compiled one); ``tests/test_dynamics_reference.py`` compares
every later solver with it. Two runs, both on N2 at the nominal table:

* the 10-span section at 300 km/h with the reference-like 2-mass pantograph (contact force and
  contact-point height at every step, 1 ms), and its EN 50318 statistics between masts 3 and 7;
* the measuring pass at 40 km/h, 36 N, 2 ms over 5 spans: the heights at the central span's
  droppers and masts.
"""

from record import ROOT  # noqa: I001  (sets one BLAS thread first)

import numpy as np

from catenary.physics.config import load_catenary
from catenary.physics.contact_statistics import contact_statistics
from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.physics.dynamics import CatenaryDynamics, run_pantograph
from catenary.physics.measuring import measuring_pass
from catenary.physics.pantograph import load_pantographs
from catenary.physics.section import uniform_section

PATH = ROOT / "tests" / "fixtures" / "dynamics_reference.npz"


def reference_runs():
    catenary = load_catenary(ROOT / "config" / "catenary.yaml")
    pantographs = load_pantographs(ROOT / "config" / "pantographs.yaml")
    n2 = catenary.span_type("N2")
    lengths = nominal_dropper_lengths(n2, catenary).dropper_lengths_m
    section = uniform_section(n2, 10, lengths)
    run = run_pantograph(CatenaryDynamics(section, catenary), pantographs["reference_2mass"], 300 / 3.6)
    masts = section.mast_chainage_m
    stats = contact_statistics(run, masts[3], masts[7], masts, cutoff_hz=20.0).as_dict()
    five = uniform_section(n2, 5, lengths)
    at = np.concatenate([five.mast_chainage_m[2] + n2.dropper_positions_m, five.mast_chainage_m[2:4]])
    heights = measuring_pass(five, catenary, pantographs["measuring"].with_static_force(36.0), speed_m_s=40 / 3.6,
                             time_step_s=0.002, chainage_m=at).height_m
    # float32 keeps 5e-7 m on heights of 5 m and 1e-5 N on forces: far below the tolerances.
    return dict(force_n=run.contact_force_n.astype(np.float32), cw_height_m=run.cw_height_m.astype(np.float32),
                max_uplift_m=run.support_uplift_m.max(axis=0),
                statistics_keys=np.array(list(stats)), statistics_values=np.array(list(stats.values())),
                measuring_heights_m=heights)


if __name__ == "__main__":
    PATH.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(PATH, **reference_runs())
    print(f"written {PATH} ({PATH.stat().st_size / 1e3:.0f} kB)")
