"""Cutting a recording into spans and projecting the dropper heights onto the chord."""

import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from catenary.plumbing.errors import ConfigError, InputError
from catenary.plumbing.parquet import read_metadata, read_table
from catenary.measurement.projection import (ProjectionResult, ProjectionSettings, check_reconciliation, project,
                                 robust_local_fit, spans_columns, write_projection)
from catenary.measurement.recording import read_masts, read_recording, validate_masts

LAYOUT = (("S1", ("N2", "N2", "N3", "N2")), ("S2", ("N3", "N3", "N2")))


def synthetic_line(catenary, seed=0, layout=LAYOUT, step=0.1, sigma=1e-3, quantum=1e-3, start=1000.0,
                   section_gap=20.0):
    """A small line with known W.

    Steady-arm heights 5.08 ± 3 cm; W at the droppers = the designed presag parabola + N(0, 4 mm);
    the true CW is straight between consecutive supports (masts and droppers) minus the sag of
    the CW self-weight over that stretch, w·ℓ²/(8·T) ≈ 3 mm for 6.75 m: kinks at every support,
    as a real CW hung from droppers. Sampled every ``step`` m with N(0, sigma) noise and
    ``quantum`` rounding. Returns the recording, the masts (with ``span_type`` on every span's
    left mast), the truth per span and the noise-free heights.
    """
    rng = np.random.default_rng(seed)
    masts, truth, knots_x, knots_h = [], [], [], []
    x, k = start, 0
    for sec, types in layout:
        h_left = 5.08 + rng.uniform(-0.03, 0.03)
        for name in types:
            span_type = catenary.span_types[name]
            length = span_type.length_m + rng.uniform(-0.2, 0.2)
            h_right = 5.08 + rng.uniform(-0.03, 0.03)
            p = span_type.dropper_positions_m
            w = -4 * span_type.presag_m * (p - p[0]) * (p[-1] - p) / (p[-1] - p[0]) ** 2 + rng.normal(0, 0.004, p.size)
            masts.append((f"M{k}", x, sec, name))
            truth.append((f"M{k}-M{k + 1}", name, w))
            knots_x.extend(np.r_[x, x + p])
            knots_h.extend(np.r_[h_left, h_left + (h_right - h_left) * p / length + w])
            x += length
            k += 1
            h_left = h_right
        masts.append((f"M{k}", x, sec, None))
        knots_x.append(x)
        knots_h.append(h_left)
        k += 1
        x += section_gap
    kx, kh = np.array(knots_x), np.array(knots_h)
    xs = np.round(np.arange(start - 5.0, kx[-1] + 5.0, step), 6)
    seg = np.clip(np.searchsorted(kx, xs, "right") - 1, 0, kx.size - 2)
    ell = kx[seg + 1] - kx[seg]
    t = np.clip((xs - kx[seg]) / ell, 0.0, 1.0)
    sag = catenary.contact.mass_per_length_kg_m * catenary.gravity_m_s2 * ell ** 2 / (8 * 25500.0)
    in_span = (xs >= kx[0]) & (xs <= kx[-1]) & (ell < 30.0)
    true_h = np.interp(xs, kx, kh) - np.where(in_span, 4 * sag * t * (1 - t), 0.0)
    measured = np.round((true_h + rng.normal(0, sigma, xs.size)) / quantum) * quantum
    recording = pd.DataFrame({"chainage_m": xs, "height_m": measured})
    masts = pd.DataFrame(masts, columns=["mast_id", "chainage_m", "section_id", "span_type"])
    truth_df = pd.DataFrame({"span_id": [s for s, _, _ in truth], "span_type": [n for _, n, _ in truth]})
    for i in range(9):
        truth_df[f"w{i + 1}_m"] = [w[i] for _, _, w in truth]
    return recording, masts, truth_df, true_h


def w_errors(result, truth):
    errors = []
    for table in result.spans.values():
        merged = table.merge(truth, on="span_id", suffixes=("", "_true"))
        assert len(merged) == len(table)
        errors.append(np.concatenate([merged[f"w{i}_m"] - merged[f"w{i}_m_true"] for i in range(1, 10)]))
    return np.concatenate(errors)


def n_spans_in(masts):
    sec = validate_masts(masts)["section_id"].to_numpy(dtype=object)
    return int((sec[1:] == sec[:-1]).sum())


