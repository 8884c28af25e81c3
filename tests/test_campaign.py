"""Truth specification, hidden effects and section simulation of the virtual campaign."""

import copy

import numpy as np
import pytest
import yaml

from catenary.campaign import simulate_section
from catenary.errors import ConfigError
from catenary.pantograph import load_pantographs
from catenary.static import solve_static
from catenary.campaign import section_model
from catenary.truth import draw_line, truth_from_dict

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


def test_simulated_section_is_consistent_and_deterministic(raw, catenary):
    r = small(raw, [{"name": "measuring_force_offset", "force_n": 4.0}], n_spans=3)
    r["measurement"]["mode"] = "quasi_static"
    r["measurement"]["dropout_rate_per_km"] = 0.0
    r["measurement"]["spike_rate_per_km"] = 0.0
    spec = truth_from_dict(r, catenary)
    line = draw_line(spec, catenary)
    pantograph = load_pantographs(ROOT / "config" / "pantographs.yaml")["measuring"]
    rec, truth = simulate_section(line, 0, catenary, pantograph, spec.measurement, spec.seed)
    rec2, truth2 = simulate_section(line, 0, catenary, pantograph, spec.measurement, spec.seed)
    assert rec.equals(rec2) and truth.equals(truth2)
    section, _ = section_model(line, 0, catenary)
    w = solve_static(section, catenary).dropper_deflection_m().reshape(3, 9)
    np.testing.assert_allclose(truth.filter(like="static_w").to_numpy(), w, atol=1e-12)
    assert truth["measuring_force_n"].iloc[0] == 40.0
    assert rec["force_n"].iloc[0] == 36.0                   # the car reports the declared force
    # Under 40 N the wire is lifted: the dynamic (here quasi-static) W lies above the static one mid-span.
    assert np.all(truth["dynamic_w5_m"] > truth["static_w5_m"])
    # Sensor: 1 mm noise and 1 mm quantisation; heights on the 1 mm grid.
    np.testing.assert_allclose(rec["height_m"] * 1e3, np.round(rec["height_m"] * 1e3), atol=1e-6)
    assert np.all(np.diff(rec["chainage_m"]) > 0)
