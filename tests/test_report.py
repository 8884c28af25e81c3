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
    # every table as its copy in an engineer's units (the file itself keeps SI: catenary.report.tables)
    tables = ([f"results/ci/report/tables/{t}/{name}" for t in SPAN_TYPES for name in TABLES]
              + [f"results/ci/report/tables/{n}" for n in LINE_TABLES])
    assert len(figures) >= 30                                     # 15 per span type in the small profile
    missing = sorted(set(figures + tables) - set(results))
    assert not missing, missing
    for path, entry in results.items():
        assert len(re.sub("<[^>]+>", "", entry["caption"]).split()) >= 15, (path, entry["caption"])
    # filed by span type and stage; the line's results and the campaign checks apart
    for span_type in SPAN_TYPES:
        assert {k.split()[0] for k in categories[span_type]} == {"1", "4", "5", "6", "7", "8"}
    assert {"Whole recording", "Validation against the campaign's truth"} <= set(categories)


def test_embedded_tables_are_the_files_in_an_engineers_units(report):
    _, results, _ = report
    for path, entry in results.items():
        if entry["mime_type"] == "text/csv":
            embedded = base64.b64decode(entry["data_uri"].split(",", 1)[1]).decode("utf-8")
            assert embedded == (ROOT / path).read_text(encoding="utf-8"), path
            # a copy of the machine table, row for row; the machine table keeps SI
            assert path.startswith("results/ci/report/tables/"), path
            machine = ROOT / "results" / "ci" / path.removeprefix("results/ci/report/tables/")
            assert len(pd.read_csv(ROOT / path)) == len(pd.read_csv(machine)), path
    for span_type in SPAN_TYPES:                                  # a dropper in mm, a tension in N
        machine = pd.read_csv(RESULTS / span_type / "identification" / "s_opt.csv").set_index("parameter")
        shown = pd.read_csv(RESULTS / "report" / "tables" / span_type / "identification" / "s_opt.csv").set_index("parameter")
        for name, label, factor in (("dropper_1_length_m", "dropper 1 length [mm]", 1e3),
                                    ("messenger_tension_n", "messenger tension T_MW [N]", 1.0),
                                    ("system_height_m", "system height ΔH [mm]", 1e3)):
            for column in ("mu", "sigma", "sigma se"):
                # 6 significant digits written (%.6g): 1 part in 10⁵ of the value
                assert shown.loc[label, column] == pytest.approx(factor * machine.loc[name, column.replace(" ", "_")],
                                                                rel=1e-5, abs=1e-9)


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


def _rendered(text: str, script: str, pre_id: str, tmp_path, *options: str) -> dict:
    """The report ``text`` with ``script`` added, opened in headless chromium (``options``): the
    JSON the script wrote into its ``<pre id=pre_id>``, checked to hold no error."""
    page = tmp_path / "report.html"
    end = text.rindex("</body>")
    page.write_text(text[:end] + script + text[end:], encoding="utf-8")
    run = subprocess.run(["chromium", "--headless", "--no-sandbox", "--disable-gpu", *options, "--dump-dom",
                          page.as_uri()], capture_output=True, text=True, timeout=300)
    found = re.search(rf'<pre id="{pre_id}">(.*?)</pre>', run.stdout, re.S)
    assert found, run.stderr[-2000:]
    out = json.loads(html.unescape(found.group(1)))
    assert out["error"] is None, out["error"]
    return out


@pytest.mark.skipif(shutil.which("chromium") is None,
                    reason="Debian's chromium is not installed (make test-pipeline installs it as root: tests/install_browser.sh)")
def test_report_renders_in_a_browser_with_every_image(report, tmp_path):
    text, results, _ = report
    out = _rendered(text, CHECK, "catenary-check", tmp_path, "--virtual-time-budget=60000")
    images = [p for p, e in results.items() if e["mime_type"].startswith("image/")]
    assert set(out["images"]) == set(images)
    broken = {p: v for p, v in out["images"].items() if not (isinstance(v, list) and min(v) >= 200)}
    assert not broken, broken                                     # every figure decoded, ≥ 200 px a side
    for span_type in SPAN_TYPES:                                  # the front page as the browser shows it
        assert f"\n{span_type}\n" in out["front"]
    assert "Summary per span type" in out["front"] and "Table 2 analogue" in out["front"]


