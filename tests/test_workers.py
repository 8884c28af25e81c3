"""A job uses the cores it is given, and gives the same answer with any number of them; a stage's
memory does not grow with the line (issue [18]).

Worker processes over blocks of spans (catenary.plumbing.workers) must give the same result, bit
for bit, as one process: the posteriors, the band's coverages, the profile intervals' ends. The
parts a long line made large are computed by stretches or blocks that must give what the whole
gave: the registration's kink signals per section, the despiking's running median by blocks,
a section's profiles read by the file's row groups."""

import copy
import dataclasses
import os

import numpy as np
import pandas as pd
import pytest
from scipy import stats
from catenary.measurement.projection import PROFILE_SCHEMA
from catenary.measurement.registration import runner as registration
from catenary.measurement.registration import supports
from catenary.plumbing.parquet import distinct_values, read_table, write_table
from catenary.plumbing.workers import KeptProcesses, map_blocks, map_each
from catenary.stages.diagnosis import refits
from catenary.stages.diagnosis.locate import bootstrap_eigenvalues
from catenary.stages.identification.fit import identify, make_likelihood
from catenary.stages.identification.likelihood import fit_gaussian
from catenary.stages.identification.profile import profile_intervals
from catenary.stages.identification.synthetic import simulate_deflections
from catenary.stages.maintenance import population
from catenary.stages.maintenance.posterior import span_posteriors

from .test_diagnosis import tension_start  # noqa: F401  (fixture)
from .test_identification_profile import MODE, _laws, start  # noqa: F401  (fixture)
from .test_maintenance import NOISE_M, _spans_from_prior, table2_prior  # noqa: F401  (fixture)


def test_map_blocks_covers_every_item_once_in_order_whatever_the_workers():
    # Blocks of a fixed size, the last shorter, in order; the same with 1 and 2 workers; an
    # empty range still calls the function once (a stage's empty result keeps its shape).
    def bounds(a, b):
        return [(a, b)]
    assert map_blocks(bounds, 10, 1, 4) == map_blocks(bounds, 10, 2, 4) == [[(0, 4)], [(4, 8)], [(8, 10)]]
    assert map_blocks(bounds, 0, 2, 4) == [[(0, 0)]]


def test_span_posteriors_are_the_same_bit_for_bit_with_two_workers(table2_prior):
    # 40 spans in blocks of 16 (three blocks, two workers), each span with its own error
    # covariance, the laws' uncertainty and a fault component: every number of every span the
    # same as in one process — a span's mode, proposal and weights are its own.
    prior = dataclasses.replace(table2_prior, fault_probability=0.01, fault_std_m=0.03,
                                mean_uncertainties=0.002 * table2_prior.means,
                                sigma_uncertainties=0.1 * table2_prior.sigmas)
    _, w = _spans_from_prior(prior, 40, seed=21)
    b = 3e-4 * np.random.default_rng(22).standard_normal((40, 9, 2))
    cov = NOISE_M**2 * np.eye(9) + np.einsum("kia,kja->kij", b, b)
    one = span_posteriors(prior, w, cov, n_samples=300, seed=5, n_draws=8, workers=1, block_spans=16)
    two = span_posteriors(prior, w, cov, n_samples=300, seed=5, n_draws=8, workers=2, block_spans=16)
    for name in ("mean", "q05", "q95", "mode_z", "mode_converged", "effective_samples", "misfit_p_value", "draws_z"):
        assert np.array_equal(getattr(one, name), getattr(two, name), equal_nan=True), name


