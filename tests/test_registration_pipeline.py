"""make test's small end-to-end version of the recording campaigns r_stagger, r_no_table and
r_table (make validate): a car's odometer 0.3 % long and 7 m ahead, a mast table that misses a
mast, lists one that is not there and places the others within ±0.3 m — or no table at all;
the stagger recorded, or the height alone. Through the rules (campaign → ingest → register →
project → the checks against the truth), every span kept must be its true span and its W as
close to the truth as the sensor allows."""

from __future__ import annotations

import subprocess

import numpy as np
import pandas as pd
import pytest
import yaml

from catenary.measurement.recording import run_samples, validate_masts
from catenary.measurement.registration import RegistrationSettings, masts_from_trace, register_run
from catenary.physics.config import load_catenary
from catenary.physics.pantograph import load_pantographs
from catenary.stages.correction import CorrectionSettings
from catenary.stages.correction.lag import measuring_lag

from .conftest import ROOT, workflow_dir

CAMPAIGN = ROOT / "tests" / "fixtures" / "r_small_campaign.yaml"
#: r_table (make validate): the height alone, two sections of 20 N2 and 20 N3 spans.
R_TABLE = ROOT / "config" / "validation" / "r_table_campaign.yaml"


def _run(tmp_path, table: bool, campaign=CAMPAIGN, span_types: str = "[N2]") -> subprocess.CompletedProcess:
    results = tmp_path / "results"
    overlay = tmp_path / "overlay.yaml"
    masts = f"{results}/campaign/masts.csv" if table else "null"
    overlay.write_text(f"results: {results}\ncampaign: {campaign}\nrecording: {results}/campaign/recording.parquet\n"
                       f"masts: {masts}\nspan_types: {span_types}\nregistration:\n  mast_table_std_m: 0.2\n")
    binary = ROOT / ".venv" / "bin" / "snakemake"
    return subprocess.run([str(binary) if binary.exists() else "snakemake", "--workflow-profile",
                           "workflow/profiles/default", "--cores", "2", "--configfile", "config/test.yaml", str(overlay),
                           "--", str(results / "validation" / "registration_check.csv"),
                           str(results / "validation" / "projection_round_trip.csv")],
                          cwd=workflow_dir(tmp_path), capture_output=True, text=True)


@pytest.mark.parametrize("table", [True, False], ids=["mast_table", "no_table"])
def test_a_drifting_odometer_and_a_wrong_table_are_registered_to_the_true_spans(tmp_path, table):
    run = _run(tmp_path, table)
    assert run.returncode == 0, run.stderr[-3000:]
    validation = tmp_path / "results" / "validation"
    reg = pd.read_csv(validation / "registration_check.csv").iloc[0]
    trip = pd.read_csv(validation / "projection_round_trip.csv").set_index("span_type").loc["N2"]
    report = pd.read_csv(tmp_path / "results" / "spans_report.csv")
    if table:
        # Every true mast registered, the missing one found, the extra one dropped — this table's
        # extra mast sits in the missing one's gap, 27 m from it — and every span used; the
        # stagger's reversals place a mast to ≈ 0.05 m RMS (0.043 m measured, 0.098 m before the
        # height's and the table's errors were weighed by their residuals' mean square; r_stagger
        # 0.075 m over 42 masts, its section ends placed by the table alone): 0.15 m.
        assert reg["n_registered"] == reg["n_true_masts"] == 13
        assert reg["n_missing_found"] == reg["n_missing_planted"] == 1
        assert reg["n_extra_dropped"] == reg["n_extra_planted"] == 1
        assert reg["rms_error_m"] < 0.15
        assert trip["n_spans"] == 12
    else:
        # Without a table, every mast but the one at the recording's first sample (no trace
        # before it to show a stagger reversal): 12 of 13 found here, 41 of 42 on r_no_table, and
        # every span between two found masts used (11 here; r_no_table 39, the same 39 spans as
        # r_stagger with its table). Before, the first found support kept the coarse kink
        # signal's place (0.18 m off on r_no_table) and its span was rejected by the cut check,
        # whose stagger fit, one-sided at the kept samples' edge, put the reversal 2.6 m away: 10.
        assert reg["n_registered"] >= reg["n_true_masts"] - 2
        assert trip["n_spans"] >= 11
    # Every span kept is its true span (n_unmatched 0), each rejected one with its reason; W
    # within the sensor's accuracy of the truth's dynamic W (0.53–0.54 mm RMS measured, 0.47–0.49
    # on r_stagger; 1 mm is 2×).
    assert trip["n_unmatched"] == 0
    assert trip["rms_vs_dynamic_m"] < 1e-3
    rejected = report[report["status"] != "used"]
    assert all(isinstance(r, str) and r for r in rejected["reason"])


