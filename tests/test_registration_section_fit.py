"""A section's supports found jointly from the height (catenary.measurement.registration.section_fit), on a
synthetic height-only trace: a contact wire hung straight between its supports (masts and
droppers, the droppers' heights drawn about the design presag) less its own sag, recorded every
0.1 m with 1 mm of noise and 1 mm quantisation by an odometer 0.3 % long and 7 m ahead; and the
table's accuracy measured from residuals."""

from itertools import product
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from catenary.measurement.recording import validate_masts
from catenary.measurement.registration import RegistrationSettings, register_run, register_runs

from catenary.measurement.registration.mapping import ChainageMap
from catenary.measurement.registration.section_chain import UNDERFLOW_ROW_SUM, SectionChain
from catenary.measurement.registration.section_fit import (GRID_STEP_M, Evidence, fit_section, height_evidence,
                                                           table_std_from_residuals)
from catenary.measurement.registration.supports import trace_of

SCALE, OFFSET_M = 1.003, 7.0


def _section(catenary, n_spans: int, seed: int, name: str = "N2"):
    """True supports (table frame), the recorded trace and the droppers' W of one section."""
    rng = np.random.default_rng(seed)
    st = catenary.span_type(name)
    masts = 100.0 + st.length_m * np.arange(n_spans + 1)
    knots_x, knots_h = [], []
    heights = 5.08 + rng.uniform(-0.03, 0.03, n_spans + 1)
    p = st.dropper_positions_m
    for k in range(n_spans):
        w = -4 * st.presag_m * (p - p[0]) * (p[-1] - p) / (p[-1] - p[0]) ** 2 + rng.normal(0, 0.004, p.size)
        knots_x += list(np.r_[masts[k], masts[k] + p])
        knots_h += list(np.r_[heights[k], heights[k] + (heights[k + 1] - heights[k]) * p / st.length_m + w])
    knots_x.append(masts[-1])
    knots_h.append(heights[-1])
    kx, kh = np.array(knots_x), np.array(knots_h)
    x = np.arange(masts[0] - 3.0, masts[-1] + 3.0, 0.1)
    seg = np.clip(np.searchsorted(kx, x, "right") - 1, 0, kx.size - 2)
    ell = kx[seg + 1] - kx[seg]
    u = np.clip((x - kx[seg]) / ell, 0.0, 1.0)
    sag = catenary.contact.mass_per_length_kg_m * catenary.gravity_m_s2 * ell ** 2 / (8 * 25500.0)
    h = np.interp(x, kx, kh) - np.where((x >= kx[0]) & (x <= kx[-1]), 4 * sag * u * (1 - u), 0.0)
    h = 1e-3 * np.round((h + rng.normal(0.0, 1e-3, x.size)) / 1e-3)
    recorded = OFFSET_M + masts[0] + SCALE * (x - masts[0])
    return masts, trace_of(recorded, h), [name] * n_spans + [None]


def _fit(catenary, masts, trace, types, table, listed=None):
    listed = np.ones(table.size, dtype=bool) if listed is None else listed
    line = ChainageMap(np.array([OFFSET_M + masts[0], SCALE]), float(masts[0]))
    guess = line.to_recorded(table)
    evidence = height_evidence(trace, guess, types, catenary, SCALE, {t: 0.0 for t in set(types) - {None}}, 1.5)
    lengths = np.array([catenary.span_type(t).length_m for t in types[:-1]])
    # the coarse line as the registration's search gives it: through the table, off by its errors
    start = np.polyfit(table[listed] - table[0], guess[listed], 1)[::-1]
    return evidence, fit_section(evidence, table, listed, lengths, initial=ChainageMap(start, float(table[0])),
                                 degree=1, prior_std_m=0.2)


@pytest.mark.parametrize("seed", [1, 2])
def test_a_loose_tables_section_is_found_jointly_and_the_table_measured(catenary, seed):
    # A table kept to the metre (uniform ±1 m: σ 0.58 m) given the prior 0.2 m of the own-data
    # template. Each support's own evidence places it to 0.05–0.065 m RMS on this trace (a
    # quasi-static wire's kinks are sharper than a dynamic pass's, where it is 0.2–0.3 m); the
    # whole section, its span lengths and the table together place every support within 0.15 m,
    # half the dynamic pass's own error (measured 0.008 / 0.020 m RMS, 0.015 / 0.035 m at worst;
    # six draws: 0.035 m at worst).
    n = 20
    masts, trace, types = _section(catenary, n, seed)
    rng = np.random.default_rng(100 + seed)
    table = masts + rng.uniform(-1.0, 1.0, masts.size)
    _, fit = _fit(catenary, masts, trace, types, table)
    truth = OFFSET_M + masts[0] + SCALE * (masts - masts[0])
    error = fit.position_m - truth
    assert np.max(np.abs(error)) < 0.15, error
    # The map's scale to 0.01 % (the section's 1.2 km read by every support).
    assert fit.chainage_map.scale == pytest.approx(SCALE, abs=1e-4)
    # The table's accuracy: the realized error's standard deviation about the best line (what any
    # estimate from 21 masts can know; of uniform errors, the planted σ itself to ≈ 10 %) within
    # 15 %: the supports' own error (≈ 0.03 m) is a twentieth of the table's (measured 0.999 and
    # 0.997 of it; six draws 0.96–1.00).
    deviation = table - masts
    a = np.vander(masts - masts[0], 2)
    realized = np.sqrt(np.sum((deviation - a @ np.linalg.lstsq(a, deviation, rcond=None)[0]) ** 2) / (n + 1 - 2))
    assert fit.table_std_m == pytest.approx(realized, rel=0.15)
    # Its standard errors say so: every error within 3 of them (measured 1.1 at worst).
    assert np.all(np.abs(error) < 3.0 * fit.std_m)


