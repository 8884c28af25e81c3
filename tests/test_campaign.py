"""Truth specification, hidden effects and section simulation of the virtual campaign."""

import copy

import numpy as np
import pandas as pd
import pytest
import yaml

from catenary.measurement.campaign import simulate_section
from catenary.measurement.campaign import section_model
from catenary.measurement.truth import draw_line, truth_from_dict
from catenary.physics.dropper_table import dropper_lengths_for_cw_heights
from catenary.physics.pantograph import load_pantographs
from catenary.plumbing.errors import ConfigError

from .conftest import ROOT


@pytest.fixture(scope="module")
def raw():
    return yaml.safe_load((ROOT / "config" / "campaign.yaml").read_text())


def small(raw, effects=(), n_spans=2, seed=7, sections=1):
    r = copy.deepcopy(raw)
    r["seed"] = seed
    r["line"]["sections"] = [{"section_id": f"T{k}", "span_type": "N2", "n_spans": n_spans} for k in range(sections)]
    r["hidden_effects"] = list(effects)
    return r


def test_draw_is_deterministic(raw, catenary):
    a = draw_line(truth_from_dict(small(raw, seed=3, n_spans=5), catenary), catenary)
    b = draw_line(truth_from_dict(small(raw, seed=3, n_spans=5), catenary), catenary)
    c = draw_line(truth_from_dict(small(raw, seed=4, n_spans=5), catenary), catenary)
    np.testing.assert_array_equal(a.params.dropper_lengths_m, b.params.dropper_lengths_m)
    assert not np.allclose(a.params.dropper_lengths_m, c.params.dropper_lengths_m)
    assert list(a.spans["span_id"][:2]) == ["M0001-M0002", "M0002-M0003"]


def test_default_campaign_shape(raw, catenary):
    line = draw_line(truth_from_dict(raw, catenary), catenary)
    types = line.spans["span_type"]
    assert (types == "N2").sum() == 117 and 55 <= (types == "N3").sum() <= 65
    # System heights are drawn per mast: adjacent spans of a section share one.
    p = line.params
    same_section = line.spans["section_id"][1:] == line.spans["section_id"][:-1]
    np.testing.assert_array_equal(p.system_height_right_m[:-1][same_section], p.system_height_left_m[1:][same_section])


def test_messenger_tension_variability_has_its_std(raw, catenary):
    # 2000 spans: the sample σ of a normal draw has relative standard error 1/√(2·1999) ≈ 1.6 %.
    spec = truth_from_dict(small(raw, [{"name": "messenger_tension_variability", "std_n": 818.0}], n_spans=2000),
                           catenary)
    t = draw_line(spec, catenary).params.messenger_tension_n
    assert np.std(t, ddof=1) == pytest.approx(818.0, rel=4 * 0.016)
    assert np.mean(t) == pytest.approx(20575.0, abs=4 * 818.0 / np.sqrt(2000))


def test_creep_and_system_height_correlation_act_as_specified(raw, catenary):
    base = draw_line(truth_from_dict(small(raw, n_spans=30), catenary), catenary).params
    crept = draw_line(truth_from_dict(small(raw, [{"name": "dropper_creep", "mean_m": 0.004, "std_m": 0.002}],
                                            n_spans=30), catenary), catenary).params
    shift = crept.dropper_lengths_m - base.dropper_lengths_m
    np.testing.assert_allclose(shift, np.repeat(crept.creep_offset_m[:, None], 9, axis=1), atol=1e-15)
    assert np.all(np.ptp(shift, axis=1) < 1e-12)          # one common offset per span
    tied = draw_line(truth_from_dict(small(raw, [{"name": "system_height_dropper_correlation", "gain": 0.5}],
                                           n_spans=30), catenary), catenary).params
    d = tied.dropper_lengths_m - base.dropper_lengths_m
    np.testing.assert_allclose(d[:, 0], 0.5 * (base.system_height_left_m - 1.388), atol=1e-15)
    np.testing.assert_allclose(d[:, -1], 0.5 * (base.system_height_right_m - 1.388), atol=1e-15)
    np.testing.assert_array_equal(d[:, 1:-1], 0.0)


