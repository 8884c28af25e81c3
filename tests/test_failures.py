"""The users' failures of issue [8], each reproduced through Snakemake as a user meets it.

Every case starts from the shipped hand-made example (data/example: 16 N2 spans of one section)
broken in one way, runs the workflow's real rules on it, and asserts what the user reads: the
terminal's message names the file, the column or row and what was expected, with no traceback,
and the failing rule's log file holds the same line (a 0-byte log was the reported defect). The
one success (a semicolon, decimal-comma export) is read to the same Parquet as the comma file.
"""

from __future__ import annotations

import os
import signal
import subprocess
import time

import numpy as np
import pandas as pd
import pytest

from .conftest import ROOT, workflow_dir

EXAMPLE = ROOT / "data" / "example"


#: config/example.yaml's settings for the hand-made example (a table in the recording's own
#: chainage, a trace without dropper kinks: no registration, no height check of the cuts).
EXAMPLE_SETTINGS = "registration:\n  enabled: false\nprojection:\n  check_cuts: false\n"


def _snakemake(tmp_path, recording, masts, target: str, extra: str = EXAMPLE_SETTINGS) -> subprocess.CompletedProcess:
    """Run the workflow on ``recording`` and ``masts`` into tmp_path/results up to ``target`` (a
    path under that folder), with the small profile's settings and ``extra`` (default: the
    example's own settings)."""
    results = tmp_path / "results"
    own = tmp_path / "own.yaml"
    own.write_text(f"recording: {recording}\nmasts: {masts}\nresults: {results}\nspan_types: [N2, N3]\n{extra}")
    binary = ROOT / ".venv" / "bin" / "snakemake"
    return subprocess.run([str(binary) if binary.exists() else "snakemake", "--workflow-profile",
                           "workflow/profiles/default", "--cores", "2", "--configfile", "config/test.yaml", str(own),
                           "--", str(results / target)], cwd=workflow_dir(tmp_path), capture_output=True, text=True)


def _assert_clear_failure(run: subprocess.CompletedProcess, log, *fragments: str) -> None:
    """Non-zero exit; every fragment in the terminal's output and in the rule's log; no traceback
    anywhere; the log's error is one line."""
    assert run.returncode != 0, run.stderr[-2000:]
    for fragment in fragments:
        assert fragment in run.stderr, (fragment, run.stderr[-3000:])
    assert "Traceback" not in run.stderr, run.stderr[-3000:]
    text = log.read_text()
    assert text.strip(), f"{log} is empty"
    errors = [line for line in text.splitlines() if " ERROR " in line]
    assert len(errors) == 1 and all(f in errors[0] for f in fragments), text
    assert "Traceback" not in text


@pytest.fixture(scope="module")
def recording() -> pd.DataFrame:
    return pd.read_csv(EXAMPLE / "recording.csv")


def test_a_missing_column_is_named_in_the_terminal_and_the_ingest_log(tmp_path, recording):
    path = tmp_path / "recording.csv"
    recording.rename(columns={"height_m": "height"}).to_csv(path, index=False)
    run = _snakemake(tmp_path, path, EXAMPLE / "masts.csv", "ingest/recording.parquet")
    _assert_clear_failure(run, tmp_path / "results" / "logs" / "ingest.log", str(path), "height_m")


def test_runs_interleaved_in_one_file_are_refused_naming_run_id(tmp_path, recording):
    # several runs in one file are read (a run_id column), each run's rows consecutive; a run
    # that starts again after another is a sorting error, refused with the row
    path = tmp_path / "recording.csv"
    half = len(recording) // 2
    pd.concat([recording.iloc[:half].assign(run_id="A"), recording.assign(run_id="B"),
               recording.iloc[half:].assign(run_id="A")]).to_csv(path, index=False)
    run = _snakemake(tmp_path, path, EXAMPLE / "masts.csv", "ingest/recording.parquet")
    _assert_clear_failure(run, tmp_path / "results" / "logs" / "ingest.log", str(path), "run_id", "appears again")


