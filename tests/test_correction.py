"""Iterative dynamic correction (paper §2.2, Fig. 5; issue [4])."""

import numpy as np
import pandas as pd
import pytest

from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.physics.measuring import measuring_pass
from catenary.physics.pantograph import load_pantographs
from catenary.physics.section import uniform_section
from catenary.physics.static import solve_static
from catenary.plumbing.errors import ConfigError
from catenary.stages.correction import CorrectionSettings, consecutive_runs, correct_spans

from .conftest import ROOT

SPEED_KMH = 40.0


@pytest.fixture(scope="module")
def measuring():
    return load_pantographs(ROOT / "config" / "pantographs.yaml")["measuring"]


def measured_spans(section, heights_d, heights_m, start_m=1000.0, section_id="S1", first=1):
    """Projected spans (the projection's table layout) from heights at droppers and masts."""
    n = section.n_spans
    chain = start_m + section.mast_chainage_m
    span = section.dropper_span
    frac = section.dropper_x_m / section.span_lengths_m[span]
    w = (heights_d - (heights_m[span] + frac * (heights_m[span + 1] - heights_m[span]))).reshape(n, -1)
    rows = {"span_id": [f"M{first + k:04d}-M{first + k + 1:04d}" for k in range(n)], "section_id": section_id,
            "span_type": "N2", "start_chainage_m": chain[:-1], "end_chainage_m": chain[1:],
            "length_m": section.span_lengths_m, "cw_height_left_m": heights_m[:-1], "cw_height_right_m": heights_m[1:]}
    rows.update({f"w{i + 1}_m": w[:, i] for i in range(w.shape[1])})
    return pd.DataFrame(rows)


def measured_run(truth, catenary, pantograph, mode, time_step_s):
    """The projected spans of ``truth`` as ``pantograph`` measures it at SPEED_KMH (no noise)."""
    points = np.concatenate([truth.dropper_chainage_m, truth.mast_chainage_m])
    heights = measuring_pass(truth, catenary, pantograph, speed_m_s=SPEED_KMH / 3.6, mode=mode,
                             time_step_s=time_step_s, chainage_m=points).height_m
    d = truth.dropper_chainage_m.size
    return measured_spans(truth, heights[:d], heights[d:])


def true_line(catenary, n2, n_spans=3, seed=0):
    rng = np.random.default_rng(seed)
    nominal = nominal_dropper_lengths(n2, catenary).dropper_lengths_m
    section = uniform_section(n2, n_spans, nominal)
    lengths = section.dropper_lengths_m + rng.normal(0.0, 0.004, section.dropper_lengths_m.size)
    heights = n2.cw_height_m + rng.normal(0.0, 0.02, n_spans + 1)
    return section.with_dropper_lengths(lengths).with_cw_support_heights(heights)


@pytest.mark.parametrize("mode, start, tolerance_m, max_error_m, max_passes", [
    ("quasi_static", False, 2e-5, 5e-5, 3),
    ("dynamic", False, 1e-3, 1e-3, 3),        # the paper's loop
    ("dynamic", True, 1e-3, 1e-3, 2),         # quasi-static passes first
])
def test_correction_recovers_the_static_geometry(catenary, n2, measuring, mode, start, tolerance_m,
                                                 max_error_m, max_passes):
    time_step_s = 0.005
    # The model has the truth's physics (design tensions and system heights), so the corrected W
    # must land on the true static W to within the tolerance; the correction itself (≈ 5 mm) is
    # much larger. The quasi-static iteration contracts by ≈ 1e-2 per pass, so a tight tolerance
    # is cheap; the dynamic one by 0.1 then 0.3–0.5 (the pantograph's dynamics respond a little
    # more to a profile change than the static CW does), so it is run at the paper's 1 mm.
    truth = true_line(catenary, n2)
    spans = measured_run(truth, catenary, measuring, mode, time_step_s)
    settings = CorrectionSettings(mode=mode, time_step_s=time_step_s, tolerance_m=tolerance_m, max_iterations=4,
                                  quasi_static_start=start)
    corrected, history, _ = correct_spans(spans, catenary, measuring, settings)
    assert corrected["converged"].all() and corrected["iterations"].max() <= max_passes
    w_true = solve_static(truth, catenary).dropper_deflection_m().reshape(3, 9)
    w = corrected[[f"w{i}_m" for i in range(1, 10)]].to_numpy()
    uplift = np.abs(spans[[f"w{i}_m" for i in range(1, 10)]].to_numpy() - w_true)
    assert uplift.max() > 3e-3                          # the correction is not trivial
    np.testing.assert_allclose(w, w_true, atol=max_error_m)
    norms = history[history["mode"] == mode].groupby("iteration")["gap_norm_m"].max().to_numpy()
    assert np.all(np.diff(norms) < 0)


