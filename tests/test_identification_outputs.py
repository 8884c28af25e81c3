"""Outputs of the identification rule: the band (paper Fig. 10), s_opt.csv, trace.parquet,
normality.json, the estimator marginals (Fig. 7), the corrected-data reader and the settings."""

import dataclasses
import json

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from scipy import stats

from catenary.physics.fast import FastSpanModel
from catenary.physics.section import uniform_section
from catenary.physics.static import StaticModel
from catenary.plumbing.errors import ConfigError, ConvergenceError, InputError
from catenary.plumbing.parquet import read_metadata, write_table
from catenary.stages.identification.band import band_abscissae, deflection_band, sample_profiles
from catenary.stages.identification.data import read_corrected
from catenary.stages.identification.design import draw_unit_design
from catenary.stages.identification.fit import identify, make_likelihood
from catenary.stages.identification.likelihood import Likelihood, fit_gaussian, kernel_bandwidth
from catenary.stages.identification.normality import henze_zirkler, normality_report
from catenary.stages.identification.outputs import IdentificationPaths, write_identification
from catenary.stages.identification.report import markdown_report
from catenary.stages.identification.runner import marginal_densities, run_identification
from catenary.stages.identification.settings import DETERMINISTIC_CV, IdentificationSettings
from catenary.stages.identification.synthetic import simulate_deflections
from catenary.stages.identification.tables import S_OPT_COLUMNS

MODE = "independent"


@pytest.fixture(scope="module")
def model(catenary, n2):
    return make_likelihood(n2, catenary, np.zeros((2, 9)), n_samples=2).model


@pytest.fixture(scope="module")
def line_model(catenary, n2):
    """The span as it hangs in the line: central of three, wires continuous over the masts."""
    return FastSpanModel(n2, catenary, neighbours=1, messenger_tension_bounds_n=(15_000.0, 26_000.0))


@pytest.fixture(scope="module")
def data(model, truth):
    """117 synthetic spans under the truth, ΔH drawn per mast (seed 21)."""
    return simulate_deflections(model, *truth, 117, seed=21, system_height_mode=MODE)


SMALL = {"n_samples": 1000, "estimators_n_samples": [200, 400], "band": {"n_samples": 300, "n_points": 31},
         "normality": {"n_samples": 200}, "system_height_mode": MODE, "seed": 5,
         "profile_intervals": {"parameters": ["messenger_tension_n"], "max_evaluations": 150}}


@pytest.fixture(scope="module")
def written(catenary, n2, data, tmp_path_factory):
    """A small identification run written to a temporary folder."""
    settings = IdentificationSettings.from_mapping(SMALL)
    run = run_identification(n2, catenary, data, settings, left_out=[("M9-M10", "test")])
    paths = IdentificationPaths.in_folder(tmp_path_factory.mktemp("identification"))
    write_identification(run, paths, config_hash="abc")
    return run, paths, settings


def test_the_outputs_written_by_two_processes_are_the_same_files(written, tmp_path):
    # The two figures and the tables written side by side by two processes: the files of one,
    # byte for byte (each writer its own files; the figures' drawing is deterministic).
    run, paths, _ = written
    two = IdentificationPaths.in_folder(tmp_path)
    write_identification(run, two, config_hash="abc", workers=2)
    for name in ("s_opt", "trace", "estimators", "normality", "band", "report", "model_error"):
        one_file, two_file = getattr(paths, name), getattr(two, name)
        assert one_file.read_bytes() == two_file.read_bytes(), name


