"""Inclined droppers: the CW clamps offset along the line from the MW clamps (hidden effect
``cw_longitudinal_offset``), in the static, dynamic and fast models."""

import dataclasses

import numpy as np
import pytest

from catenary.physics.config import SteadyArm
from catenary.physics.dropper_table import dropper_lengths_for_cw_heights, nominal_dropper_lengths
from catenary.physics.dynamics import CatenaryDynamics, quasi_static_heights
from catenary.physics.fast import FastSpanModel
from catenary.physics.section import single_span, uniform_section
from catenary.physics.static import StaticModel
from catenary.plumbing.errors import ConfigError

OFFSET_M = 0.15


@pytest.fixture(scope="module")
def nominal(catenary, n2):
    return nominal_dropper_lengths(n2, catenary).dropper_lengths_m


def test_dropper_force_matches_the_exact_inclined_bar(catenary, n2, nominal):
    # Independent of the linearisation: the axial force of a bar of rest length L stretched to
    # ℓ = √(Δz² + δ²) is EA (ℓ − L)/L, its vertical part × Δz/ℓ. The FE model uses the
    # linearised vertical spring (rest √(L² − δ²), stiffness EA L_v²/L³); the two agree to second
    # order in the strain (≈ F/EA ≈ 5e-4), so 1 % of the force is a safe bound.
    section = single_span(n2, nominal).with_dropper_offsets(OFFSET_M)
    model = StaticModel(section, catenary)
    sol = model.solve()
    dz = sol.dofs[model.dropper_mw_dof] - sol.dofs[model.dropper_cw_dof]
    length = np.hypot(dz, OFFSET_M)
    exact = catenary.droppers.axial_stiffness_n * (length - nominal) / nominal * dz / length
    np.testing.assert_allclose(sol.dropper_force_n, exact, rtol=1e-2)
    # The CW clamps sit δ from the MW clamps.
    mesh = model.mesh
    np.testing.assert_allclose(mesh.x_m[mesh.cw_clamp_nodes] - mesh.x_m[mesh.dropper_nodes], OFFSET_M, atol=1e-9)
    # The shorter vertical reach δ²/2L (9–12 mm) is shared between lifting the CW and lowering
    # the MW, so the CW rises by a part of it; the supports still carry all the weight.
    vertical = StaticModel(single_span(n2, nominal), catenary).solve()
    lift = sol.dropper_deflection_m() - vertical.dropper_deflection_m()
    assert np.all(lift > 2e-3) and np.all(lift < OFFSET_M ** 2 / (2 * nominal))
    assert sol.cw_reaction_n.sum() + sol.mw_reaction_n.sum() == pytest.approx(model.total_weight_n(), rel=1e-9)


def test_mirrored_offsets_give_the_mirrored_profile(catenary, n2, nominal):
    # N2's droppers and nominal table are symmetric about mid-span: offsets +δ and the mirror
    # image −δ must give mirrored W (checks the clamp nodes on both sides of a dropper).
    assert np.allclose(n2.dropper_positions_m, n2.length_m - n2.dropper_positions_m[::-1])
    forward = StaticModel(single_span(n2, nominal).with_dropper_offsets(OFFSET_M), catenary).solve()
    backward = StaticModel(single_span(n2, nominal).with_dropper_offsets(-OFFSET_M), catenary).solve()
    np.testing.assert_allclose(forward.dropper_deflection_m(), backward.dropper_deflection_m()[::-1], atol=1e-7)


def test_inverse_recovers_inclined_dropper_lengths(catenary, n2, nominal):
    rng = np.random.default_rng(1)
    # One offset per span (as the campaign plants it): independent offsets of ±0.2 m per dropper
    # would change neighbouring reaches by up to 20 mm and slacken droppers.
    section = uniform_section(n2, 3, nominal).with_dropper_offsets(np.repeat([0.18, -0.1, 0.05], 9))
    truth = section.dropper_lengths_m + rng.normal(0.0, 0.003, 27)
    model = StaticModel(section.with_dropper_lengths(truth), catenary)
    forward = model.solve()
    assert not forward.any_slack
    heights = forward.dofs[model.dropper_cw_dof]
    found = dropper_lengths_for_cw_heights(section, catenary, heights)
    np.testing.assert_allclose(found.dropper_lengths_m, truth, atol=1e-9)


def test_fast_model_follows_the_fe_model_with_offsets(catenary, n2, nominal):
    offsets = np.linspace(-0.12, 0.2, 9)
    fast = FastSpanModel(n2, catenary, cw_clamp_offset_m=offsets)
    rng = np.random.default_rng(2)
    n = 12
    lengths = nominal + rng.normal(0.0, 0.003, (n, 9))
    t_mw = rng.uniform(19000.0, 22000.0, n)
    dh = rng.normal(1.388, 0.0065, (n, 2))
    result = fast.evaluate(lengths, t_mw, dh[:, 0], dh[:, 1])
    w_fast = result.w_m
    assert not np.any(result.slack)
    for k in range(n):
        section = single_span(n2, lengths[k], messenger_tension_n=t_mw[k], system_height_left_m=dh[k, 0],
                              system_height_right_m=dh[k, 1]).with_dropper_offsets(offsets)
        w_fe = StaticModel(section, catenary).solve().dropper_deflection_m()
        # The fast model's only approximation is the dropper weight in the force equation at
        # L_v instead of L: ½ m_d g (L − L_v) ≈ 0.01 N, times a flexibility ≈ 1e-4 m/N.
        np.testing.assert_allclose(w_fast[k], w_fe, atol=2e-6)


def test_dynamic_operator_keeps_the_static_solution_with_offsets(catenary, n2, nominal):
    # Negative offsets couple the MW at node n with the CW at node n − 1 and widen the band.
    fixed = dataclasses.replace(catenary, steady_arm=SteadyArm(None, 0.0))
    rng = np.random.default_rng(3)
    section = uniform_section(n2, 2, nominal).with_dropper_offsets(rng.uniform(-0.2, 0.2, 18))
    ops = CatenaryDynamics(section, fixed)
    static = StaticModel(section, fixed)
    # (CatenaryDynamics takes its gravity state from StaticModel.solve: comparing the two would
    # restate the code. The dynamic operator's own quasi-static solve is the independent check.)
    points = section.dropper_chainage_m[[2, 7, 12]]
    qs = quasi_static_heights(ops, points, 36.0)
    ref = [static.solve(cw_point_loads=(np.array([x]), np.array([36.0]))).cw_height_at(np.array([x]))[0]
           for x in points]
    np.testing.assert_allclose(qs, ref, atol=1e-9)


@pytest.mark.parametrize("offset, message", [(1.5, "cannot reach"), (np.ones(3), "one per dropper")])
def test_bad_offsets_are_refused(n2, nominal, offset, message):
    with pytest.raises(ConfigError, match=message):
        single_span(n2, nominal).with_dropper_offsets(offset)


def test_sub_millimetre_offsets_count_as_vertical(catenary, n2, nominal):
    # Its shortening δ²/2L would be 1e-7 m: the model treats it as vertical, identically.
    tiny = StaticModel(single_span(n2, nominal).with_dropper_offsets(5e-4), catenary)
    np.testing.assert_array_equal(tiny.mesh.cw_clamp_nodes, tiny.mesh.dropper_nodes)
    vertical = StaticModel(single_span(n2, nominal), catenary).solve().dropper_deflection_m()
    np.testing.assert_array_equal(tiny.solve().dropper_deflection_m(), vertical)
