"""Ingestion of recording and masts files and the Parquet intermediates."""

import hashlib

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import catenary
from catenary.plumbing.errors import InputError
from catenary.plumbing.parquet import config_hash, read_metadata, read_table, settings_hash, unit_of, write_table
from catenary.measurement.recording import (MASTS_SCHEMA, RECORDING_SCHEMA, read_masts, read_recording, read_recordings,
                                run_samples, runs_table, validate_masts, validate_recording, write_masts,
                                write_recording)


def recording_frame(n=200, step=0.1, start=100.0, height=5.08):
    x = start + step * np.arange(n)
    return pd.DataFrame({"chainage_m": np.round(x, 6), "height_m": height + 0.01 * np.sin(x / 7.0),
                         "speed_kmh": 40.0, "force_n": 36.0, "run_id": "R1"})


def masts_frame():
    return pd.DataFrame({"mast_id": ["A1", "A2", "A3", "B1", "B2"],
                         "chainage_m": [0.0, 58.5, 112.5, 130.0, 188.5],
                         "section_id": ["S1", "S1", "S1", "S2", "S2"],
                         "span_type": ["N2", "N3", None, "N2", None],
                         "cw_height_m": [5.08, 5.08, 5.08, 5.1, 5.1]})


def write_csv(df, path):
    df.to_csv(path, index=False)
    return path


# --------------------------------------------------------------------------------------------
# Parquet intermediates
# --------------------------------------------------------------------------------------------

def test_unit_from_column_suffix():
    assert [unit_of(c) for c in ("chainage_m", "force_n", "speed_kmh", "height_mm", "run_id",
                                 "stiffness_n_m", "w9_m", "outliers_removed")] == \
        ["m", "N", "km/h", "mm", "", "N/m", "m", ""]


def test_config_hash_is_canonical():
    a = config_hash({"b": [1, 2.5], "a": {"y": "s", "x": np.float64(1.0)}})
    b = config_hash({"a": {"x": 1.0, "y": "s"}, "b": (1, 2.5)})
    assert a == b and len(a) == 64
    assert config_hash({"a": 1}) != config_hash({"a": 2})


def test_settings_hash_ignores_only_the_results_folder():
    # a local run and a cluster run of the same settings into two folders write identical tables
    local = {"results": "results/ci", "recording": "r.parquet", "correction": {"tolerance_m": 0.001}}
    assert settings_hash(local) == settings_hash({**local, "results": "results/cluster"})
    assert settings_hash(local) != settings_hash({**local, "correction": {"tolerance_m": 0.002}})
    assert settings_hash(local) != settings_hash({**local, "recording": "other.parquet"})


def test_parquet_bytes_are_deterministic(tmp_path):
    df = validate_recording(recording_frame())
    df.loc[5, "height_m"] = np.nan
    p1, p2 = tmp_path / "a.parquet", tmp_path / "sub" / "b.parquet"
    write_table(df, p1, RECORDING_SCHEMA, config_hash="abc", kind="recording")
    write_table(df.copy(), p2, RECORDING_SCHEMA, config_hash="abc", kind="recording")
    assert hashlib.sha256(p1.read_bytes()).digest() == hashlib.sha256(p2.read_bytes()).digest()
    # ... and a different hash gives a different file (the metadata is really written).
    write_table(df, p2, RECORDING_SCHEMA, config_hash="abd", kind="recording")
    assert p1.read_bytes() != p2.read_bytes()


def test_parquet_schema_units_and_metadata(tmp_path):
    path = tmp_path / "rec.parquet"
    write_recording(recording_frame(), path, config_hash="h1")
    schema = pq.read_schema(path)
    assert schema.names == RECORDING_SCHEMA.names
    assert schema.field("chainage_m").metadata[b"unit"] == b"m"
    assert schema.field("speed_kmh").metadata[b"unit"] == b"km/h"
    assert schema.field("force_n").metadata[b"unit"] == b"N"
    assert schema.field("run_id").metadata[b"unit"] == b""
    assert schema.field("chainage_m").type == pa.float64() and not schema.field("chainage_m").nullable
    meta = read_metadata(path)
    assert meta["catenary.schema_version"] == "1"
    assert meta["catenary.package_version"] == catenary.__version__
    assert meta["catenary.config_hash"] == "h1"
    assert meta["catenary.kind"] == "recording"
    assert "pandas" not in meta


