"""Per span and per section: explained by the final model or not ([16])."""

import numpy as np
import pandas as pd
from scipy import stats

from catenary.stages.diagnosis.span_check import (SpanCheckSettings, WLaw, benjamini_hochberg, check_spans, section_tests,
                                           w_law, w_tests)
from catenary.physics.fast import FastSpanModel


def model_law(catenary, n2) -> WLaw:
    """The default campaign's N2 laws (paper Table 2) as the final model, its W law sampled."""
    model = FastSpanModel(n2, catenary, neighbours=1)
    means = np.r_[model.reference_lengths_m, 20575.0, 1.388]
    sigmas = np.r_[[0.0067, 0.0050, 0.0045, 0.0045, 0.0038, 0.0044, 0.0035, 0.0034, 0.0070], 818.0, 0.0065]
    rng = np.random.default_rng(0)
    z = rng.standard_normal((20000, 12))
    w = model.evaluate(means[:9] + sigmas[:9] * z[:, :9], means[9] + sigmas[9] * z[:, 9],
                       means[10] + sigmas[10] * z[:, 10], means[10] + sigmas[10] * z[:, 11]).w_m
    return w_law(model, means, sigmas, w.mean(axis=0), np.cov(w.T) + (6e-4) ** 2 * np.eye(9))


def draw(law: WLaw, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return law.mean_m + rng.standard_normal((n, law.mean_m.size)) @ np.linalg.cholesky(law.covariance_m2).T


def test_benjamini_hochberg_matches_the_definition():
    # q_(i) = min_{j ≥ i} p_(j) m / j (Benjamini & Hochberg 1995), by hand for five p-values.
    p = np.array([0.01, 0.04, 0.03, 0.005, 0.5])
    np.testing.assert_allclose(benjamini_hochberg(p), [0.025, 0.05, 0.05, 0.025, 0.5])


def test_w_test_is_uniform_under_the_law_and_keeps_faulty_droppers_explained(catenary, n2):
    # 400 spans drawn from the law: the p-values are uniform (KS at 1 %); a span with two
    # droppers made 3 cm wrong — the maintenance stage's faults — is far from a false-discovery
    # line (p > 1e-3: its penalised distance is about χ²₇ + 18.4), while one displaced by 8
    # standard deviations of the law along a direction of no fault (drawn at random: two
    # droppers set free take about half of its square) is beyond it (p < 1e-4).
    law = model_law(catenary, n2)
    settings = SpanCheckSettings(w_draws=20000)
    p, _ = w_tests(draw(law, 400, 1), law, settings)
    assert stats.kstest(p, "uniform").pvalue > 0.01
    base = draw(law, 1, 2)[0]
    faulty = base + law.dropper_m_m[:, [2, 6]] @ np.array([0.03, -0.03])
    direction = np.random.default_rng(5).standard_normal(9)
    shifted = base + np.linalg.cholesky(law.covariance_m2) @ (8.0 * direction / np.linalg.norm(direction))
    p2, _ = w_tests(np.vstack([faulty, shifted]), law, settings)
    assert p2[0] > 1e-3 and p2[1] < 1e-4


def test_a_misadjusted_section_is_found_as_one_group_with_its_offset(catenary, n2):
    # Five sections of 20 spans sharing masts; one with its T_MW 2 000 N below the line's (2.4
    # per-span σ): no span of it alone is beyond the model, the section is, and the offset read
    # from its spans' mean is within 3 standard errors of the planted one; the others are not
    # flagged (their p-values above the false-discovery line).
    law = model_law(catenary, n2)
    w = draw(law, 100, 3)
    sections = np.repeat([f"S{k}" for k in range(5)], 20)
    w[sections == "S2"] += law.tension_m_n * -2000.0
    pairs = np.array([(k, k + 1) for k in range(99) if sections[k] == sections[k + 1]])
    spans = pd.DataFrame({"span_id": [f"x{k}" for k in range(100)], "section_id": sections,
                          "start_chainage_m": 58.5 * np.arange(100), "end_chainage_m": 58.5 * np.arange(1, 101)})
    check = check_spans(spans, w, law, None, pairs, SpanCheckSettings())
    table = check.sections.set_index("section_id")
    assert table.loc["S2", "unexplained"] and not table.drop("S2")["unexplained"].any()
    assert table.loc["S2", "tension_offset"]
    z = (table.loc["S2", "messenger_tension_offset_n"] + 2000.0) / table.loc["S2", "messenger_tension_offset_se_n"]
    assert abs(z) < 3.0
    assert (check.spans.loc[check.spans["section_id"] == "S2", "group"] == "S2").all()
    assert not check.spans.loc[check.spans["section_id"] != "S2", "unexplained"].any()


def test_sections_are_calibrated_with_shared_masts(catenary, n2):
    # Under the law, with each mast's ΔH shared by its two spans (as on a line), the sections'
    # statistic is χ²₉: over 200 lines of 6 sections of 20 spans, the p-values are uniform (KS at
    # 1 %); without the shared-ΔH covariance in V they would be too small.
    law = model_law(catenary, n2)
    rng = np.random.default_rng(4)
    chol = np.linalg.cholesky(law.covariance_m2 - law.system_height_std_m ** 2 * (
        np.outer(law.system_height_left_m_m, law.system_height_left_m_m)
        + np.outer(law.system_height_right_m_m, law.system_height_right_m_m)))
    p = []
    for _ in range(200):
        dh = law.system_height_std_m * rng.standard_normal(121)
        w = (law.mean_m + rng.standard_normal((120, 9)) @ chol.T + np.outer(dh[:-1], law.system_height_left_m_m)
             + np.outer(dh[1:], law.system_height_right_m_m))
        sections = np.repeat(np.arange(6), 20)
        pairs = np.array([(k, k + 1) for k in range(119) if sections[k] == sections[k + 1]])
        p += section_tests(w - w.mean(axis=0), sections, pairs, law, 120,
                           SpanCheckSettings())["p_value"].tolist()
    assert stats.kstest(p, "uniform").pvalue > 0.01
