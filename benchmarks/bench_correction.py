"""Correction speed (issue [4]): wall time to correct the default campaign's projected spans with
its sections in parallel on 2 processes (as the workflow runs them on 2 cores), with the
dynamic and with the quasi-static measuring pass. Needs the projected spans of the default run;
they are made with Snakemake when missing."""

from record import ROOT, record  # noqa: I001  (sets one BLAS thread first)

import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace

import pandas as pd
import yaml

from catenary.physics.config import load_catenary
from catenary.physics.pantograph import load_pantographs
from catenary.plumbing.parquet import read_table
from catenary.stages.correction import CorrectionSettings, correct_spans

CONFIG = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
RESULTS = ROOT / CONFIG["results"]
INPUTS = [RESULTS / t / "spans.parquet" for t in CONFIG["span_types"]] + [RESULTS / "ingest" / "recording.parquet"]


def _spans() -> pd.DataFrame:
    return pd.concat([read_table(RESULTS / t / "spans.parquet").assign(span_type=t) for t in CONFIG["span_types"]],
                     ignore_index=True)


def _correct(job: tuple[str, str]) -> pd.DataFrame:
    section_id, mode = job
    catenary = load_catenary(ROOT / CONFIG["catenary"])
    settings = replace(CorrectionSettings.from_mapping(CONFIG["correction"]), mode=mode)
    pantograph = load_pantographs(ROOT / CONFIG["pantographs"])[settings.pantograph]
    spans = _spans()
    return correct_spans(spans[spans["section_id"] == section_id], catenary, pantograph, settings)[0]


def main() -> None:
    if not all(p.exists() for p in INPUTS):
        subprocess.run([sys.executable, "-m", "snakemake", "--cores", "2", "--"] + [str(p.relative_to(ROOT)) for p in INPUTS],
                       cwd=ROOT, check=True)
    sections = sorted(_spans()["section_id"].unique())
    figures = {}
    for mode in ("quasi_static", "dynamic"):
        start = time.perf_counter()
        with ProcessPoolExecutor(2) as pool:
            corrected = pd.concat(pool.map(_correct, [(s, mode) for s in sections]), ignore_index=True)
        figures[f"correction_default_campaign_{mode}_2_processes_s"] = time.perf_counter() - start
        figures[f"correction_default_campaign_{mode}_converged_percent"] = 100.0 * corrected["converged"].mean()
    figures = record(figures)
    for key in sorted(k for k in figures if k.startswith("correction_")):
        print(f"{key}: {figures[key]:.4g}")


if __name__ == "__main__":
    main()
