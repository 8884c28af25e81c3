"""The correction's step under the measuring pass's response to the static CW (issue [18])."""

import numpy as np
import pandas as pd
import pytest

from catenary.physics.measuring import profile_influence, support_response
from catenary.physics.static import solve_static
from catenary.stages.correction import CorrectionSettings, correct_spans
from catenary.stages.correction.step import (SupportResponse, measuring_responses, read_responses, response_table,
                                             run_response, step_move)

from .test_correction import SPEED_KMH, measured_run, measuring, true_line  # noqa: F401 (fixture)

TIME_STEP_S = 0.01   # the same model measures and corrects: only its linearity matters here


def test_the_quasi_static_response_is_one_for_one(catenary, n2, measuring):
    # Statically a dropper raised by the inverse solver moves the CW at that dropper alone (the
    # others are held), and the uplift under a static force does not depend on the geometry
    # while the droppers stay taut: the measured height moves one for one at the raised support
    # and nowhere else. Tolerance: a raise changes the droppers' lengths, hence their axial
    # stiffness EA/L by ≈ 0.1 % per mm of a 1 m dropper, and the uplift under the 36 N with it
    # (measured: ≤ 1.9e-4 of the raise, N2); an error of the inverse or of the columns' places
    # would be of order 1.
    r = support_response(n2, catenary, measuring, speed_m_s=SPEED_KMH / 3.6, mode="quasi_static", neighbours=1)
    n = n2.n_droppers
    expected = np.zeros_like(r)
    expected[n + np.arange(n), np.arange(n)] = 1.0        # the central span's droppers
    expected[3 * n + 1, n] = 1.0                          # its left mast
    np.testing.assert_allclose(r, expected, atol=1e-3)


def test_the_dynamic_response_stays_near_the_raised_support(catenary, n2, measuring):
    # The pantograph's inertia answers a change of the profile: the height measured at a raised
    # dropper moves by less than the raise (0.7–1.0, as profile_influence states), and the
    # change is local — two spans away it is a small fraction of it.
    r = support_response(n2, catenary, measuring, speed_m_s=SPEED_KMH / 3.6, time_step_s=TIME_STEP_S)
    n = n2.n_droppers
    own = r[2 * n + np.arange(n), np.arange(n)]
    assert np.all((own > 0.7) & (own <= 1.0))
    assert np.abs(r[:n]).max() < 0.05 and np.abs(r[4 * n:5 * n]).max() < 0.05
    # the same columns as the profile's sensitivity, read at the central span's droppers
    along = profile_influence(n2, catenary, measuring, speed_m_s=SPEED_KMH / 3.6, time_step_s=TIME_STEP_S,
                              x_m=n2.dropper_positions_m)
    np.testing.assert_allclose(r[2 * n:3 * n], along[:, :n + 1], atol=1e-12)


def _response(matrix, span_type="A", neighbours=1):
    return SupportResponse(span_type, 1, 11.0, 36.0, neighbours, matrix)


def test_a_run_takes_each_span_s_columns_shifted():
    # 2 droppers per span, one neighbour each side: rows 3 spans × 2 droppers, then 4 masts.
    rng = np.random.default_rng(1)
    m = rng.normal(size=(10, 3))
    a = run_response(["A", "A", "A", "A"], [2, 2, 2, 2], [_response(m)], 1)
    nd = 8
    # dropper 1 (second) of span 2: spans 1–3 and masts 1–4 from the nominal rows
    col = a[:, 2 * 2 + 1]
    np.testing.assert_array_equal(col[2:8], m[:6, 1])
    np.testing.assert_array_equal(col[:2], 0.0)
    np.testing.assert_array_equal(col[nd + 1:nd + 5], m[6:10, 1])
    np.testing.assert_array_equal(col[nd], 0.0)
    # the first span's dropper: its left neighbour is outside the run
    np.testing.assert_array_equal(a[0:4, 0], m[2:6, 0])
    np.testing.assert_array_equal(a[nd:nd + 3, 0], m[7:10, 0])
    # the last mast (right of the last span) answers as a left mast would, shifted
    np.testing.assert_array_equal(a[6:8, nd + 4], m[0:2, 2])
    np.testing.assert_array_equal(a[nd + 3:nd + 5, nd + 4], m[6:8, 2])