def test_leave_one_out_from_a_capped_pool_keeps_the_nominal_coverage(monkeypatch):
    # The others' draws capped (here at 2 000 of 19 950, as 40 000 caps a long line's): each span
    # checked against its own random pick of them is still one more draw of the pooled law, so it
    # falls inside the 5–95 % band at 0.90 (binomial standard error over 400 spans × 3 columns
    # 0.87 %; the cap's quantiles from 2 000 draws add ≈ 0.5 %: tolerance 4 standard errors of
    # both). Workers change nothing.
    monkeypatch.setattr(population, "LOO_POOL_DRAWS", 2000)
    rng = np.random.default_rng(1)
    k, m, n = 400, 50, 3
    draws, w = rng.standard_normal((k, m, n)), rng.standard_normal((k, n))
    chol = np.broadcast_to(1e-12 * np.eye(n), (k, n, n))
    inside = population.leave_one_out_inside(draws, w, chol, 0.9, seed=2)
    assert abs(inside.mean() - 0.9) < 4 * np.hypot(np.sqrt(0.9 * 0.1 / (k * n)), 0.005)
    assert np.array_equal(inside, population.leave_one_out_inside(draws, w, chol, 0.9, seed=2, workers=2))


def test_a_left_out_span_never_sees_its_own_draws_in_a_capped_pool(monkeypatch):
    # Span j's draws all equal j and its W too: the pool each span is checked against (picked
    # from the others' draws past the cap) holds every other span's values and never its own.
    monkeypatch.setattr(population, "LOO_POOL_DRAWS", 400)
    k, m, n = 30, 20, 2
    draws = np.repeat(np.arange(k, dtype=float)[:, None, None], m, axis=1) * np.ones((1, 1, n))
    w = np.arange(k, dtype=float)[:, None] * np.ones((1, n))
    seen = []

    def record(pooled, w_left_out, level):
        seen.append((w_left_out[0], np.unique(np.round(pooled[:, 0]))))
        return np.zeros(w_left_out.shape, dtype=bool)

    monkeypatch.setattr(population, "_inside", record)
    population.leave_one_out_inside(draws, w, np.broadcast_to(1e-12 * np.eye(n), (k, n, n)), 0.5, seed=3)
    assert len(seen) == k
    for own, pool in seen:
        assert own not in pool and pool.size == k - 1     # 400 picks of 29 spans: each drawn (P ≈ 1 − 29 e^-14)


def test_a_stretch_of_the_run_grid_is_the_whole_grids_points_bit_for_bit():
    # np.arange's points (start + i δ), so that a section's kink signals sit where the whole
    # run's did.
    for start, stop in ((1234.5678, 180_000.123), (-37.11, 61_234.9)):
        whole = np.arange(start, stop, registration._COARSE_STEP_M)
        assert np.array_equal(registration._run_grid(start, stop, None, None), whole)
        part = registration._run_grid(start, stop, 5000.0, 9000.0)
        i = np.searchsorted(whole, part[0])
        assert np.array_equal(part, whole[i:i + part.size]) and part[0] <= 5000.0 and part[-1] >= 9000.0


def _trace(seed=4, length_m=3000.0):
    """A height trace with dropper-like kinks every 6 m, a stagger-free run."""
    rng = np.random.default_rng(seed)
    x = np.sort(rng.uniform(0.0, length_m, int(length_m / 0.1)))
    h = 5.3 + 0.02 * np.abs(((x / 6.0) % 1.0) - 0.5) + 2e-4 * rng.standard_normal(x.size)
    h[rng.choice(x.size, 20, replace=False)] += 0.05        # spikes for the despiking
    return supports.trace_of(x, h)


def test_kink_signals_of_a_stretch_are_the_whole_runs_inside_it():
    # The signals are local (a window of 8 m at most): away from a stretch's ends by more than
    # that, its values are the whole grid's, to the rounding of the grid step's median (one ulp
    # of a 0.05 m step moves a slope by ≈ 1e-15 of itself).
    trace = _trace()
    grid, fine, sag = registration.support_kinks(trace)
    part_grid, part_fine, part_sag = registration.support_kinks(trace, 1000.0, 2000.0)
    i = np.searchsorted(grid, part_grid[0])
    inner = (part_grid > 1000.0 + 10.0) & (part_grid < 2000.0 - 10.0)
    for whole, part in ((fine, part_fine), (sag, part_sag)):
        a, b = whole[i:i + part_grid.size][inner], part[inner]
        assert np.all(np.isfinite(a) == np.isfinite(b))
        assert np.allclose(a, b, rtol=1e-12, atol=1e-14, equal_nan=True)