def test_the_whole_profile_is_corrected(catenary, n2, measuring):
    # Between the droppers, where W holds nothing, the final model's simulated pass must follow
    # the measured profile as closely as at the droppers, and the corrected profile (measured
    # minus the model's uplift) must land on the true static CW: the correction's 1 mm tolerance
    # bounds both (the pass is noise-free, so nothing else enters).
    time_step_s = 0.005
    truth = true_line(catenary, n2)
    spans = measured_run(truth, catenary, measuring, "dynamic", time_step_s)
    x = np.arange(0.0, truth.mast_chainage_m[-1], 0.1)
    measured = measuring_pass(truth, catenary, measuring, speed_m_s=SPEED_KMH / 3.6, mode="dynamic",
                              time_step_s=time_step_s, chainage_m=x).height_m
    span = np.minimum(np.searchsorted(truth.mast_chainage_m, x, side="right") - 1, truth.n_spans - 1)
    profiles = pd.DataFrame({"span_id": spans["span_id"].to_numpy()[span], "run_id": "run",
                             "x_m": x - truth.mast_chainage_m[span], "height_m": measured})
    settings = CorrectionSettings(mode="dynamic", time_step_s=time_step_s, tolerance_m=1e-3, max_iterations=4)
    corrected, _, profile = correct_spans(spans, catenary, measuring, settings, profiles=profiles)
    assert corrected["converged"].all() and len(profile) == len(profiles)
    at = truth.mast_chainage_m[spans.set_index("span_id").index.get_indexer(profile["span_id"])] + profile["x_m"]
    residual = profile["height_m"] - profile["simulated_height_m"]
    static_true = solve_static(truth, catenary).cw_height_at(at.to_numpy())
    corrected_profile = profile["height_m"] - (profile["simulated_height_m"] - profile["static_height_m"])
    uplift = profile["height_m"] - static_true
    assert np.abs(uplift).max() > 5e-3                         # the uplift is not trivial
    assert np.abs(residual).max() < 1e-3
    assert np.abs(corrected_profile - static_true).max() < 1e-3


def test_runs_split_at_missing_spans_and_sections(catenary, n2):
    truth = true_line(catenary, n2, n_spans=4)
    h_d = solve_static(truth, catenary).cw_height_at(truth.dropper_chainage_m)
    spans = measured_spans(truth, h_d, truth.cw_support_heights_m)
    other = measured_spans(truth, h_d, truth.cw_support_heights_m, start_m=5000.0, section_id="S2", first=20)
    table = pd.concat([spans.drop(index=2), other], ignore_index=True).sample(frac=1.0, random_state=1)
    runs = consecutive_runs(table)
    assert [list(r["span_id"]) for r in runs] == [
        ["M0001-M0002", "M0002-M0003"], ["M0004-M0005"], [f"M{20 + k:04d}-M{21 + k:04d}" for k in range(4)]]