def test_a_span_type_without_response_steps_by_its_gap():
    m = np.random.default_rng(2).normal(size=(10, 3))
    a = run_response(["A", "B", "A"], [2, 2, 2], [_response(m)], 1)
    np.testing.assert_array_equal(a[:, 2], np.eye(10)[2])      # span B's droppers: one for one
    np.testing.assert_array_equal(a[2:4, 0], 0.0)             # no coupling across a type change
    np.testing.assert_array_equal(a[:2, 0], m[2:4, 0])
    np.testing.assert_array_equal(run_response(["A"], [2], [], 1), np.eye(4))
    np.testing.assert_array_equal(run_response(["A"], [2], [_response(m)], -1), np.eye(4))   # other direction


def test_the_step_closes_the_gap_on_the_measured_points():
    rng = np.random.default_rng(3)
    a = np.eye(7) + 0.1 * rng.normal(size=(7, 7))
    gap_d, gap_m = rng.normal(size=4), rng.normal(size=3)
    on_d, on_m = np.array([True, True, False, True]), np.array([True, False, True])
    gap_d[~on_d], gap_m[~on_m] = 0.0, 0.0
    move_d, move_m = step_move(a, gap_d, gap_m, on_d, on_m)
    on = np.r_[on_d, on_m]
    move = np.r_[move_d, move_m]
    np.testing.assert_allclose(a[np.ix_(on, on)] @ move[on], np.r_[gap_d, gap_m][on], atol=1e-12)
    np.testing.assert_array_equal(move[~on], 0.0)
    assert step_move(None, gap_d, gap_m, on_d, on_m) == (gap_d, gap_m)


def test_responses_are_computed_per_type_and_direction_and_read_back(catenary, measuring):
    spans = pd.DataFrame({"span_type": ["N2", "N2", "N2"], "direction": [1, -1, 1], "speed_kmh": [40.0, 40.0, 44.0],
                          "force_n": [np.nan, 36.0, 36.0]})
    responses = measuring_responses(spans, catenary, measuring, default_speed_m_s=30 / 3.6, default_force_n=30.0,
                                    time_step_s=0.01)
    assert [(r.span_type, r.direction) for r in responses] == [("N2", -1), ("N2", 1)]
    assert responses[1].speed_m_s == pytest.approx(42 / 3.6) and responses[1].force_n == 36.0
    back = read_responses(response_table(responses))
    for r, b in zip(responses, back):
        assert (b.span_type, b.direction, b.speed_m_s, b.force_n, b.neighbours) == (
            r.span_type, r.direction, r.speed_m_s, r.force_n, r.neighbours)
        np.testing.assert_array_equal(b.matrix, r.matrix)


def test_the_response_step_converges_in_fewer_dynamic_passes(catenary, n2, measuring):
    # A tight tolerance shows the contraction: the plain step leaves ≈ 0.15–0.3 of the first
    # dynamic gap, the response's step (taken after the first dynamic pass) only what the run's
    # ends and the response's finite differences leave. Both land on the true static W within
    # their tolerance divided by the smallest response of a measured height to its own support
    # (0.78: a gap norm of 0.1 mm leaves a W error up to ≈ 0.13 mm).
    truth = true_line(catenary, n2, n_spans=5, seed=4)
    spans = measured_run(truth, catenary, measuring, "dynamic", TIME_STEP_S)
    settings = CorrectionSettings(mode="dynamic", time_step_s=TIME_STEP_S, tolerance_m=0.1e-3, max_iterations=6)
    responses = measuring_responses(spans.assign(direction=1), catenary, measuring, default_speed_m_s=SPEED_KMH / 3.6,
                                    default_force_n=measuring.static_force_n, time_step_s=TIME_STEP_S)
    w_true = solve_static(truth, catenary).dropper_deflection_m().reshape(5, 9)
    gaps = {}
    for name, given in (("plain", ()), ("response", responses)):
        corrected, history, _ = correct_spans(spans, catenary, measuring, settings, responses=given)
        assert corrected["converged"].all()
        w = corrected[[f"w{i}_m" for i in range(1, 10)]].to_numpy()
        np.testing.assert_allclose(w, w_true, atol=0.1e-3 / 0.78)
        gaps[name] = history[history["mode"] == "dynamic"].groupby("iteration")["gap_norm_m"].max().to_numpy()
    assert gaps["response"][0] == gaps["plain"][0]                # the same first dynamic pass
    assert gaps["response"][1] < 0.7 * gaps["plain"][1]
    assert gaps["response"].size < gaps["plain"].size
