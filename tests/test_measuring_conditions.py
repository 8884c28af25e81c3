"""How the car measures: direction of travel, speed along the run, fluctuating uplift force."""

import numpy as np
import pytest

from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.physics.dynamics import CatenaryDynamics, contact_path, run_pantograph
from catenary.physics.measuring import measuring_pass
from catenary.physics.pantograph import load_pantographs
from catenary.physics.section import Section, uniform_section
from catenary.physics.static import StaticModel

from .conftest import ROOT

SPEED_M_S = 40 / 3.6


@pytest.fixture(scope="module")
def pantograph():
    return load_pantographs(ROOT / "config" / "pantographs.yaml")["measuring"]


@pytest.fixture(scope="module")
def symmetric_section(catenary, n2):
    """Three N2 spans with mirror-symmetric droppers (N2's positions are symmetric)."""
    lengths = nominal_dropper_lengths(n2, catenary).dropper_lengths_m
    return uniform_section(n2, 3, 0.5 * (lengths + lengths[::-1]))


def lopsided_section(catenary, n2) -> Section:
    """A section with nothing symmetric: span lengths, heights, tensions, inclined droppers."""
    rng = np.random.default_rng(3)
    base = uniform_section(n2, 3, nominal_dropper_lengths(n2, catenary).dropper_lengths_m)
    return Section(span_lengths_m=np.array([58.5, 55.0, 61.0]), dropper_span=base.dropper_span,
                   dropper_x_m=base.dropper_x_m * np.repeat([1.0, 55.0 / 58.5, 61.0 / 58.5], 9),
                   dropper_lengths_m=base.dropper_lengths_m + rng.normal(0, 0.01, 27),
                   cw_support_heights_m=np.array([5.08, 5.10, 5.07, 5.12]),
                   system_heights_m=np.array([1.40, 1.45, 1.38, 1.42]),
                   contact_tension_n=np.array([20000.0, 20300.0, 19800.0]), messenger_tension_n=14000.0,
                   dropper_offset_m=rng.normal(0, 0.05, 27), cw_mass_factor=np.array([1.0, 0.9, 0.95]))


def test_mirrored_section_hangs_as_the_mirror_image(catenary, n2):
    # The same static problem numbered from the other end: equal to round-off (the FE models
    # are nodally exact on either mesh, whose nodes mirror each other).
    section = lopsided_section(catenary, n2)
    mirror = section.mirrored()
    length = section.mast_chainage_m[-1]
    x = np.concatenate([section.dropper_chainage_m, section.mast_chainage_m])
    h = StaticModel(section, catenary).solve().cw_height_at(x)
    h_mirror = StaticModel(mirror, catenary).solve().cw_height_at(length - x)
    np.testing.assert_allclose(h_mirror, h, atol=1e-9)
    twice = mirror.mirrored()
    for name in Section.__dataclass_fields__:
        np.testing.assert_allclose(np.asarray(getattr(twice, name), dtype=float),
                                   np.asarray(getattr(section, name), dtype=float), atol=1e-12, err_msg=name)


def test_reverse_run_over_a_symmetric_section_is_the_mirror_of_the_forward_run(catenary, pantograph,
                                                                              symmetric_section):
    # Physics is invariant under x → L − x: a car running backwards over a mirror-symmetric
    # section records at x what the forward car records at L − x. Checks the mirroring of the
    # section, of the chainages and the mapping back of the heights.
    length = symmetric_section.mast_chainage_m[-1]
    x = np.linspace(5.0, length - 5.0, 41)
    forward = measuring_pass(symmetric_section, catenary, pantograph, speed_m_s=SPEED_M_S, chainage_m=length - x)
    reverse = measuring_pass(symmetric_section, catenary, pantograph, speed_m_s=SPEED_M_S, chainage_m=x,
                             direction=-1)
    np.testing.assert_allclose(reverse.chainage_m, x)
    # round-off of the mirrored mesh only: the two runs are the same arithmetic
    np.testing.assert_allclose(reverse.height_m, forward.height_m, atol=1e-9)


