"""catenary.report.front_page: the report's opening panel, from the pipeline's own tables."""

import json

import pandas as pd
from docutils.core import publish_parts

from catenary.report.front_page import SpanTypePage, front_page

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
    page = front_page("Title\n=====\n\nThe method {{ in a few }} lines.", SPANS, CORRECTION,
                      {"N2": SpanTypePage(S_OPT, FINDINGS)})
    assert "3 used, 1 rejected (1 × gap of 9.0 m in the recording)" in page
    assert "2 of 3 spans converged" in page and "largest final gap 2.1 mm" in page
    # in an engineer's units and words (the files keep SI): a dropper in mm, a tension in N
    assert "dropper 1 length [mm]" in page and "1243.0" in page and "6.3" in page and "1.3" in page
    assert "messenger tension T_MW [N]" in page and "20536" in page and "800" in page and "160" in page
    assert "held fixed" in page and "_length_m" not in page
    assert "**messenger_tension_variability** named (p = 1.7e-115" in page and "per-span messenger tension σ = 833 ± 58 N" in page
    assert "ambiguous between **dropper_creep** and **cw_longitudinal_offset**" in page
    assert "step 3: no missing effect detected" in page
    assert "{{" not in page                                          # Snakemake renders it with Jinja first
    # docutils (Snakemake's renderer) takes it without a warning or an error
    body = publish_parts(page, writer="html", settings_overrides={"report_level": 2, "halt_level": 2})["body"]
    assert body.count("<tr>") == 3                                   # header + 2 inputs


def test_a_span_type_without_diagnosis_says_so():
    page = front_page("T\n=\n", SPANS, CORRECTION, {"N2": SpanTypePage(S_OPT)})
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
    page = front_page("T\n=\n", SPANS, CORRECTION,
                      {"N2": SpanTypePage(s_opt, findings, budget, recommendations=recs),
                       "N3": SpanTypePage(s_opt, findings, budget, recommendations=recs.assign(power=0.9))})
    assert "[20120, 20960]" in page and "[550, 1240]" in page and "[3.5, 11.0]" in page
    assert "μ: measuring_force; σ: speed" in page and "σ: head_mass" in page
    assert page.count("W alone cannot tell a measuring force 2 N off the declared one") == 1
    assert "static force of the measuring pantograph once (1 h), predicted power 1.00 on N2, 0.90 on N3" in page
    assert "could equally be" not in page and "check the car before acting" not in page
    assert "to settle it, measure the MW tension in the span in 12 spans (6 h)" in page
    body = publish_parts(page, writer="html", settings_overrides={"report_level": 2, "halt_level": 2})["body"]
    assert body.count("<tr>") == 12                                  # per type: two tables of header + 2 inputs
    # without a budget the table keeps its five columns and says nothing of a total
    assert "95 % total" not in front_page("T\n=\n", SPANS, CORRECTION, {"N2": SpanTypePage(S_OPT, FINDINGS)})


def test_the_front_page_says_the_tables_accuracy_each_run_measured_and_the_refusals():
    sections = pd.DataFrame({"run_id": ["R1", "R1", "R1"], "section_id": ["S01", "S02", "S03"],
                             "status": ["registered", "registered", "refused"],
                             "reason": ["", "", "section S03, run R1: registration failed: the trace's height confirms "
                                                "2 of the 21 masts"],
                             "table_std_m": [0.152, 0.181, float("nan")], "support_std_m": [0.17, 0.17, float("nan")]})
    page = front_page("T\n=\n", SPANS, CORRECTION, {"N2": SpanTypePage(S_OPT)}, sections=sections, prior_std_m=0.2)
    assert ("**Registration, run R1:** 2 of 3 sections registered; the mast table is accurate to 152–181 mm as the "
            "run measures it (prior ``mast_table_std_m`` 200 mm), the masts placed to 170 mm") in page
    assert "refused: section S03, run R1: registration failed: the trace's height confirms 2 of the 21 masts" in page
    publish_parts(page, writer="html", settings_overrides={"report_level": 2, "halt_level": 2})
    off = sections.assign(status="unregistered")
    assert "**Registration, run R1:** switched off" in front_page("T\n=\n", SPANS, CORRECTION, {"N2": SpanTypePage(S_OPT)},
                                                                   sections=off, prior_std_m=0.2)