LAYOUT = """<script>
window.addEventListener('load', function () {
  var pre = document.createElement('pre'); pre.id = 'catenary-layout'; document.body.appendChild(pre);
  var out = {error: null};
  function write() { pre.textContent = JSON.stringify(out); }
  (async function () {
    for (var k = 0; k < 200 && !document.querySelector('canvas'); k++) {   // the workflow graph drawn
      await new Promise(function (r) { setTimeout(r, 50); });
    }
    await new Promise(function (r) { setTimeout(r, 500); });
    var graph = document.querySelector('canvas');
    var main = graph && graph.closest('div.gap-3');                  // the front page and the graph
    if (!main) { out.error = 'no workflow graph beside the front page'; return; }
    var doc = main.querySelector('div.document');
    out.text = doc ? doc.innerText : '';
    out.title_top = doc ? doc.getBoundingClientRect().top : null;
    out.boxes = Array.from(main.querySelectorAll('table, p, ul, ol, h1, h2, h3, h4, pre, img, canvas'))
      .map(function (e, i) { e.dataset.k = i; return e; })
      .filter(function (e) { var r = e.getBoundingClientRect(); return r.width > 0 && r.height > 0; })
      .map(function (e) {
        var r = e.getBoundingClientRect(), up = [], a = e.parentElement;
        for (; a && a !== main; a = a.parentElement) { if (a.dataset.k !== undefined) up.push(+a.dataset.k); }
        return {k: +e.dataset.k, tag: e.tagName, text: (e.innerText || '').slice(0, 40), up: up,
                left: r.left, top: r.top, right: r.right, bottom: r.bottom};
      });
  })().catch(function (e) { out.error = String(e); }).finally(write);
  write();
});
</script>"""


@pytest.mark.skipif(shutil.which("chromium") is None,
                    reason="Debian's chromium is not installed (make test-pipeline installs it as root: tests/install_browser.sh)")
def test_the_front_page_reads_at_1400_px_without_an_element_on_another(report, tmp_path):
    # The front page as a maintainer opens it, in a 1 400 px window: it starts at its top (not cut
    # off above the window), says per span type the maintenance headline and the contact-force
    # verdict, speaks mm and N, and no block (table, paragraph, list, heading, figure, the
    # workflow graph) lies on another that does not hold it.
    text, _, _ = report
    out = _rendered(text, LAYOUT, "catenary-layout", tmp_path, "--window-size=1400,1000", "--virtual-time-budget=30000")
    assert out["title_top"] >= 0                                     # its top can be read
    front = out["text"]
    for span_type in SPAN_TYPES:
        section = front.split(f"\n{span_type}\n")[1]
        assert "Maintenance:" in section and "Contact force (EN 50367)" in section
        assert "km/h: meets" in section or "km/h: fails" in section
        assert "dropper 1 length [mm]" in section and "messenger tension T_MW [N]" in section
        assert "system height ΔH [mm]" in section
    # no input in SI names, no length in metres with the digits of a millimetre (1.38692 m)
    assert "_length_m" not in front and "system_height_m" not in front and "messenger_tension_n" not in front
    assert not re.search(r"(?<![\d.])\d\.\d{4,}(?!\d)", front), re.findall(r"(?<![\d.])\d\.\d{4,}", front)[:5]
    boxes = out["boxes"]
    assert sum(b["tag"] == "TABLE" for b in boxes) >= 2 * len(SPAN_TYPES) and any(b["tag"] == "CANVAS" for b in boxes)
    overlaps = []
    for i, a in enumerate(boxes):
        for b in boxes[i + 1:]:
            if a["k"] in b["up"] or b["k"] in a["up"]:
                continue                                             # one holds the other
            width = min(a["right"], b["right"]) - max(a["left"], b["left"])
            height = min(a["bottom"], b["bottom"]) - max(a["top"], b["top"])
            if width > 1 and height > 1:                             # a shared border is not an overlap
                overlaps.append((a["tag"], a["text"], b["tag"], b["text"], round(width), round(height)))
    assert not overlaps, overlaps[:10]
