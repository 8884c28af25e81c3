"""The cluster test's own checks (tests/cluster/): they must fail when what they look for is absent."""

import importlib.util
import re

import numpy as np
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


def test_slurm_profile_covers_every_measured_job_of_the_default_run_and_a_long_line():
    # workflow/profiles/slurm/measured.csv: each job's peak RSS, wall time and input size, of the
    # default run and of a 10 000-span line (benchmarks/cluster_resources.py --write); each
    # job's request, evaluated at its own inputs' size as Snakemake would, must cover it with the
    # profile's margins (memory 1.5 ×, time 3 ×), or the job would be killed on a cluster like this
    resources = cluster_resources
    measured = pd.read_csv(resources.MEASURED)
    assert {"correct_section", "identify", "diagnose", "contact_force_batch", "register"} <= set(measured["rule"])
    assert measured["run"].nunique() >= 2 and measured["run"].str.contains("line_10000").any()
    assert measured["input_size_mb"].notna().all()
    _, short = resources.table(measured, resources.requests())
    assert short == []
    # the rules whose memory grows with the line ask for more on a longer one
    asked = resources.requests()
    assert isinstance(asked["diagnose"]["mem_mb"], str) and isinstance(asked["ingest"]["mem_mb"], str)
    assert resources.evaluate(asked["ingest"]["mem_mb"], 10_000.0) > resources.evaluate(asked["ingest"]["mem_mb"], 1.0)


def test_a_scaled_request_covers_each_job_and_grows_with_its_inputs():
    # Jobs whose peak grows with their inputs (a + b · size and a scatter): the fitted request,
    # at each job's own size, covers 1.5 × its peak, and grows beyond the largest measured size;
    # a rule whose peak does not grow gets a plain number, 1.5 × its largest, at least the floor.
    resources = cluster_resources
    rng = np.random.default_rng(3)
    size = np.array([0.2, 0.3, 2.0, 20.0, 180.0, 200.0])
    peak = 300.0 + 40.0 * size + rng.normal(0.0, 30.0, size.size)
    request = resources.scaled(size, peak, resources.MEMORY_MARGIN, 1000)
    assert isinstance(request, str)
    got = np.array([resources.evaluate(request, x) for x in size])
    assert np.all(got >= resources.MEMORY_MARGIN * peak) and np.all(got >= 1000)
    assert resources.evaluate(request, 2000.0) > resources.evaluate(request, 200.0)
    flat = resources.scaled(size, np.full(size.size, 700.0), resources.MEMORY_MARGIN, 1000)
    assert flat == 1050
    assert resources.scaled(size, np.full(size.size, 300.0), resources.MEMORY_MARGIN, 1000) == 1000


def test_the_coverage_check_fails_on_a_short_request_and_an_expression_snakemake_cannot_read():
    # A job of 5 GB against the 1 GB default is reported; an expression naming `math` is passed on
    # by Snakemake as a string (its eval sees no `math`): refused rather than submitted.
    resources = cluster_resources
    measured = pd.DataFrame({"rule": ["diagnose"], "job": ["diagnose/N2"], "input_size_mb": [10.0],
                             "rss_mb": [5000.0], "pss_mb": [5000.0], "wall_s": [60.0]})
    default = {"mem_mb": 1000, "runtime": 10, "cpus_per_task": 1}
    _, short = resources.table(measured, {"*": default})
    assert len(short) == 1 and short[0].startswith("diagnose (diagnose/N2): mem_mb 1000")
    with pytest.raises(ValueError, match="not a number"):
        resources.evaluate("max(1000, math.ceil(2.0 * input.size_mb))", 10.0)
    assert resources.evaluate("max(1000, int(2.0 * input.size_mb) + 1)", 1000.0) == 2001


def test_slurm_cpus_follow_each_rules_threads():
    # cpus_per_task must equal the rule's `threads` (Snakemake sets the BLAS threads to `threads`;
    # project, invert, identify, diagnose, maintenance and maintenance_repair reset them to 1 in
    # each of their `threads` processes)
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