def test_write_table_refuses_a_frame_that_does_not_match(tmp_path):
    df = validate_recording(recording_frame()).drop(columns="force_n")
    with pytest.raises(ValueError, match="force_n"):
        write_table(df, tmp_path / "x.parquet", RECORDING_SCHEMA, config_hash="h", kind="recording")
    df = validate_recording(recording_frame())
    df.loc[3, "chainage_m"] = np.nan
    with pytest.raises(ValueError, match="chainage_m.*row 4"):
        write_table(df, tmp_path / "x.parquet", RECORDING_SCHEMA, config_hash="h", kind="recording")


def test_ingest_round_trip(tmp_path):
    rec, masts = recording_frame(), masts_frame()
    write_recording(rec, tmp_path / "recording.parquet", config_hash="h")
    write_masts(masts, tmp_path / "masts.parquet", config_hash="h")
    back = read_recording(tmp_path / "recording.parquet")
    pd.testing.assert_frame_equal(back, validate_recording(rec), check_dtype=False)
    mback = read_masts(tmp_path / "masts.parquet")
    assert mback["mast_id"].tolist() == masts["mast_id"].tolist()
    assert mback["span_type"].isna().tolist() == [False, False, True, False, True]
    assert read_metadata(tmp_path / "masts.parquet")["catenary.kind"] == "masts"
    assert pq.read_schema(tmp_path / "masts.parquet").names == MASTS_SCHEMA.names


def test_csv_and_parquet_inputs_agree(tmp_path):
    rec = recording_frame()
    rec.loc[[10, 11], "height_m"] = np.nan
    a = read_recording(write_csv(rec, tmp_path / "r.csv"))
    rec.to_parquet(tmp_path / "r.parquet")
    b = read_recording(tmp_path / "r.parquet")
    np.testing.assert_array_equal(a["chainage_m"], b["chainage_m"])
    np.testing.assert_allclose(a["height_m"], b["height_m"], equal_nan=True)
    assert a["height_m"].isna().sum() == 2
    assert list(a.columns) == RECORDING_SCHEMA.names


def test_optional_columns_absent_and_extra_columns_ignored(tmp_path):
    rec = recording_frame()[["chainage_m", "height_m"]].assign(temperature_c=20.0)
    out = read_recording(write_csv(rec, tmp_path / "r.csv"))
    assert list(out.columns) == RECORDING_SCHEMA.names
    assert out["speed_kmh"].isna().all() and out["stagger_m"].isna().all()
    # a file without run_id is one run, named after the file, in the direction of its rows
    assert (out["run_id"] == "r").all() and (out["direction"] == 1).all()
    assert out.attrs["ignored_columns"] == ["temperature_c"]
    masts = read_masts(write_csv(masts_frame()[["mast_id", "chainage_m", "section_id"]], tmp_path / "m.csv"))
    assert masts["span_type"].isna().all() and masts["cw_height_m"].isna().all()


def test_text_ids_keep_leading_zeros(tmp_path):
    m = masts_frame().assign(mast_id=["001", "002", "003", "004", "005"], section_id=["07", "07", "07", "08", "08"])
    out = read_masts(write_csv(m, tmp_path / "m.csv"))
    assert out["mast_id"].tolist()[0] == "001" and out["section_id"].tolist()[0] == "07"


def test_validation_is_idempotent():
    rec = validate_recording(recording_frame())
    pd.testing.assert_frame_equal(validate_recording(rec), rec)
    masts = validate_masts(masts_frame())
    pd.testing.assert_frame_equal(validate_masts(masts), masts)


# --------------------------------------------------------------------------------------------
# bad inputs: each names the file, the row and/or the column, and what was expected
# --------------------------------------------------------------------------------------------

def test_missing_column(tmp_path):
    path = write_csv(recording_frame().drop(columns="height_m"), tmp_path / "rec.csv")
    with pytest.raises(InputError, match=r"rec\.csv: missing required column\(s\) 'height_m'; expected columns "
                                         r"chainage_m, height_m .*found: chainage_m, speed_kmh"):
        read_recording(path)
    path = write_csv(masts_frame().drop(columns=["section_id", "mast_id"]), tmp_path / "masts.csv")
    with pytest.raises(InputError, match=r"masts\.csv: missing required column\(s\) 'mast_id', 'section_id'"):
        read_masts(path)


def test_heights_in_millimetres(tmp_path):
    rec = recording_frame()
    rec["height_m"] *= 1000.0
    path = write_csv(rec, tmp_path / "rec.csv")
    with pytest.raises(InputError, match=r"rec\.csv: column 'height_m': median 50\d\d.*heights look like "
                                         r"millimetres; expected metres \(3–8 m above rail\)"):
        read_recording(path)
    path = write_csv(recording_frame().rename(columns={"height_m": "height_mm"}), tmp_path / "rec2.csv")
    with pytest.raises(InputError, match=r"rec2\.csv: missing required column.*'height_m'.*millimetres"):
        read_recording(path)