@pytest.mark.parametrize("neighbours", [0, 1])
def test_profile_map_reproduces_the_fe_solve_of_each_sample(catenary, n2, line_model, truth, neighbours):
    # The band's CW profile (fast-model dropper forces through the profile map) against a full
    # FE solve of the same span, along the whole span and at the droppers: pinned (the paper's
    # model) or as the central span of three, wires continuous over its masts, neighbours at
    # the nominal table, design ΔH at the outer masts. The fast model is exact to ~1e-9 m, so
    # 1e-7 m is a bound with margin, far below any plotted detail.
    fast = line_model if neighbours else FastSpanModel(n2, catenary, messenger_tension_bounds_n=(15_000.0, 26_000.0))
    x = band_abscissae(n2, 117)
    op = fast.profile_map(x)
    rng = np.random.default_rng(3)
    means, sigmas = truth
    lengths = means[:9] + sigmas[:9] * rng.standard_normal((3, 9))
    t_mw = means[9] + sigmas[9] * rng.standard_normal(3)
    dh = means[10] + sigmas[10] * rng.standard_normal((3, 2))
    profiles, slack = sample_profiles(fast, op, lengths, t_mw, dh[:, 0], dh[:, 1])
    assert not slack.any()
    nominal = means[:9]
    for k in range(3):
        section = uniform_section(n2, 1 + 2 * neighbours, nominal, messenger_tension_n=t_mw[k])
        all_lengths = section.dropper_lengths_m.copy()
        all_lengths[9 * neighbours:9 * (neighbours + 1)] = lengths[k]
        heights = np.full(2 + 2 * neighbours, n2.system_height_m)
        heights[neighbours:neighbours + 2] = dh[k]
        # Steady arms on one straight line (the central span's 5.12 → 5.03 m continued): a rigid
        # tilt of the whole run leaves W unchanged, so the model's level run applies exactly.
        cw = 5.12 - 0.09 * (np.arange(2 + 2 * neighbours) - neighbours)
        section = dataclasses.replace(section.with_dropper_lengths(all_lengths), system_heights_m=heights,
                                      cw_support_heights_m=cw)
        solution = StaticModel(section, catenary).solve()
        start = neighbours * n2.length_m
        np.testing.assert_allclose(profiles[k], solution.cw_deflection_at(start + x), atol=1e-7)
        at = np.searchsorted(x, n2.dropper_positions_m)
        np.testing.assert_allclose(profiles[k, at], solution.dropper_deflection_m()[9 * neighbours:9 * neighbours + 9],
                                   atol=1e-7)


def test_band_holds_its_level_of_fresh_spans_at_every_station(catenary, n2, model, truth):
    # The 98 % band from 4000 Sobol samples must contain ≈ 98 % of 4000 fresh spans drawn by
    # plain Monte Carlo (NumPy's Gamma generator, taut spans only, as the band) at every
    # station. Binomial standard deviation of the coverage: √(0.98·0.02/4000) ≈ 0.0022 for the
    # fresh draw, at most as much again for the band's own quantiles: σ ≈ 0.0031. Each station
    # must lie within 5σ (0.016) and the mean over stations within 3σ (0.0094). Observed:
    # 0.976–0.985, mean 0.981; a 95 % band gives 0.947–0.958 and fails.
    means, sigmas = truth
    x = band_abscissae(n2, 59)
    band = deflection_band(model, means, sigmas, x_m=x, n_samples=4000, level=0.98, seed=3,
                           system_height_mode=MODE)
    op = model.profile_map(x)
    rng = np.random.default_rng(17)
    shape, scale = (means / sigmas) ** 2, sigmas**2 / means
    draws = rng.gamma(shape, scale, size=(4500, 11))
    dh_right = rng.gamma(shape[10], scale[10], size=4500)
    profiles, slack = sample_profiles(model, op, draws[:, :9], draws[:, 9], draws[:, 10], dh_right)
    fresh = profiles[~slack][:4000]
    assert fresh.shape[0] == 4000
    inside = (fresh >= band.lower_m) & (fresh <= band.upper_m)
    interior = (x > 0) & (x < n2.length_m)               # at the masts W ≡ 0: the band is a point
    coverage = inside.mean(axis=0)[interior]
    print(f"\ncoverage over {interior.sum()} stations: {coverage.min():.4f}–{coverage.max():.4f}, "
          f"mean {coverage.mean():.4f}; slack dropped from the band: {band.n_slack}")
    assert np.all(band.upper_m[interior] - band.lower_m[interior] > 1e-3)
    assert np.all(np.abs(coverage - 0.98) < 0.016)
    assert abs(coverage.mean() - 0.98) < 0.0094


