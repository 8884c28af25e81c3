"""The correction's model-error budget (issue [13]): shifts of the corrected W per source."""

import numpy as np
import pytest

from catenary.correction import CorrectionSettings, correct_spans
from catenary.errors import ConfigError
from catenary.model_error.correction import run_shifts
from catenary.model_error.sources import ModelErrorSettings, Source

from .test_correction import measured_run, measuring, true_line  # noqa: F401  (measuring: a fixture)

W = [f"w{i}_m" for i in range(1, 10)]


def _corrected(catenary, n2, pantograph, mode, sources, tolerance_m, time_step_s=0.005, max_iterations=5):
    spans = measured_run(true_line(catenary, n2), catenary, pantograph, mode, time_step_s)
    settings = CorrectionSettings(mode=mode, time_step_s=time_step_s, tolerance_m=tolerance_m,
                                  max_iterations=max_iterations, quasi_static_start=False)
    tables = []

    def budget(rows, result, panto, speed, direction, profile):
        tables.append(run_shifts(rows, result, catenary, panto, speed, sources, mode=mode, time_step_s=time_step_s,
                                 direction=direction, speed_profile=profile))

    corrected, _ = correct_spans(spans, catenary, pantograph, settings, after_run=budget)
    return spans, corrected, tables[0]


def test_force_shift_is_the_quasi_static_uplift_scaled(catenary, n2, measuring):
    # Quasi-static passes: the uplift is proportional to the force (taut droppers, linear
    # statics), so +1 N moves the corrected W by (corrected − measured W) / 36 N at every dropper.
    # Tolerance: the linearisation holds the geometry fixed; the uplift's dependence on a 0.1 mm
    # change of geometry is ~1e-3 of it: 2 µm against a shift of ≈ 0.12 mm.
    source = Source("measuring_force", "force_n", std=1.0)
    spans, corrected, shifts = _corrected(catenary, n2, measuring, "quasi_static", [source], 2e-6)
    correction = corrected[W].to_numpy() - spans[W].to_numpy()
    assert np.abs(correction).max() > 3e-3
    assert (shifts["status"] == "").all()
    np.testing.assert_allclose(shifts[W].to_numpy(), correction / 36.0, atol=2e-6)


def test_linear_shifts_match_a_full_correction_at_the_perturbed_inputs(catenary, n2, measuring):
    # Dynamic passes: the shift, iterated from the converged model, against the difference of two
    # full corrections each converged to a gap norm of 0.01 mm over a span's 9 droppers (≈ 3 µm per
    # dropper, twice). A 20 % heavier head (shift ≈ 0.07 mm RMS) and +2 N (≈ 0.19 mm): agreement
    # within that convergence plus 10 % of the largest shift (measured: 3–5 µm; the first-order
    # shift alone is off by up to 0.1 mm for the head mass, the dynamic passes contracting by 0.4).
    sources = [Source("measuring_force", "force_n", std=2.0), Source("head_mass", "pantograph.masses_kg.0",
                                                                     relative_std=0.2)]
    tolerance_m = 1e-5
    spans, corrected, shifts = _corrected(catenary, n2, measuring, "dynamic", sources, tolerance_m, max_iterations=25)
    assert corrected["converged"].all()
    from dataclasses import replace
    # the correction sets the force from the recording or its settings' force_n
    moved = {"measuring_force": (measuring, 38.0),
             "head_mass": (replace(measuring, masses_kg=measuring.masses_kg * np.array([1.2, 1.0, 1.0])), 36.0)}
    for name, (pantograph, force_n) in moved.items():
        settings = CorrectionSettings(mode="dynamic", time_step_s=0.005, tolerance_m=tolerance_m, max_iterations=25,
                                      quasi_static_start=False, force_n=force_n)
        again, _ = correct_spans(spans, catenary, pantograph, settings)
        assert again["converged"].all()
        full = again[W].to_numpy() - corrected[W].to_numpy()
        linear = shifts.loc[shifts["source"] == name, W].to_numpy()
        rms = np.sqrt(np.mean(full ** 2))
        assert rms > 1e-5, name                         # the source moves W
        np.testing.assert_allclose(linear, full, atol=0.1 * np.abs(full).max() + 2 * tolerance_m / 3, err_msg=name)


@pytest.mark.parametrize("block, message", [
    ({"enabled": True, "sources": [{"name": "f", "input": "force", "std": 1.0}]}, "model_error"),
    ({"enabled": True, "sources": [{"name": "f", "input": "force_n"}]}, "model_error"),
    ({"enabled": True, "sources": [{"name": "f", "input": "force_n", "std": 1.0},
                                   {"name": "f", "input": "speed", "relative_std": 0.01}]}, "repeated"),
])
def test_bad_budget_names_the_block(block, message):
    with pytest.raises(ConfigError, match=message):
        ModelErrorSettings.from_mapping(block)


def test_w_budget_combines_the_sources_and_measures_assumption_one():
    # Two spans, two sources: mean shifts 0.3 and 0.4 mm at every dropper combine to 0.5 mm
    # (root sum of squares); a correction of 4 mm is 8 such systematics. A span whose shift could
    # not be measured is counted apart and left out of the means.
    import pandas as pd

    from catenary.model_error.budget import w_budget

    def table(**columns):
        return pd.DataFrame({"span_type": "N2", "run_id": "R1", **columns})

    ids = ["A", "B", "C"]
    shifts = pd.concat([table(span_id=ids, source=name, status=["", "", "solver"],
                              **{c: [v - 1e-4, v + 1e-4, 9.0] for c in W})
                        for name, v in (("force", 3e-4), ("mass", -4e-4))], ignore_index=True)
    corrected = table(span_id=ids, converged=True, **{c: [0.024, 0.024, 0.024] for c in W})
    spans = table(span_id=ids, **{c: [0.020, 0.020, 0.020] for c in W})
    budget = w_budget(shifts, corrected, spans)
    assert len(budget) == 9 and (budget["n_spans"] == 2).all() and (budget["n_not_measured"] == 1).all()
    np.testing.assert_allclose(budget["shift_force_m"], 3e-4, rtol=1e-12)
    np.testing.assert_allclose(budget["systematic_m"], 5e-4, rtol=1e-12)
    np.testing.assert_allclose(budget["correction_over_systematic"], 4e-3 / 5e-4, rtol=1e-9)
    assert (budget["dominant_source"] == "mass").all()


def test_a_pantograph_entry_it_does_not_have_is_refused(catenary, measuring):
    from catenary.model_error.sources import perturbed

    with pytest.raises(ConfigError, match="has 3 masses_kg"):
        perturbed(Source("fourth_mass", "pantograph.masses_kg.3", relative_std=0.1), 1.0, measuring, catenary, 11.1)
    moved, _, _ = perturbed(Source("head_mass", "pantograph.masses_kg.0", relative_std=0.1), 2.0, measuring, catenary,
                            11.1)
    assert moved.masses_kg.tolist() == pytest.approx([7.5 * 1.2, 9.0, 6.0]) and measuring.masses_kg[0] == 7.5
