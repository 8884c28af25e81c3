"""Measurements besides W: the wear geometry, the joint log-density with W, and the quantities
as the model and the campaign give them."""

import numpy as np
import pytest
from scipy import integrate, stats

from catenary.measurement.channels.observations import LineObservation, Observations, joint_log_density, line_log_density
from catenary.measurement.channels.quantities import QUANTITIES, model_columns, observe
from catenary.measurement.channels.wear import residual_thickness_m, segment_area_m2, wear_depth_m, wear_fraction
from catenary.physics.config import Wire
from catenary.physics.effects import SpanParameters

WIRE = Wire(1.35, 195.0, diameter_m=0.0148, section_area_m2=150e-6)


def test_segment_area_is_the_integral_of_the_chord():
    # A(w) = ∫₀ʷ 2√(2 r t − t²) dt: the area of the flat worn off a circle, independently by quadrature
    r = 0.0074
    for w in (1e-5, 5e-4, 2e-3, r, 1.5 * r):
        exact, _ = integrate.quad(lambda t: 2 * np.sqrt(2 * r * t - t * t), 0.0, w, epsabs=1e-16)
        assert segment_area_m2(w, r) == pytest.approx(exact, rel=1e-9)
    assert segment_area_m2(2 * r, r) == pytest.approx(np.pi * r * r, rel=1e-12)     # the whole circle


def test_thickness_and_fraction_are_inverse_maps():
    eps = np.array([-0.1, -1e-4, 0.0, 1e-6, 0.01, 0.08, 0.2, 0.3])
    t = residual_thickness_m(eps, WIRE)
    assert np.allclose(wear_fraction(t, WIRE), eps, atol=1e-12)          # Newton to 1e-12 of the diameter
    assert np.all(np.diff(t) < 0)                                        # more wear, thinner wire
    # 10 % of a 150 mm² AC-150 wire (∅ 14.8 mm) is the segment of 15 mm²: a flat 2.1 mm deep, a little
    # deeper than the shallow-flat law (4/3)√(2r) w^1.5 gives (its next term is −w/10r of the area)
    w = wear_depth_m(0.10, WIRE)
    assert segment_area_m2(w, 0.0074) == pytest.approx(15e-6, rel=1e-9)
    assert 1.0 < w / (3 * 15e-6 / (4 * np.sqrt(0.0148))) ** (2 / 3) < 1.0 + 0.28 / 10 * 1.5


def test_quantities_read_the_span_parameters():
    p = SpanParameters.independent_spans(np.full((3, 9), 1.0), np.array([2.0e4, 2.1e4, 2.2e4]),
                                         np.array([1.38, 1.39, 1.40]), np.array([1.38, 1.39, 1.40]),
                                         system_height_mean_m=1.39, contact_tension_n=25500.0, measuring_force_n=36.0)
    p.cw_wear_fraction = np.array([0.0, 0.05, 0.1])

    class _Catenary:                      # the quantities read only the contact wire of the catenary
        contact = WIRE
    names = ("cw_residual_thickness_m", "messenger_tension_n", "system_height_m", "measuring_force_n")
    y = observe(p, _Catenary(), names)
    assert model_columns(names) == ["cw_residual_thickness_m", "messenger_tension_n", "system_height_m_left",
                                    "system_height_m_right", "measuring_force_n"]
    assert y.shape == (3, 5)
    assert np.allclose(y[:, 0], residual_thickness_m(p.cw_wear_fraction, WIRE))
    assert np.allclose(y[:, 1], p.messenger_tension_n) and np.allclose(y[:, 4], 36.0)
    assert set(QUANTITIES) >= set(names)


def _dense_log_density(w, obs, mean, cov):
    """The same law written out over every span at once: the stacked vector of what was
    measured, its covariance block-diagonal per span plus the shared offsets' s² e eᵀ."""
    k, n = w.shape
    parts, means, index = [], [], []
    for i in range(k):
        cols = np.r_[np.arange(n), n + np.flatnonzero(np.isfinite(obs.values[i]))]
        parts.append(np.r_[w[i], obs.values[i][np.isfinite(obs.values[i])]])
        means.append(mean[cols])
        index.append((i, cols))
    x, m = np.concatenate(parts), np.concatenate(means)
    big = np.zeros((x.size, x.size))
    starts = np.cumsum([0] + [c.size for _, c in index])
    for (i, cols), a in zip(index, starts[:-1]):
        block = cov[np.ix_(cols, cols)].copy()
        for j, c in enumerate(cols[n:]):
            block[n + j, n + j] += obs.std[i, c - n] ** 2
        big[a:a + cols.size, a:a + cols.size] = block
    for c in np.flatnonzero(obs.common_std > 0):
        e = np.concatenate([(cols == n + c).astype(float) for _, cols in index])
        big += obs.common_std[c] ** 2 * np.outer(e, e)
    return stats.multivariate_normal(m, big).logpdf(x)