def assert_reconciles(result, masts):
    report = result.report
    assert len(report) == n_spans_in(masts)
    assert set(report["status"]) <= {"used", "rejected"}
    rejected = report["status"] == "rejected"
    assert (report.loc[rejected, "reason"].str.len() > 0).all()
    assert (report.loc[~rejected, "reason"] == "").all()
    used_ids = [s for table in result.spans.values() for s in table["span_id"]]
    assert sorted(used_ids) == sorted(report.loc[~rejected, "span_id"])


def reason_of(result, span_id):
    row = result.report.set_index("span_id").loc[span_id]
    assert row["status"] == "rejected"
    return row["reason"]


# --------------------------------------------------------------------------------------------
# round trip on synthetic data
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("with_types", [True, False])
def test_round_trip_recovers_w(catenary, with_types):
    recording, masts, truth, true_h = synthetic_line(catenary, seed=1)
    rng = np.random.default_rng(7)
    # Short drop-outs (0.3–1.0 m) at random places, spikes of ±5 cm inside dropper and mast windows.
    for start in rng.choice(len(recording) - 20, 8, replace=False):
        recording.loc[start:start + rng.integers(3, 10), "height_m"] = np.nan
    x = recording["chainage_m"].to_numpy()
    targets = [m + p for m, name in zip(masts["chainage_m"], masts["span_type"]) if isinstance(name, str)
               for p in catenary.span_types[name].dropper_positions_m[[0, 4, 8]]] + list(masts["chainage_m"])
    spike_rows = sorted({int(np.argmin(np.abs(x - (t + rng.uniform(-0.8, 0.8))))) for t in targets})
    spike_rows = [r for r in spike_rows if np.isfinite(recording.loc[r, "height_m"])]
    recording.loc[spike_rows, "height_m"] += rng.choice([-0.05, 0.05], len(spike_rows))
    if not with_types:
        masts = masts.drop(columns="span_type")

    result = project(recording, masts, catenary)
    assert_reconciles(result, masts)
    assert (result.report["status"] == "used").all(), result.report["reason"].tolist()
    assert sorted(s for t in result.spans.values() for s in t["span_id"]) == sorted(truth["span_id"])
    for name, table in result.spans.items():
        assert set(table["span_id"]) == set(truth.loc[truth["span_type"] == name, "span_id"])
        assert list(table.columns) == spans_columns(9)
    errors = w_errors(result, truth)
    rms = float(np.sqrt(np.mean(errors ** 2)))
    assert rms < 1e-3, rms
    assert np.abs(errors).max() < 3e-3
    # Every spike in a fitting window was removed: spikes inside the windows of used spans
    # (a mast window counts for both of its spans).
    used = pd.concat(result.spans.values())
    assert used["outliers_removed"].sum() >= len(spike_rows)
    assert (used["fit_rms_m"] < 2e-3).all() and (used["max_gap_m"] < 1.1).all()
    assert (used["min_samples_per_point"] >= 5).all()
    # Without outlier rejection the same spikes spoil W by several mm.
    naive = project(recording, masts, catenary, ProjectionSettings(outlier_threshold=1e9))
    assert np.sqrt(np.mean(w_errors(naive, truth) ** 2)) > 2 * rms
    # Steady-arm heights are the fitted heights at the masts.
    steady = used.set_index("left_mast_id")["cw_height_left_m"]
    i = np.searchsorted(x, masts.set_index("mast_id").loc[steady.index, "chainage_m"].to_numpy())
    np.testing.assert_allclose(steady.to_numpy(), true_h[i], atol=1.5e-3)


def test_steady_arm_offsets_do_not_change_w(catenary):
    # Paper Fig. 3 in projection terms: adding a straight line (different steady-arm
    # heights) to the recording of a span leaves its W unchanged.
    recording, masts, truth, _ = synthetic_line(catenary, seed=3, sigma=0.0, quantum=1e-9)
    base = project(recording, masts, catenary)
    x = recording["chainage_m"].to_numpy()
    tilted = recording.assign(height_m=recording["height_m"] + 0.05 - 1e-3 * (x - x[0]))
    moved = project(tilted, masts, catenary)
    for name in base.spans:
        w = [f"w{i}_m" for i in range(1, 10)]
        np.testing.assert_allclose(moved.spans[name][w].to_numpy(), base.spans[name][w].to_numpy(), atol=1e-9)
    assert np.sqrt(np.mean(w_errors(base, truth) ** 2)) < 3e-4