def test_despiking_by_blocks_is_the_despiking_of_the_whole(monkeypatch):
    # Each sample's running median is its own window's: blocks of 1 000 samples give what one
    # block of all 30 000 gave, bit for bit.
    rng = np.random.default_rng(6)
    v = np.cumsum(1e-3 * rng.standard_normal(30_000))
    v[rng.choice(v.size, 50, replace=False)] += 0.1
    v[100:140] = np.nan                                       # a dropout
    whole = supports.despike(v, 5e-4)
    monkeypatch.setattr(supports, "_DESPIKE_BLOCK", 1000)
    assert np.array_equal(supports.despike(v, 5e-4), whole, equal_nan=True)


def test_a_sections_profiles_read_by_row_groups_are_its_rows_of_the_whole_file(tmp_path):
    # Profiles of 300 spans of 200 samples in row groups of 4 096 rows: the rows of 20 spans read
    # through the groups' statistics are those of the whole file, in its order; the run ids of a
    # recording come in order of first appearance.
    ids = [f"M{k:04d}-M{k + 1:04d}" for k in range(300)]
    frame = pd.DataFrame({"span_id": np.repeat(ids, 200), "run_id": "r1", "x_m": np.tile(np.linspace(0, 60, 200), 300),
                          "height_m": np.random.default_rng(7).normal(5.3, 0.01, 60_000)})
    path = tmp_path / "profiles.parquet"
    write_table(frame, path, PROFILE_SCHEMA, config_hash="x", kind="profiles", row_group_rows=4096)
    wanted = ids[140:160]
    part = read_table(path, filters=[("span_id", "in", wanted)])
    expected = frame[frame["span_id"].isin(wanted)].reset_index(drop=True)
    pd.testing.assert_frame_equal(part, expected)
    frame["run_id"] = np.repeat(["r2", "r1", "r3"], 20_000)
    write_table(frame, path, PROFILE_SCHEMA, config_hash="x", kind="profiles", row_group_rows=4096)
    assert distinct_values(path, "run_id") == ["r2", "r1", "r3"]


def test_profile_intervals_are_the_same_with_two_workers(catenary, n2, start):  # noqa: F811
    # Each end of each interval is searched from s_opt alone: the ends and their evaluation
    # counts with 2 worker processes are those of one.
    model = make_likelihood(n2, catenary, np.zeros((1, 9)), start=start, n_samples=2).model
    means, sigmas = _laws(start, 818.0)
    data = simulate_deflections(model, means, sigmas, 117, seed=7, system_height_mode=MODE)
    lik = make_likelihood(n2, catenary, data, start=start, n_samples=2000, seed=1, system_height_mode=MODE)
    result = identify(lik, start)
    names = ("messenger_tension_n", "dropper_5_length_m")
    assert profile_intervals(lik, start, result, parameters=names) == profile_intervals(lik, start, result,
                                                                                         parameters=names, workers=2)


def test_what_fixing_buys_is_the_same_with_two_workers(catenary, n2, monkeypatch):
    # Two repair windows of a 20-span nominal section (a 3 cm long dropper in span 5, another in
    # span 12), one window a block: the table of their runs with 2 worker processes is one
    # process's, bit for bit.
    from catenary.stages.maintenance import repair

    from .test_maintenance import _section_posterior, repair_setup

    settings, pantograph, nominal = repair_setup(catenary, n2)
    post = _section_posterior(20, nominal, [])
    listed = pd.DataFrame({"span_id": ["S05", "S12"], "input": ["dropper_5_length_m", "dropper_9_length_m"]})
    for span, name in zip(listed["span_id"], listed["input"]):
        post.loc[(post.span_id == span) & (post.input == name), "mean"] += 0.03
    monkeypatch.setattr(repair, "WINDOWS_PER_BLOCK", 1)
    one, _ = repair.fixing_buys(post, listed, n2, catenary, pantograph, settings)
    two, _ = repair.fixing_buys(post, listed, n2, catenary, pantograph, settings, workers=2)
    assert len(one) == 4
    pd.testing.assert_frame_equal(one, two, check_exact=True)