def test_the_spans_place_a_support_the_trace_and_the_table_cannot(catenary):
    # The trace has a drop-out over mast 10's whole window (its droppers' kinks and its own are
    # lost) and the table puts it 1.2 m off: its neighbours' supports and its two spans' lengths
    # still place it within 0.15 m (measured 0.005 m), not where the table says.
    masts, trace, types = _section(catenary, 20, seed=3)
    truth = OFFSET_M + masts[0] + SCALE * (masts - masts[0])
    lost = np.abs(trace.chainage_m - truth[10]) < 31.0        # its window reaches 29.6 m each side
    trace = trace_of(trace.chainage_m, np.where(lost, np.nan, trace.height_m))
    table = masts + np.random.default_rng(4).uniform(-0.3, 0.3, masts.size)
    table[10] = masts[10] + 1.2
    evidence, fit = _fit(catenary, masts, trace, types, table)
    assert np.all(evidence.log_likelihood[10] == 0.0) and np.isnan(evidence.own_m[10])
    assert abs(fit.position_m[10] - truth[10]) < 0.15


def test_the_table_accuracy_from_gaussian_residuals_recovers_the_planted_one():
    # 200 masts, a table with σ 0.3 m, each trace position with its own known error 0.01–0.2 m,
    # a line fitted to them: the residuals' mean square less the traces' variances. Its sampling
    # error: var(σ̂²) ≈ 2 (σ² + mean s²)² / n, so σ̂ is known to ≈ 5.5 % here; three of those.
    rng = np.random.default_rng(11)
    n, sigma = 200, 0.3
    t = np.sort(rng.uniform(0.0, 1200.0, n))
    trace_std = rng.uniform(0.01, 0.2, n)
    position = 3.0 + 1.002 * (t + rng.normal(0.0, sigma, n)) + rng.normal(0.0, trace_std)
    a = np.vander(t, 2)
    residual = position - a @ np.linalg.lstsq(a, position, rcond=None)[0]
    estimate = table_std_from_residuals(residual / 1.002, trace_std / 1.002, 2, prior_std_m=0.01)
    spread = np.sqrt(2.0) * (sigma ** 2 + np.mean(trace_std ** 2)) / np.sqrt(n) / (2 * sigma ** 2)
    assert estimate == pytest.approx(sigma, rel=3 * spread)
    # With no more masts than the map has coefficients the run cannot tell: the configured value.
    assert table_std_from_residuals(residual[:2], trace_std[:2], 2, prior_std_m=0.07) == 0.07


def test_supports_placed_within_a_grid_cell_are_uncorrelated_far_down_the_line():
    # Evidence sharper than the grid (σ 5 mm against its 0.05 m step) puts every support's
    # posterior on one node, 60 km down the line: what is left of each position's error is its
    # cell's quantisation, independent between supports, so neighbours are uncorrelated. The
    # correlation is a covariance about the posterior means over the two variances with their
    # quantisation (raw second moments of 60 km chainages cancelled to noise there: NaN or ±1,
    # as on 302 of a 1 000-span line's 1 050 masts).
    step = GRID_STEP_M
    truth = 60_000.0 + 60.0 * np.arange(21) + np.random.default_rng(5).uniform(-step / 4, step / 4, 21)
    nodes = np.round(truth / step) * step                   # each support near a node of its grid
    grid = nodes[:, None] + step * np.arange(-30, 31)[None, :]
    log_likelihood = -0.5 * ((grid - truth[:, None]) / 0.005) ** 2
    evidence = Evidence(grid, log_likelihood - log_likelihood.max(axis=1, keepdims=True), truth, np.full(21, 0.005))
    fit = fit_section(evidence, truth, np.ones(21, dtype=bool), np.diff(truth),
                      initial=ChainageMap(np.array([truth[0], 1.0]), float(truth[0])), degree=1, prior_std_m=0.01)
    assert np.all(np.isfinite(fit.corr_next[:-1])) and np.isnan(fit.corr_next[-1])
    # |ρ| ≤ 0.01: a posterior that is one node to 1e-6 of its mass has a covariance of that order
    assert np.max(np.abs(fit.corr_next[:-1])) < 0.01, fit.corr_next


