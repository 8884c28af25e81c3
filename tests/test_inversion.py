"""Dropper-only inversion (paper §4.1, Table 1, Fig. 8) and the T_MW impact check (Fig. 6)."""

import numpy as np
import pandas as pd
import pytest

from catenary.physics.dropper_table import nominal_dropper_lengths, presag_deflection_m
from catenary.physics.fast import FastSpanModel
from catenary.plumbing.errors import InputError
from catenary.stages.inversion import (converged_spans, dropper_statistics, invert_span, invert_spans, min_correlation,
                                pearson_matrix, w_columns)
from catenary.physics.pantograph import load_pantographs
from catenary.physics.section import single_span
from catenary.physics.static import solve_static
from catenary.stages.tension_impact import tension_impact

from .conftest import ROOT, TABLE2_DROPPER_SIGMA_M, TABLE2_MESSENGER_TENSION_N, TABLE2_SYSTEM_HEIGHT_M

N_SPANS = 117  # the paper's data set


@pytest.fixture(scope="module")
def nominal(catenary, n2):
    return nominal_dropper_lengths(n2, catenary).dropper_lengths_m


def test_inversion_returns_the_droppers_of_the_forward_model(catenary, n2, nominal):
    # W from the FE model of a span with known droppers (at the T_MW and ΔH the inversion
    # holds fixed) gives those droppers back; also at a non-design T_MW held on both sides.
    rng = np.random.default_rng(11)
    for t_mw in (None, 18000.0):
        truth = nominal + rng.normal(0.0, 0.004, (3, nominal.size))
        w = np.array([solve_static(single_span(n2, row, messenger_tension_n=t_mw), catenary).dropper_deflection_m()
                      for row in truth])
        result = invert_spans(n2, catenary, ["a", "b", "c"], w, messenger_tension_n=t_mw)
        assert result.left_out.empty
        np.testing.assert_allclose(result.dropper_lengths_m, truth, atol=1e-9)
    # The design profile gives the nominal table back.
    np.testing.assert_allclose(invert_span(n2, catenary, presag_deflection_m(n2, n2.dropper_positions_m)),
                               nominal, atol=1e-9)


def _draw_spans(catenary, n2, nominal, messenger_tension_sigma_n, seed):
    """Paper Table 2 laws (normal: σ/μ < 4 %, Gamma and normal agree), ΔH drawn per mast end
    independently; forward by the fast model (exact to 1e-8 m). Draws whose droppers would go
    slack (≈ 2 %: a dropper 1 cm shorter than its neighbours unloads) are skipped."""
    rng = np.random.default_rng(seed)
    n = 2 * N_SPANS
    lengths = nominal + rng.standard_normal((n, nominal.size)) * np.asarray(TABLE2_DROPPER_SIGMA_M)
    t_mw = TABLE2_MESSENGER_TENSION_N[0] + messenger_tension_sigma_n * rng.standard_normal(n)
    dh_mean, dh_sigma = TABLE2_SYSTEM_HEIGHT_M
    dh_l, dh_r = dh_mean + dh_sigma * rng.standard_normal((2, n))
    forward = FastSpanModel(n2, catenary).evaluate(lengths, t_mw, dh_l, dh_r)
    keep = np.flatnonzero(~forward.slack)[:N_SPANS]
    assert keep.size == N_SPANS
    return forward.w_m[keep]


@pytest.fixture(scope="module")
def inverted(catenary, n2, nominal):
    """Inverted dropper lengths of 117 spans with and without T_MW variability (Table 2 σ = 818 N)."""
    # The inversion holds T_MW and ΔH at the design values, which are the Table 2 means.
    assert n2.messenger_tension_n == TABLE2_MESSENGER_TENSION_N[0] and n2.system_height_m == TABLE2_SYSTEM_HEIGHT_M[0]
    out = {}
    for sigma in (TABLE2_MESSENGER_TENSION_N[1], 0.0):
        w = _draw_spans(catenary, n2, nominal, sigma, seed=2014)
        result = invert_spans(n2, catenary, [f"s{i}" for i in range(N_SPANS)], w)
        assert result.left_out.empty
        out[sigma] = result.dropper_lengths_m
    return out


def _centre_to_end_ratio(lengths):
    s = lengths.std(axis=0, ddof=1)
    return s[3:6].mean() / s[[0, 8]].mean()