def test_what_follows_s_opt_is_the_same_in_two_worker_processes(written, catenary, n2, data):
    # After s_opt, the profile intervals' ends, the normality tests, the estimators' marginals
    # and the band are independent tasks handed to worker processes (the largest design first):
    # every one of them the same, bit for bit, as in one process, and each in its own place.
    run, _, settings = written
    two = run_identification(n2, catenary, data, settings, left_out=[("M9-M10", "test")], workers=2)
    assert two.profiles == run.profiles and two.normality == run.normality
    assert [m.n_samples for m in two.marginals] == list(settings.estimators_n_samples)
    for a, b in zip(run.marginals, two.marginals):
        for name in ("grid_m", "gaussian", "kernel", "l1_distance"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    for name in ("x_m", "lower_m", "upper_m", "median_m"):
        np.testing.assert_array_equal(getattr(run.band, name), getattr(two.band, name))
    np.testing.assert_array_equal(run.data_in_band, two.data_in_band)


def test_s_opt_csv_has_the_columns_and_fixed_means_keep_their_start(written, n2, catenary):
    run, paths, settings = written
    table = pd.read_csv(paths.s_opt)
    assert tuple(table.columns) == S_OPT_COLUMNS
    start = settings.start_inputs(n2, catenary)
    assert list(table["parameter"]) == [s.name for s in start]
    fixed = table["mu_fixed"].to_numpy(dtype=bool)
    assert fixed.tolist() == [True] * 9 + [False, False]
    # Fixed means are the start values, bit for bit through the CSV, with a zero standard error.
    np.testing.assert_array_equal(table["mu"][fixed], [s.mean for s, f in zip(start, fixed) if f])
    assert np.all(table["mu_se"][fixed] == 0.0)
    # Free means moved, and every identified parameter has a positive finite standard error.
    assert np.all(table["mu"][~fixed].to_numpy() != [s.mean for s, f in zip(start, fixed) if not f])
    assert np.all(np.isfinite(table["sigma_se"])) and np.all(table["sigma_se"] > 0)
    np.testing.assert_array_equal(table["sigma"], run.result.sigmas)


def test_deterministic_inputs_keep_a_negligible_fixed_sigma(catenary, n2, data):
    random = [f"dropper_{i}_length_m" for i in (1, 2, 3, 4, 6, 7, 8, 9)] + ["messenger_tension_n", "system_height_m"]
    settings = IdentificationSettings.from_mapping({**SMALL, "random_inputs": random})
    start = settings.start_inputs(n2, catenary)
    assert start[4].sigma / start[4].mean == pytest.approx(DETERMINISTIC_CV, rel=1e-12)
    assert start[3].sigma == 0.005 and start[9].sigma == pytest.approx(0.03 * start[9].mean)
    lik = make_likelihood(n2, catenary, data, start=start, n_samples=500, seed=1, system_height_mode=MODE)
    r = identify(lik, start, free_means=settings.free_mean_names(9), free_sigmas=settings.random_names(9),
                 standard_errors=False)
    assert "dropper_5_length_m.sigma" not in r.free_parameters and len(r.free_parameters) == 2 + 10
    assert r.sigmas[4] == start[4].sigma and np.isfinite(r.j_opt)
    # Too few random scalars: W would live on a lower-dimensional set, its 9-D law singular.
    few = IdentificationSettings.from_mapping({"random_inputs": ["messenger_tension_n", "system_height_m"]})
    with pytest.raises(ConfigError, match="3 random scalar\\(s\\) for span type N2"):
        few.start_inputs(n2, catenary)


def test_trace_parquet_holds_every_optimiser_evaluation(written):
    run, paths, _ = written
    table = pq.read_table(paths.trace)
    names = [e.parameter for e in run.result.estimates]
    assert table.schema.names == ["evaluation", "j"] + [f"{p}_{n}" for n in names for p in ("mu", "sigma")]
    assert table.schema.field("evaluation").type == pa.int64()
    assert all(table.schema.field(c).type == pa.float64() for c in table.schema.names[1:])
    assert table.schema.field("mu_messenger_tension_n").metadata[b"unit"] == b"N"
    assert table.schema.field("sigma_system_height_m").metadata[b"unit"] == b"m"
    assert read_metadata(paths.trace)["catenary.kind"] == "identification_trace"
    df = table.to_pandas()
    assert len(df) == run.result.n_evaluations
    assert df["evaluation"].tolist() == list(range(1, len(df) + 1))
    for k in range(9):                                   # fixed dropper means never move
        assert df[f"mu_{names[k]}"].nunique() == 1


def test_normality_json_tests_what_it_names(written, model, data, n2, catenary):
    # Not a recomputation of the same calls: facts the report must show. The data entry tests
    # the 117 measured spans, and HZ is affine invariant, so the data in millimetres, shifted,
    # give the same statistic (to rounding). The model entries test i.i.d. draws of the size
    # configured; a Gaussian-looking data set of Gamma inputs with small CV is not rejected
    # at α = 0.05 only by chance, so the decision itself is not asserted.
    run, paths, settings = written
    report = json.loads(paths.normality.read_text())
    assert report["identification_status"] == "ok"
    assert report["data"]["n_samples"] == data.shape[0] == 117 and report["data"]["dimension"] == 9
    scaled = henze_zirkler(1e3 * data + 7.0, alpha=settings.normality_alpha)
    assert report["data"]["statistic"] == pytest.approx(scaled.statistic, rel=1e-9)
    for key in ("model_s0", "model_s_opt"):
        assert report[key]["n_samples"] == settings.normality_n_samples
        assert 0.0 <= report[key]["p_value"] <= 1.0
        assert report[key]["normal"] == (report[key]["p_value"] >= settings.normality_alpha)
    start = settings.start_inputs(n2, catenary)
    # With no more spans than droppers the data test is undefined: reported as null, with why.
    few = normality_report(model, start, run.result, data[:5], n_samples=50, seed=0, system_height_mode=MODE)
    assert few["data"]["statistic"] is None and "more observations" in few["data"]["reason"]


def test_marginals_are_those_of_the_estimators_used_by_j(model, truth):
    # Gaussian marginal = N(m_i, Σ_ii) of the weighted fit; kernel marginal = 1-D Gaussian KDE
    # with the n-dimensional bandwidth factor h (scipy's gaussian_kde, same weights).
    lik = Likelihood(model, draw_unit_design(3000, 12, seed=2), np.zeros((2, 9)), system_height_mode=MODE)
    sample = lik.model_sample(*truth)
    fit = fit_gaussian(sample.w_m, sample.weight)
    sd = np.sqrt(np.diag(fit.chol @ fit.chol.T))
    grid = fit.mean + np.linspace(-4, 4, 41)[:, None] * sd
    m = marginal_densities(sample, grid, block=1000)
    h = kernel_bandwidth(fit.n_effective, 9)
    for i in (0, 4, 8):
        np.testing.assert_allclose(m.gaussian[:, i], stats.norm.pdf(grid[:, i], fit.mean[i], sd[i]), rtol=1e-10)
        kde = stats.gaussian_kde(sample.w_m[:, i], bw_method=h, weights=sample.weight)
        np.testing.assert_allclose(m.kernel[:, i], kde(grid[:, i]), rtol=1e-8)
    assert np.all(m.l1_distance > 0) and np.all(m.l1_distance < 0.5)


def test_report_names_the_run_figures(written):
    run, paths, _ = written
    text = paths.report.read_text()
    r = run.result
    for needle in (f"{r.n_evaluations} by the optimiser", f"{r.n_hessian_evaluations} for the standard errors",
                   f"J(s0) | {run.j_start:.3f}", f"J(s_opt) | {r.j_opt:.3f}", "observed information",
                   "nelder-mead", "N = 1000", "seed 5", "left out M9-M10: test", "](band.png)",
                   "](estimators.png)", "| messenger tension T_MW |", "| system height ΔH |", "## 95 % intervals",
                   "| messenger tension T_MW | σ |", "| dropper 1 length |",
                   "Span model: the span as it hangs in the line"):
        assert needle in text, needle
    assert paths.band.stat().st_size > 0 and paths.estimators.stat().st_size > 0


def _corrected(tmp_path, converged, w=None):
    n = len(converged)
    df = pd.DataFrame({"span_id": [f"S{i}" for i in range(n)], "section_id": "A", "length_m": 58.5})
    w = np.full((n, 9), -0.01) if w is None else w
    for i in range(9):
        df[f"w{i + 1}_m"] = w[:, i]
    df["iterations"] = np.int64(2)
    df["gap_norm_m"] = 0.0005
    df["converged"] = converged
    schema = pa.schema([("span_id", pa.string()), ("section_id", pa.string()), ("length_m", pa.float64())]
                       + [(f"w{i + 1}_m", pa.float64()) for i in range(9)]
                       + [("iterations", pa.int64()), ("gap_norm_m", pa.float64()), ("converged", pa.bool_())])
    path = tmp_path / "corrected.parquet"
    write_table(df, path, schema, config_hash="x", kind="corrected")
    return path


def test_read_corrected_keeps_converged_spans_and_says_why_others_left(tmp_path, n2):
    path = _corrected(tmp_path, [True, False, True, True])
    d = read_corrected(path, n2)
    assert d.w_m.shape == (3, 9) and d.span_id.tolist() == ["S0", "S2", "S3"]
    assert d.left_out == [("S1", "dynamic correction did not converge (gap norm 0.50 mm after 2 iterations)")]
    w = np.full((2, 9), -0.01)
    w[1, 3] = np.nan
    with pytest.raises(InputError, match=r"row 2 \(span S1\), column w4_m"):
        read_corrected(_corrected(tmp_path, [True, True], w), n2)
    w[0, 0] = np.nan                                     # NaN on a non-converged span is not used: fine
    assert read_corrected(_corrected(tmp_path, [False, True], np.where(np.isnan(w), 0, w)), n2).w_m.shape == (1, 9)
    df = pq.read_table(path).to_pandas().drop(columns=["w9_m"])
    df.to_parquet(tmp_path / "bad.parquet")
    with pytest.raises(InputError, match="bad.parquet: missing column.*w9_m"):
        read_corrected(tmp_path / "bad.parquet", n2)


def test_read_corrected_says_which_used_spans_share_a_mast(tmp_path, n2):
    path = _corrected(tmp_path, [True, False, True, True])
    assert read_corrected(path, n2).mast_pairs is None          # no chainages: adjacency unknown
    df = pq.read_table(path).to_pandas()
    df["start_chainage_m"] = [0.0, 58.5, 117.0, 175.5]
    df["end_chainage_m"] = df["start_chainage_m"] + 58.5
    df.to_parquet(tmp_path / "with_chainages.parquet")
    d = read_corrected(tmp_path / "with_chainages.parquet", n2)
    # S1 did not converge: of the used rows S0, S2, S3 only S2 and S3 still share a mast.
    assert d.mast_pairs.tolist() == [[1, 2]]


def test_report_says_how_spans_sharing_masts_widened_the_intervals(written, tmp_path):
    import dataclasses

    from catenary.stages.identification.profile import ProfileInterval

    run, _, _ = written
    assert "treated as independent" in markdown_report(run)     # no adjacency given to that run
    r = run.result
    sandwich = r.theta_covariance * 1.5                           # λ = 1.5 on every coordinate
    widened = dataclasses.replace(r, covariance="sandwich", theta_covariance_sandwich=sandwich, n_mast_pairs=111)
    none = ProfileInterval("messenger_tension_n", "sigma", 12.0, 0.0, 65.0, True, False, 100)
    paths = IdentificationPaths.in_folder(tmp_path)
    write_identification(dataclasses.replace(run, result=widened, profiles=[none]), paths, config_hash="abc")
    text = paths.report.read_text()
    assert "111 pairs of spans sharing a mast" in text and "T_MW σ ×1.50" in text
    assert "consistent with no spread" in text
    table = pd.read_csv(paths.s_opt).set_index("parameter")
    assert table.loc["messenger_tension_n", "sigma_variance_widening"] == pytest.approx(1.5)
    assert table.loc["messenger_tension_n", "no_spread_detected"]
    assert table.loc["messenger_tension_n", "sigma_profile_low"] == 0.0
    assert np.isnan(table.loc["dropper_1_length_m", "mu_variance_widening"])     # μ fixed: not identified


@pytest.mark.parametrize("mapping, message", [
    ({"n_sample": 10}, "identification: unknown key"),
    ({"random_inputs": ["dropper_lengths_m", "contact_tension_n"]}, r"random_inputs\[1\]: expected an input name .*got 'contact_tension_n'"),
    ({"optimiser": {"method": "powell"}}, "optimiser.method: expected one of"),
    ({"band": {"level": 1.5}}, "band.level"),
    ({"start": {"dropper_length_m": {"mean": "design"}}}, "start.dropper_length_m.mean"),
    ({"n_samples": 10.5}, "n_samples: expected an integer"),
])
def test_settings_refuse_bad_values_naming_the_key(mapping, message):
    with pytest.raises(ConfigError, match=message):
        IdentificationSettings.from_mapping(mapping)


def test_settings_check_per_span_type_values(catenary, n2):
    s = IdentificationSettings.from_mapping({"start": {"dropper_length_m": {"mean": [1.0] * 8, "sigma": 0.005}}})
    with pytest.raises(ConfigError, match="one value per dropper \\(9 for span type N2\\), got 8"):
        s.start_inputs(n2, catenary)
    s = IdentificationSettings.from_mapping({"free_means": ["dropper_12_length_m"]})
    with pytest.raises(ConfigError, match="dropper_12_length_m.*9 droppers"):
        s.free_mean_names(9)
    s = IdentificationSettings.from_mapping({"n_samples": 1e4, "free_means": ["dropper_lengths_m"]})
    assert s.n_samples == 10_000 and isinstance(s.n_samples, int)
    assert s.free_mean_names(9) == tuple(f"dropper_{i}_length_m" for i in range(1, 10))


def test_a_capped_optimiser_fails_the_run_or_marks_every_output(catenary, n2, data, tmp_path, caplog):
    # 20 evaluations cannot maximise J over 13 parameters. Default: the run fails with the reason
    # and what to change. With on_non_convergence: mark, every output a program reads says so.
    capped = {**SMALL, "optimiser": {"max_evaluations": 20}}
    with pytest.raises(ConvergenceError, match=r"N2: the nelder-mead optimiser did not converge after 2\d evaluations"
                                               r".*identification.optimiser.max_evaluations"):
        run_identification(n2, catenary, data, IdentificationSettings.from_mapping(capped))
    settings = IdentificationSettings.from_mapping({**capped, "on_non_convergence": "mark"})
    with caplog.at_level("WARNING"):
        run = run_identification(n2, catenary, data, settings)
    assert any(r.levelname == "WARNING" and "did not converge" in r.getMessage() for r in caplog.records)
    assert not run.result.converged and run.result.status == "not_converged"
    paths = IdentificationPaths.in_folder(tmp_path)
    write_identification(run, paths, config_hash="abc")
    table = pd.read_csv(paths.s_opt)
    assert (~table["converged"]).all() and (table["status"] == "not_converged").all()
    assert json.loads(paths.normality.read_text())["identification_status"] == "not_converged"
    assert read_metadata(paths.trace)["catenary.status"] == "not_converged"
    assert "**Status: not_converged**" in paths.report.read_text()


def test_a_singular_information_leaves_no_standard_errors_and_says_so(written, tmp_path):
    # −H not positive definite (a ridge, or s_opt at the box edge): NaN standard errors, which
    # s_opt.csv shows as blanks, and a status that every output carries.
    import dataclasses

    run, _, _ = written
    assert run.result.status == "ok"                  # the small run converged, with standard errors
    singular = dataclasses.replace(run.result, theta_covariance=np.full_like(run.result.theta_covariance, np.nan))
    assert singular.status == "singular_information" and not singular.standard_errors_available
    paths = IdentificationPaths.in_folder(tmp_path)
    write_identification(dataclasses.replace(run, result=singular), paths, config_hash="abc")
    assert (pd.read_csv(paths.s_opt)["status"] == "singular_information").all()
    assert "no standard errors" in paths.report.read_text()


def test_too_few_spans_are_refused_and_few_spans_warned_about(catenary, n2, data, caplog):
    # 13 identified parameters (defaults: 11 σ, T_MW and ΔH means): 12 spans are refused before
    # any sampling, naming the counts and the settings to change; 13–38 spans (< 3 per
    # parameter) pass with a warning.
    from catenary.plumbing.errors import InputError
    from catenary.stages.identification.runner import check_span_count

    settings = IdentificationSettings.from_mapping(SMALL)
    with pytest.raises(InputError, match=r"span type N2: 12 measured span\(s\) for 13 identified parameters; "
                                         r"expected at least 13 spans.*identification.random_inputs"):
        run_identification(n2, catenary, data[:12], settings)
    import logging
    log = logging.getLogger("test_span_count")
    with caplog.at_level("WARNING"):
        check_span_count("N2", 20, 13, log)
        check_span_count("N2", 39, 13, log)
    warnings = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert len(warnings) == 1 and "20 spans for 13 identified parameters" in warnings[0]
    # spans lost upstream are named as the reason (a hand-made recording whose correction did not
    # converge left 2 of 15 spans: the refusal must point at the correction, not the recording)
    with pytest.raises(InputError, match=r"2 measured span\(s\) \(13 more left out because their correction "
                                         r"did not converge"):
        check_span_count("N2", 2, 13, log, n_left_out=13)


def test_the_spans_left_out_of_the_explained_laws_are_those_the_diagnosis_flags():
    # unexplained, or explained only by an effect of the user's own: both left out; the rest kept
    from catenary.stages.identification.explained import unexplained_spans

    spans = pd.DataFrame({"span_id": ["A", "B", "C", "D"], "unexplained": [True, False, False, "True"],
                          "explained_by": ["", "clamp_mass", "", None]})
    assert unexplained_spans(spans) == {"A", "B", "D"}