@pytest.mark.parametrize("shared", [False, True])
def test_joint_log_density_is_the_dense_gaussian_of_every_span(shared):
    rng = np.random.default_rng(3)
    n, c, k = 3, 3, 7
    a = rng.standard_normal((n + c, n + c))
    cov = a @ a.T + 0.5 * np.eye(n + c)
    cov[n + 1, :] = cov[:, n + 1] = 0.0                     # a quantity the model holds fixed
    mean = rng.standard_normal(n + c)
    w = rng.standard_normal((k, n))
    values = rng.standard_normal((k, c))
    values[rng.uniform(size=(k, c)) < 0.4] = np.nan          # measured on some spans only
    values[0] = np.nan
    std = np.where(np.isfinite(values), rng.uniform(0.2, 0.6, size=(k, c)), np.nan)
    obs = Observations(("cw_residual_thickness_m", "system_height_m"), values, std,
                       common_std=np.array([0.7, 0.0, 0.4]) if shared else None)
    per_span, common = joint_log_density(w, obs, mean, cov)
    assert per_span.sum() + common == pytest.approx(_dense_log_density(w, obs, mean, cov), rel=1e-10)
    assert (common != 0.0) == shared
    if shared:
        # each span's term is its own Gaussian at the shared offsets' posterior mode ô, found here
        # by a generic optimiser over o of Σ_k ln N(x_k − E_k o) − ½ oᵀS⁻¹o (tolerance: the optimiser's)
        from scipy import optimize
        offsets = np.flatnonzero(obs.common_std > 0)

        def span_terms(o):
            shifted = obs.values.copy()
            shifted[:, offsets] -= o
            zero = Observations(obs.quantities, shifted, obs.std)
            return joint_log_density(w, zero, mean, cov)[0]

        best = optimize.minimize(lambda o: -(span_terms(o).sum() - 0.5 * np.sum(o ** 2 / obs.common_std[offsets] ** 2)),
                                 np.zeros(offsets.size), method="BFGS", options={"gtol": 1e-10})
        assert per_span == pytest.approx(span_terms(best.x), abs=1e-6)


def test_line_observation_is_a_normal_density():
    obs = Observations((), np.zeros((2, 0)), np.zeros((2, 0)), (LineObservation("measuring_force_n", 38.0, 0.5),))
    assert line_log_density(obs, np.array([36.0]), np.array([0.0])) == pytest.approx(stats.norm(36.0, 0.5).logpdf(38.0))


def test_observations_refuse_what_they_cannot_read():
    with pytest.raises(ValueError, match="standard uncertainty"):
        Observations(("messenger_tension_n",), np.array([[2e4]]), np.array([[0.0]]))
    with pytest.raises(ValueError, match="unknown"):
        Observations(("tension",), np.zeros((1, 1)), np.ones((1, 1)))
    with pytest.raises(ValueError, match="LineObservation"):
        Observations(("measuring_force_n",), np.zeros((1, 1)), np.ones((1, 1)))


# --- the survey file and the assembly of one type's measurements --------------------------------

def _spans_table():
    """Two spans of one section, each measured by two runs (the second declared at 40 N)."""
    import pandas as pd
    return pd.DataFrame({
        "span_id": ["A-B", "B-C", "A-B", "B-C"], "run_id": ["r1", "r1", "r2", "r2"], "force_n": [36.0, 36.0, 40.0, 40.0],
        "section_id": ["S1"] * 4, "left_mast_id": ["A", "B", "A", "B"], "right_mast_id": ["B", "C", "B", "C"],
        "cw_residual_thickness_m": [0.0140, 0.0138, 0.0142, np.nan],
        "cw_residual_thickness_se_m": [4e-5, 4e-5, 4e-5, np.nan],
        "contact_force_n": [37.0, 39.0, 42.0, 44.0]})


def test_survey_errors_name_the_row_and_column(tmp_path):
    from catenary.measurement.channels.survey import read_survey
    from catenary.plumbing.errors import InputError
    path = tmp_path / "survey.csv"
    path.write_text("quantity,span_id,section_id,mast_id,value,std\n"
                    "messenger_tension_n,A-B,,,20400,800\n"
                    "system_height_m,,,,1.39,\n")
    with pytest.raises(InputError, match=r"survey.csv: row 2 \(line 3\), column 'mast_id'"):
        read_survey(path)
    path.write_text("quantity,span_id,value\nmessenger_tension_n,A-B,20.4\n")      # kN, not N
    with pytest.raises(InputError, match=r"row 1 \(line 2\), column 'value': 20.4"):
        read_survey(path)
    path.write_text("quantity,value\ntension,20400\n")
    with pytest.raises(InputError, match="column 'quantity': 'tension'; expected one of"):
        read_survey(path)
    path.write_text("quantity,span_id,section_id,mast_id,value,std\n")
    assert read_survey(path).empty