def test_messenger_tension_variability_gives_paper_table1_pattern(inverted):
    # Margins from 300 seeds of this very draw: the σ ratio (droppers 4–6 over 1 and 9) is
    # 1.83 ± 0.10 (min 1.52) and the smallest correlation among droppers 3–7 is 0.924 ± 0.013
    # (min 0.86). The paper's "twice" (Table 1: 1.83 cm vs 0.33–0.41 cm) is not reached with
    # Table 2's own end-dropper σ (6.7, 7.0 mm) and ΔH σ, which keep the end spread near 1 cm;
    # the bounds below sit 4–5 standard deviations inside the seed-to-seed scatter.
    lengths = inverted[TABLE2_MESSENGER_TENSION_N[1]]
    assert _centre_to_end_ratio(lengths) > 1.4
    assert min_correlation(pearson_matrix(lengths), 3, 7) > 0.85
    # The central spread is over 3 times the input dropper σ (≤ 4.5 mm): 1.94 ± 0.12 cm
    # (min 1.60 cm over 300 seeds) for the smallest of droppers 4–6.
    assert lengths.std(axis=0, ddof=1)[3:6].min() > 3 * 0.0045


def test_without_tension_variability_the_pattern_disappears(inverted, n2):
    # With T_MW at its assumed value, the inversion returns the true droppers up to the ΔH
    # variability, which moves the MW at dropper ξ = x/L by (1 − ξ)ΔH_l + ξ ΔH_r: the spread is
    # predicted dropper by dropper. The σ of a σ estimate from 117 spans is 6.5 %; the largest
    # of the 9 relative errors is 0.12 ± 0.04 over 300 seeds (max 0.22).
    lengths = inverted[0.0]
    xi = n2.dropper_positions_m / n2.length_m
    predicted = np.sqrt(np.asarray(TABLE2_DROPPER_SIGMA_M) ** 2
                        + TABLE2_SYSTEM_HEIGHT_M[1] ** 2 * ((1 - xi) ** 2 + xi ** 2))
    np.testing.assert_allclose(lengths.std(axis=0, ddof=1), predicted, rtol=0.3)
    # 0.68 ± 0.04 and 0.41 ± 0.07 over 300 seeds.
    assert _centre_to_end_ratio(lengths) < 1.0
    assert min_correlation(pearson_matrix(lengths), 3, 7) < 0.7


def test_tension_spread_is_the_inversion_sensitivity_times_sigma(inverted, catenary, n2, nominal):
    # The cause, quantitatively: a span at T_MW + δ inverted at T_MW gets droppers shifted by
    # (∂L/∂T) δ (its MW sags less), so the added variance is (∂L/∂T · 818 N)² per dropper.
    # Largest relative error over droppers 3–7: 0.07 ± 0.04 over 300 seeds (max 0.22).
    dt = 200.0
    w = presag_deflection_m(n2, n2.dropper_positions_m)
    shifted = solve_static(single_span(n2, nominal, messenger_tension_n=n2.messenger_tension_n + dt),
                           catenary).dropper_deflection_m()
    sensitivity = (invert_span(n2, catenary, shifted) - invert_span(n2, catenary, w)) / dt  # [m/N]
    assert np.all(sensitivity[1:-1] < 0) and np.argmin(sensitivity) == 4  # largest at mid-span
    added = (sensitivity * TABLE2_MESSENGER_TENSION_N[1]) ** 2
    var_with, var_without = (inverted[s].var(axis=0, ddof=1) for s in (TABLE2_MESSENGER_TENSION_N[1], 0.0))
    np.testing.assert_allclose(np.sqrt(var_with[2:7]), np.sqrt(var_without[2:7] + added[2:7]), rtol=0.25)


def test_paper_nominal_assumptions_give_table1_mean_signs(catenary, n2, nominal):
    # Spans at the Table 2 means (20 575 N, 1.388 m) inverted at the paper's nominal 20 kN and
    # 1.40 m: the assumed MW is 12 mm higher at the masts (end droppers come out longer) and
    # sags more mid-span (central droppers shorter) — the signs of Table 1's means.
    w = presag_deflection_m(n2, n2.dropper_positions_m)
    delta_cm = 100 * (invert_span(n2, catenary, w, messenger_tension_n=20000.0, system_height_m=1.40) - nominal)
    assert delta_cm[0] > 0.5 and delta_cm[-1] > 0.5
    assert np.all(delta_cm[3:6] < 0)