def test_the_projection_is_the_same_with_two_workers(catenary, monkeypatch):
    # Two sections cut one a block in two worker processes: the spans, the profiles and the
    # report of one process, bit for bit.
    from catenary.measurement import projection

    from .test_projection import synthetic_line

    recording, masts, _, _ = synthetic_line(catenary, seed=3)
    monkeypatch.setattr(projection, "SECTIONS_PER_BLOCK", 1)
    one = projection.project(recording, masts, catenary)
    two = projection.project(recording, masts, catenary, workers=2)
    pd.testing.assert_frame_equal(one.report, two.report, check_exact=True)
    for name in catenary.span_types:
        pd.testing.assert_frame_equal(one.spans[name], two.spans[name], check_exact=True)
        pd.testing.assert_frame_equal(one.profiles[name], two.profiles[name], check_exact=True)


def test_the_eigenvalue_bootstrap_by_blocks_is_the_same_with_two_workers_and_draws_the_models_law(
        tension_start, monkeypatch):  # noqa: F811
    # The diagnosis' eigenvalue bootstrap (B data sets of ν spans drawn from the fitted model) by
    # blocks of 1 000 // 60 = 16 data sets, each from its own stream: the band the same bit for bit
    # with 2 workers. And the blocks draw the model's law: their 300 values of λ₁ against 300
    # from one draw of 300 × 60 spans from an independent stream, two-sample Kolmogorov–Smirnov
    # (p > 0.001: a false alarm once in a thousand runs of this seed-fixed test, which it passes
    # or fails the same every time).
    monkeypatch.setattr(refits, "BOOTSTRAP_BLOCK_DRAWS", 1000)
    settings, ctx, start = tension_start
    looks = []
    for workers in (1, 2):
        c = copy.copy(ctx)
        c.settings = dataclasses.replace(settings, bootstrap_replicates=300)
        c.rng, c.workers = np.random.default_rng(5), workers
        looks.append(c.locate(c.problem(()), start))
    one, two = looks
    assert np.array_equal(one.eigen_low, two.eigen_low) and np.array_equal(one.eigen_high, two.eigen_high)
    problem = ctx.problem(())
    fit = problem.evaluate(start.theta).fit
    nu = ctx.data.shape[0]
    c = copy.copy(ctx)
    c.settings = dataclasses.replace(settings, bootstrap_replicates=300)
    seed = int(np.random.default_rng(5).integers(2**63))      # the blocks' own top eigenvalues
    blocks = np.concatenate([bootstrap_eigenvalues(c.model_draws(problem, start.theta, (b - a) * nu,
                                                                 np.random.default_rng([seed, a])), fit, nu, b - a)
                             for a, b in [(a, min(a + 16, 300)) for a in range(0, 300, 16)]])
    assert np.quantile(blocks[:, 0], 0.975) == one.eigen_high[0]
    whole = bootstrap_eigenvalues(c.model_draws(problem, start.theta, 300 * nu, np.random.default_rng(99)), fit, nu,
                                  300)
    assert stats.ks_2samp(blocks[:, 0], whole[:, 0]).pvalue > 1e-3


