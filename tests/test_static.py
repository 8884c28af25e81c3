"""Static FE model against analytic results (§7)."""

import dataclasses

import numpy as np
import pytest

from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.physics.section import Section, single_span, uniform_section
from catenary.physics.static import StaticModel, solve_static
from catenary.plumbing.errors import ConfigError, ConvergenceError


def bare_wires(span_m=58.5, t_cw=25500.0, t_mw=20575.0):
    """One span with no droppers: each wire hangs on its own between its supports."""
    return Section(span_lengths_m=[span_m], dropper_span=[], dropper_x_m=[], dropper_lengths_m=[],
                   cw_support_heights_m=[5.08, 5.08], system_heights_m=[1.4, 1.4],
                   contact_tension_n=t_cw, messenger_tension_n=t_mw)


@pytest.mark.parametrize("wire", ["contact", "messenger"])
def test_taut_wire_sag_matches_string_formula(catenary, wire):
    # Mid-span sag of a taut wire under its weight: w L² / (8 T). Bending stiffness adds a
    # relative correction of order 8 EI / (T L²) ≈ 2e-5, far inside the 0.1 % tolerance.
    section = bare_wires()
    sol = solve_static(section, catenary)
    props = getattr(catenary, wire)
    tension = section.contact_tension_n if wire == "contact" else section.messenger_tension_n
    q = props.mass_per_length_kg_m * catenary.gravity_m_s2
    expected = q * 58.5**2 / (8 * tension)
    height = sol.cw_height_at if wire == "contact" else sol.mw_height_at
    support = 5.08 if wire == "contact" else 6.48
    sag = support - height(np.array([58.5 / 2]))[0]
    assert sag == pytest.approx(expected, rel=1e-3)


def test_tensioned_beam_matches_analytic_solution(catenary):
    # Pinned tensioned beam under uniform load, exact: w = q/T [x(L−x)/2 + EI/T (cosh(λ(x−L/2))
    # / cosh(λL/2) − 1)], λ = √(T/EI). Away from the 8 cm boundary layers the Hermite mesh must
    # reproduce it to 1e-6 of the sag.
    sol = solve_static(bare_wires(), catenary)
    ei, t = catenary.contact.bending_stiffness_n_m2, 25500.0
    q = catenary.contact.mass_per_length_kg_m * catenary.gravity_m_s2
    lam, length = np.sqrt(t / ei), 58.5
    x = np.linspace(2.0, 56.5, 40)
    exact = q / t * (x * (length - x) / 2 + ei / t * (np.cosh(lam * (x - length / 2)) / np.cosh(lam * length / 2) - 1))
    sag = 5.08 - sol.cw_height_at(x)
    assert np.max(np.abs(sag - exact)) < 1e-6 * exact.max()


def test_support_reactions_carry_total_weight(catenary, n2):
    lengths = nominal_dropper_lengths(n2, catenary).dropper_lengths_m
    section = uniform_section(n2, 3, lengths)
    model = StaticModel(section, catenary)
    sol = model.solve()
    c, d = catenary.contact, catenary.droppers
    total_length = section.span_lengths_m.sum()
    weight = catenary.gravity_m_s2 * (
        (c.mass_per_length_kg_m + catenary.messenger.mass_per_length_kg_m) * total_length
        + section.dropper_lengths_m.size * (d.clamp_mass_contact_kg + d.clamp_mass_messenger_kg)
        + d.mass_per_length_kg_m * section.dropper_lengths_m.sum())
    reactions = sol.cw_reaction_n.sum() + sol.mw_reaction_n.sum()
    assert reactions == pytest.approx(weight, rel=1e-9)
    # With an upward point load the supports carry that much less.
    sol = model.solve(cw_point_loads=(np.array([70.0]), np.array([36.0])))
    assert sol.cw_reaction_n.sum() + sol.mw_reaction_n.sum() == pytest.approx(weight - 36.0, rel=1e-9)


def test_dropper_forces_balance_contact_wire_weight(catenary, n2):
    # Vertical equilibrium of the CW alone: steady-arm reactions + dropper tensions = CW weight.
    sol = solve_static(single_span(n2, nominal_dropper_lengths(n2, catenary).dropper_lengths_m), catenary)
    d = catenary.droppers
    cw_weight = catenary.gravity_m_s2 * (catenary.contact.mass_per_length_kg_m * n2.length_m
                                         + n2.n_droppers * d.clamp_mass_contact_kg
                                         + 0.5 * d.mass_per_length_kg_m * sol.section.dropper_lengths_m.sum())
    assert sol.cw_reaction_n.sum() + sol.dropper_force_n.sum() == pytest.approx(cw_weight, rel=1e-9)


def test_long_dropper_goes_slack_and_solution_says_so(catenary, n2):
    lengths = nominal_dropper_lengths(n2, catenary).dropper_lengths_m.copy()
    lengths[4] += 0.10
    sol = solve_static(single_span(n2, lengths), catenary)
    assert sol.any_slack
    assert sol.dropper_slack.tolist() == [i == 4 for i in range(9)]
    assert sol.dropper_force_n[4] == 0.0
    # A slack dropper is not stretched: the wires are further apart than its length.
    gap = sol.mw_height_m[sol.mesh.dropper_nodes[4]] - sol.cw_height_m[sol.mesh.dropper_nodes[4]]
    assert gap < lengths[4]
    # ... and the taut ones carry positive tension.
    assert np.all(sol.dropper_force_n[np.arange(9) != 4] > 0)