REGISTERED = "registration:\n  enabled: true\n  mast_table_std_m: 0.2\n"


def test_a_trace_without_usable_supports_is_refused_with_its_section(tmp_path, recording):
    # A height trace with no sag and no kinks (a flat wire under noise): the registration finds
    # no support, refuses the section with its reason, and the projection, left with no span,
    # stops naming that reason; the registration's log holds it too.
    path = tmp_path / "recording.csv"
    rng = np.random.default_rng(5)
    flat = recording.assign(height_m=np.round(5.08 + rng.normal(0.0, 0.001, len(recording)), 3))
    flat.to_csv(path, index=False)
    run = _snakemake(tmp_path, path, EXAMPLE / "masts.csv", "spans_report.csv", REGISTERED)
    _assert_clear_failure(run, tmp_path / "results" / "logs" / "project.log", "the projection kept 0 of 16",
                          "section E01, run recording: registration failed")
    sections = pd.read_csv(tmp_path / "results" / "registration" / "sections.csv")
    assert list(sections["status"]) == ["refused"]
    assert "registration failed" in (tmp_path / "results" / "logs" / "register.log").read_text()


def test_a_mast_table_from_another_line_is_refused_with_its_section(tmp_path):
    # The masts of another line over the same chainages: 54 m N3 spans where the trace has its
    # supports every 58.5 m. No common offset and scale (within max_scale_error) puts half of
    # them on the trace's supports: the section is refused, every span rejected with the reason.
    masts = pd.DataFrame({"mast_id": [f"X{k:02d}" for k in range(18)], "chainage_m": 104250.0 + 54.0 * np.arange(18),
                          "section_id": "X01", "span_type": ["N3"] * 17 + [""]})
    path = tmp_path / "masts.csv"
    masts.to_csv(path, index=False)
    run = _snakemake(tmp_path, EXAMPLE / "recording.csv", path, "spans_report.csv", REGISTERED)
    _assert_clear_failure(run, tmp_path / "results" / "logs" / "project.log", "the projection kept 0 of 17",
                          "section X01, run recording: registration failed")


def test_a_semicolon_export_with_decimal_commas_is_read_as_the_comma_file(tmp_path, recording):
    path = tmp_path / "recording.csv"
    recording.to_csv(path, index=False, sep=";", decimal=",")
    assert "," in path.read_text().splitlines()[1]                # decimal commas really written
    run = _snakemake(tmp_path, path, EXAMPLE / "masts.csv", "ingest/recording.parquet")
    assert run.returncode == 0, run.stderr[-3000:]
    read = pd.read_parquet(tmp_path / "results" / "ingest" / "recording.parquet")
    # exact: the same decimal strings are parsed, only the separators differ (drop-outs stay NaN)
    for column in ("chainage_m", "height_m", "speed_kmh"):
        np.testing.assert_array_equal(read[column].to_numpy(), recording[column].to_numpy())


def test_an_empty_projection_stops_at_the_projection_with_its_reason(tmp_path):
    masts = pd.read_csv(EXAMPLE / "masts.csv", dtype=str)
    masts["chainage_m"] = (masts["chainage_m"].astype(float) + 50_000.0).map("{:.2f}".format)   # 50 km away
    path = tmp_path / "masts.csv"
    masts.to_csv(path, index=False)
    run = _snakemake(tmp_path, EXAMPLE / "recording.csv", path, "spans_report.csv")
    _assert_clear_failure(run, tmp_path / "results" / "logs" / "project.log", str(path),
                          "the projection kept 0 of", "covers the masts' chainages")
    assert not (tmp_path / "results" / "spans_report.csv").exists()


def test_too_few_spans_for_the_identified_parameters_are_refused(tmp_path):
    # 5 masts: 4 N2 spans for the 13 parameters of the default identification (9 dropper σ,
    # μ and σ of T_MW and ΔH). The correction of 4 spans runs first (≈ 20 s).
    path = tmp_path / "masts.csv"
    pd.read_csv(EXAMPLE / "masts.csv", dtype=str).head(5).to_csv(path, index=False)
    run = _snakemake(tmp_path, EXAMPLE / "recording.csv", path, "N2/identification/s_opt.csv")
    _assert_clear_failure(run, tmp_path / "results" / "logs" / "identify" / "N2.log",
                          "span type N2: 4 measured span(s) for 13 identified parameters", "expected at least 13")