def test_robust_local_fit_ignores_spikes():
    rng = np.random.default_rng(0)
    x = np.arange(-1.0, 1.0001, 0.1)
    h = 5.0 + 0.002 * x + 0.001 * x ** 2 + rng.normal(0, 5e-4, x.size)
    h[[3, 10, 15]] += [0.05, -0.05, 0.05]
    fit = robust_local_fit(x, h, 0.0, ProjectionSettings())
    assert fit.n_outliers == 3 and fit.n_inliers == x.size - 3
    assert abs(fit.height_m - 5.0) < 6e-4
    few = robust_local_fit(x[:4], h[:4], 0.0, ProjectionSettings())
    assert np.isnan(few.height_m) and few.n_inliers == 4


# --------------------------------------------------------------------------------------------
# span-level problems: rejected with the reason, never an error
# --------------------------------------------------------------------------------------------

def test_gap_longer_than_a_dropper_spacing_rejects_the_span(catenary):
    recording, masts, _, _ = synthetic_line(catenary, seed=2)
    x = recording["chainage_m"].to_numpy()
    a = masts.loc[1, "chainage_m"] + 20.0  # inside span M1-M2 (N2, smallest spacing 4.5 m)
    rows = np.flatnonzero((x >= a) & (x < a + 5.0))
    recording.loc[rows, "height_m"] = np.nan
    result = project(recording, masts, catenary)
    assert_reconciles(result, masts)
    reason = reason_of(result, "M1-M2")
    assert "gap without valid height of 5.1" in reason
    assert f"from chainage {x[rows[0] - 1]:.3f} to {x[rows[-1] + 1]:.3f} m" in reason
    assert f"recording rows {rows[0] + 1}–{rows[-1] + 1}: height_m is missing" in reason
    assert "exceeds 4.500 m (smallest dropper spacing of N2)" in reason
    assert result.report.set_index("span_id").loc["M1-M2", "span_type"] == "N2"
    assert result.n_used == 6 and result.n_rejected == 1
    # A gap shorter than the spacing is fine unless it empties a fitting window.
    recording2, _, _, _ = synthetic_line(catenary, seed=2)
    d4 = masts.loc[1, "chainage_m"] + catenary.span_types["N2"].dropper_positions_m[3]
    recording2.loc[(x > d4 - 1.2) & (x < d4 + 1.2), "height_m"] = np.nan
    result = project(recording2, masts, catenary)
    assert_reconciles(result, masts)
    reason = reason_of(result, "M1-M2")
    assert reason.startswith("too few samples for a local fit (need 5): dropper 4 at chainage")
    assert "has 0 valid samples within ±1 m" in reason


def test_gap_from_missing_samples_and_a_custom_limit(catenary):
    recording, masts, _, _ = synthetic_line(catenary, seed=2)
    x = recording["chainage_m"].to_numpy()
    a = masts.loc[5, "chainage_m"] + 30.0
    recording = recording[(x < a) | (x > a + 3.0)].reset_index(drop=True)
    assert project(recording, masts, catenary).n_used == 7
    result = project(recording, masts, catenary, ProjectionSettings(max_gap_m=2.0))
    reason = reason_of(result, "M5-M6")
    assert "(no samples in recording there) exceeds 2.000 m (max_gap_m)" in reason


def test_span_with_no_samples(catenary):
    recording, masts, _, _ = synthetic_line(catenary, seed=2)
    masts = pd.concat([masts, pd.DataFrame({"mast_id": ["X1", "X2"], "chainage_m": [5000.0, 5054.0],
                                            "section_id": ["S9", "S9"], "span_type": [None, None]})],
                      ignore_index=True)
    result = project(recording, masts, catenary)
    assert_reconciles(result, masts)
    reason = reason_of(result, "X1-X2")
    assert reason.startswith("no recording samples between chainage 5000.000 and 5054.000 m (recording covers 995")
    assert result.report.set_index("span_id").loc["X1-X2", "span_type"] == "N3"


def test_unknown_span_type(catenary, tmp_path):
    recording, masts, _, _ = synthetic_line(catenary, seed=2)
    masts.loc[2, "span_type"] = "N7"
    masts.to_csv(tmp_path / "masts.csv", index=False)
    recording.to_parquet(tmp_path / "recording.parquet")
    result = project(read_recording(tmp_path / "recording.parquet"), read_masts(tmp_path / "masts.csv"), catenary)
    assert_reconciles(result, masts)
    reason = reason_of(result, "M2-M3")
    assert reason == f"unknown span type 'N7' (mast M2, row 3 (line 4) of {tmp_path / 'masts.csv'}); known: N2, N3"
    assert result.report.set_index("span_id").loc["M2-M3", "span_type"] == ""


