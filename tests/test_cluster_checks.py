"""The cluster test's own checks (tests/cluster/): they must fail when what they look for is absent."""

import importlib.util
import re

import pandas as pd
import pytest

from .conftest import ROOT


def _load(relative_path):
    """A script of the repository (not a package module) imported by its path."""
    path = ROOT / relative_path
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


check_failure = _load("tests/cluster/check_failure.py")
compare = _load("tests/cluster/compare.py")
cluster_resources = _load("benchmarks/cluster_resources.py")


def _snakemake_error(results, section, slurm_log, rule="correct_section"):
    log = results / "logs" / rule / f"{section}.log" if section else results / "logs" / f"{rule}.log"
    return (f"[Mon Nov 23 21:28:02 2026]\n"
            f"Error in rule {rule}:\n"
            f"    message: SLURM-job '11' failed, SLURM status is: 'FAILED'.\n"
            f"    jobid: 8\n"
            f"    output: {results}/correction/sections/{section}.parquet\n"
            f"    log: {log}, {slurm_log} (check log file(s) for error details)\n"
            f"    external_jobid: 11\n"
            f"Shutting down, this might take some time.\n")


@pytest.fixture
def failed_run(tmp_path):
    results = tmp_path / "results"
    (results / "logs" / "correct_section").mkdir(parents=True)
    slurm_log = tmp_path / "slurm_logs" / "rule_correct_section" / "C02" / "11.log"
    slurm_log.parent.mkdir(parents=True)
    slurm_log.write_text("WorkflowError\n")
    (results / "logs" / "correct_section" / "C02.log").write_text(
        "ERROR catenary.correct_section: ConfigError: /tmp/x/bad_pantographs.yaml:measuring.masses_kg: "
        "expected values ≥ 0, got [7.5, -9.0, 6.0]\n")
    return results, slurm_log


def test_failure_check_accepts_a_complete_message(failed_run):
    results, slurm_log = failed_run
    assert check_failure.check(_snakemake_error(results, "C02", slurm_log), results, "correct_section") == []


def test_failure_check_of_a_job_without_wildcard(tmp_path):
    # the registration, one job for the line: its log is logs/register.log, no section to name
    results = tmp_path / "results"
    (results / "logs").mkdir(parents=True)
    slurm_log = tmp_path / "slurm_logs" / "rule_register" / "4.log"
    slurm_log.parent.mkdir(parents=True)
    slurm_log.write_text("WorkflowError\n")
    (results / "logs" / "register.log").write_text(
        "ERROR catenary.register: ConfigError: /tmp/x/bad_pantographs.yaml:measuring.masses_kg: "
        "expected values ≥ 0, got [7.5, -9.0, 6.0]\n")
    output = _snakemake_error(results, None, slurm_log, rule="register")
    assert check_failure.check(output, results) == []
    problems = check_failure.check(output, results, "correct_section")
    assert problems == ["expected the failing rule correct_section, got: Error in rule register:"]


def test_failure_check_wants_the_reason_in_the_rule_log(failed_run):
    results, slurm_log = failed_run
    (results / "logs" / "correct_section" / "C02.log").write_text("")      # the 0-byte log of issue [8]
    problems = check_failure.check(_snakemake_error(results, "C02", slurm_log), results, "correct_section")
    assert len(problems) == 1 and "expected the reason" in problems[0]


def test_failure_check_wants_the_slurm_log_and_an_error_block(failed_run):
    results, slurm_log = failed_run
    slurm_log.unlink()
    assert "SLURM log is missing" in check_failure.check(_snakemake_error(results, "C02", slurm_log), results, "correct_section")[0]
    assert check_failure.check("Nothing to be done.\n", results) == ["no 'Error in rule' block in Snakemake's output"]


def test_compare_tells_metadata_from_values_and_masks_only_report_times(tmp_path, capsys):
    frame = pd.DataFrame({"w1_m": [0.01, 0.02]})
    for name, value, seconds in (("a", "1", "61.4"), ("b", "2", "99.4")):
        (tmp_path / name / "logs").mkdir(parents=True)
        table = frame.copy()
        table.attrs["hash"] = value                       # pandas keeps attrs in the file metadata
        table.to_parquet(tmp_path / name / "t.parquet")
        (tmp_path / name / "r.md").write_text(f"18316 J evaluations, {seconds} s.\n")
        (tmp_path / name / "logs" / "x.log").write_text(value)          # logs are not compared
    (tmp_path / "c").mkdir()
    (tmp_path / "c" / "r.md").write_text("18316 J evaluations, 61.4 s, 3 spans.\n")
    assert compare.compare(tmp_path / "a", tmp_path / "a", ["t.parquet"])
    assert compare.compare(tmp_path / "a", tmp_path / "b", ["r.md"]) is False      # the Parquet metadata
    assert not compare.compare(tmp_path / "a", tmp_path / "c", ["missing.csv"])   # not only times differ
    out = capsys.readouterr().out
    assert "identical r.md" in out and "same values, metadata keys differ" in out
    assert "MISSING   missing.csv" in out and "DIFFERENT r.md" in out


def test_slurm_profile_covers_the_measured_default_run():
    # workflow/profiles/slurm/measured.csv: peak RSS and longest wall time per rule of the default
    # run (benchmarks/cluster_resources.py --write); each request must cover them with the profile's
    # stated margins (memory 1.5 ×, time 3 ×), or a job would be killed on a cluster like this one
    resources = cluster_resources
    measured = pd.read_csv(resources.MEASURED)
    assert {"correct_section", "identify", "diagnose", "contact_force_batch", "campaign_section"} <= set(measured["rule"])
    _, short = resources.table(measured, resources.requests())
    assert short == []


def test_slurm_cpus_follow_each_rules_threads():
    # cpus_per_task must equal the rule's `threads` (Snakemake sets the BLAS threads to `threads`;
    # project, identify, diagnose and maintenance reset them to 1 in each of their `threads` processes)
    threads = {}
    for smk in (ROOT / "workflow" / "rules").glob("*.smk"):
        for block in re.split(r"^(?=rule |checkpoint )", smk.read_text(), flags=re.MULTILINE)[1:]:
            name = re.match(r"(?:rule|checkpoint) (\w+):", block).group(1)
            found = re.search(r"^    threads: (\d+)", block, flags=re.MULTILINE)
            threads[name] = int(found.group(1)) if found else 1
    asked = cluster_resources.requests()
    assert threads["diagnose"] == threads["maintenance"] == threads["project"] == 2
    for rule, n in threads.items():
        assert asked.get(rule, asked["*"])["cpus_per_task"] == n, rule
