"""The own-data command on a recording of N2 spans only (issue [8]).

A user's line rarely holds every span type of the config. The small profile's recording cut to
its N2 section (20 spans) goes through the `measurements` target with the default
`span_types: [N2, N3]`: the run must finish, write the identification and the diagnosis of N2,
and start no job for N3 (before, N3's identification failed on "0 measured span(s)").
Marker ``pipeline``: it reads the small profile's campaign files, so `make test` runs it after
the profile.
"""

import subprocess

import pandas as pd
import pytest

from .conftest import ROOT

pytestmark = pytest.mark.pipeline

CAMPAIGN = ROOT / "results" / "ci" / "campaign"


def test_n2_only_recording_runs_the_measurement_pipeline_for_n2_alone(tmp_path):
    if not (CAMPAIGN / "recording.parquet").exists():
        pytest.fail(f"{CAMPAIGN} is missing: run the small profile first (make test does)")
    masts = pd.read_csv(CAMPAIGN / "masts.csv", dtype={"mast_id": str, "section_id": str, "span_type": str})
    n2 = masts[masts["span_type"] == "N2"]
    recording = pd.read_parquet(CAMPAIGN / "recording.parquet")
    recording = recording[recording["chainage_m"] <= n2["chainage_m"].max() + 5.0]
    n2.to_csv(tmp_path / "masts.csv", index=False)
    recording.to_csv(tmp_path / "recording.csv", index=False)
    results = tmp_path / "results"
    own = tmp_path / "own.yaml"
    own.write_text(f"recording: {tmp_path / 'recording.csv'}\nmasts: {tmp_path / 'masts.csv'}\n"
                   f"results: {results}\nspan_types: [N2, N3]\n")
    snakemake = ROOT / ".venv" / "bin" / "snakemake"
    run = subprocess.run([str(snakemake) if snakemake.exists() else "snakemake", "--cores", "2",
                          "--configfile", "config/test.yaml", str(own), "--", "measurements"],
                         cwd=ROOT, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-3000:]
    s_opt = pd.read_csv(results / "N2" / "identification" / "s_opt.csv")
    assert (s_opt["status"] == "ok").all()
    assert (results / "N2" / "diagnosis" / "findings.csv").exists()
    assert not (results / "N3" / "identification").exists() and not (results / "N3" / "diagnosis").exists()
    report = pd.read_csv(results / "spans_report.csv")
    assert (report["status"] == "used").sum() == 20
    assert not (results / "N2" / "contact_force").exists()        # the study is not part of own-data