@pytest.mark.parametrize("mutate, key", [
    (lambda r: r["hidden_effects"].append({"name": "gremlins"}), r"hidden_effects\[1\]\.name"),
    (lambda r: r["line"]["sections"][0].__setitem__("span_type", "N9"), r"sections\[0\]\.span_type"),
    (lambda r: r["span_parameters"]["N2"]["dropper_lengths_m"].__setitem__("std", [0.001] * 3),
     r"N2\.dropper_lengths_m\.std"),
    (lambda r: r["measurement"].__setitem__("mode", "psychic"), r"measurement\.mode"),
    (lambda r: r["contact_tension_n"].__setitem__("law", "cauchy"), r"contact_tension_n\.law"),
])
def test_bad_truth_names_the_key(raw, catenary, mutate, key):
    bad = copy.deepcopy(raw)
    mutate(bad)
    with pytest.raises(ConfigError, match=key):
        truth_from_dict(bad, catenary)


def quasi_static_section(raw, catenary, effects=()):
    """One simulated 3-span N2 section (quasi-static pass, no drop-outs or spikes): the drawn
    line, the spec, the recording and the truth table."""
    r = small(raw, effects, n_spans=3)
    r["measurement"]["mode"] = "quasi_static"
    r["measurement"]["dropout_rate_per_km"] = 0.0
    r["measurement"]["spike_rate_per_km"] = 0.0
    spec = truth_from_dict(r, catenary)
    line = draw_line(spec, catenary)
    pantograph = load_pantographs(ROOT / "config" / "pantographs.yaml")["measuring"]
    rec, truth, _ = simulate_section(line, 0, catenary, pantograph, spec.measurement, spec.seed)
    return line, spec, pantograph, rec, truth


def test_simulated_section_is_consistent_and_deterministic(raw, catenary):
    line, spec, pantograph, rec, truth = quasi_static_section(
        raw, catenary, [{"name": "measuring_force_offset", "force_n": 4.0},
                        {"name": "cw_longitudinal_offset", "mean_m": 0.1}])
    rec2, truth2, _ = simulate_section(line, 0, catenary, pantograph, spec.measurement, spec.seed)
    assert rec.equals(rec2) and truth.equals(truth2)
    np.testing.assert_array_equal(truth["cw_offset_m"], 0.1)  # inclined droppers
    assert truth["measuring_force_n"].iloc[0] == 40.0
    assert rec["force_n"].iloc[0] == 36.0                   # the car reports the declared force
    # Under 40 N the wire is lifted: the dynamic (here quasi-static) W lies above the static one mid-span.
    assert np.all(truth["dynamic_w5_m"] > truth["static_w5_m"])
    # Sensor: 1 mm noise and 1 mm quantisation; heights on the 1 mm grid.
    np.testing.assert_allclose(rec["height_m"] * 1e3, np.round(rec["height_m"] * 1e3), atol=1e-6)
    assert np.all(np.diff(rec["chainage_m"]) > 0)


def _simulated(raw, catenary, tmp_path, name):
    from catenary.measurement.campaign import masts_table, truth_schema
    from catenary.plumbing.parquet import write_table
    from catenary.measurement.recording import RECORDING_SCHEMA

    r = small(raw, n_spans=3, sections=2, seed=11)
    r["line"]["sections"][1]["span_type"] = "N3"
    r["measurement"]["mode"] = "quasi_static"
    r["measurement"]["dropout_rate_per_km"] = 6.0
    r["measurement"]["spike_rate_per_km"] = 20.0
    spec = truth_from_dict(r, catenary)
    line = draw_line(spec, catenary)
    pantograph = load_pantographs(ROOT / "config" / "pantographs.yaml")["measuring"]
    parts = [simulate_section(line, k, catenary, pantograph, spec.measurement, spec.seed) for k in range(2)]
    import pandas as pd
    recording = pd.concat([p[0] for p in parts], ignore_index=True)
    truth = pd.concat([p[1] for p in parts], ignore_index=True)
    out = tmp_path / name
    write_table(recording, out / "recording.parquet", RECORDING_SCHEMA, config_hash="x", kind="recording")
    write_table(truth, out / "truth.parquet", truth_schema(truth.columns), config_hash="x", kind="truth")
    masts_table(line).to_csv(out / "masts.csv", index=False)
    return out, recording, truth


