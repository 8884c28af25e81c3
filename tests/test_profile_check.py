"""The profile between the droppers: calibrated under the model, sharp on a point load ([16])."""

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from catenary.stages.diagnosis.profile_check import (ProfileSettings, base_columns, hunter_max_normal_sf, knots_of,
                                              profile_tests, tent_columns)

LENGTH_M = 58.5
DROPPERS_M = np.array([4.5, 11.25, 18.0, 24.75, 29.25, 33.75, 40.5, 47.25, 54.0])
T_CW_N = 25500.0
NOISE_M = 1e-3


def synthetic_profiles(n_spans: int, seed: int, load: dict | None = None, step_m: float = 0.1) -> pd.DataFrame:
    """Residual profiles as the correction leaves them under the model: the model's own freedoms
    (hats at the knots, a little sag) at random sub-millimetre amplitudes, plus white noise;
    ``load``: span index → (x₀ [m], point load [N]) bending the CW into a string's tent."""
    rng = np.random.default_rng(seed)
    x = np.arange(0.0, LENGTH_M + 1e-9, step_m)
    knots = knots_of(LENGTH_M, DROPPERS_M)
    basis = base_columns(x, knots)
    rows = []
    for k in range(n_spans):
        y = basis[:, :-1] @ rng.normal(0.0, 3e-4, knots.size) + basis[:, -1] * rng.normal(0.0, 2e-6)
        if load and k in load:
            x0, force = load[k]
            bay = np.searchsorted(knots, x0) - 1
            a, b = knots[bay], knots[bay + 1]
            depth = force * (x0 - a) * (b - x0) / (T_CW_N * (b - a))
            y -= depth * tent_columns(x, knots, np.array([x0]))[:, 0]
        y += NOISE_M * rng.standard_normal(x.size)
        rows.append(pd.DataFrame({"span_id": f"S{k:03d}", "run_id": "run", "x_m": x, "height_m": y,
                                  "simulated_height_m": 0.0}))
    return pd.concat(rows, ignore_index=True)


def test_the_profile_test_is_calibrated_under_the_model():
    # Lines of 150 spans where the model holds: the profile p-values are uniform (KS at 1 % on
    # every line), the noise is measured from the line within 3 % (its standard error over
    # 150 × 570 samples is 0.2 %; the median of χ²/dof ratios costs a factor ≈ 1.3), and the
    # share of lines with any p-value below the Benjamini–Hochberg line's first step at 5 %
    # (0.05/150, a false discovery) is the procedure's 5 %: at most 2 of 12 lines (binomial
    # probability of 3 or more 2 %; measured: 1 of 12).
    false_discoveries = 0
    for seed in range(1, 13):
        table, noise = profile_tests(synthetic_profiles(150, seed=seed), LENGTH_M, DROPPERS_M, T_CW_N,
                                     ProfileSettings(calibration_draws=2000))
        assert abs(noise.std_m / NOISE_M - 1.0) < 0.03 and abs(noise.ar1) < 0.05
        for column in ("p_global", "p_profile"):
            assert stats.kstest(table[column], "uniform").pvalue > 0.01, (seed, column)
        false_discoveries += int(table["p_profile"].min() < 0.05 / 150)
    assert false_discoveries <= 2


def test_a_point_load_between_droppers_is_found_where_it_is():
    # 30 N (3 kg) clamped 2.6 m into a 6.75 m bay bends the CW by 1.8 mm there: among 60 spans
    # under the model, the loaded span has the smallest p-value by orders of magnitude, its peak
    # lies within two steps of the scan's 0.25 m grid of the load (one for the grid, one for the
    # noise, which moves the apex of a tent of t ≈ 9 by ≈ 0.2 m), and the load read back from
    # the tent's height is within 25 % (the noise's share of a 1.8 mm tent over 67 samples at 1 mm).
    table, _ = profile_tests(synthetic_profiles(60, seed=2, load={7: (7.1, 30.0)}), LENGTH_M, DROPPERS_M, T_CW_N,
                             ProfileSettings(calibration_draws=2000))
    loaded = table.set_index("span_id").loc["S007"]
    others = table[table["span_id"] != "S007"]
    assert loaded["p_profile"] < 1e-6 < others["p_profile"].min() * 1e3
    assert abs(loaded["peak_x_m"] - 7.1) <= 0.5
    assert loaded["peak_height_m"] < 0 and abs(loaded["peak_load_n"] / 30.0 - 1.0) < 0.25


def test_hunter_bound_holds_and_is_tight_in_the_tail():
    # The maximum of 200 standard normals in an AR(1) chain of correlation 0.9: the bound is
    # above the Monte Carlo tail at every level and within 25 % of it at the 1 % level (400 000
    # draws: the Monte Carlo's own error there is 0.2 %).
    rng = np.random.default_rng(3)
    rho, n = 0.9, 200
    z = np.empty((400_000, n))
    z[:, 0] = rng.standard_normal(z.shape[0])
    for j in range(1, n):
        z[:, j] = rho * z[:, j - 1] + np.sqrt(1 - rho ** 2) * rng.standard_normal(z.shape[0])
    top = np.abs(z).max(axis=1)
    links = np.r_[False, np.ones(n - 1, dtype=bool)]
    chain = np.full(n, rho)
    for u in (3.0, 3.5, 4.0):
        mc = float(np.mean(top >= u))
        bound = hunter_max_normal_sf(u, chain, n, links)
        assert bound >= mc * (1 - 0.05)
        if mc < 0.02:
            assert bound <= 1.25 * mc, (u, bound, mc)


@pytest.mark.parametrize("slack_force_n, scanned", [(60.0, True), (8.0, False)])
def test_bays_next_to_a_nearly_slack_dropper_are_not_scanned(slack_force_n, scanned):
    # A dropper the correction's model holds with less than the pass unloads it by may slacken
    # under the pantograph: the two bays beside it are not scanned for a point load, so the peak
    # is never placed there (the global statistic still reads the load, and so does the bays'
    # common sag, which spreads part of it over the other bays).
    profiles = synthetic_profiles(20, seed=4, load={3: (27.0, 60.0)})
    forces = {f"S{k:03d}": np.full(9, 80.0) for k in range(20)}
    forces["S003"] = np.r_[80.0, 80.0, 80.0, 80.0, slack_force_n, 80.0, 80.0, 80.0, 80.0]   # dropper 5, at 29.25 m
    table, _ = profile_tests(profiles, LENGTH_M, DROPPERS_M, T_CW_N, ProfileSettings(calibration_draws=500),
                             dropper_forces_n=forces)
    row = table.set_index("span_id").loc["S003"]
    assert bool(row["bays_not_scanned"] == 0) == scanned
    if scanned:
        assert row["p_local"] < 1e-6 and abs(row["peak_x_m"] - 27.0) <= 0.5
    else:
        assert not 24.75 <= row["peak_x_m"] <= 33.75