def test_slack_dropper_in_the_truth_is_found(catenary, n2, measuring):
    # A dropper 4 cm too long hangs slack in the truth. The measurement cannot tell it from a just
    # taut dropper holding the CW 1.4 mm higher: under the pantograph the slack point lifts more,
    # by the same 1.4 mm. Everywhere else the correction must land on the true static W.
    truth = true_line(catenary, n2, n_spans=2)
    lengths = truth.dropper_lengths_m.copy()
    lengths[13] += 0.04
    truth = truth.with_dropper_lengths(lengths)
    static = solve_static(truth, catenary)
    assert np.flatnonzero(static.dropper_slack).tolist() == [13]
    points = np.concatenate([truth.dropper_chainage_m, truth.mast_chainage_m])
    measured = measuring_pass(truth, catenary, measuring, speed_m_s=SPEED_KMH / 3.6, mode="quasi_static",
                              chainage_m=points).height_m
    spans = measured_spans(truth, measured[:18], measured[18:])
    settings = CorrectionSettings(mode="quasi_static", tolerance_m=2e-5)
    corrected, *_ = correct_spans(spans, catenary, measuring, settings)
    assert corrected["converged"].all()
    w = corrected[[f"w{i}_m" for i in range(1, 10)]].to_numpy()
    error = np.abs(w - static.dropper_deflection_m().reshape(2, 9)).ravel()
    assert np.all(np.delete(error, 13) < 5e-5) and error[13] < 2e-3


def test_impossible_span_is_reported_not_lost(catenary, n2, measuring):
    truth = true_line(catenary, n2, n_spans=2)
    h_d = solve_static(truth, catenary).cw_height_at(truth.dropper_chainage_m)
    spans = measured_spans(truth, h_d, truth.cw_support_heights_m)
    spans.loc[1, "w5_m"] += 0.3          # a CW 30 cm above its neighbours: no dropper can hold it there
    settings = CorrectionSettings(mode="quasi_static", max_iterations=3)
    corrected, *_ = correct_spans(spans, catenary, measuring, settings)
    assert len(corrected) == 2 and corrected["converged"].tolist() == [True, False]
    assert corrected.loc[1, "slack_droppers"] >= 1 and "gap" in corrected.loc[1, "reason"]


@pytest.mark.parametrize("mapping, message", [({"mode": "fast"}, "correction.mode"),
                                              ({"tolerance_m": 0.0}, "correction.tolerance_m"),
                                              ({"max_iterations": 0}, "max_iterations"),
                                              ({"tolerance": 1e-3}, r"correction: unknown key\(s\) tolerance")])
def test_bad_settings_name_the_key(mapping, message):
    with pytest.raises(ConfigError, match=message):
        CorrectionSettings.from_mapping(mapping)


def test_only_a_solver_failure_is_reported_as_a_failed_run(catenary, n2, measuring, monkeypatch):
    # A ConvergenceError of a solve is a property of that run: the run's spans are kept, marked
    # not converged, with the reason. Any other error (here a ConfigError, as a bad pantograph or
    # mode would raise) is a configuration or programming error and must stop the correction.
    import catenary.stages.correction.runner as correction
    from catenary.plumbing.errors import ConvergenceError

    truth = true_line(catenary, n2, n_spans=2)
    h_d = solve_static(truth, catenary).cw_height_at(truth.dropper_chainage_m)
    spans = measured_spans(truth, h_d, truth.cw_support_heights_m)
    settings = CorrectionSettings(mode="quasi_static", max_iterations=2)

    def unsettled(*args, **kwargs):
        raise ConvergenceError("dropper/contact states did not settle in 50 iterations")

    monkeypatch.setattr(correction, "measuring_pass", unsettled)
    corrected, *_ = correct_spans(spans, catenary, measuring, settings)
    assert len(corrected) == 2 and not corrected["converged"].any()
    assert corrected["reason"].str.contains("a solver did not converge on this run .*did not settle").all()

    def misconfigured(*args, **kwargs):
        raise ConfigError("correction.pantograph: unknown pantograph 'measurin'")

    monkeypatch.setattr(correction, "measuring_pass", misconfigured)
    with pytest.raises(ConfigError, match="unknown pantograph"):
        correct_spans(spans, catenary, measuring, settings)