def test_campaign_files_are_byte_identical_for_the_same_seed(raw, catenary, tmp_path):
    a, _, _ = _simulated(raw, catenary, tmp_path, "a")
    b, _, _ = _simulated(raw, catenary, tmp_path, "b")
    for name in ("recording.parquet", "truth.parquet", "masts.csv"):
        assert (a / name).read_bytes() == (b / name).read_bytes()


def test_round_trip_through_ingestion_and_projection(raw, catenary, tmp_path):
    # Noise 1 mm, quantisation 1 mm, drop-outs and ±5 cm spikes: the robust projection must
    # still give the truth's W under the measuring pass within 1 mm RMS.
    from catenary.measurement.truth_checks import projection_round_trip
    from catenary.measurement.projection import ProjectionSettings, project
    from catenary.measurement.recording import read_masts, read_recording

    out, _, truth = _simulated(raw, catenary, tmp_path, "rt")
    result = project(read_recording(out / "recording.parquet"), read_masts(out / "masts.csv"), catenary,
                     ProjectionSettings())
    assert len(result.report) == 6 and result.n_used + result.n_rejected == 6
    for span_type, spans in result.spans.items():
        figures = projection_round_trip(spans, truth)
        assert figures["rms_vs_dynamic_m"] < 1e-3, (span_type, figures)


def test_cw_longitudinal_offset_inclines_every_dropper_of_a_span(raw, catenary):
    # 2000 spans: mean within 4 standard errors (σ/√n), σ within 4 × 1.6 %.
    effect = {"name": "cw_longitudinal_offset", "mean_m": 0.05, "std_m": 0.03}
    line = draw_line(truth_from_dict(small(raw, [effect], n_spans=2000), catenary), catenary)
    delta = line.params.cw_offset_m
    assert np.mean(delta) == pytest.approx(0.05, abs=4 * 0.03 / np.sqrt(2000))
    assert np.std(delta, ddof=1) == pytest.approx(0.03, rel=4 * 0.016)
    section, spans = section_model(line, 0, catenary)
    np.testing.assert_array_equal(section.dropper_offset_m, np.repeat(delta[spans], 9))


def test_effect_magnitudes_are_checked_against_the_effect(raw, catenary):
    with pytest.raises(ConfigError, match=r"hidden_effects\[0\].*'cw_longitudinal_offset'.*unknown \['std'\]"):
        truth_from_dict(small(raw, [{"name": "cw_longitudinal_offset", "mean_m": 0.05, "std": 0.01}]), catenary)
    with pytest.raises(ConfigError, match=r"missing \['std_n'\]"):
        truth_from_dict(small(raw, [{"name": "messenger_tension_variability"}]), catenary)


def test_truth_static_w_gives_back_the_truth_dropper_lengths(raw, catenary):
    # The truth's static W checked by another algorithm: the inverse static solver (CW heights
    # prescribed at the droppers, from a guess at the system height) must give back the truth's
    # dropper lengths; it is exact (1e-9 m, test_dropper_table). Vertical droppers, where W at the
    # design position is the height of the CW clamp that the inverse solver prescribes.
    line, _, _, _, truth = quasi_static_section(raw, catenary)
    section, _ = section_model(line, 0, catenary)
    heights = section.chord_at_droppers(section.cw_support_heights_m) + truth.filter(like="static_w").to_numpy().ravel()
    guess = section.with_dropper_lengths(np.full(27, 1.388))
    lengths = dropper_lengths_for_cw_heights(guess, catenary, heights).dropper_lengths_m
    np.testing.assert_allclose(lengths, truth.filter(regex=r"^dropper_\d+_length_m$").to_numpy().ravel(), atol=1e-9)