def test_a_config_error_is_at_most_five_lines_naming_the_file_and_key(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("identification:\n  n_samples: -5\n")
    binary = ROOT / ".venv" / "bin" / "snakemake"
    run = subprocess.run([str(binary) if binary.exists() else "snakemake", "--workflow-profile",
                          "workflow/profiles/default", "--dry-run", "--configfile", "config/test.yaml", str(bad)],
                         cwd=ROOT, capture_output=True, text=True)
    terminal = run.stdout + run.stderr                             # all the user sees
    assert run.returncode != 0
    assert len(terminal.strip().splitlines()) <= 5, terminal
    assert str(bad) in terminal and "identification.n_samples" in terminal and "≥ 16" in terminal


def test_a_run_killed_mid_job_is_resumed_by_the_next_run(tmp_path):
    # A run killed hard (SIGKILL to its process group: a closed terminal, a second Ctrl-C, a power
    # loss) while the correction writes its output leaves the directory locked and the output
    # marked incomplete. The lock is Snakemake's guard against two runs at once: the next run's
    # message says how to lift it (the README's `make unlock`). Then the run with the profile every
    # make target uses (rerun-incomplete) simply does the job again (≈ 10 s here). (Snakemake
    # 9.27 reran this job even without the flag: the IncompleteFilesException of the report did
    # not reproduce, so the test does not assert it.) The run has its own working directory (its
    # own .snakemake and locks: :func:`tests.conftest.workflow_dir`), with links to the project's files.
    where = workflow_dir(tmp_path)
    results = tmp_path / "results"
    own = tmp_path / "own.yaml"
    # the model-error budget (4 more corrections of the section, ≈ 30 s) is not what is resumed
    own.write_text(f"recording: {EXAMPLE / 'recording.csv'}\nmasts: {EXAMPLE / 'masts.csv'}\nresults: {results}\n"
                   + EXAMPLE_SETTINGS + "model_error:\n  enabled: false\n")
    binary = ROOT / ".venv" / "bin" / "snakemake"
    command = [str(binary) if binary.exists() else "snakemake", "--cores", "2", "--configfile", "config/test.yaml",
               str(own)]
    profile = ["--workflow-profile", "workflow/profiles/default"]
    target = str(results / "N2" / "corrected.parquet")

    def snakemake(*arguments):
        return subprocess.run(command + list(arguments), cwd=where, capture_output=True, text=True)

    run = subprocess.Popen(command + profile + ["--", target], cwd=where, stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL, start_new_session=True)
    log = results / "logs" / "correct_section" / "E01.log"
    deadline = time.monotonic() + 120.0
    while not (log.exists() and log.stat().st_size) and time.monotonic() < deadline and run.poll() is None:
        time.sleep(0.2)
    assert run.poll() is None, "the run ended before the correction started"
    os.killpg(run.pid, signal.SIGKILL)
    run.wait()
    # what a writer killed mid-file leaves (the job writes its Parquet at its end: the kill cannot
    # be timed into the write itself)
    (results / "correction" / "sections").mkdir(parents=True, exist_ok=True)
    (results / "correction" / "sections" / "E01.parquet").write_bytes(b"PAR1")

    locked = snakemake(*profile, "--", target)
    assert locked.returncode != 0 and "--unlock" in locked.stderr, locked.stderr[-2000:]
    assert snakemake("--unlock").returncode == 0
    resumed = snakemake(*profile, "--", target)
    assert resumed.returncode == 0, resumed.stderr[-3000:]
    assert "rule correct_section" in resumed.stderr
    assert len(pd.read_parquet(target)) == 15                            # the job finished: 15 spans used