def test_length_mismatch_and_no_type_by_length(catenary):
    recording, masts, _, _ = synthetic_line(catenary, seed=2)
    masts.loc[2, "span_type"] = "N2"  # an N3 span declared N2
    masts.loc[6:8, "chainage_m"] -= 10.0  # span M5-M6 (N3) becomes 44 m long
    result = project(recording, masts, catenary)
    assert_reconciles(result, masts)
    assert reason_of(result, "M2-M3").startswith("length mismatch: measured 54.")
    assert "span type N2 is 58.5 m (tolerance ±0.5 m)" in reason_of(result, "M2-M3")
    assert reason_of(result, "M5-M6").startswith("length mismatch: measured 44.")
    masts.loc[5, "span_type"] = None
    result = project(recording, masts, catenary)
    assert_reconciles(result, masts)
    reason = reason_of(result, "M5-M6")
    assert reason.startswith("length 44.")
    assert "matches no span type within ±0.5 m (known: N2 58.5 m, N3 54 m) and mast M5 gives no span_type" in reason
    assert result.report.set_index("span_id").loc["M5-M6", "span_type"] == ""


def test_file_level_problems_raise(catenary):
    recording, masts, _, _ = synthetic_line(catenary, seed=2)
    with pytest.raises(InputError, match=r"masts: row 6, column 'section_id': section 'S2' has only 1 mast"):
        project(recording, masts.drop(index=[5, 6, 7]).reset_index(drop=True), catenary)
    rec = recording.copy()
    rec.loc[10, "chainage_m"] = 0.0
    with pytest.raises(InputError, match=r"recording: row 11, column 'chainage_m'"):
        project(rec, masts, catenary)


def test_settings_are_checked():
    # The config schema says it: a quadratic (default) or kinked fit has 3 parameters and needs 4
    # samples, a linear one 3.
    with pytest.raises(ConfigError, match=r"projection.min_samples: expected a value ≥ 4, got 3"):
        ProjectionSettings(min_samples=3)
    assert ProjectionSettings(min_samples=3, fit_model="linear").min_samples == 3
    with pytest.raises(ConfigError, match=r"projection.min_samples: expected a value ≥ 3, got 2"):
        ProjectionSettings(min_samples=2, fit_model="linear")
    with pytest.raises(ConfigError, match=r"projection.fit_model"):
        ProjectionSettings(fit_model="cubic")
    with pytest.raises(ConfigError, match=r"unknown key\(s\) window_m"):
        ProjectionSettings.from_mapping({"window_m": 1.0})
    assert ProjectionSettings.from_mapping({"max_gap_m": 3.0}).max_gap_m == 3.0


def test_bookkeeping_check_catches_a_lost_span(catenary):
    recording, masts, _, _ = synthetic_line(catenary, seed=2)
    result = project(recording, masts, catenary)
    broken = ProjectionResult(spans={k: v.iloc[1:] for k, v in result.spans.items()}, report=result.report)
    with pytest.raises(RuntimeError, match="spans in the tables"):
        check_reconciliation(broken, 7)
    report = result.report.copy()
    report.loc[0, "status"] = "rejected"
    with pytest.raises(RuntimeError, match="a rejected span has no reason"):
        check_reconciliation(ProjectionResult(spans=result.spans, report=report), 7)
    with pytest.raises(RuntimeError, match="report has 7 rows for 8 spans"):
        check_reconciliation(result, 8)