def test_spans_found_without_a_table_match_the_truth_in_the_recorded_chainage():
    # No mast table: the masts' chainage frame is the recording's, offset 7 m and scaled 0.3 %
    # from the line's. Matching by chainage finds nothing; by each run's recorded chainage (the
    # masts' recorded_chainage_m against the truth's recorded ends) every span, a reverse run too.
    from catenary.measurement.truth_checks import match_spans

    true_x = np.array([0.0, 58.5, 117.0, 175.5])
    truth = pd.DataFrame({"span_id": ["A", "B", "C"], "start_chainage_m": true_x[:-1], "end_chainage_m": true_x[1:]})
    recorded = {"F": 7.0 + 1.003 * true_x, "R": 190.0 - 1.003 * true_x}      # forward and reverse runs
    truth_runs = pd.concat([pd.DataFrame({"span_id": truth["span_id"], "run_id": run,
                                          "recorded_start_chainage_m": x[:-1], "recorded_end_chainage_m": x[1:]})
                            for run, x in recorded.items()], ignore_index=True)
    found = recorded["F"] + np.array([0.05, -0.1, 0.0, 0.2])                  # masts found to decimetres
    masts = pd.concat([pd.DataFrame({"run_id": run, "mast_id": [f"T{k}" for k in range(4)],
                                     "recorded_chainage_m": x}) for run, x in (("F", found),
                                                                                ("R", recorded["R"][::-1]))])
    spans = pd.DataFrame({"run_id": ["F", "F", "F", "R"], "left_mast_id": ["T0", "T1", "T2", "T0"],
                          "right_mast_id": ["T1", "T2", "T3", "T1"],
                          "start_chainage_m": found[:3].tolist() + [0.0], "end_chainage_m": found[1:].tolist() + [1.0]})
    assert match_spans(spans, truth).tolist() == ["", "", "", ""]
    # the reverse run's masts T0, T1 are listed from the far end: the truth's span C
    assert match_spans(spans, truth, masts=masts, truth_runs=truth_runs).tolist() == ["A", "B", "C", "C"]


@pytest.mark.parametrize("same_direction", [True, False])
def test_repeatability_round_trip_splits_the_runs_scatter_into_sensor_and_correction(same_direction):
    # Two runs over three spans. Run 1's projected W is the true dynamic W + a, run 2's − a; the
    # correction leaves + b on both (same direction) or + b and − b: within-span scatter of two
    # runs differing by d is |d|/√2, so sensor a√2, correction 0 or b√2, total (a or a + b)√2.
    from catenary.measurement.truth_checks import repeatability_round_trip

    a, b, n = 0.4e-3, 0.3e-3, 9
    x = np.array([0.0, 58.5, 117.0, 175.5])
    ids = ["A", "B", "C"]
    rng = np.random.default_rng(7)
    static = 0.02 + 0.01 * rng.random((3, n))
    dynamic = {"R1": static - 0.004, "R2": static - 0.005}
    w = [f"w{i}_m" for i in range(1, n + 1)]
    truth = pd.DataFrame(static, columns=[f"static_{c}" for c in w]).assign(
        span_id=ids, start_chainage_m=x[:-1], end_chainage_m=x[1:])
    truth_runs = pd.concat([pd.DataFrame(d, columns=[f"dynamic_{c}" for c in w]).assign(span_id=ids, run_id=run)
                            for run, d in dynamic.items()], ignore_index=True)
    sensor = {"R1": a, "R2": -a}
    left = {"R1": b, "R2": b if same_direction else -b}
    spans = pd.concat([pd.DataFrame(dynamic[run] + sensor[run], columns=w).assign(
        span_id=ids, run_id=run, start_chainage_m=x[:-1], end_chainage_m=x[1:]) for run in dynamic], ignore_index=True)
    corrected = pd.concat([pd.DataFrame(static + sensor[run] + left[run], columns=w).assign(
        span_id=ids, run_id=run, converged=True) for run in dynamic], ignore_index=True)
    figures = repeatability_round_trip(corrected, spans, truth, truth_runs)
    assert figures["n_spans"] == 3 and figures["dof"] == 3
    assert figures["within_sensor_m"] == pytest.approx(a * np.sqrt(2), rel=1e-9)
    assert figures["within_correction_m"] == pytest.approx(0.0 if same_direction else b * np.sqrt(2), abs=1e-12)
    assert figures["within_total_m"] == pytest.approx((a if same_direction else a + b) * np.sqrt(2), rel=1e-9)