def test_height_out_of_range_names_the_row(tmp_path):
    rec = recording_frame()
    rec.loc[6, "height_m"] = -1.0
    with pytest.raises(InputError, match=r"r\.csv: row 7 \(line 8\), column 'height_m': height -1 m is outside "
                                         r"\[0, 20\] m"):
        read_recording(write_csv(rec, tmp_path / "r.csv"))


def test_non_monotonic_chainage(tmp_path):
    rec = recording_frame()
    rec.loc[3, "chainage_m"] = rec.loc[2, "chainage_m"]
    path = write_csv(rec.drop(columns="run_id"), tmp_path / "rec.csv")
    with pytest.raises(InputError, match=r"rec\.csv: row 4 \(line 5\), column 'chainage_m': 100\.2 m is not "
                                         r"greater than the previous row's 100\.2 m in run 'rec', whose chainage "
                                         r"is increasing from row 1 \(line 2\); expected strictly increasing "
                                         r"chainage within a run .*needs a run_id column"):
        read_recording(path)
    # up then back down in one run: refused where it turns
    rec = recording_frame()
    turned = pd.concat([rec, rec.iloc[::-1].iloc[1:]], ignore_index=True)
    turned.to_parquet(tmp_path / "turn.parquet")
    with pytest.raises(InputError, match=r"turn\.parquet: row 201, column 'chainage_m': .* in run 'R1'"):
        read_recording(tmp_path / "turn.parquet")


def test_a_run_in_decreasing_chainage_is_a_run_towards_decreasing_chainage(tmp_path):
    rec = recording_frame()
    rec.iloc[::-1].to_parquet(tmp_path / "rev.parquet")
    out = read_recording(tmp_path / "rev.parquet")
    assert (out["direction"] == -1).all() and out["chainage_m"].iloc[0] > out["chainage_m"].iloc[-1]
    # a run sorted by chainage keeps its direction from the direction column; a contradiction is refused
    back = read_recording(write_csv(rec.assign(direction=-1), tmp_path / "sorted.csv"))
    assert (back["direction"] == -1).all()
    with pytest.raises(InputError, match=r"bad\.csv: column 'direction': run 'R1' .* declared \+1"):
        read_recording(write_csv(rec.iloc[::-1].assign(direction=1), tmp_path / "bad.csv"))
    with pytest.raises(InputError, match=r"odd\.csv: column 'direction' holds 2 in run 'R1'.*expected \+1"):
        read_recording(write_csv(rec.assign(direction=2), tmp_path / "odd.csv"))


def test_masts_chainage_must_increase_within_a_section(tmp_path):
    m = masts_frame()
    m.loc[2, "chainage_m"] = 50.0
    with pytest.raises(InputError, match=r"m\.csv: row 3 \(line 4\), column 'chainage_m': mast 'A3' at 50 m is "
                                         r"not after the previous mast 'A2' .*section 'S1'"):
        read_masts(write_csv(m, tmp_path / "m.csv"))


def test_missing_chainage_and_junk_in_a_numeric_column(tmp_path):
    rec = recording_frame()
    rec["chainage_m"] = rec["chainage_m"].astype(object)
    rec.loc[9, "chainage_m"] = "12,5"
    with pytest.raises(InputError, match=r"rec\.csv: row 10 \(line 11\), column 'chainage_m': expected a number "
                                         r"\(chainage along the line \[m\]\), got '12,5'"):
        read_recording(write_csv(rec, tmp_path / "rec.csv"))
    rec = recording_frame()
    rec.loc[0, "chainage_m"] = np.nan
    with pytest.raises(InputError, match=r"row 1 \(line 2\), column 'chainage_m': missing value"):
        read_recording(write_csv(rec, tmp_path / "rec.csv"))
    rec = recording_frame()
    rec.loc[4, "height_m"] = np.inf
    with pytest.raises(InputError, match=r"rec\.parquet: row 5, column 'height_m': expected a finite number"):
        rec.to_parquet(tmp_path / "rec.parquet")
        read_recording(tmp_path / "rec.parquet")


def test_all_heights_missing(tmp_path):
    rec = recording_frame().assign(height_m=np.nan)
    with pytest.raises(InputError, match=r"r\.csv: column 'height_m' holds no value"):
        read_recording(write_csv(rec, tmp_path / "r.csv"))


def test_sampling_too_coarse(tmp_path):
    with pytest.raises(InputError, match=r"r\.csv: column 'chainage_m': median sampling step 1 m in run 'R1'; expected at "
                                         r"most 0\.5 m"):
        read_recording(write_csv(recording_frame(step=1.0), tmp_path / "r.csv"))


