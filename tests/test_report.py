"""The HTML report of the small profile (make test-pipeline writes results/ci/report.html, as make run
writes results/report.html): every figure and table of the pipeline's stages, with captions, and
a front page that a browser renders.

The report is Snakemake's: one HTML file whose results are embedded as data URIs in a
``var results = {...}`` object and shown by a React app. The browser test opens it in Debian's
chromium (headless), lets the app show every image through its own view
(``app.setView({content: "img", ...})``) and reads each image's natural size after it loaded,
waiting until each is complete: a missing or corrupt image is complete with no width (checked by
breaking one PNG's signature: it reads 0 × 0). It also reads the rendered front page.
Marker ``pipeline``: make test-pipeline runs it after the small profile.
"""

from __future__ import annotations

import base64
import html
import json
import re
import shutil
import subprocess

import pandas as pd
import pytest

from .conftest import ROOT

pytestmark = pytest.mark.pipeline

RESULTS = ROOT / "results" / "ci"
REPORT = RESULTS / "report.html"
SPAN_TYPES = ("N2", "N3")
# The tables of issues [1]–[7] (and the contact-force study) per span type, and for the line.
TABLES = ["nominal/dropper_table.csv", "sensitivity/summary.csv", "dynamics/statistics.csv",
          "tension_impact/summary.csv", "inversion/table1.csv", "identification/s_opt.csv",
          "diagnosis/findings.csv", "diagnosis/candidates.csv", "contact_force/summary.csv",
          "contact_force/nominal.csv", "contact_force/tolerance.csv", "contact_force/sensitivity.csv",
          "maintenance/maintenance.csv"]
LINE_TABLES = ["spans_report.csv", "correction/convergence.csv", "correction/summary.csv",
               "validation/projection_round_trip.csv", "validation/correction_check.csv",
               "validation/identification_check.csv", "validation/diagnosis_check.csv",
               "validation/maintenance_check.csv"]


def _variable(text: str, name: str) -> dict:
    """The JSON object of ``var name = {...};`` (one line) in the report."""
    start = text.index(f"var {name} = {{") + len(f"var {name} = ")
    return json.loads(text[start:text.index("\n", start)].strip().rstrip(";"))


@pytest.fixture(scope="module")
def report():
    if not REPORT.exists():
        pytest.fail(f"{REPORT} missing: make test-pipeline writes it (snakemake --report … --report-after-run)")
    text = REPORT.read_text(encoding="utf-8")
    return text, _variable(text, "results"), _variable(text, "categories")


def test_every_figure_and_table_is_in_the_report_with_a_caption(report):
    _, results, categories = report
    figures = sorted(str(p.relative_to(ROOT)) for p in RESULTS.rglob("*.png") if "benchmarks" not in p.parts)
    tables = [f"results/ci/{t}/{name}" for t in SPAN_TYPES for name in TABLES] + [f"results/ci/{n}" for n in LINE_TABLES]
    assert len(figures) >= 30                                     # 15 per span type in the small profile
    missing = sorted(set(figures + tables) - set(results))
    assert not missing, missing
    for path, entry in results.items():
        assert len(re.sub("<[^>]+>", "", entry["caption"]).split()) >= 15, (path, entry["caption"])
    # filed by span type and stage; the line's results and the campaign checks apart
    for span_type in SPAN_TYPES:
        assert {k.split()[0] for k in categories[span_type]} == {"1", "4", "5", "6", "7", "8"}
    assert {"Whole recording", "Validation against the campaign's truth"} <= set(categories)


def test_embedded_tables_are_the_files(report):
    _, results, _ = report
    for path, entry in results.items():
        if entry["mime_type"] == "text/csv":
            embedded = base64.b64decode(entry["data_uri"].split(",", 1)[1]).decode("utf-8")
            assert embedded == (ROOT / path).read_text(encoding="utf-8"), path


def test_front_page_summarises_each_span_type(report):
    text, _, _ = report
    page = (RESULTS / "report" / "front_page.rst").read_text(encoding="utf-8")
    for span_type in SPAN_TYPES:
        s_opt = pd.read_csv(RESULTS / span_type / "identification" / "s_opt.csv")
        findings = pd.read_csv(RESULTS / span_type / "diagnosis" / "findings.csv")
        section = page.split(f"\n{span_type}\n~~")[1].split("\n~~")[0]
        tension = s_opt.set_index("parameter").loc["messenger_tension_n"]
        assert f"{tension['sigma']:.0f}" in section and f"{tension['sigma_se']:.0f}" in section
        assert "20 used" in section and "converged" in section
        assert section.count("- step ") == len(findings)
    assert "Summary per span type" in html.unescape(text)


CHECK = """<script>
window.addEventListener('load', function () {
  var pre = document.createElement('pre'); pre.id = 'catenary-check'; document.body.appendChild(pre);
  var out = {front: document.body.innerText, images: {}, error: null};
  function write() { pre.textContent = JSON.stringify(out); }
  (async function () {
    for (var k = 0; k < 200 && typeof app === 'undefined'; k++) {      // the React app mounts after load
      await new Promise(function (r) { setTimeout(r, 50); });
    }
    out.front = document.body.innerText;
    for (var path in results) {
      var entry = results[path];
      if (!String(entry.mime_type).startsWith('image/')) continue;
      app.setView({content: 'img', contentPath: entry.data_uri, resultPath: path});
      await new Promise(function (r) { setTimeout(r, 50); });
      var shown = Array.from(document.images).filter(function (i) { return i.src === entry.data_uri; });
      if (!shown.length) { out.images[path] = 'not shown'; continue; }
      for (var t = 0; t < 100 && !shown[0].complete; t++) {
        await new Promise(function (r) { setTimeout(r, 20); });
      }
      // a missing or corrupt image is complete with no width
      out.images[path] = shown[0].complete ? [shown[0].naturalWidth, shown[0].naturalHeight] : 'never loaded';
      write();
    }
  })().catch(function (e) { out.error = String(e); }).finally(write);
  write();
});
</script>"""


@pytest.mark.skipif(shutil.which("chromium") is None,
                    reason="Debian's chromium is not installed (make test-pipeline installs it as root: tests/install_browser.sh)")
def test_report_renders_in_a_browser_with_every_image(report, tmp_path):
    text, results, _ = report
    page = tmp_path / "report.html"
    end = text.rindex("</body>")
    page.write_text(text[:end] + CHECK + text[end:], encoding="utf-8")
    run = subprocess.run(["chromium", "--headless", "--no-sandbox", "--disable-gpu", "--virtual-time-budget=60000",
                          "--dump-dom", page.as_uri()], capture_output=True, text=True, timeout=300)
    found = re.search(r'<pre id="catenary-check">(.*?)</pre>', run.stdout, re.S)
    assert found, run.stderr[-2000:]
    out = json.loads(html.unescape(found.group(1)))
    assert out["error"] is None, out["error"]
    images = [p for p, e in results.items() if e["mime_type"].startswith("image/")]
    assert set(out["images"]) == set(images)
    broken = {p: v for p, v in out["images"].items() if not (isinstance(v, list) and min(v) >= 200)}
    assert not broken, broken                                     # every figure decoded, ≥ 200 px a side
    for span_type in SPAN_TYPES:                                  # the front page as the browser shows it
        assert f"\n{span_type}\n" in out["front"]
    assert "Summary per span type" in out["front"] and "Table 2 analogue" in out["front"]
