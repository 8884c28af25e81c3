"""The default campaign shipped in data/default_campaign (catenary.measurement.shipped).

``make run`` copies it instead of simulating it while its manifest matches the configured
campaign, catenary and pantographs files. These tests hold the copy to what it claims: written
from today's files (fast), refused when a file moved (fast), and — the slow one — equal to what the
campaign's rules write today, so that a change of the code that moves the campaign cannot leave a
stale copy behind.
"""

from __future__ import annotations

import shutil
import subprocess

import pandas as pd
import pytest
import yaml

from catenary.measurement.shipped import FILES, SOURCES, copy_out, matches
from catenary.plumbing.errors import InputError
from catenary.plumbing.parquet import read_table

from .conftest import ROOT, workflow_dir

COPY = ROOT / "data" / "default_campaign"


def _sources() -> dict[str, str]:
    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    assert config["campaign_copy"] == "data/default_campaign"
    return {key: str(ROOT / config[key]) for key in SOURCES}


def test_the_copy_was_written_from_the_default_configuration():
    # Fails when config/campaign.yaml, catenary.yaml or pantographs.yaml changed without
    # `make default-data`: make run would then simulate the campaign (correct, but 85 s slower).
    usable, why = matches(COPY, _sources())
    assert usable, why


def test_a_copy_written_from_other_files_is_not_used(tmp_path):
    sources = _sources()
    edited = tmp_path / "campaign.yaml"
    edited.write_text(open(sources["campaign"]).read().replace("seed: 2014", "seed: 2015"))
    usable, why = matches(COPY, {**sources, "campaign": str(edited)})
    assert not usable and "campaign" in why and "simulated" in why
    assert not matches(None, sources)[0]
    assert not matches(tmp_path, sources)[0]          # an empty folder: files missing


def test_a_corrupted_file_of_the_copy_is_refused_by_name(tmp_path):
    copy = tmp_path / "copy"
    shutil.copytree(COPY, copy)
    with open(copy / "truth.parquet", "r+b") as f:      # truncated, as a failed checkout leaves it
        f.truncate(1000)
    with pytest.raises(InputError, match="truth.parquet: its SHA-256"):
        copy_out(copy, tmp_path / "campaign")
    (copy / "manifest.json").write_text('{"sources": ')      # a manifest cut short
    with pytest.raises(InputError, match="manifest.json: not a manifest"):
        matches(copy, _sources())


@pytest.mark.slow
def test_the_copy_is_what_the_campaign_rules_write_today(tmp_path):
    """Simulate the default campaign through its rules (42 s on 2 cores, alone) and compare every file
    of the copy with it: Parquet tables to 1e-12 (the same arithmetic on this machine gives the
    same bits; another BLAS may move the last bits, never a millimetre-quantised height by a
    quantum except at a rounding tie), CSV tables the same way."""
    results = tmp_path / "results"
    binary = ROOT / ".venv" / "bin" / "snakemake"
    run = subprocess.run([str(binary) if binary.exists() else "snakemake", "--workflow-profile",
                          "workflow/profiles/default", "--cores", "2", "--configfile", "config/config.yaml",
                          "--config", "campaign_copy=", f"results={results}", "--",
                          str(results / "campaign" / "recording.parquet")],
                         cwd=workflow_dir(tmp_path), capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-3000:]
    assert "campaign_section" in run.stderr           # simulated, not copied
    for name in FILES:
        read = read_table if name.endswith(".parquet") else pd.read_csv
        pd.testing.assert_frame_equal(read(COPY / name), read(results / "campaign" / name), check_exact=False,
                                      rtol=0.0, atol=1e-12, obj=f"{name} (rewrite the copy: make default-data)")
