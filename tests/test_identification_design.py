"""Random inputs, Gamma laws and the unit-cube design of the identification."""

import numpy as np
import openturns as ot
import pytest
from scipy import special, stats

from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.stages.identification.design import (CORNISH_FISHER_MAX_CV, RandomInput, default_inputs,
                                            design_dimension, draw_unit_design, dropper_names,
                                            gamma_quantiles, map_inputs)

from .conftest import TABLE2_MESSENGER_TENSION_N, TABLE2_SYSTEM_HEIGHT_M

# u from 1e-9 to 1 − 1e-9 (the design's clipping), dense in both tails.
U = np.concatenate([np.linspace(1e-9, 1 - 1e-9, 20001), np.geomspace(1e-9, 1e-2, 400),
                    1 - np.geomspace(1e-9, 1e-2, 400)])


def test_gamma_law_has_the_requested_mean_and_sigma_in_openturns_and_scipy():
    law = RandomInput("messenger_tension_n", *TABLE2_MESSENGER_TENSION_N)
    ot_law = law.distribution()
    assert ot_law.getMean()[0] == pytest.approx(20575.0, rel=1e-12)
    assert ot_law.getStandardDeviation()[0] == pytest.approx(818.0, rel=1e-12)
    sp_law = stats.gamma(a=law.shape, scale=1.0 / law.rate)
    assert sp_law.mean() == pytest.approx(20575.0, rel=1e-12)
    assert sp_law.std() == pytest.approx(818.0, rel=1e-12)
    # Exact inverse CDF agrees with OpenTURNS' quantile.
    u = np.array([1e-6, 0.01, 0.3, 0.5, 0.9, 1 - 1e-6])
    expected = np.array(ot_law.computeQuantile(u.tolist())).ravel()
    np.testing.assert_allclose(law.quantile(u), expected, rtol=1e-10)


@pytest.mark.parametrize("cv, bound", [(0.005, 1e-10), (0.04, 2e-7), (0.1, 2e-5)])
def test_fast_gamma_quantiles_match_the_exact_inverse(cv, bound):
    # Cornish–Fisher to order c⁴ for σ/μ ≤ 0.1 (error O(c⁵) in units of σ), exact above.
    mu = 1.7
    law = RandomInput("x_m", mu, cv * mu)
    fast = gamma_quantiles(special.ndtri(U)[:, None], [mu], [law.sigma])[:, 0]
    error_in_sigma = np.max(np.abs(fast - law.quantile(U))) / law.sigma
    assert error_in_sigma < bound


def test_fast_path_threshold():
    # Above the threshold the exact inverse is used: agreement to rounding.
    mu, cv = 2.0, 1.01 * CORNISH_FISHER_MAX_CV
    law = RandomInput("x_m", mu, cv * mu)
    fast = gamma_quantiles(special.ndtri(U)[:, None], [mu], [law.sigma])[:, 0]
    np.testing.assert_allclose(fast, law.quantile(U), rtol=1e-12)


def test_lhs_design_has_one_point_per_stratum_and_is_drawn_once():
    n, d = 500, 11
    design = draw_unit_design(n, d, method="lhs", seed=4)
    assert design.u.shape == (n, d)
    for column in design.u.T:
        np.testing.assert_array_equal(np.sort(np.floor(column * n)), np.arange(n))
    again = draw_unit_design(n, d, method="lhs", seed=4)
    np.testing.assert_array_equal(design.u, again.u)
    assert not np.array_equal(design.u, draw_unit_design(n, d, method="lhs", seed=5).u)
    assert not design.u.flags.writeable
    np.testing.assert_array_equal(design.z, special.ndtri(design.u))


def test_lhs_seed_does_not_disturb_the_global_openturns_generator():
    ot.RandomGenerator.SetSeed(99)
    expected = ot.RandomGenerator.Generate()
    ot.RandomGenerator.SetSeed(99)
    draw_unit_design(50, 3, method="lhs", seed=1)
    assert ot.RandomGenerator.Generate() == expected


def test_sobol_design_is_seeded_and_uniform():
    n, d = 4096, 11
    design = draw_unit_design(n, d, method="sobol", seed=3)
    np.testing.assert_array_equal(design.u, draw_unit_design(n, d, method="sobol", seed=3).u)
    assert not np.array_equal(design.u, draw_unit_design(n, d, method="sobol", seed=4).u)
    # A scrambled Sobol net of 2^12 points has exactly n/8 points in each eighth of each axis.
    for column in design.u.T:
        np.testing.assert_array_equal(np.bincount(np.floor(column * 8).astype(int)), np.full(8, n // 8))


def test_design_is_clipped_away_from_zero_and_one():
    design = draw_unit_design(10, 2, method="lhs", seed=0, eps=0.05)
    assert design.u.min() >= 0.05 and design.u.max() <= 0.95
    with pytest.raises(ValueError, match="method"):
        draw_unit_design(10, 2, method="grid")


def test_default_inputs_follow_the_nominal_table_and_design(catenary, n2):
    inputs = default_inputs(n2, catenary)
    names = [s.name for s in inputs]
    assert names == [*dropper_names(9), "messenger_tension_n", "system_height_m"]
    np.testing.assert_allclose([s.mean for s in inputs[:9]],
                               nominal_dropper_lengths(n2, catenary).dropper_lengths_m)
    assert inputs[9].mean == n2.messenger_tension_n
    assert inputs[10].mean == TABLE2_SYSTEM_HEIGHT_M[0]


def test_shared_and_independent_system_heights():
    means = np.r_[np.full(9, 1.0), 20575.0, 1.388]
    sigmas = np.r_[np.full(9, 0.005), 818.0, 0.0065]
    n = 20000
    shared = map_inputs(draw_unit_design(n, design_dimension(9, "shared"), seed=2).z, means, sigmas, "shared")
    np.testing.assert_array_equal(shared.system_height_left_m, shared.system_height_right_m)
    indep = map_inputs(draw_unit_design(n, design_dimension(9, "independent"), seed=2).z, means, sigmas,
                       "independent")
    left, right = indep.system_height_left_m, indep.system_height_right_m
    # Same law at both masts (sample moments within 1 % of σ: Sobol/LHS integrate these smooth
    # moments far better than the Monte Carlo 1/√n = 0.7 %), independent draws (|correlation|
    # < 4/√n, the plain Monte Carlo bound).
    for x in (left, right):
        assert abs(x.mean() - 1.388) < 0.01 * 0.0065
        assert x.std() == pytest.approx(0.0065, rel=0.01)
    assert abs(np.corrcoef(left, right)[0, 1]) < 4 / np.sqrt(n)
    assert indep.dropper_lengths_m.shape == (n, 9)
    with pytest.raises(ValueError, match="columns"):
        map_inputs(draw_unit_design(10, 11, seed=0).z, means, sigmas, "independent")
