"""Every machine-readable output keeps its name and its columns (issue [19] moved the package into
layers and changed what people read, never what programs read): the small profile's CSV and
Parquet files against their manifest from the tree before that change
(tests/fixtures/outputs/ci.json, written by ``python -m tests.outputs_manifest`` on commit
8ebe823's ``make test-pipeline``). A file another issue adds is no change of this kind: additions
are allowed, and listed when the check fails.
Marker ``pipeline``: make test-pipeline runs it after the small profile."""

import json

import pytest

from .conftest import ROOT
from .outputs_manifest import differences, manifest

pytestmark = pytest.mark.pipeline


def test_the_small_profile_keeps_every_output_and_its_columns():
    results = ROOT / "results" / "ci"
    if not (results / "report.html").exists():
        pytest.fail(f"{results} has no finished run: make test-pipeline writes it")
    before = json.loads((ROOT / "tests" / "fixtures" / "outputs" / "ci.json").read_text())
    gone, changed, added = differences(before, manifest(results))
    assert not gone and not changed, {"gone": gone, "changed": changed, "added": added}
    assert len(before) >= 100                                        # the manifest is the whole tree


def test_the_manifest_sees_a_column_renamed_and_a_file_gone():
    before = {"N2/identification/s_opt.csv": ["parameter", "mu", "sigma"], "spans_report.csv": ["span_id"]}
    after = {"N2/identification/s_opt.csv": ["parameter", "mu_m", "sigma"], "new.csv": ["x"]}
    gone, changed, added = differences(before, after)
    assert gone == ["spans_report.csv"] and added == ["new.csv"]
    assert changed == ["N2/identification/s_opt.csv: ['parameter', 'mu', 'sigma'] -> ['parameter', 'mu_m', 'sigma']"]