def test_duplicate_mast_ids(tmp_path):
    m = masts_frame()
    m.loc[3, "mast_id"] = "A2"
    with pytest.raises(InputError, match=r"masts\.csv: column 'mast_id': id 'A2' appears 2 times, at row 2 "
                                         r"\(line 3\), row 4 \(line 5\); expected unique mast ids"):
        read_masts(write_csv(m, tmp_path / "masts.csv"))


def test_section_layout(tmp_path):
    m = masts_frame().drop(index=4)
    with pytest.raises(InputError, match=r"m\.csv: row 4 \(line 5\), column 'section_id': section 'S2' has only "
                                         r"1 mast; expected at least 2"):
        read_masts(write_csv(m, tmp_path / "m.csv"))
    m = masts_frame()
    m.loc[4, "section_id"] = "S1"
    with pytest.raises(InputError, match=r"row 5 \(line 6\), column 'section_id': section 'S1' appears again"):
        read_masts(write_csv(m, tmp_path / "m.csv"))
    m = masts_frame()
    m.loc[[3, 4], "chainage_m"] = [-100.0, -50.0]
    with pytest.raises(InputError, match=r"row 4 \(line 5\), column 'chainage_m': section 'S2' starts at -100 m, "
                                         r"before section 'S1'"):
        read_masts(write_csv(m, tmp_path / "m.csv"))
    m = masts_frame()
    m.loc[1, "section_id"] = None
    with pytest.raises(InputError, match=r"row 2 \(line 3\), column 'section_id': missing value"):
        read_masts(write_csv(m, tmp_path / "m.csv"))


def test_design_cw_height_in_millimetres(tmp_path):
    m = masts_frame()
    m["cw_height_m"] *= 1000
    with pytest.raises(InputError, match=r"m\.csv: column 'cw_height_m'.*millimetres"):
        read_masts(write_csv(m, tmp_path / "m.csv"))


@pytest.mark.parametrize("reader", [read_recording, read_masts])
def test_empty_files(tmp_path, reader):
    (tmp_path / "empty.csv").write_text("")
    with pytest.raises(InputError, match=r"empty\.csv: empty file; expected a header row"):
        reader(tmp_path / "empty.csv")
    (tmp_path / "header.csv").write_text("mast_id,chainage_m,section_id,height_m\n")
    with pytest.raises(InputError, match=r"header\.csv: no data rows"):
        reader(tmp_path / "header.csv")
    (tmp_path / "empty.parquet").write_bytes(b"")
    with pytest.raises(InputError, match=r"empty\.parquet: empty file"):
        reader(tmp_path / "empty.parquet")
    pd.DataFrame({"mast_id": pd.Series([], dtype=str), "chainage_m": pd.Series([], dtype=float),
                  "section_id": pd.Series([], dtype=str), "height_m": pd.Series([], dtype=float)}
                 ).to_parquet(tmp_path / "rows0.parquet")
    with pytest.raises(InputError, match=r"rows0\.parquet: no data rows"):
        reader(tmp_path / "rows0.parquet")
    with pytest.raises(InputError, match=r"masts: empty table"):
        validate_masts(pd.DataFrame())