@pytest.mark.parametrize("far", [False, True])
def test_the_chains_marginal_likelihood_is_the_sum_over_every_path(far):
    """The forward pass without transition matrices (``forward_pass``) against the chain's marginal
    likelihood summed over every path of a small grid, path by path (4 supports × 5 trials: 625
    paths). ``far``: one span's expected length puts its rows' sums below ``UNDERFLOW_ROW_SUM``, the rows
    normalised in logarithms. Tolerance 1e-12 relative: sums of 625 positive terms in another
    order; the posteriors (forward–backward with the matrices) against each support's trials
    summed over the paths through them, to 1e-12."""
    rng = np.random.default_rng(7)
    n, s = 4, 5
    lengths = np.array([60.0, 55.0, 63.0])
    table = np.r_[0.0, np.cumsum(lengths)] + rng.normal(0, 0.05, n)
    grid = table[:, None] + (np.arange(s) - s // 2)[None, :] * GRID_STEP_M
    log_l = rng.normal(0, 2.0, (n, s))
    chain = SectionChain(grid, log_l, table, np.ones(n, bool), lengths)
    chainage_map = ChainageMap(np.array([0.0, 1.0 + (0.05 if far else 0.0)]), 0.0)
    length_std = 0.001 if far else 0.04
    log_steps = chain.log_steps(chainage_map, length_std)
    scaled = log_steps - log_steps.max(axis=1, keepdims=True)
    rows = np.array([[np.exp(scaled[k, s - 1 - a:2 * s - 1 - a]).sum() for a in range(s)] for k in range(n - 1)])
    assert (rows < UNDERFLOW_ROW_SUM).any() == far                  # the case the test means to reach
    log_e = log_l + chain.table_terms(chainage_map, 0.1)
    total = -np.inf
    through = np.full((n, s), -np.inf)                  # log of the paths' sum through each trial
    for path in product(range(s), repeat=n):
        term = np.log(1.0 / s) + sum(log_e[k, path[k]] for k in range(n))
        for k in range(n - 1):
            window = log_steps[k, s - 1 - path[k]:2 * s - 1 - path[k]]
            term += log_steps[k, path[k + 1] - path[k] + s - 1] - np.logaddexp.reduce(window)
        total = np.logaddexp(total, term)
        for k in range(n):
            through[k, path[k]] = np.logaddexp(through[k, path[k]], term)
    assert chain.run(chainage_map, 0.1, length_std) == pytest.approx(total, rel=1e-12)
    dense, (gamma, _, _) = chain.run(chainage_map, 0.1, length_std, posterior=True)
    assert dense == chain.run(chainage_map, 0.1, length_std)
    np.testing.assert_allclose(gamma, np.exp(through - total), rtol=0, atol=1e-12)


def test_a_recordings_runs_are_registered_alike_in_one_process_or_two(catenary):
    """``register_runs`` hands the runs to worker processes: each run's registration is its own,
    so the tables are the same, bit for bit, as one process's and as ``register_run`` run by run
    (two runs of a 6-span section, each its own trace)."""
    config = yaml.safe_load((Path(__file__).resolve().parents[1] / "config" / "test.yaml").read_text())
    settings = RegistrationSettings.from_mapping(config["registration"])
    runs = {}
    for run_id, seed in (("R1", 3), ("R2", 4)):
        masts, trace, types = _section(catenary, 6, seed)
        runs[run_id] = pd.DataFrame({"chainage_m": trace.chainage_m, "height_m": trace.height_m, "stagger_m": np.nan,
                                     "speed_kmh": 40.0, "run_id": run_id, "direction": 1})
    table = validate_masts(pd.DataFrame({"mast_id": [f"M{k}" for k in range(7)], "section_id": "S1",
                                         "chainage_m": masts, "span_type": ["N2"] * 6 + [""]}), source="test table")

    def lag(span_type, speed_kmh):
        return 0.0

    one = register_runs(runs.__getitem__, ["R1", "R2"], table, catenary, settings, lag, workers=1)
    two = register_runs(runs.__getitem__, ["R1", "R2"], table, catenary, settings, lag, workers=2)
    for run_id, a, b in zip(runs, one, two):
        alone = register_run(runs[run_id], table, catenary, settings, lag)
        assert a.run_id == b.run_id == run_id
        assert list(a.sections["status"]) == ["registered"]               # a registration, not a refusal
        for left, right in ((a, b), (a, alone)):
            pd.testing.assert_frame_equal(left.masts, right.masts, check_exact=True)
            pd.testing.assert_frame_equal(left.sections, right.sections, check_exact=True)
