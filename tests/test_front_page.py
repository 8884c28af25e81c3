"""catenary.front_page: the report's opening panel, from the pipeline's own tables."""

import json

import pandas as pd
from docutils.core import publish_parts

from catenary.front_page import front_page

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
    assert "20536.5" in page and "799.9" in page and "160" in page and "held fixed" in page
    assert "**messenger_tension_variability** named (p = 1.7e-115" in page and "std_n = 833.2 ± 58" in page
    assert "ambiguous between **dropper_creep** and **cw_longitudinal_offset**" in page
    assert "step 3: no missing effect detected" in page
    assert "{{" not in page                                          # Snakemake renders it with Jinja first
    # docutils (Snakemake's renderer) takes it without a warning or an error
    body = publish_parts(page, writer="html", settings_overrides={"report_level": 2, "halt_level": 2})["body"]
    assert body.count("<tr>") == 3                                   # header + 2 inputs


def test_a_span_type_without_diagnosis_says_so():
    page = front_page("T\n=\n", SPANS, CORRECTION, {"N2": S_OPT}, {"N2": None})
    assert "**Diagnosis:** not run for this span type." in page
