"""Where the height trace puts a mast, and how well it says it does: the fit of a mast's dropper
pattern (:func:`catenary.measurement.registration.supports.align_pattern`) over the window the registration
gives it (:func:`catenary.measurement.registration.runner._pattern`), on the correction's own model of a
measuring pass over a nominal section, with the sensor of the validation campaigns (1 mm of noise,
1 mm quantisation, a sample every 0.1 m)."""

import numpy as np
import pytest

from catenary.measurement.registration.lag import height_lag_m
from catenary.measurement.registration.runner import _pattern
from catenary.measurement.registration.supports import Trace, align_pattern, pattern_misfit, trace_of
from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.physics.measuring import measuring_pass
from catenary.physics.pantograph import load_pantographs
from catenary.physics.section import uniform_section

from .conftest import ROOT

SPEED_M_S = 40.0 / 3.6
SEARCH_M = 1.5          # registration.search_m of config/config.yaml


@pytest.mark.parametrize("name", ["N2", "N3"])
def test_no_kink_crosses_the_window_of_a_mast_fit(catenary, name):
    # Every kink of a mast's pattern stays further than the search and the lag (0.35 m at most,
    # 50 km/h) from the window's edges, so that every trial shift fits the same model. Both span
    # types have a dropper at mid-span: a window ending there (as before) let it cross the edge,
    # changing the fit's number of parameters between neighbouring trials.
    st = catenary.span_type(name)
    table = st.length_m * np.arange(3.0)
    offsets, left, right = _pattern(table, [name, name, None], 1, catenary)
    assert left > 0 and right > 0
    margin = np.min(np.abs(np.r_[offsets + left, offsets - right]))
    assert margin > SEARCH_M + 0.35


@pytest.mark.parametrize("name", ["N2", "N3"])
def test_the_height_fit_states_its_own_error(catenary, name):
    # 24 noise draws over the same pass: the spread of the positions found is the fit's error,
    # which its standard error must state. Measured: spread 0.136 / 0.352 m (N2 / N3) against a
    # median standard error of 0.126 / 0.186 m (ratio 1.08 / 1.89); the three-point curvature used
    # before said 0.105 / 0.112 m (ratio 1.16 / 3.25). Bound 2.5: the spread of 24 draws is known
    # to ≈ 15 %, so 1.89 is 2 standard errors below it.
    st = catenary.span_type(name)
    pantograph = load_pantographs(ROOT / "config" / "pantographs.yaml")["measuring"].with_static_force(36.0)
    section = uniform_section(st, 4, nominal_dropper_lengths(st, catenary).dropper_lengths_m)
    masts = section.mast_chainage_m
    x = np.arange(masts[0], masts[-1] + 1e-9, 0.1)
    clean = measuring_pass(section, catenary, pantograph, speed_m_s=SPEED_M_S, mode="dynamic", chainage_m=x).height_m
    lag = height_lag_m(st, catenary, pantograph, SPEED_M_S)
    offsets, left, right = _pattern(masts, [name] * 4 + [None], 2, catenary)
    rng = np.random.default_rng(1)
    positions, stds = [], []
    for _ in range(24):
        h = 1e-3 * np.round((clean + 1e-3 * rng.standard_normal(x.size)) / 1e-3)
        fit = align_pattern(Trace(x, h, None), masts[2] + offsets, masts[2] - left, masts[2] + right, SEARCH_M,
                            lag_m=lag)
        positions.append(fit.position_m)
        stds.append(fit.std_m)
    spread = float(np.std(positions, ddof=1))
    assert spread / float(np.median(stds)) < 2.5
    # the lag is measured with a span's pattern, the mast with its two half-spans': they differ
    # by ≈ 0.11 / 0.16 m here (mean position), well inside the projection's cut tolerance (0.5 m)
    assert abs(float(np.mean(positions))) < 0.25


def test_the_pattern_misfit_is_the_least_squares_fit_of_its_spline_at_every_shift():
    # The misfit of each shift, solved segment by segment for all shifts at once, against an
    # independent least-squares fit of the ramps' design at each shift (numpy's SVD solver):
    # shifts where a knot enters or leaves the window, and ones where the last knot lies beyond
    # the last sample (its ramps all zero: dependent columns) are among them. Within 1e-9
    # relative: the segments' normal equations in local coordinates, measured 2.4e-13.
    rng = np.random.default_rng(7)
    x = np.sort(rng.uniform(0.0, 100.0, 1000))
    h = 5.0 + 0.02 * np.abs(np.sin(x / 9.0)) + rng.normal(0.0, 1e-3, x.size)
    trace = trace_of(x, h, None)
    kinks = np.array([6.0, 10.0, 14.5, 20.0, 26.0, 33.0, 40.0, 47.0, 54.0, 60.0, 65.0, 70.2, 101.5])
    shifts = np.arange(-3.0, 3.0001, 0.05)
    low, high = 5.0, 103.0
    rss, dof = pattern_misfit(trace, kinks, low, high, shifts)
    u = x[(x >= low) & (x <= high)] - low
    y = h[(x >= low) & (x <= high)]
    expected, most = [], 0
    for d in shifts:
        k = kinks + d - low
        k = k[(k > 0) & (k < high - low)]
        ramp = np.clip(u[:, None] - k[None, :], 0.0, None)
        a = np.column_stack([np.ones_like(u), u, u * u, ramp, ramp * ramp])
        r = y - a @ np.linalg.lstsq(a, y, rcond=None)[0]
        expected.append(r @ r)
        most = max(most, u.size - a.shape[1])
    np.testing.assert_allclose(rss, expected, rtol=1e-9)
    assert dof == most                 # the largest degrees of freedom over the shifts