def test_table1_statistics():
    lengths = np.array([[1.0, 2.0], [1.02, 2.0], [1.04, 2.0]])
    table = dropper_statistics(lengths, np.array([1.0, 2.01]))
    np.testing.assert_allclose(table["mean_minus_nominal_cm"], [2.0, -1.0])
    np.testing.assert_allclose(table["std_cm"], [2.0, 0.0])
    assert table["dropper"].tolist() == [1, 2]
    assert np.isnan(pearson_matrix(lengths)[0, 1])  # no spread: undefined, not a number
    assert np.isnan(dropper_statistics(lengths[:1], np.array([1.0, 2.0]))["std_cm"]).all()


def test_corrected_table_checks_and_left_out_spans(catenary, n2, nominal):
    w = np.tile(presag_deflection_m(n2, n2.dropper_positions_m), (3, 1))
    df = pd.DataFrame(w, columns=w_columns(9))
    df.insert(0, "span_id", ["a", "b", "c"])
    df["converged"] = [True, False, True]
    kept, left_out = converged_spans(df, 9, "corrected.parquet")
    assert kept["span_id"].tolist() == ["a", "c"] and left_out == 1
    with pytest.raises(InputError, match=r"corrected.parquet.*w9_m"):
        converged_spans(df.drop(columns="w9_m"), 9, "corrected.parquet")
    bad = df.copy()
    bad.loc[0, "w3_m"] = np.nan
    with pytest.raises(InputError, match=r"corrected.parquet: column 'w3_m'.*'a'"):
        converged_spans(bad, 9, "corrected.parquet")
    with pytest.raises(InputError, match="converged"):
        converged_spans(df.assign(converged=["yes", "no", "yes"]), 9, "corrected.parquet")
    # A 5 cm kink up at mid-span needs a pushing dropper: reported, not inverted.
    w[1, 4] += 0.05
    result = invert_spans(n2, catenary, ["a", "b", "c"], w)
    assert result.span_id.tolist() == ["a", "c"]
    assert result.left_out["span_id"].tolist() == ["b"] and "compression" in result.left_out["reason"].iloc[0]


def test_same_static_sag_at_16_and_20_kn_measures_within_2_mm(catenary, n2):
    # Paper Fig. 6 with a coarse set-up (3 spans, 5 ms step; against 5 spans at 2 ms the
    # differences move by < 0.3 mm): same static CW heights, measured sags within 2 mm at the
    # droppers, while the measuring pass itself lifts the CW by ≈ 15 mm.
    pantograph = load_pantographs(ROOT / "config" / "pantographs.yaml")["measuring"]
    result = tension_impact(n2, catenary, pantograph, messenger_tensions_n=(16000.0, 20000.0), n_spans=3,
                            speed_m_s=40 / 3.6, force_n=36.0, time_step_s=0.005, sampling_step_m=0.25)
    assert np.max(np.abs(result.static_droppers_m[0] - result.static_droppers_m[1])) < 1e-6
    assert np.max(np.abs(result.static_m[0] - result.static_m[1])) < 1e-6  # the whole CW, not only droppers
    assert not np.allclose(result.dropper_lengths_m[0], result.dropper_lengths_m[1], atol=5e-3)
    summary = result.summary().set_index("where")
    assert summary.loc["droppers", "max_difference_mm"] < 2.0
    assert summary.loc["span", "max_difference_mm"] < 2.5
    assert summary.loc["span", "max_correction_mm"] > 10.0
    # The softer catenary (16 kN) is lifted more everywhere on average.
    assert np.mean(result.difference_m) > 0


def test_a_config_error_inside_the_inversion_is_not_a_left_out_span(catenary, n2, monkeypatch):
    # Only "no taut dropper lengths produce this W" leaves a span out (above); an error of the
    # configuration or the code must surface, not be reported as the physics of one span.
    import catenary.stages.inversion as inversion
    from catenary.plumbing.errors import ConfigError

    def misconfigured(*args, **kwargs):
        raise ConfigError("catenary.droppers.axial_stiffness_n: expected a value > 0, got 0")

    monkeypatch.setattr(inversion, "dropper_lengths_for_many", misconfigured)
    w = np.tile(presag_deflection_m(n2, n2.dropper_positions_m), (2, 1))
    with pytest.raises(ConfigError, match="axial_stiffness_n"):
        invert_spans(n2, catenary, ["a", "b"], w)
