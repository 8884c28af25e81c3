"""Dynamic model speed and where its time goes.

Figures: real-time factor (simulated / wall time) of the 10-span N2 run at 300 km/h with the
reference-like pantograph, wall time of a 20-span measuring pass at 40 km/h (dynamic at the
catenary's 1 ms step and at the correction's 4 ms, and quasi-static), and the profile of the
300 km/h run and of the 4 ms measuring pass:

* ``assembly``: building the section's operators (:class:`catenary.physics.dynamics.CatenaryDynamics`);
* ``set-up``: what ``run_pantograph`` does before its time loop (factorising the effective
  stiffness, the droppers' Green's functions, the initial equilibrium);
* inside the compiled time loop, timed by running each kernel alone as often as the loop does:
  ``solve`` (one banded back-substitution per step), ``unit responses`` (two more each time the
  contact enters an element), ``M (p + κ q)`` (the right-hand side's product; no product with
  C is needed, see :func:`catenary.physics.dynamics_kernel.newmark_contact_loop`) and the rest
  (``active set and updates``: the Newmark vectors, the dropper/contact active set, outputs).

Numba's compilation is paid before any timing (a warm-up run), as a user pays it once per
installation.
"""

from record import ROOT, record  # noqa: I001  (sets one BLAS thread first)

import time

import numpy as np
from numba import njit

import catenary.physics.dynamics as dynamics
from catenary.physics.config import load_catenary
from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.physics.dynamics import CatenaryDynamics, PseudoForceSolver, run_pantograph
from catenary.physics.dynamics_kernel import band_rows, band_solve, mass_band, symmetric_band_product
from catenary.physics.measuring import measuring_pass
from catenary.physics.pantograph import load_pantographs
from catenary.physics.section import uniform_section


@njit(cache=True)
def _repeat_solve(rows, inv_diag_sq, rhs, out, count):
    for _ in range(count):
        band_solve(rows, inv_diag_sq, rhs, out)


@njit(cache=True)
def _repeat_products(m_upper, p, f, out, count):
    for _ in range(count):
        symmetric_band_product(m_upper, p, f, out)


def _timed_loop():
    """Wrap the compiled loop so that its wall time is recorded."""
    inner = dynamics.newmark_contact_loop
    spent: list[float] = []

    def loop(*args):
        start = time.perf_counter()
        result = inner(*args)
        spent.append(time.perf_counter() - start)
        return result

    return loop, spent, inner


def profile(name: str, section, catenary, pantograph, speed_m_s: float, time_step_s: float | None) -> dict:
    """Wall time of one run of ``pantograph`` over ``section`` split into its parts [s]."""
    start = time.perf_counter()
    ops = CatenaryDynamics(section, catenary)
    assembly = time.perf_counter() - start
    loop, spent, inner = _timed_loop()
    dynamics.newmark_contact_loop = loop
    try:
        start = time.perf_counter()
        run = run_pantograph(ops, pantograph, speed_m_s, time_step_s=time_step_s)
        total = time.perf_counter() - start
    finally:
        dynamics.newmark_contact_loop = inner
    dt = run.time_s[1] - run.time_s[0]
    n_steps = run.time_s.size
    beta, gamma = dynamics.NEWMARK_BETA, dynamics.NEWMARK_GAMMA
    solver = PseudoForceSolver(ops, ops.k0 + ops.mass / (beta * dt**2) + gamma / (beta * dt) * ops.damping)
    rows, inv_diag_sq = band_rows(solver.factor)
    kd = rows.shape[1] - 1
    n = ops.n_free
    rhs, out = np.random.default_rng(0).normal(size=n), np.empty(n)
    _repeat_solve(rows, inv_diag_sq, rhs, out, 1)
    start = time.perf_counter()
    _repeat_solve(rows, inv_diag_sq, rhs, out, n_steps)
    solve = time.perf_counter() - start
    elements = np.unique(np.searchsorted(ops.mesh.x_m, run.chainage_m, side="right")).size
    unit = solve * 2 * elements / n_steps
    m_upper = mass_band(ops.mass, kd)
    p = np.zeros(n + 2 * kd)
    p[kd:-kd] = rhs
    _repeat_products(m_upper, p, ops.f_const, out, 1)
    start = time.perf_counter()
    _repeat_products(m_upper, p, ops.f_const, out, n_steps)
    products = time.perf_counter() - start
    loop_s = spent[0]
    parts = {"assembly": assembly, "set_up": total - loop_s, "solve": solve, "unit_responses": unit,
             "products": products, "active_set_and_updates": loop_s - solve - unit - products}
    whole = assembly + total
    figures = {f"{name}_wall_s": whole, f"{name}_steps": n_steps, f"{name}_free_dofs": n,
               f"{name}_simulated_s": run.time_s[-1]}
    figures.update({f"{name}_{part}_percent": 100.0 * value / whole for part, value in parts.items()})
    return figures


def main() -> None:
    catenary = load_catenary(ROOT / "config" / "catenary.yaml")
    pantographs = load_pantographs(ROOT / "config" / "pantographs.yaml")
    n2 = catenary.span_type("N2")
    lengths = nominal_dropper_lengths(n2, catenary).dropper_lengths_m
    # Warm-up: Numba compiles (or loads from its cache) every kernel once.
    run_pantograph(CatenaryDynamics(uniform_section(n2, 2, lengths), catenary), pantographs["reference_2mass"],
                   300 / 3.6)

    section = uniform_section(n2, 10, lengths)
    start = time.perf_counter()
    run = run_pantograph(CatenaryDynamics(section, catenary), pantographs["reference_2mass"], 300 / 3.6)
    wall = time.perf_counter() - start
    simulated = run.time_s[-1]

    long_section = uniform_section(n2, 20, lengths)
    walls = {}
    for mode, step in (("40kmh", catenary.dynamics.time_step_s), ("40kmh_4ms", 0.004), ("quasi_static", None)):
        start = time.perf_counter()
        measuring_pass(long_section, catenary, pantographs["measuring"], speed_m_s=40 / 3.6, sampling_step_m=0.1,
                       mode="quasi_static" if step is None else "dynamic", time_step_s=step)
        walls[mode] = time.perf_counter() - start
    figures = {
        "dynamics_10_spans_300kmh_real_time_factor": simulated / wall,
        "dynamics_10_spans_300kmh_wall_s": wall,
        "measuring_pass_20_spans_40kmh_wall_s": walls["40kmh"],
        "measuring_pass_20_spans_40kmh_4ms_wall_s": walls["40kmh_4ms"],
        "measuring_pass_20_spans_quasi_static_wall_s": walls["quasi_static"],
    }
    figures.update(profile("profile_10_spans_300kmh", section, catenary, pantographs["reference_2mass"], 300 / 3.6,
                           None))
    figures.update(profile("profile_measuring_20_spans_40kmh_4ms", long_section, catenary, pantographs["measuring"],
                           40 / 3.6, 0.004))
    record(figures)
    for key, value in figures.items():
        print(f"{key}: {value:.4g}")


if __name__ == "__main__":
    main()