def test_solve_that_cannot_settle_raises(catenary, n2):
    lengths = nominal_dropper_lengths(n2, catenary).dropper_lengths_m.copy()
    lengths[4] += 0.10  # needs a second active-set iteration
    model = StaticModel(single_span(n2, lengths), catenary)
    with pytest.raises(ConvergenceError, match="did not settle in 1"):
        model.solve(max_iterations=1)


def test_exact_elements_make_results_mesh_independent(catenary, n2):
    # The exact tensioned-beam element is nodally exact: W on a 5-span section is the same
    # with 2 m and 0.1 m elements although the bending layer √(EI/T) is 8 cm.
    lengths = nominal_dropper_lengths(n2, catenary).dropper_lengths_m
    section = uniform_section(n2, 5, lengths)
    coarse = solve_static(section, dataclasses.replace(catenary, max_element_length_m=2.0))
    fine = solve_static(section, dataclasses.replace(catenary, max_element_length_m=0.1))
    np.testing.assert_allclose(coarse.dropper_deflection_m(), fine.dropper_deflection_m(), atol=1e-9)
    np.testing.assert_allclose(coarse.mw_height_m[coarse.mesh.dropper_nodes],
                               fine.mw_height_m[fine.mesh.dropper_nodes], atol=1e-9)


def test_continuity_over_masts_lifts_a_section_span(catenary, n2):
    # A wire continuous over a mast cannot kink there: over √(EI/T) its slope turns smoothly,
    # which lifts its far field by about (slope jump / 2) · √(EI/T). For the MW at the masts
    # that is ≈ 0.033 · 0.080 m ≈ 2.6 mm; the CW at the droppers follows it partly. The
    # single-span model (pinned ends, the paper's identification model) has no such lift.
    lengths = nominal_dropper_lengths(n2, catenary).dropper_lengths_m
    single = solve_static(single_span(n2, lengths), catenary)
    section = solve_static(uniform_section(n2, 5, lengths), catenary)
    mw_slope_jump = 2 * single.mw_reaction_n[0] / n2.messenger_tension_n
    lift_bound = 0.5 * mw_slope_jump * np.sqrt(catenary.messenger.bending_stiffness_n_m2 / n2.messenger_tension_n)
    lift = section.dropper_deflection_m().reshape(5, 9)[2] - single.dropper_deflection_m()
    assert np.all(lift > 0.2 * lift_bound) and np.all(lift < lift_bound)


def test_section_with_spans_of_their_own(catenary, n2):
    mixed = Section(span_lengths_m=[58.5, 54.0], dropper_span=np.repeat([0, 1], 9),
                    dropper_x_m=np.concatenate([n2.dropper_positions_m, catenary.span_type("N3").dropper_positions_m]),
                    dropper_lengths_m=np.full(18, 1.0), cw_support_heights_m=[5.08, 5.10, 5.05],
                    system_heights_m=[1.4, 1.39, 1.41], contact_tension_n=25500.0, messenger_tension_n=20000.0)
    sol = solve_static(mixed, catenary)
    np.testing.assert_allclose(sol.cw_height_m[sol.mesh.mast_nodes], [5.08, 5.10, 5.05], atol=1e-12)
    np.testing.assert_allclose(sol.mw_height_m[sol.mesh.mast_nodes], [6.48, 6.49, 6.46], atol=1e-12)


def test_per_span_tensions(catenary, n2):
    # One tension per span: equal values reproduce the scalar case exactly; raising T_MW in
    # the middle span lifts that span (string: sag ∝ 1/T) far more than its neighbours, and
    # the supports still carry the whole weight.
    lengths = nominal_dropper_lengths(n2, catenary).dropper_lengths_m
    section = uniform_section(n2, 3, lengths)
    same = section.with_tensions(messenger_tension_n=np.full(3, section.messenger_tension_n))
    np.testing.assert_allclose(solve_static(same, catenary).dofs, solve_static(section, catenary).dofs, atol=1e-12)
    raised = section.with_tensions(messenger_tension_n=section.messenger_tension_n * np.array([1.0, 1.1, 1.0]))
    model = StaticModel(raised, catenary)
    sol = model.solve()
    dw = (sol.dropper_deflection_m() - solve_static(section, catenary).dropper_deflection_m()).reshape(3, 9)
    assert dw[1, 4] > 10e-3                      # ≈ +20 mm at mid-span (46.9 mm per +20 % on one span)
    assert np.max(np.abs(dw[[0, 2]])) < 0.1 * dw[1, 4]
    assert sol.cw_reaction_n.sum() + sol.mw_reaction_n.sum() == pytest.approx(model.total_weight_n(), rel=1e-9)
    with pytest.raises(ConfigError, match="one per span"):
        section.with_tensions(messenger_tension_n=np.ones(2) * 20000.0)