def test_direction_of_travel_shifts_the_recorded_pattern(catenary, pantograph, symmetric_section):
    # The moving pantograph's uplift trails behind it: forward and reverse recordings of the
    # same span differ, by far more than round-off, by less than the uplift itself (≈ 4 cm).
    x = symmetric_section.dropper_chainage_m[9:18]
    forward = measuring_pass(symmetric_section, catenary, pantograph, speed_m_s=SPEED_M_S, chainage_m=x).height_m
    reverse = measuring_pass(symmetric_section, catenary, pantograph, speed_m_s=SPEED_M_S, chainage_m=x,
                             direction=-1).height_m
    difference = np.abs(forward - reverse).max()
    assert 1e-4 < difference < 1e-2


def test_constant_speed_profile_is_the_constant_speed_run(catenary, pantograph, symmetric_section):
    ops = CatenaryDynamics(symmetric_section, catenary)
    plain = run_pantograph(ops, pantograph, SPEED_M_S)
    knots = np.array([0.0, 60.0, 175.5])
    profiled = run_pantograph(ops, pantograph, SPEED_M_S, speed_profile=(knots, np.full(3, SPEED_M_S)))
    # t(x) by the trapezoidal rule is exact for a constant speed up to round-off
    assert profiled.chainage_m.size == plain.chainage_m.size
    np.testing.assert_allclose(profiled.chainage_m, plain.chainage_m, atol=1e-9)
    np.testing.assert_allclose(profiled.cw_height_m, plain.cw_height_m, atol=1e-9)


def test_contact_path_follows_the_speed_profile():
    # v(x) = v0 (1 + x/a): t(x) = a/v0 ln(1 + x/a) exactly, so x(t) = a (exp(v0 t / a) − 1).
    v0, a = 10.0, 100.0
    knots = np.linspace(0.0, 200.0, 2001)
    x = contact_path(0.0, 200.0, v0, 1e-3, (knots, v0 * (1 + knots / a)))
    t = np.arange(x.size) * 1e-3
    # the 0.1 m knots' linear interpolation and the 0.05 m trapezoid: relative error < 1e-5
    np.testing.assert_allclose(x, a * np.expm1(v0 * t / a), atol=2e-3)
    assert x[-1] <= 200.0 and 200.0 - x[-1] < v0 * 3 * 1e-3


def test_force_fluctuation_acts_as_the_static_force_it_adds(catenary, pantograph, symmetric_section):
    # A constant +3 N on the force profile is a pantograph whose static force is 3 N higher.
    ops = CatenaryDynamics(symmetric_section, catenary)
    knots = np.array([0.0, 175.5])
    profiled = run_pantograph(ops, pantograph, SPEED_M_S, force_profile=(knots, np.full(2, 3.0)))
    stronger = run_pantograph(ops, pantograph.with_static_force(pantograph.static_force_n + 3.0), SPEED_M_S)
    np.testing.assert_allclose(profiled.cw_height_m, stronger.cw_height_m, atol=1e-12)
    np.testing.assert_allclose(profiled.contact_force_n, stronger.contact_force_n, atol=1e-9)


def test_faster_car_records_a_different_height_where_it_runs_faster(catenary, pantograph, symmetric_section):
    # A speed profile changes the run only where the speed changes: slowing from 40 to 30 km/h
    # over the last span leaves the first span's heights (recorded before the change, the wave
    # ahead of the pantograph small) within 0.05 mm and changes the last span's.
    ops = CatenaryDynamics(symmetric_section, catenary)
    plain = run_pantograph(ops, pantograph, SPEED_M_S)
    knots = np.array([0.0, 117.0, 130.0, 175.5])
    slower = run_pantograph(ops, pantograph, SPEED_M_S,
                            speed_profile=(knots, np.array([SPEED_M_S, SPEED_M_S, 30 / 3.6, 30 / 3.6])))
    first = np.linspace(10.0, 50.0, 21)
    last = np.linspace(140.0, 170.0, 21)
    h = lambda run, x: np.interp(x, run.chainage_m, run.cw_height_m)   # noqa: E731
    assert np.abs(h(slower, first) - h(plain, first)).max() < 5e-5
    assert np.abs(h(slower, last) - h(plain, last)).max() > 1e-4