def test_the_height_alone_registers_a_drifting_odometer_and_a_wrong_table(tmp_path):
    # r_table itself (its recording takes ≈ 10 s): the car without a stagger sensor, the masts
    # placed from the height's dropper kinks. Each section is searched as a whole (the line of
    # offset and scale along which the masts' comb scores add up): every true mast registered,
    # the missing ones found, the extra one dropped, no span kept that is not its true span.
    # Before, the first section was refused (8 of its 21 masts' own best offsets agreed).
    run = _run(tmp_path, True, campaign=R_TABLE, span_types="[N2, N3]")
    assert run.returncode == 0, run.stderr[-3000:]
    validation = tmp_path / "results" / "validation"
    reg = pd.read_csv(validation / "registration_check.csv").iloc[0]
    trip = pd.read_csv(validation / "projection_round_trip.csv").set_index("span_type")
    sections = pd.read_csv(tmp_path / "results" / "registration" / "sections.csv")
    assert list(sections["status"]) == ["registered", "registered"]
    assert reg["n_registered"] == reg["n_true_masts"] == 42
    assert reg["n_missing_found"] == reg["n_missing_planted"] == 2
    assert reg["n_extra_dropped"] == reg["n_extra_planted"] == 1
    # The whole section's height, its spans and the table together place a mast to ≈ 0.14 m (0.143 m
    # RMS measured; 0.221 m mast by mast before, where the table's own error is 0.17 m and the
    # height's fits 0.2–0.3 m; the stagger's reversals 0.075 m): 0.25 m.
    assert reg["rms_error_m"] < 0.25
    assert (trip["n_unmatched"] == 0).all()
    # Every span used (40 of 40 measured; 39 when each mast was placed on its own, the first span
    # with its first mast placed by the table alone rejected as placed too loosely; 32 before the
    # height's fits stated their own error), within 1 mm RMS of the truth's dynamic W (0.479 /
    # 0.539 mm measured, against 0.469 / 0.466 mm with an exact table; 0.533 / 0.697 mm mast by
    # mast). The campaign's seeds are fixed: 2 spans of margin.
    assert trip["n_spans"].sum() >= 38
    assert (trip["rms_vs_dynamic_m"] < 1e-3).all()
    # The same trace against 8 more tables drawn like the campaign's (each mast within ±0.3 m,
    # 2 missing, 1 extra) and 4 kept to the metre (±1 m): both sections register every time,
    # every mast within 0.35 m of its true position — its own mast — and 0.2 m RMS over all
    # (measured 0.199 / 0.207 m at worst, 0.140 / 0.139 m RMS). Mast by mast, the first section
    # was refused for 6 of 12 such ±0.3 m tables with each mast's own best coarse offset required
    # to agree; the ±1 m tables' sections were refused for their residuals' RMS.
    catenary, settings, lag, samples, truth = _registration_inputs(tmp_path / "results")
    _register_against_random_tables(catenary, settings, lag, samples, truth, n_tables=8, half_width_m=0.3)
    _register_against_random_tables(catenary, settings, lag, samples, truth, n_tables=4, half_width_m=1.0)
    # No table at all: each stretch's chain of spans found at once (catenary.measurement.registration.chain)
    # finds every one of the 42 masts and the type of every span, each mast within a metre of
    # the truth (0.50 / 0.73 m measured; the registration then places them: 0.25 m RMS through
    # the rules). Followed span by span, the height found 3.
    found = masts_from_trace(samples, catenary, settings, lag)
    assert len(found) == len(truth) == 42
    for (_, section), kind in zip(found.groupby("section_id"), ["N2", "N3"]):
        assert len(section) == 21 and set(section["span_type"].iloc[:-1]) == {kind}
    # The table found is in the run's chainage from its first support on, divided by the odometer
    # scale the spans' spacing gave: back in the recorded chainage with the scale that fits best,
    # every support within a metre of its true mast, the scale within 0.1 % of the planted 1.003.
    found_m = found["chainage_m"].to_numpy() - found["chainage_m"].iloc[0]
    recorded = np.sort(truth["recorded_m"].to_numpy())
    scale = float(found_m @ (recorded - found["chainage_m"].iloc[0]) / (found_m @ found_m))
    assert scale == pytest.approx(1.003, abs=0.001)
    assert np.max(np.abs(found["chainage_m"].iloc[0] + scale * found_m - recorded)) < 1.0