def test_runs_in_opposite_directions_give_the_sensor_noise_in_their_measured_residuals(catenary, n2, measuring):
    # Eight spans measured in both directions, each run's W with its own sensor noise of
    # σ = 0.5 mm per dropper (independent). Over the runs' mean corrected W, each run's measured
    # minus simulated W is its noise less the runs' mean noise, to first order: the pooled
    # within-span scatter of those residuals (72 degrees of freedom) estimates σ with a relative
    # standard error of 1/√(2·72) = 8 %; 25 % is three of them. The corrected W's scatter also
    # holds how the two directions' corrections stop apart, so it is not asked to match.
    from catenary.measurement.repeatability import estimate_repeatability

    time_step_s, sigma = 0.005, 5e-4
    truth = true_line(catenary, n2, n_spans=8, seed=3)
    points = np.concatenate([truth.dropper_chainage_m, truth.mast_chainage_m])
    d = truth.dropper_chainage_m.size
    runs = []
    for run_id, direction, seed in (("up", 1, 11), ("down", -1, 12)):
        kwargs = {} if direction == 1 else {"direction": -1}
        heights = measuring_pass(truth, catenary, measuring, speed_m_s=SPEED_KMH / 3.6, mode="dynamic",
                                 time_step_s=time_step_s, chainage_m=points, **kwargs).height_m
        heights_d = heights[:d] + np.random.default_rng(seed).normal(0.0, sigma, d)
        runs.append(measured_spans(truth, heights_d, heights[d:]).assign(run_id=run_id, direction=direction))
    settings = CorrectionSettings(time_step_s=time_step_s, max_iterations=5)
    corrected, *_ = correct_spans(pd.concat(runs, ignore_index=True), catenary, measuring, settings)
    assert corrected["converged"].all()
    residuals = corrected[[f"residual_w{i}_m" for i in range(1, 10)]].to_numpy()
    assert np.isfinite(residuals).all()
    result = estimate_repeatability(corrected)
    assert result.measured_dof == 8
    assert result.measured_rms_m == pytest.approx(sigma, rel=0.25)


def test_a_single_run_has_no_measured_residuals(catenary, n2, measuring):
    # Nothing to compare it with: the residual columns are there and empty, no pass is added.
    truth = true_line(catenary, n2)
    spans = measured_run(truth, catenary, measuring, "quasi_static", 0.005)
    corrected, *_ = correct_spans(spans, catenary, measuring, CorrectionSettings(mode="quasi_static"))
    assert corrected[[f"residual_w{i}_m" for i in range(1, 10)]].isna().all().all()


def test_a_stalled_gap_ends_the_loop_before_its_budget(catenary, n2, measuring):
    # The impossible span's gap cannot shrink (no dropper holds the CW 30 cm up): once a pass takes
    # less than 3 % off it (DYNAMIC_STALL), further passes are not run, and the span is reported
    # unconverged with its gap, its neighbour converged.
    truth = true_line(catenary, n2, n_spans=2)
    h_d = solve_static(truth, catenary).cw_height_at(truth.dropper_chainage_m)
    spans = measured_spans(truth, h_d, truth.cw_support_heights_m)
    spans.loc[1, "w5_m"] += 0.3
    settings = CorrectionSettings(mode="quasi_static", max_iterations=10)
    corrected, history, _ = correct_spans(spans, catenary, measuring, settings)
    gaps = history[history["span_id"] == spans.loc[1, "span_id"]]["gap_norm_m"].to_numpy()
    assert 2 <= gaps.size < 10
    assert gaps[-1] > 0.97 * gaps[-2] and gaps[-1] > settings.tolerance_m
    assert corrected["converged"].tolist() == [True, False]