def test_write_projection(catenary, tmp_path):
    recording, masts, _, _ = synthetic_line(catenary, seed=4)
    masts.loc[0, "span_type"] = "N7"
    result = project(recording, masts, catenary)
    files = write_projection(result, tmp_path, config_hash="c0ffee", span_types=["N2", "N3"])
    assert files == [tmp_path / "N2" / "spans.parquet", tmp_path / "N2" / "profiles.parquet",
                     tmp_path / "N3" / "spans.parquet", tmp_path / "N3" / "profiles.parquet",
                     tmp_path / "spans_report.csv"]
    # The whole profile of every used span: its valid samples between its masts, from the left mast.
    profile = read_table(tmp_path / "N2" / "profiles.parquet")
    assert set(profile["span_id"]) == set(n2["span_id"]) if (n2 := read_table(tmp_path / "N2" / "spans.parquet")
                                                              ).size else profile.empty
    lengths = n2.set_index("span_id")["length_m"]
    assert (profile["x_m"] >= 0).all() and (profile["x_m"] <= profile["span_id"].map(lengths) + 1e-9).all()
    n2 = read_table(tmp_path / "N2" / "spans.parquet")
    pd.testing.assert_frame_equal(n2, result.spans["N2"], check_dtype=False)
    schema = pq.read_schema(tmp_path / "N2" / "spans.parquet")
    assert schema.field("w5_m").metadata[b"unit"] == b"m"
    assert schema.field("outliers_removed").metadata[b"unit"] == b""
    meta = read_metadata(tmp_path / "N3" / "spans.parquet")
    assert meta["catenary.kind"] == "spans:N3" and meta["catenary.config_hash"] == "c0ffee"
    report = pd.read_csv(tmp_path / "spans_report.csv", keep_default_na=False)
    assert len(report) == 7 and list(report["status"]).count("rejected") == 1
    assert report.loc[0, "reason"].startswith("unknown span type 'N7'")
    first = (tmp_path / "N2" / "spans.parquet").read_bytes()
    write_projection(result, tmp_path, config_hash="c0ffee")
    assert (tmp_path / "N2" / "spans.parquet").read_bytes() == first
    # A type without used spans still gets its (empty) table.
    empty = project(recording, masts.assign(span_type="N7"), catenary)
    write_projection(empty, tmp_path / "e", config_hash="c", span_types=["N2"])
    assert read_table(tmp_path / "e" / "N2" / "spans.parquet").shape == (0, len(spans_columns(9)))


# --------------------------------------------------------------------------------------------
# property: malformed tables never crash with anything but InputError, never lose a span
# --------------------------------------------------------------------------------------------

_BASE: dict = {}


def _base(catenary):
    if not _BASE:
        rec, masts, _, _ = synthetic_line(catenary, seed=5, layout=(("S1", ("N2", "N3")), ("S2", ("N3", "N2"))),
                                          step=0.2)
        rec["speed_kmh"] = 40.0
        masts["cw_height_m"] = 5.08
        _BASE.update(recording=rec, masts=masts)
    return _BASE["recording"].copy(), _BASE["masts"].copy()


JUNK = st.one_of(st.text(max_size=4), st.just("NaN"), st.just(""), st.none(), st.floats(allow_nan=True),
                 st.integers(-10, 10_000), st.just(np.inf), st.booleans())


@st.composite
def mutation(draw):
    kind = draw(st.sampled_from(["drop_col", "nan", "junk", "swap", "shuffle", "dup_row", "empty", "no_cols", "scale",
                                 "shift", "extra_col", "set_type", "drop_rows", "nan_run", "dup_id",
                                 "section"]))
    return kind, draw(st.integers(0, 10 ** 6)), draw(JUNK), draw(st.floats(-200, 200, allow_nan=False))