def test_corrupt_parquet(tmp_path):
    good = tmp_path / "good.parquet"
    recording_frame().to_parquet(good)
    data = good.read_bytes()
    truncated = tmp_path / "recording.parquet"
    truncated.write_bytes(data[: len(data) // 2])
    with pytest.raises(InputError, match=r"recording\.parquet: not a readable Parquet file .*expected a Parquet file"):
        read_recording(truncated)
    text = tmp_path / "masts.parquet"
    text.write_text("mast_id,chainage_m\nA,0\n")
    with pytest.raises(InputError, match=r"masts\.parquet: not a readable Parquet file"):
        read_masts(text)
    # Garbled pages with an intact footer.
    garbled = bytearray(data)
    for i in range(8, len(data) // 3):
        garbled[i] ^= 0x5A
    bad = tmp_path / "garbled.parquet"
    bad.write_bytes(bytes(garbled))
    with pytest.raises(InputError, match=r"garbled\.parquet: .*Parquet"):
        read_table(bad)


def test_missing_file_and_unknown_extension(tmp_path):
    with pytest.raises(InputError, match=r"nope\.csv: file not found"):
        read_recording(tmp_path / "nope.csv")
    with pytest.raises(InputError, match=r"nope\.parquet: file not found"):
        read_masts(tmp_path / "nope.parquet")
    (tmp_path / "r.xlsx").write_text("x")
    with pytest.raises(InputError, match=r"r\.xlsx: unsupported file type '\.xlsx'; expected \.csv or \.parquet"):
        read_recording(tmp_path / "r.xlsx")


# --------------------------------------------------------------------------------------------
# what a user meets first (issue [8])
# --------------------------------------------------------------------------------------------

def test_semicolon_csv_with_decimal_commas_reads_as_the_comma_file(tmp_path):
    # The common European export: ';' separators, ',' decimal marks. Read to the same numbers.
    rec = recording_frame()
    reference = read_recording(write_csv(rec, tmp_path / "r.csv"))
    rec.to_csv(tmp_path / "eu.csv", index=False, sep=";", decimal=",")
    eu = read_recording(tmp_path / "eu.csv")
    pd.testing.assert_frame_equal(eu, reference, check_like=False, check_exact=True)


def test_one_column_header_with_other_separators_gets_a_hint(tmp_path):
    path = tmp_path / "tabs.csv"
    path.write_text("chainage_m\theight_m\n1.0\t5.08\n")         # tab-separated: not read, but said
    with pytest.raises(InputError, match=r"tabs\.csv: missing required column.*separators other than commas"):
        read_recording(path)


def test_several_runs_in_one_file_and_in_several_files(tmp_path):
    up = recording_frame().assign(run_id="up")
    down = recording_frame().iloc[::-1].assign(run_id="down", stagger_m=0.2)
    out = read_recording(write_csv(pd.concat([up, down], ignore_index=True), tmp_path / "two.csv"))
    runs = runs_table(out)
    assert runs["run_id"].tolist() == ["up", "down"] and runs["direction"].tolist() == [1, -1]
    assert runs["n_samples"].tolist() == [200, 200] and runs["has_stagger"].tolist() == [False, True]
    np.testing.assert_array_equal(run_samples(out, "down")["chainage_m"], up["chainage_m"])   # sorted by chainage
    # several files: one run each, named after the files; the same run id twice is refused
    a = write_csv(up.drop(columns="run_id"), tmp_path / "monday.csv")
    b = write_csv(down.drop(columns="run_id"), tmp_path / "tuesday.csv")
    both = read_recordings([a, b])
    assert runs_table(both)["run_id"].tolist() == ["monday", "tuesday"]
    assert both.attrs["runs"] == {"monday": str(a), "tuesday": str(b)}
    (tmp_path / "other").mkdir()
    twin = write_csv(up.drop(columns="run_id"), tmp_path / "other" / "monday.csv")
    with pytest.raises(InputError, match=r"other/monday\.csv: run 'monday' is also in .*monday\.csv; expected each "
                                         r"run id once"):
        read_recordings([a, twin])
    # a run's rows must be together
    split = pd.concat([up.iloc[:100], down, up.iloc[100:]], ignore_index=True)
    with pytest.raises(InputError, match=r"split\.csv: row 301 \(line 302\), column 'run_id': run 'up' appears "
                                         r"again after other runs"):
        read_recording(write_csv(split, tmp_path / "split.csv"))


def test_stagger_in_millimetres_is_refused(tmp_path):
    rec = recording_frame().assign(stagger_m=200.0)
    with pytest.raises(InputError, match=r"s\.csv: row 1 \(line 2\), column 'stagger_m': 200 m; expected .* "
                                         r"within ±1 m \(millimetres\?\)"):
        read_recording(write_csv(rec, tmp_path / "s.csv"))


def test_a_rule_script_error_is_one_line_in_its_log_and_no_traceback(tmp_path):
    # What a rule script does on bad input: rule_logger, then an InputError left uncaught.
    import subprocess
    import sys

    log = tmp_path / "rule.log"
    script = (f"from catenary.plumbing.logs import rule_logger\nfrom catenary.measurement.recording import read_recording\n"
              f"rule_logger('ingest', {str(log)!r})\nread_recording({str(tmp_path / 'absent.csv')!r})\n")
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert run.returncode == 1
    assert "Traceback" not in run.stderr
    lines = log.read_text().strip().splitlines()
    assert len(lines) == 1 and "InputError" in lines[0] and "absent.csv: file not found" in lines[0]
    # A bug (not a CatenaryError) keeps its traceback, in the log too.
    bug = subprocess.run([sys.executable, "-c", f"from catenary.plumbing.logs import rule_logger\n"
                          f"rule_logger('x', {str(log)!r})\n1 / 0\n"], capture_output=True, text=True)
    assert bug.returncode == 1 and "Traceback" in log.read_text() and "a bug" in log.read_text()