def test_a_long_lines_sections_are_corrected_in_batches_each_section_once():
    # Up to AUTO_JOBS sections: one per job, named by the section (a short line's files keep
    # their names). Beyond: ceil(sections / AUTO_JOBS) per job; the sections measuring the
    # model-error budget each alone; every section in exactly one batch, in sorted order.
    from catenary.stages.correction.batches import AUTO_JOBS, section_batches
    short = [f"C{k:02d}" for k in range(12)]
    assert section_batches(short, alone={"C03"}) == {s: [s] for s in short}
    line = [f"L{k:04d}" for k in range(1, 501)]
    batches = section_batches(line[::-1], alone={"L0001", "L0002"})
    assert batches["L0001"] == ["L0001"] and batches["L0002"] == ["L0002"]
    assert [s for b in batches.values() for s in b] == line
    assert max(len(b) for b in batches.values()) == -(-500 // AUTO_JOBS) == 5
    assert len(batches) == 2 + -(-498 // 5) and batches["L0003+4"] == line[2:7]
    assert set(map(len, section_batches(line, sections_per_job=2).values())) == {2}
    # an alone section in the middle ends the batch before it: a batch is consecutive sections
    middle = section_batches(short, alone={"C03"}, sections_per_job=3)
    assert list(middle.items())[:3] == [("C00+2", ["C00", "C01", "C02"]), ("C03", ["C03"]),
                                        ("C04+2", ["C04", "C05", "C06"])]
    assert [s for b in middle.values() for s in b] == short


def test_the_inversion_is_the_same_with_two_workers(catenary, n2, monkeypatch):
    # 7 spans in blocks of 3 (three blocks, two workers), one of them needing a pushing dropper
    # (a 5 cm kink up at mid-span): the same lengths, spans and left-out reason as in one process.
    from catenary.physics.dropper_table import presag_deflection_m
    from catenary.stages import inversion
    monkeypatch.setattr(inversion, "BLOCK_SPANS", 3)
    w = np.tile(presag_deflection_m(n2, n2.dropper_positions_m), (7, 1))
    w += 1e-3 * np.random.default_rng(8).standard_normal(w.shape)
    w[4, 4] += 0.05
    ids = [f"s{k}" for k in range(7)]
    one = inversion.invert_spans(n2, catenary, ids, w, workers=1)
    two = inversion.invert_spans(n2, catenary, ids, w, workers=2)
    assert one.span_id.tolist() == two.span_id.tolist() == [i for i in ids if i != "s4"]
    assert np.array_equal(one.dropper_lengths_m, two.dropper_lengths_m)
    assert one.left_out.equals(two.left_out) and one.left_out["span_id"].tolist() == ["s4"]


def test_the_profile_test_is_the_same_with_two_workers_and_reads_runs_in_any_row_order():
    # Each span's fits, scan and p-values are its own (blocks of SPANS_PER_BLOCK spans): the
    # table and the noise are the same bit for bit with 2 workers. 300 spans (two blocks at
    # 250, one shorter), two runs on some spans, one with a point load, rows shuffled: a span's
    # runs are read in the order they first appear and each run's samples by x, as a groupby
    # per span and run of the unshuffled table reads them (the independent computation here).
    from catenary.stages.diagnosis import profile_check
    from .test_profile_check import DROPPERS_M, LENGTH_M, T_CW_N, synthetic_profiles

    profiles = synthetic_profiles(300, seed=5, load={7: (7.1, 30.0)})
    second = profiles[profiles["span_id"] < "S040"].assign(run_id="again")
    second["height_m"] += 1e-4
    profiles = pd.concat([profiles, second], ignore_index=True)
    shuffled = profiles.sample(frac=1.0, random_state=3).reset_index(drop=True)
    settings = profile_check.ProfileSettings(calibration_draws=300)
    one, noise_one = profile_check.profile_tests(shuffled, LENGTH_M, DROPPERS_M, T_CW_N, settings)
    two, noise_two = profile_check.profile_tests(shuffled, LENGTH_M, DROPPERS_M, T_CW_N, settings, workers=2)
    pd.testing.assert_frame_equal(one, two, check_exact=True)
    assert noise_one == noise_two
    spans = profile_check._span_data(shuffled)
    order = shuffled.groupby("span_id", sort=False)
    assert [s.span_id for s in spans] == list(order.groups)
    for span in spans:
        rows = shuffled[shuffled["span_id"] == span.span_id]
        runs = list(rows.groupby("run_id", sort=False))
        assert len(span.runs) == len(runs)
        for (x, y, _), (_, run) in zip(span.runs, runs):
            run = run.sort_values("x_m", kind="stable")
            np.testing.assert_array_equal(x, run["x_m"].to_numpy())
            np.testing.assert_array_equal(y, (run["height_m"] - run["simulated_height_m"]).to_numpy())
    assert one.loc[one["span_id"] == "S007", "p_profile"].item() < 1e-3       # the point load is still found
    # A table already grouped by span and run with x ascending (as the correction writes it) is
    # read without sorting; one whose run runs backwards, or whose span comes back later, is sorted.
    grouped = profiles.sort_values(["span_id", "run_id", "x_m"], kind="stable").reset_index(drop=True)
    assert profile_check._grouped_in_order(*_codes(grouped))
    backwards = pd.concat([grouped.iloc[:40].iloc[::-1], grouped.iloc[40:]], ignore_index=True)
    first = grouped["span_id"] == grouped["span_id"].iloc[0]
    come_back = pd.concat([grouped[first].iloc[:20], grouped[~first], grouped[first].iloc[20:]], ignore_index=True)
    assert not profile_check._grouped_in_order(*_codes(backwards))
    assert not profile_check._grouped_in_order(*_codes(come_back))
    for table in (grouped, backwards, come_back):
        for a, b in zip(profile_check._span_data(table), profile_check._span_data(grouped)):
            assert a.span_id == b.span_id and len(a.runs) == len(b.runs)
            for (xa, ya, _), (xb, yb, _) in zip(a.runs, b.runs):
                np.testing.assert_array_equal(xa, xb)
                np.testing.assert_array_equal(ya, yb)


def _codes(profiles: pd.DataFrame) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Span and (span, run) codes by first appearance and x, as the profile test numbers them."""
    span_code, _ = pd.factorize(profiles["span_id"])
    run_code, _ = pd.factorize(profiles["span_id"] + "|" + profiles["run_id"])
    return span_code, run_code, profiles["x_m"].to_numpy(dtype=float)


def test_the_hessian_and_scores_are_the_same_with_two_workers_and_recorded_in_order(catenary, n2, start):  # noqa: F811
    # The finite-difference Hessian's and the sandwich's J evaluations in worker processes give
    # the same standard errors bit for bit, and the problem counts and traces them as if
    # evaluated one after the other (a worker's own bookkeeping stays in the worker).
    from catenary.stages.identification.fit import ScaledProblem, observed_information

    model = make_likelihood(n2, catenary, np.zeros((1, 9)), start=start, n_samples=2).model
    means, sigmas = _laws(start, 818.0)
    data = simulate_deflections(model, means, sigmas, 40, seed=3, system_height_mode=MODE)
    lik = make_likelihood(n2, catenary, data, start=start, n_samples=600, seed=1, system_height_mode=MODE)
    one = identify(lik, start, mast_pairs=np.array([[k, k + 1] for k in range(39)]), covariance="sandwich")
    two = identify(lik, start, mast_pairs=np.array([[k, k + 1] for k in range(39)]), covariance="sandwich", workers=2)
    # the optimiser's J shared by two processes: the same path, evaluation by evaluation
    assert one.j_opt == two.j_opt and one.n_evaluations == two.n_evaluations
    np.testing.assert_array_equal(one.trace_j, two.trace_j)
    np.testing.assert_array_equal(one.theta_opt, two.theta_opt)
    np.testing.assert_array_equal(one.theta_covariance, two.theta_covariance)
    assert [(e.mu_se, e.sigma_se) for e in one.estimates] == [(e.mu_se, e.sigma_se) for e in two.estimates]
    assert one.n_hessian_evaluations == two.n_hessian_evaluations
    # The Hessian of a quadratic is exact whatever evaluates it; the trace keeps the order.
    problems = [ScaledProblem(lik, start, np.array([9, 10]), np.array([10])) for _ in range(2)]
    theta = np.array([0.1, -0.2, 0.05])
    a = observed_information(problems[0].j, theta, 0.01)
    b = observed_information(problems[1].j, theta, 0.01, j_many=lambda x: [v.j for v in problems[1].evaluate_many(x, 2)])
    np.testing.assert_array_equal(a, b)
    assert problems[0].n_evaluations == problems[1].n_evaluations == 1 + 2 * 3 + 4 * 3
    for p, q in zip(problems[0].trace, problems[1].trace):
        np.testing.assert_array_equal(p[0], q[0])
        assert p[3] == q[3]
    quadratic = np.array([[2.0, 0.5, 0.0], [0.5, 1.0, 0.2], [0.0, 0.2, 3.0]])
    np.testing.assert_allclose(observed_information(lambda t: -0.5 * t @ quadratic @ t, theta, 0.01), quadratic,
                               rtol=1e-9)


def test_the_measuring_passs_responses_are_the_same_with_two_workers(catenary, n2):
    # The profile test's base columns: the pass over the nominal section once, then once per
    # raised support point (9 droppers, 2 masts), each its own run: the same columns bit for bit
    # with 2 workers, in both directions of travel. And each column is the response to raising
    # the static CW there, in its own place: statically the hat of a tensioned wire, 1 at its
    # support point and 0 at the others; the pass at 40 km/h takes 0.02–0.22 of it off there
    # (measured 0.78–0.98) and spreads at most 0.36 to a neighbour. So at each support point
    # its own column lies in [0.7, 1.0] and is the largest (a column out of order, or a worker's
    # result put in another's place, is not).
    from catenary.physics.measuring import profile_influence
    from catenary.physics.pantograph import load_pantographs
    from .conftest import ROOT

    pantograph = load_pantographs(ROOT / "config" / "pantographs.yaml")["measuring"]
    x = np.linspace(0.0, n2.length_m, 118)
    for direction in (1, -1):
        one, two = (profile_influence(n2, catenary, pantograph, speed_m_s=40 / 3.6, x_m=x, time_step_s=0.004,
                                      direction=direction, workers=w) for w in (1, 2))
        np.testing.assert_array_equal(one, two)
        assert one.shape == (x.size, n2.n_droppers + 2)
        at = [int(np.argmin(np.abs(x - p))) for p in (*n2.dropper_positions_m, 0.0, n2.length_m)]
        rows = one[at]
        own = np.diag(rows)
        assert np.all((own >= 0.7) & (own <= 1.0))
        assert np.all(own > np.abs(rows - np.diag(own)).max(axis=1))


def test_kept_processes_give_each_part_in_order_raise_a_helpers_error_and_stay_in_step():
    # Part 0 in this process, the others in the helpers, results in the parts' order; an error
    # in a helper is raised here with its type and message, and the next call gets its own
    # answers (none left over from the failed one); in a process forked from the owner every
    # part is computed there, in turn.
    def part(k, fail=False):
        if fail:
            raise ValueError(f"part {k} failed")
        return k, os.getpid()

    with KeptProcesses(part, 3) as kept:
        out = kept.map([(0,), (1,), (2,)])
        assert [k for k, _ in out] == [0, 1, 2]
        assert out[0][1] == os.getpid() and len({pid for _, pid in out}) == 3
        with pytest.raises(ValueError, match="part 2 failed"):
            kept.map([(0,), (1,), (2, True)])
        assert [k for k, _ in kept.map([(5,), (6,)])] == [5, 6]
        forked = map_each(lambda k: {pid for _, pid in kept.map([(0,), (1,)])}, 2, 2, 1)
        assert all(len(pids) == 1 and os.getpid() not in pids for pids in forked)
        with pytest.raises(ValueError, match="at most 3"):
            kept.map([(0,)] * 4)


def test_a_j_shared_by_kept_processes_is_the_same_and_its_blocks_add_up_to_the_whole_sample(catenary, n2,
                                                                                            start):  # noqa: F811
    # J's model sample is summed in fixed blocks whichever process computes them: with 2 or 3
    # processes J and every span's ln p are those of one, bit for bit, and a T_MW out of the
    # model's range is refused the same way. The blocks' moments added up are those of the whole
    # sample at once (fit_gaussian of the taper-weighted sample, another order of the same sums:
    # 1e-9 relative on the covariance's factor, whose entries are differences of sums ~1e4 times
    # larger than them). The moments read other data give that data's J (the model-error
    # budget reads every shifted W under one model sample): 1e-12 relative, the sums' rounding.
    model = make_likelihood(n2, catenary, np.zeros((1, 9)), start=start, n_samples=2).model
    means, sigmas = _laws(start, 818.0)
    data = simulate_deflections(model, means, sigmas, 60, seed=4, system_height_mode=MODE)
    lik = make_likelihood(n2, catenary, data, start=start, n_samples=1000, seed=1, system_height_mode=MODE)
    assert len(lik.moment_blocks) == 4
    far = means.copy()
    far[9] *= 3.0                                            # T_MW far beyond the fast model's range
    points = [(means, sigmas), (means, 1.3 * sigmas), (far, sigmas)]
    one = [lik.evaluate(m, s) for m, s in points]
    assert [v.status for v in one] == ["ok", "ok", "tension_out_of_bounds"]
    for workers in (2, 3):
        with lik.parallel(workers):
            other = [lik.evaluate(m, s) for m, s in points]
        for a, b in zip(one, other):
            assert (a.j, a.status) == (b.j, b.status)
            if a.log_density is not None:
                np.testing.assert_array_equal(a.log_density, b.log_density)
    sample = lik.model_sample(means, sigmas)
    whole = fit_gaussian(sample.w_m, sample.weight)
    np.testing.assert_allclose(one[0].fit.mean, whole.mean, rtol=1e-12)
    np.testing.assert_allclose(one[0].fit.chol, whole.chol, rtol=1e-9, atol=1e-9 * np.abs(whole.chol).max())
    shifted = lik.with_data(data + 2e-4)
    assert shifted.value_of(lik.moments(means, sigmas)).j == pytest.approx(shifted(means, sigmas), rel=1e-12)


def test_the_diagnosis_fast_models_built_in_workers_are_those_built_here(catenary, n2):
    # A model set's models built side by side in worker processes (and pickled back) evaluate
    # as the ones built here, bit for bit: the pinned base, and the CW offset's (an interpolant
    # in δ too, whose condensation is a method, not a closure, so that it travels whole).
    from catenary.physics.dropper_table import nominal_dropper_lengths
    from catenary.physics.fast import FastSpanModel
    from catenary.stages.diagnosis.model import CONTACT_DEGREE, OFFSET_BOUNDS_M, OFFSET_DEGREE, ModelSet

    models = ModelSet(n2, catenary, (15_000.0, 26_000.0), 0)
    models.prepare([(frozenset(), None), (frozenset({"offset"}), None), (frozenset(), None)], workers=2)
    rng = np.random.default_rng(3)
    lengths = nominal_dropper_lengths(n2, catenary).dropper_lengths_m + 0.005 * rng.standard_normal((50, 9))
    t_mw = rng.uniform(18_000.0, 23_000.0, 50)
    for needs, offset in ((frozenset(), {}), (frozenset({"offset"}), {"cw_offset_m": rng.uniform(-0.2, 0.2, 50)})):
        here = FastSpanModel(n2, catenary, messenger_tension_bounds_n=(15_000.0, 26_000.0), degree=models.degree,
                             contact_degree=CONTACT_DEGREE, cw_clamp_offset_bounds_m=OFFSET_BOUNDS_M if offset else None,
                             offset_degree=OFFSET_DEGREE)
        built = models.model(needs)
        a = built.evaluate(lengths, t_mw, 0.01, -0.01, **offset)
        assert built.cw_clamp_offset_bounds_m == here.cw_clamp_offset_bounds_m
        np.testing.assert_array_equal(a.w_m, here.evaluate(lengths, t_mw, 0.01, -0.01, **offset).w_m)