def _registration_inputs(results):
    config = yaml.safe_load((ROOT / "config" / "test.yaml").read_text())
    catenary = load_catenary(ROOT / config["catenary"])
    settings = RegistrationSettings.from_mapping({**config["registration"], "mast_table_std_m": 0.2})
    lag = measuring_lag(catenary, load_pantographs(ROOT / config["pantographs"]),
                        CorrectionSettings.from_mapping(config["correction"]))
    samples = run_samples(pd.read_parquet(results / "ingest" / "recording.parquet"), "R1")
    truth = pd.read_csv(results / "campaign" / "masts_truth.csv")
    truth = truth[truth["status"] != "extra_in_table"].reset_index(drop=True)
    odometer = yaml.safe_load(R_TABLE.read_text())["measurement"]["runs"][0]["odometer"]
    truth["recorded_m"] = odometer["offset_m"] + odometer["scale"] * truth["chainage_m"]     # the car's chainage
    return catenary, settings, lag, samples, truth


def _register_against_random_tables(catenary, settings, lag, samples, truth, n_tables: int,
                                    half_width_m: float) -> None:
    everywhere = np.sort(truth["recorded_m"].to_numpy())
    errors = []
    for seed in range(n_tables):
        rng = np.random.default_rng(seed)
        table = truth[["mast_id", "section_id", "chainage_m"]].assign(
            span_type=np.where(truth["section_id"] == "C01", "N2", "N3"))
        table["chainage_m"] += rng.uniform(-half_width_m, half_width_m, len(table))
        ends = np.r_[0, np.flatnonzero(np.diff(table["section_id"].factorize()[0])) + [0, 1], len(table) - 1]
        table.loc[ends[1::2], "span_type"] = ""                       # a section's last mast
        inner = np.setdiff1d(np.arange(len(table)), ends)
        dropped = rng.choice(inner, 2, replace=False)
        left = rng.choice(np.setdiff1d(inner, np.r_[dropped, dropped - 1, ends - 1]))
        extra = table.loc[[left]].assign(mast_id="X", chainage_m=table.loc[left, "chainage_m"] + rng.uniform(20.0, 35.0))
        table = pd.concat([table.drop(index=dropped), extra]).sort_values("chainage_m").reset_index(drop=True)
        run = register_run(samples, validate_masts(table, source=f"table {seed}"), catenary, settings, lag)
        assert list(run.sections["status"]) == ["registered"] * 2, (seed, run.sections["reason"].tolist())
        assert (run.masts["status"] == "extra_in_table").sum() == 1
        placed = run.masts.loc[run.masts["status"] != "extra_in_table", "recorded_chainage_m"].to_numpy()
        # each placed mast against the nearest true one (the inserted ones have no id of the truth)
        error = np.min(np.abs(placed[:, None] - everywhere[None, :]), axis=1)
        errors.append(error)
        assert error.max() < 0.35, (seed, half_width_m, error.max())
    errors = np.concatenate(errors)
    assert np.sqrt(np.mean(errors ** 2)) < 0.2