LISTED = pd.DataFrame([
    # an unexplained span and a section sharing a T_MW offset come first, without a probability
    {"span_id": "M0031-M0032", "section_id": "S02", "start_chainage_m": 1746.5, "end_chainage_m": 1805.0,
     "input": "span", "p_out_of_tolerance": float("nan"), "deviation": float("nan"),
     "action": "inspect span: its profile departs from the model at chainage 1754.9 m", "status": "unexplained"},
    {"span_id": "section S04", "section_id": "S04", "start_chainage_m": 3660.0, "end_chainage_m": 4771.5,
     "input": "messenger_tension_n", "p_out_of_tolerance": float("nan"), "deviation": -2470.5,
     "action": "inspect the tensioning device of section S04", "status": "unexplained"},
    {"span_id": "M0088-M0089", "section_id": "S05", "start_chainage_m": 5055.5, "end_chainage_m": 5114.0,
     "input": "dropper_1_length_m", "p_out_of_tolerance": 0.963, "deviation": -0.01673, "action": "lengthen",
     "status": "ok"},
    {"span_id": "M0011-M0012", "section_id": "S01", "start_chainage_m": 585.0, "end_chainage_m": 643.5,
     "input": "dropper_9_length_m", "p_out_of_tolerance": 0.936, "deviation": 0.01541, "action": "shorten",
     "status": "ok"},
    {"span_id": "M0011-M0012", "section_id": "S01", "start_chainage_m": 585.0, "end_chainage_m": 643.5,
     "input": "dropper_8_length_m", "p_out_of_tolerance": 0.41, "deviation": 0.0101, "action": "shorten",
     "status": "few effective samples"},
    {"span_id": "M0040-M0041", "section_id": "S02", "start_chainage_m": 2281.5, "end_chainage_m": 2340.0,
     "input": "messenger_tension_n", "p_out_of_tolerance": 0.62, "deviation": 1490.0,
     "action": "inspect tensioning device (T_MW high)", "status": "ok"},
    {"span_id": "M0050-M0051", "section_id": "S03", "start_chainage_m": 2866.5, "end_chainage_m": 2925.0,
     "input": "dropper_4_force_n", "p_out_of_tolerance": 0.55, "deviation": -60.2,
     "action": "unloaded dropper (slack or nearly): check it, shorten", "status": "ok"},
    {"span_id": "M0060-M0061", "section_id": "S03", "start_chainage_m": 3451.5, "end_chainage_m": 3510.0,
     "input": "dropper_5_length_m", "p_out_of_tolerance": 0.30, "deviation": -0.0111, "action": "lengthen",
     "status": "ok"}])


def test_the_maintenance_headline_counts_each_action_and_lists_the_five_most_likely():
    from catenary.report.front_page import maintenance_lines

    text = "\n".join(maintenance_lines(LISTED))
    # 4 dropper adjustments (2 lengthen, 2 shorten) in 3 spans; 1 unloaded dropper; 2 tensioning
    # devices (a listed T_MW and the section sharing an offset); 1 span to inspect; 1 few-samples row
    assert ("**Maintenance:** 4 droppers to adjust (2 to lengthen, 2 to shorten) in 3 spans; 1 unloaded dropper to "
            "check; 2 tensioning devices to inspect; 1 span or section to inspect") in text
    assert "1 of the listed probabilities rest on few effective samples" in text
    body = publish_parts(text, writer="html", settings_overrides={"report_level": 2, "halt_level": 2})["body"]
    assert body.count("<tr>") == 6                                   # header + the five most likely
    rows = [r for r in text.split("   * - ")[2:]]
    # most likely first, in mm, N and m: the unexplained rows and the least likely action left out
    assert rows[0].startswith("M0088-M0089") and "5055.5–5114.0" in rows[0] and "dropper 1 length" in rows[0]
    assert "-16.7 mm" in rows[0] and "0.96" in rows[0]
    assert "+1490 N" in text and "dropper 4 force" in text and "-60 N" in text
    assert "M0060-M0061" not in text and "M0031-M0032" not in text


def test_contact_force_verdict_per_speed_against_en_50367():
    from catenary.report.front_page import contact_force_lines
    from catenary.stages.contact_force.settings import Limits
    from catenary.stages.contact_force.summary import clopper_pearson

    n = 32
    rows = []
    for speed, failures in ((300, {}), (320, {"std_above_limit": 25, "statistical_min_below_limit": 1})):
        for name in ("mean_force_above_target", "std_above_limit", "statistical_min_below_limit",
                     "uplift_above_limit", "contact_lost"):
            k = failures.get(name, 0)
            low, high = clopper_pearson(k, n)
            rows.append({"speed_kmh": speed, "quantity": name, "n_replicates": n, "probability": k / n,
                         "probability_low": low, "probability_high": high})
    text = "\n".join(contact_force_lines(pd.DataFrame(rows), Limits()))
    # 0 of 32: the exact upper bound is 1 − 0.025^(1/32) = 10.9 %
    assert "300 km/h: **meets** every limit in all 32 sections (the share that would fail is below 11 % at 95 %)" in text
    # 25 of 32 = 78 %, Clopper–Pearson [60, 91] %; 1 of 32 = 3 % [0, 16]
    assert ("320 km/h: **fails in most sections**: σ_F above 0.3 F_m in 78 % [60, 91]; F_m − 3σ_F at or below "
            "0 N in 3 % [0, 16] of 32 sections") in text
    assert "not part of this run" in "\n".join(contact_force_lines(None, None))


def test_what_fixing_buys_per_speed():
    from catenary.report.front_page import repair_lines

    summary = pd.DataFrame({"section_id": ["S01", "S01", "S02", "S02", "S07"], "speed_kmh": [300, 320, 300, 320, None],
                            "std_force_change_n": [-0.42, -0.32, 0.08, -0.69, None],
                            "statistical_min_margin_change_n": [1.29, 1.00, -0.23, 2.09, None]})
    text = "\n".join(repair_lines(summary))
    # 300 km/h: mean of −0.42 and +0.08 = −0.17 N; margin (1.29 − 0.23) / 2 = +0.53 N
    assert "at 300 km/h σ_F changes by -0.17 N on average over 2 windows (-0.42 to +0.08 N)" in text
    assert "the margin of F_m − 3σ_F by +0.53 N" in text
    assert "at 320 km/h σ_F changes by -0.51 N" in text