def _apply(df, mut, is_masts):
    kind, seed, junk, value = mut
    rng = np.random.default_rng(seed)
    n, cols = len(df), list(df.columns)
    if kind == "drop_col" and cols:
        return df.drop(columns=cols[rng.integers(len(cols))])
    if kind == "empty":
        return df.iloc[:0]
    if kind == "no_cols":
        return pd.DataFrame()
    if n == 0 or not cols:
        return df
    col = cols[rng.integers(len(cols))]
    i = int(rng.integers(n))
    df = df.copy()
    if kind == "nan":
        df[col] = df[col].astype(object)
        df.loc[rng.choice(n, size=min(n, 1 + int(rng.integers(3))), replace=False), col] = np.nan
    elif kind == "junk":
        df[col] = df[col].astype(object)
        df.loc[i, col] = junk
    elif kind == "swap":
        j = int(rng.integers(n))
        df.loc[[i, j], "chainage_m" if "chainage_m" in cols else col] = \
            df.loc[[j, i], "chainage_m" if "chainage_m" in cols else col].to_numpy()
    elif kind == "shuffle":
        order = np.arange(n)
        k = min(n, 2 + int(rng.integers(5)))
        picked = rng.choice(n, size=k, replace=False)
        order[np.sort(picked)] = picked
        df = df.iloc[order].reset_index(drop=True)
    elif kind == "dup_row":
        df = pd.concat([df.iloc[: i + 1], df.iloc[i:]], ignore_index=True)
    elif kind == "scale" and "chainage_m" in cols and not is_masts:
        df["height_m"] = pd.to_numeric(df.get("height_m"), errors="coerce") * 1000
    elif kind == "shift" and "chainage_m" in cols:
        c = pd.to_numeric(df["chainage_m"], errors="coerce")
        df["chainage_m"] = np.where(np.arange(n) >= i, c + value, c)
    elif kind == "extra_col":
        df["junk_col"] = junk
    elif kind == "set_type" and is_masts:
        df["span_type"] = df.get("span_type", pd.Series([None] * n)).astype(object)
        df.loc[i, "span_type"] = junk if rng.random() < 0.5 else rng.choice(["N7", "N2", "N3", None])
    elif kind == "drop_rows":
        df = df.drop(index=df.index[rng.choice(n, size=min(n, 1 + int(rng.integers(max(1, n // 3)))),
                                               replace=False)]).reset_index(drop=True)
    elif kind == "nan_run" and "height_m" in cols:
        df["height_m"] = df["height_m"].astype(object)
        df.loc[i:i + int(rng.integers(1, 80)), "height_m"] = np.nan
    elif kind == "dup_id" and "mast_id" in cols:
        df.loc[i, "mast_id"] = df["mast_id"].iloc[int(rng.integers(n))]
    elif kind == "section" and "section_id" in cols:
        df["section_id"] = df["section_id"].astype(object)
        df.loc[i, "section_id"] = junk if junk is not None else "S3"
    return df


# derandomize: CI runs the same 100 examples every time (a failure reproduces; the run never
# depends on a local example database).
@settings(max_examples=100, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(rec_muts=st.lists(mutation(), max_size=3), mast_muts=st.lists(mutation(), max_size=3),
       via=st.sampled_from(["frames", "csv", "parquet"]))
def test_malformed_tables_never_crash_or_lose_a_span(catenary, rec_muts, mast_muts, via):
    recording, masts = _base(catenary)
    for m in rec_muts:
        recording = _apply(recording, m, is_masts=False)
    for m in mast_muts:
        masts = _apply(masts, m, is_masts=True)
    try:
        if via == "frames":
            result = project(recording, masts, catenary)
            masts_in = masts
        else:
            with tempfile.TemporaryDirectory() as tmp:
                paths = []
                for name, df in (("recording", recording), ("masts", masts)):
                    path = Path(tmp) / f"{name}.{via}"
                    if via == "csv":
                        df.to_csv(path, index=False)
                    else:
                        try:
                            df.to_parquet(path)
                        except Exception:  # pandas/pyarrow cannot store this mix: not our concern
                            df.astype(str).to_parquet(path)
                    paths.append(path)
                masts_in = read_masts(paths[1])
                result = project(read_recording(paths[0]), masts_in, catenary)
    except InputError as exc:
        assert str(exc)
        return
    assert_reconciles(result, masts_in)


def test_a_robust_fit_that_cannot_settle_rejects_its_span(catenary):
    # A 2 cm/m ramp with a 1.5 cm spike at the point: the first screen (distance to the window
    # median, scale ≈ 1.5 cm) keeps the spike, the first fit drops it, so the inlier set changes
    # at pass 1 and settles at pass 2. Capped at one pass, the fit has not settled: the height is
    # not a converged robust estimate and must say so.
    x = np.linspace(-1.0, 1.0, 21)
    h = 5.08 + 0.02 * x
    h[10] += 0.015
    settled = robust_local_fit(x, h, 0.0, ProjectionSettings())
    assert settled.settled and settled.n_outliers == 1
    assert settled.height_m == pytest.approx(5.08, abs=1e-12)
    capped = robust_local_fit(x, h, 0.0, ProjectionSettings(max_iterations=1))
    assert not capped.settled
    # Through the projection: spans whose fits did not settle are rejected with that reason, and
    # every span is still accounted for.
    recording, masts, _, _ = synthetic_line(catenary, seed=1)
    x = recording["chainage_m"].to_numpy()
    for mast in masts["chainage_m"]:
        at = np.flatnonzero(np.abs(x - mast) < 1.0)
        recording.loc[at, "height_m"] += 0.02 * (x[at] - mast)       # a ramp through each mast window
        recording.loc[at[len(at) // 2], "height_m"] += 0.015            # and a spike on it
    result = project(recording, masts, catenary, ProjectionSettings(max_iterations=1))
    assert_reconciles(result, masts)
    reasons = result.report.loc[result.report["status"] == "rejected", "reason"]
    assert len(reasons) > 0 and reasons.str.contains("did not settle in 1 reweighting passes").all()
    # (the ramps bend every mast's window, which the check of the cuts rightly questions: off here)
    assert project(recording, masts, catenary, ProjectionSettings(check_cuts=False)).n_rejected == 0