def test_observations_place_each_value_on_its_span(tmp_path):
    from catenary.measurement.channels.assemble import observations_for
    from catenary.measurement.channels.settings import MeasurementSettings
    from catenary.measurement.channels.survey import read_survey
    path = tmp_path / "survey.csv"
    path.write_text("quantity,span_id,section_id,mast_id,value,std\n"
                    "cw_residual_thickness_m,A-B,,,0.0139,0.0001\n"
                    "contact_tension_n,,S1,,25600,\n"
                    "system_height_m,,,C,1.40,0.004\n"
                    "system_height_m,,,Z,1.40,0.004\n"
                    "measuring_force_n,,,,38.5,0.5\n")
    settings = MeasurementSettings()
    obs, unused = observations_for(["A-B", "B-C"], _spans_table(), read_survey(path), settings, 36.0)
    assert obs.quantities == ("cw_residual_thickness_m", "contact_tension_n", "system_height_m")
    col = {c: i for i, c in enumerate(obs.columns)}
    # span A-B: two runs' means averaged, their error (3e-5 accuracy and 4e-5 samples) over √2,
    # then the calliper's 0.0139 ± 0.0001 by inverse variance
    chan, chan_std = 0.0141, np.sqrt((3e-5 ** 2 + 4e-5 ** 2) / 2)
    w = np.array([1 / chan_std ** 2, 1 / 1e-4 ** 2])
    assert obs.values[0, col["cw_residual_thickness_m"]] == pytest.approx((w[0] * chan + w[1] * 0.0139) / w.sum(),
                                                                       rel=1e-12)
    assert obs.std[0, col["cw_residual_thickness_m"]] == pytest.approx(1 / np.sqrt(w.sum()), rel=1e-12)
    assert obs.values[1, col["cw_residual_thickness_m"]] == pytest.approx(0.0138)       # one run only
    # the section's CW tension on its first span, with the config's accuracy; mast C ends B-C
    assert obs.values[0, col["contact_tension_n"]] == 25600 and np.isnan(obs.values[1, col["contact_tension_n"]])
    assert obs.std[0, col["contact_tension_n"]] == settings.accuracy["contact_tension_n"].std
    assert obs.values[1, col["system_height_m_right"]] == 1.40
    assert obs.common_std[col["cw_residual_thickness_m"]] == settings.accuracy["cw_residual_thickness_m"].common_std
    # the line: the calibration, and each run's mean contact force less its declared force's excess
    assert [(o.value, o.std) for o in obs.line][0] == (38.5, 0.5)
    assert [o.value for o in obs.line[1:]] == pytest.approx([38.0, 39.0])
    assert list(unused["mast_id"]) == ["Z"] and "not among" in unused["reason"].iloc[0]


# --- the recommendation's non-centrality ------------------------------------------------------

def test_noncentrality_reads_a_mean_only_beyond_its_calibration():
    # One quantity measured on N units with variance v; the truth moves its mean by Δ. Free: λ =
    # N Δ²/v. With a shared calibration error of variance 1/p (a coordinate the null may move at
    # the price of its prior), the mean is one measurement of variance v/N + 1/p: λ = Δ²/(v/N + 1/p).
    # A null coordinate that moves exactly along the change absorbs it all: λ = 0. Exact algebra:
    # tolerance is round-off.
    from catenary.stages.diagnosis.recommend import noncentrality
    n_units, v, delta, p = 40, 0.3 ** 2, 0.2, 1.0 / 0.05 ** 2
    e = np.array([1.0])
    change = (delta * e, np.zeros((1, 1)))
    ref = np.zeros((1, 1))
    groups = [(n_units, np.array([0]), np.array([v]))]
    assert noncentrality(change, [], ref, groups) == pytest.approx(n_units * delta ** 2 / v, rel=1e-12)
    shared = [(e, np.zeros((1, 1)))]
    assert noncentrality(change, shared, ref, groups, [p]) == pytest.approx(delta ** 2 / (v / n_units + 1 / p),
                                                                         rel=1e-10)
    assert noncentrality(change, shared, ref, groups, [0.0]) == pytest.approx(0.0, abs=1e-12)
    # a change of variance: ½ N (Δv / v)² (the Fisher information of a normal variance)
    dv = 0.01
    assert noncentrality((np.zeros(1), np.array([[dv]])), [], ref, groups) == pytest.approx(
        0.5 * n_units * (dv / v) ** 2, rel=1e-12)


def test_lr_power_is_the_normal_and_chi2_power():
    from catenary.stages.diagnosis.locate import lr_power
    level, lam = 0.01, 9.0
    # one spread alone: one-sided √LR ~ N(√λ, 1)
    assert lr_power(lam, 0, 1, level) == pytest.approx(stats.norm.cdf(3.0 - stats.norm.isf(level)), rel=1e-9)
    # one shift: χ²₁(λ) beyond its level's critical value, i.e. |N(√λ, 1)| > z_{α/2}
    z = stats.norm.isf(level / 2)
    assert lr_power(lam, 1, 0, level) == pytest.approx(stats.norm.sf(z - 3.0) + stats.norm.cdf(-z - 3.0), rel=1e-6)
