"""Fast sampling model against the FE model."""

import numpy as np
import pytest
from scipy.stats import qmc

from catenary.physics.chebyshev import fit_chebyshev
from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.physics.fast import FastSpanModel
from catenary.physics.section import single_span
from catenary.physics.static import solve_static

from .conftest import (TABLE2_DROPPER_MEAN_M, TABLE2_DROPPER_SIGMA_M, TABLE2_MESSENGER_TENSION_N,
                       TABLE2_SYSTEM_HEIGHT_M)


def table2_lhs(n, seed, width=3.0):
    """Latin-hypercube samples uniform over ±width σ of the paper's Table 2, as columns:
    9 dropper lengths, T_MW, ΔH_left, ΔH_right."""
    mean = np.r_[TABLE2_DROPPER_MEAN_M, TABLE2_MESSENGER_TENSION_N[0], TABLE2_SYSTEM_HEIGHT_M[0],
                 TABLE2_SYSTEM_HEIGHT_M[0]]
    sigma = np.r_[TABLE2_DROPPER_SIGMA_M, TABLE2_MESSENGER_TENSION_N[1], TABLE2_SYSTEM_HEIGHT_M[1],
                  TABLE2_SYSTEM_HEIGHT_M[1]]
    u = qmc.LatinHypercube(d=12, seed=seed).random(n)
    return mean + width * sigma * (2 * u - 1)


def test_fast_model_matches_fe_over_table2_lhs(catenary, n2):
    # The issue asks for < 0.1 mm; the condensation is exact and the Chebyshev interpolation
    # in 1/T converges spectrally, so the agreement is checked at 1e-6 m (measured ≈ 4e-9 m).
    x = table2_lhs(200, seed=11)
    model = FastSpanModel(n2, catenary)
    fast = model.evaluate(x[:, :9], x[:, 9], x[:, 10], x[:, 11])
    worst = 0.0
    for i in range(200):
        sol = solve_static(single_span(n2, x[i, :9], messenger_tension_n=x[i, 9], system_height_left_m=x[i, 10],
                                       system_height_right_m=x[i, 11]), catenary)
        assert fast.slack[i] == sol.any_slack
        if not sol.any_slack:
            worst = max(worst, np.max(np.abs(fast.w_m[i] - sol.dropper_deflection_m())))
            np.testing.assert_allclose(fast.dropper_force_n[i], sol.dropper_force_n, atol=1e-4)
    assert worst < 1e-6
    # Uniform ±3σ corners do slacken some droppers: both models must agree on which.
    assert 0 < fast.slack.sum() < 200


def test_fast_model_with_varying_contact_tension(catenary, n2):
    x = table2_lhs(40, seed=5)
    t_cw = np.linspace(0.8, 1.2, 40) * n2.contact_tension_n
    model = FastSpanModel(n2, catenary, contact_tension_bounds_n=(0.75 * n2.contact_tension_n,
                                                                    1.25 * n2.contact_tension_n))
    fast = model.evaluate(x[:, :9], x[:, 9], x[:, 10], x[:, 11], t_cw)
    taut = 0
    for i in range(0, 40, 4):
        sol = solve_static(single_span(n2, x[i, :9], messenger_tension_n=x[i, 9], contact_tension_n=t_cw[i],
                                       system_height_left_m=x[i, 10], system_height_right_m=x[i, 11]), catenary)
        assert fast.slack[i] == sol.any_slack
        if not sol.any_slack:
            taut += 1
            assert np.max(np.abs(fast.w_m[i] - sol.dropper_deflection_m())) < 1e-6
    # Not vacuous: most of these ±3σ cases are taut (7 of 10 with this seed; 18 % of the 40
    # samples are slack, so fewer than 5 taut of 10 would mean the draw or the flags broke).
    assert taut >= 5, taut


def test_fast_model_refuses_tension_outside_its_bounds(catenary, n2):
    model = FastSpanModel(n2, catenary, messenger_tension_bounds_n=(18000.0, 23000.0))
    lengths = nominal_dropper_lengths(n2, catenary).dropper_lengths_m[None]
    with pytest.raises(ValueError, match="messenger_tension_n.*bounds"):
        model.evaluate(lengths, 25000.0, 1.388, 1.388)


def test_fast_model_is_vectorised_and_deterministic(catenary, n2):
    x = table2_lhs(5000, seed=2)
    model = FastSpanModel(n2, catenary)
    a = model.evaluate(x[:, :9], x[:, 9], x[:, 10], x[:, 11], chunk_size=777)
    b = model.evaluate(x[:, :9], x[:, 9], x[:, 10], x[:, 11])
    np.testing.assert_allclose(a.w_m, b.w_m, rtol=0, atol=1e-15)


def test_chebyshev_interpolation_converges_spectrally():
    # exp on [0, 1] x [1, 2]: degree 12 tensor interpolation is exact to ~1e-13.
    f = lambda p: np.array([np.exp(p[0] * p[1]), np.sin(p[0]) + p[1] ** 2])
    interp = fit_chebyshev(f, [0.0, 1.0], [1.0, 2.0], 12)
    pts = np.random.default_rng(0).uniform([0, 1], [1, 2], size=(100, 2))
    exact = np.array([f(p) for p in pts])
    assert np.max(np.abs(interp(pts) - exact)) < 1e-11


