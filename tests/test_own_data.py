"""The own-data command on the shipped hand-made example (issue [8]).

data/example/ holds a measuring run over one section of 16 N2 spans written by hand
(data/example/make_example.py), not by the campaign code: every column a recording car exports,
a spike, a drop-out the projection tolerates and one that rejects its span, a masts file whose
every fourth span type is left blank. `config/example.yaml` runs it with the default
`span_types: [N2, N3]`: the run must finish, write the identification and the diagnosis of N2,
start no job for N3 (a type the data do not hold) and account for every span. The test adds
config/test.yaml's smaller designs (the small profile's) and diagnoses one step over the three
candidates that matter on these spans, and leaves out the correction's model-error budget
(make test-pipeline's small profile runs it) and the profile intervals (16 of the
identification's 20 s; tests/test_identification_profile.py and the small profile check them),
so that it costs ≈ 40 s; the whole diagnosis of the example (9 candidates, 3 steps) names
nothing for sure: it finds the spans' smooth shapes
ambiguous between a T_MW spread and a ΔH–dropper correlation (adjusted p 5·10⁻⁷), which is
what a half-sine of σ 4 mm per span looks like to both.
It needs nothing but the repository, so make test runs it: the workflow end to end through the
rules, from a recording the campaign code did not write.
"""

import subprocess

import pandas as pd

from .conftest import ROOT, workflow_dir


def test_shipped_example_runs_the_measurement_pipeline_for_its_span_type(tmp_path):
    results = tmp_path / "results"
    own = tmp_path / "own.yaml"
    own.write_text((ROOT / "config" / "example.yaml").read_text().replace("results: results/example",
                                                                          f"results: {results}")
                   + "diagnosis:\n  max_steps: 1\n  bootstrap_replicates: 200\n  candidates: [messenger_tension_variability, "
                     "system_height_dropper_correlation, dropper_creep]\n"
                   + "model_error:\n  enabled: false\n"
                   + "identification:\n  profile_intervals:\n    parameters: []\n")
    snakemake = ROOT / ".venv" / "bin" / "snakemake"
    run = subprocess.run([str(snakemake) if snakemake.exists() else "snakemake",
                          "--workflow-profile", "workflow/profiles/default", "--cores", "2",
                          "--configfile", "config/test.yaml", str(own), "--report", str(results / "report.html"),
                          "--report-after-run", "--", "measurements"],
                         cwd=workflow_dir(tmp_path), capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-3000:]
    s_opt = pd.read_csv(results / "N2" / "identification" / "s_opt.csv")
    assert (s_opt["status"] == "ok").all()
    # the spans: 16 between 17 masts; the one under the 9 m drop-out is rejected with its reason
    report = pd.read_csv(results / "spans_report.csv")
    assert len(report) == 16 and (report["status"] == "used").sum() == 15
    rejected = report[report["status"] != "used"]
    assert rejected["reason"].str.contains("gap|samples", regex=True).all(), rejected.to_dict("records")
    corrected = pd.read_parquet(results / "N2" / "corrected.parquet")
    assert len(corrected) == 15
    assert corrected["converged"].all(), corrected[["span_id", "reason"]].to_dict("records")
    findings = pd.read_csv(results / "N2" / "diagnosis" / "findings.csv")
    assert set(findings["verdict"]) <= {"named", "ambiguous", "none_detected"}
    assert not (results / "N3" / "identification").exists()        # no job for a type without spans
    assert not (results / "N3" / "diagnosis").exists()
    assert not (results / "N2" / "contact_force").exists()          # the study is not part of own-data
    html_report = (results / "report.html").read_text()             # make own-data's report: N2's results
    assert f"{results}/N2/identification/band.png" in html_report
    assert f"{results}/report/tables/N2/diagnosis/findings.csv" in html_report   # in an engineer's units
    # the report's opening panel: own-data's, without the contact-force study it does not run
    front = (results / "report" / "front_page_measurements.rst").read_text()
    assert "\nN2\n~~" in front and "\nN3\n~~" not in front and "15 used, 1 rejected" in front
    assert "**Maintenance:**" in front and "Contact force (EN 50367):** not part of this run" in front
