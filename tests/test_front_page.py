"""catenary.report.front_page: the report's opening panel, from the pipeline's own tables."""

import json

import pandas as pd
from docutils.core import publish_parts

from catenary.report.front_page import front_page

SPANS = pd.DataFrame({"span_type": ["N2"] * 4, "status": ["used", "used", "used", "rejected"],
                      "reason": [None, None, None, "gap of 9.0 m in the recording"]})
CORRECTION = pd.DataFrame([{"span_type": "N2", "n_spans": 3, "n_converged": 2, "converged_within_3_percent": 66.7,
                            "median_iterations": 2.0, "max_gap_norm_m": 0.0021}])
S_OPT = pd.DataFrame([
    {"parameter": "dropper_1_length_m", "mu": 1.2430, "sigma": 0.0063, "mu_se": 0.0, "sigma_se": 0.0013,
     "mu_fixed": True, "converged": True, "status": "ok"},
    {"parameter": "messenger_tension_n", "mu": 20536.5, "sigma": 799.85, "mu_se": 193.1, "sigma_se": 160.4,
     "mu_fixed": False, "converged": True, "status": "ok"}])
FINDINGS = pd.DataFrame([
    {"step": 1, "verdict": "named", "effect": "messenger_tension_variability", "runner_up": "dropper_creep",
     "p_value": 1.7e-115, "parameters": json.dumps({"std_n": [833.2, 57.6]})},
    {"step": 2, "verdict": "ambiguous", "effect": "dropper_creep", "runner_up": "cw_longitudinal_offset",
     "p_value": 2e-4, "parameters": "{}"},
    {"step": 3, "verdict": "none_detected", "effect": None, "runner_up": "x", "p_value": None, "parameters": "{}"}])


def test_front_page_says_what_each_table_says_and_is_valid_rst():
    page = front_page("Title\n=====\n\nThe method {{ in a few }} lines.", SPANS, CORRECTION, {"N2": S_OPT},
                      {"N2": FINDINGS})
    assert "3 used, 1 rejected (1 × gap of 9.0 m in the recording)" in page
    assert "2 of 3 spans converged" in page and "largest final gap 2.1 mm" in page
    # in an engineer's units and words (the files keep SI): a dropper in mm, a tension in N
    assert "dropper 1 length [mm]" in page and "1243.0" in page and "6.3" in page and "1.3" in page
    assert "messenger tension T_MW [N]" in page and "20536" in page and "800" in page and "160" in page
    assert "held fixed" in page and "_length_m" not in page
    assert "**messenger_tension_variability** named (p = 1.7e-115" in page and "std_n = 833.2 N ± 57.6 N" in page
    assert "ambiguous between **dropper_creep** and **cw_longitudinal_offset**" in page
    assert "step 3: no missing effect detected" in page
    assert "{{" not in page                                          # Snakemake renders it with Jinja first
    # docutils (Snakemake's renderer) takes it without a warning or an error
    body = publish_parts(page, writer="html", settings_overrides={"report_level": 2, "halt_level": 2})["body"]
    assert body.count("<tr>") == 3                                   # header + 2 inputs


def test_a_span_type_without_diagnosis_says_so():
    page = front_page("T\n=\n", SPANS, CORRECTION, {"N2": S_OPT}, {"N2": None})
    assert "**Diagnosis:** not run for this span type." in page


def test_front_page_carries_the_total_intervals_and_says_the_cars_caveat_once():
    # With the model-error budget: the 95 % total interval beside each parameter and the source
    # dominating it; the car's caveat is said once for the page, however many span types, with
    # the measurement that settles it and its power on each, and no finding is singled out; an
    # ambiguous step carries its measurement.
    s_opt = S_OPT.assign(mu_total_low=[float("nan"), 20120.0], mu_total_high=[float("nan"), 20960.0],
                         sigma_total_low=[0.0035, 550.0], sigma_total_high=[0.0110, 1240.0])
    budget = pd.DataFrame([
        {"parameter": "dropper_1_length_m", "statistic": "sigma", "systematic": 3e-5, "dominant_source": "head_mass"},
        {"parameter": "messenger_tension_n", "statistic": "mu", "systematic": 29.2,
         "dominant_source": "measuring_force"},
        {"parameter": "messenger_tension_n", "statistic": "sigma", "systematic": 1.4, "dominant_source": "speed"}])
    findings = FINDINGS.assign(recommended_measurement=["", "MW tension in the span in 12 spans (6 h): predicted "
                                                        "power 0.83", ""])
    row = dict(kind="car", step=2, asked="", option="force_calibration", quantity="measuring_force_n", per="line",
               extent=1, available=1, cost_h=1.0, power=1.0, power_full=1.0, enough=True, recommended=True,
               question="a measuring force 2 N off the declared one")
    recs = pd.DataFrame([row, {**row, "option": "wear_channel", "recommended": False}])
    page = front_page("T\n=\n", SPANS, CORRECTION, {"N2": s_opt, "N3": s_opt}, {"N2": findings, "N3": findings},
                      {"N2": budget, "N3": budget}, recommendations={"N2": recs, "N3": recs.assign(power=0.9)})
    assert "[20120, 20960]" in page and "[550, 1240]" in page and "[3.5, 11.0]" in page
    assert "μ: measuring_force; σ: speed" in page and "σ: head_mass" in page
    assert page.count("W alone cannot tell a measuring force 2 N off the declared one") == 1
    assert "static force of the measuring pantograph once (1 h), predicted power 1.00 on N2, 0.90 on N3" in page
    assert "could equally be" not in page and "check the car before acting" not in page
    assert "to settle it, measure the MW tension in the span in 12 spans (6 h)" in page
    body = publish_parts(page, writer="html", settings_overrides={"report_level": 2, "halt_level": 2})["body"]
    assert body.count("<tr>") == 6
    # without a budget the table keeps its five columns and says nothing of a total
    assert "95 % total" not in front_page("T\n=\n", SPANS, CORRECTION, {"N2": S_OPT}, {"N2": FINDINGS})


def test_the_front_page_says_the_tables_accuracy_each_run_measured_and_the_refusals():
    sections = pd.DataFrame({"run_id": ["R1", "R1", "R1"], "section_id": ["S01", "S02", "S03"],
                             "status": ["registered", "registered", "refused"],
                             "reason": ["", "", "section S03, run R1: registration failed: the trace's height confirms "
                                                "2 of the 21 masts"],
                             "table_std_m": [0.152, 0.181, float("nan")], "support_std_m": [0.17, 0.17, float("nan")]})
    page = front_page("T\n=\n", SPANS, CORRECTION, {"N2": S_OPT}, {"N2": None}, sections=sections, prior_std_m=0.2)
    assert ("**Registration, run R1:** 2 of 3 sections registered; the mast table is accurate to 0.15–0.18 m as the "
            "run measures it (prior ``mast_table_std_m`` 0.2 m)") in page
    assert "refused: section S03, run R1: registration failed: the trace's height confirms 2 of the 21 masts" in page
    publish_parts(page, writer="html", settings_overrides={"report_level": 2, "halt_level": 2})
    off = sections.assign(status="unregistered")
    assert "**Registration, run R1:** switched off" in front_page("T\n=\n", SPANS, CORRECTION, {"N2": S_OPT},
                                                                   {"N2": None}, sections=off, prior_std_m=0.2)
