"""Measurement data speed (issue [3]): wall time to generate the default campaign with its
sections in parallel on 2 processes (as the workflow runs them on 2 cores), and ingestion plus
projection throughput [samples/s] on the resulting recording."""

from record import ROOT, record  # noqa: I001  (sets one BLAS thread first)

import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import pandas as pd

from catenary.measurement.campaign import masts_table, simulate_section
from catenary.measurement.projection import ProjectionSettings, project
from catenary.measurement.recording import RECORDING_SCHEMA, read_masts, read_recording
from catenary.measurement.truth import draw_line, load_truth
from catenary.physics.config import load_catenary
from catenary.physics.pantograph import load_pantographs
from catenary.plumbing.parquet import write_table


def _section(k: int):
    catenary = load_catenary(ROOT / "config" / "catenary.yaml")
    spec = load_truth(ROOT / "config" / "campaign.yaml", catenary)
    pantograph = load_pantographs(ROOT / "config" / "pantographs.yaml")[spec.measurement.pantograph]
    return simulate_section(draw_line(spec, catenary), k, catenary, pantograph, spec.measurement, spec.seed)


def main() -> None:
    catenary = load_catenary(ROOT / "config" / "catenary.yaml")
    spec = load_truth(ROOT / "config" / "campaign.yaml", catenary)
    start = time.perf_counter()
    with ProcessPoolExecutor(2) as pool:
        parts = list(pool.map(_section, range(len(spec.sections))))
    campaign_s = time.perf_counter() - start
    recording = pd.concat([p[0] for p in parts], ignore_index=True)
    with tempfile.TemporaryDirectory() as tmp:
        rec_path, masts_path = Path(tmp) / "recording.parquet", Path(tmp) / "masts.csv"
        write_table(recording, rec_path, RECORDING_SCHEMA, config_hash="bench", kind="recording")
        masts_table(draw_line(spec, catenary)).to_csv(masts_path, index=False)
        start = time.perf_counter()
        result = project(read_recording(rec_path), read_masts(masts_path), catenary, ProjectionSettings())
        ingest_project_s = time.perf_counter() - start
    figures = record({
        "campaign_default_generation_2_processes_s": campaign_s,
        "ingest_projection_samples_per_s": len(recording) / ingest_project_s,
    })
    print(f"campaign_default_generation_2_processes_s: {figures['campaign_default_generation_2_processes_s']:.4g}")
    print(f"ingest_projection_samples_per_s: {figures['ingest_projection_samples_per_s']:.4g} "
          f"({len(recording)} samples, {result.n_used} spans used)")


if __name__ == "__main__":
    main()