def test_span_in_the_line_matches_the_central_span_of_a_section(catenary, n2):
    # The span as it hangs in the line (neighbours=1): the fast model must equal the FE model of
    # three spans, wires continuous over the masts, the central span's droppers, T_MW and ΔH
    # drawn, the neighbours at the nominal table and design ΔH, to the same 1e-6 m as the pinned
    # span (measured 8e-10 m), and flag the same slack droppers.
    import dataclasses
    from catenary.physics.section import uniform_section

    x = table2_lhs(60, seed=13)
    nominal = nominal_dropper_lengths(n2, catenary).dropper_lengths_m
    line = FastSpanModel(n2, catenary, neighbours=1)
    fast = line.evaluate(x[:, :9], x[:, 9], x[:, 10], x[:, 11])
    pinned = FastSpanModel(n2, catenary).evaluate(x[:, :9], x[:, 9], x[:, 10], x[:, 11])
    taut = 0
    for i in range(0, 60, 3):
        section = uniform_section(n2, 3, nominal, messenger_tension_n=x[i, 9])
        lengths = section.dropper_lengths_m.copy()
        lengths[9:18] = x[i, :9]
        heights = np.array([n2.system_height_m, x[i, 10], x[i, 11], n2.system_height_m])
        sol = solve_static(dataclasses.replace(section.with_dropper_lengths(lengths), system_heights_m=heights),
                           catenary)
        assert fast.slack[i] == sol.dropper_slack[9:18].any()
        if not fast.slack[i]:
            taut += 1
            assert np.max(np.abs(fast.w_m[i] - sol.dropper_deflection_m()[9:18])) < 1e-6
    assert taut >= 10, taut
    # Continuity over the masts lifts W almost uniformly: 1.17 mm (N2) at the nominal geometry
    # (1.155 mm at the end droppers, 1.175 mm inside), the lift a pinned identification model
    # puts into its ΔH mean. Over these ±3σ draws it stays within 1.07–1.38 mm (measured), and
    # varies along one span by < 0.05 mm.
    ok = ~fast.slack & ~pinned.slack
    lift = fast.w_m[ok] - pinned.w_m[ok]
    assert np.all((lift > 0.9e-3) & (lift < 1.5e-3)), (lift.min(), lift.max())
    assert np.max(np.ptp(lift, axis=1)) < 0.05e-3
    # One neighbour each side is enough: two change W by < 1 µm (measured 0.9 µm against three).
    two = FastSpanModel(n2, catenary, neighbours=2).evaluate(x[:, :9], x[:, 9], x[:, 10], x[:, 11])
    assert np.max(np.abs(two.w_m[ok] - fast.w_m[ok])) < 1.5e-6


def test_slack_droppers_solved_match_the_fe_active_set(catenary, n2):
    # Droppers a few centimetres too long or short go slack (a long one sheds its load, a short
    # central one unloads its neighbours). With slack="solve" the fast model must give the FE
    # model's W and dropper forces (its active set solved by the FE code itself), to 2e-6 m and
    # 0.01 N: the compliance step's error on a changed load path (measured 1.7e-6 m, 0.008 N).
    import dataclasses

    from catenary.physics.section import uniform_section

    nominal = nominal_dropper_lengths(n2, catenary).dropper_lengths_m
    model = FastSpanModel(n2, catenary, neighbours=1, degree=14)
    rng = np.random.default_rng(1)
    n_slack = 0
    for case in range(10):
        lengths = nominal + rng.normal(0.0, 0.004, 9)
        lengths[rng.integers(0, 9)] += rng.choice([0.02, 0.03, -0.03])
        t_mw = 20575.0 + rng.normal(0.0, 800.0)
        dh = 1.388 + rng.normal(0.0, 0.006, 2)
        fast = model.evaluate(lengths[None], np.r_[t_mw], dh[:1], dh[1:], slack="solve")
        section = uniform_section(n2, 3, nominal, messenger_tension_n=t_mw)
        all_lengths = section.dropper_lengths_m.copy()
        all_lengths[9:18] = lengths
        sol = solve_static(dataclasses.replace(section.with_dropper_lengths(all_lengths),
                                               system_heights_m=np.r_[n2.system_height_m, dh, n2.system_height_m]),
                           catenary)
        assert fast.slack[0] == sol.dropper_slack[9:18].any()
        assert np.array_equal(fast.dropper_force_n[0] <= 0, sol.dropper_slack[9:18])
        assert np.max(np.abs(fast.w_m[0] - sol.dropper_deflection_m()[9:18])) < 2e-6
        assert np.max(np.abs(fast.dropper_force_n[0] - sol.dropper_force_n[9:18])) < 0.01
        n_slack += int(sol.dropper_slack[9:18].any())
    assert n_slack >= 4, n_slack           # the cases exercise the slack path
