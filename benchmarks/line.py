"""``make bench-line``: a 1 000-span line end to end on this machine's cores.

The truth is ``config/line/line_1000_campaign.yaml`` (50 sections of 20 spans, N2 and N3
alternating, the default campaign's laws); the workflow runs from a fresh results folder
(``results/line/``, overlay ``config/line/line_1000.yaml``): campaign → ingestion → projection →
correction → identification → diagnosis of both span types. Into ``results/benchmarks.json``:

* ``line_1000_spans_wall_s``: the whole run, Snakemake's start-up included;
* per rule (stage): ``line_1000_spans_<rule>_wall_s``, the summed wall time of its jobs (with
  2 cores two jobs overlap, so these add up to more than the whole), ``..._longest_job_s``
  and ``..._peak_rss_mb``, the largest peak memory of one of its jobs (Snakemake's
  ``benchmark:`` record, the process and its children);
* ``line_1000_spans_peak_rss_mb``: the largest over every job.

Usage: ``python benchmarks/line.py [--cores N] [--keep]`` (``--keep``: reuse what an earlier
run left in ``results/line/`` instead of starting afresh).
"""

from record import ROOT, record  # noqa: I001  (sets one BLAS thread first)

import argparse
import shutil
import subprocess
import time

from cluster_resources import measure

RESULTS = ROOT / "results" / "line"
OVERLAY = "config/line/line_1000.yaml"
TARGETS = [f"results/line/{t}/{part}" for t in ("N2", "N3")
           for part in ("identification/s_opt.csv", "diagnosis/findings.csv")]
STAGES = ("campaign_section", "campaign", "ingest", "project", "correct_section", "correction", "identify", "diagnose")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cores", type=int, default=2)
    parser.add_argument("--keep", action="store_true")
    args = parser.parse_args()
    if RESULTS.exists() and not args.keep:
        shutil.rmtree(RESULTS)
    snakemake = ROOT / ".venv" / "bin" / "snakemake"
    cmd = [str(snakemake) if snakemake.exists() else "snakemake", "--workflow-profile", "workflow/profiles/default",
           "--cores", str(args.cores), "--configfile", "config/config.yaml", OVERLAY, "--", *TARGETS]
    print("+", " ".join(cmd), flush=True)
    start = time.perf_counter()
    subprocess.run(cmd, cwd=ROOT, check=True)
    wall = time.perf_counter() - start
    per_rule = measure(RESULTS).set_index("rule")
    figures = {"line_1000_spans_wall_s": wall, "line_1000_spans_peak_rss_mb": float(per_rule["peak_rss_mb"].max())}
    for rule in STAGES:
        if rule in per_rule.index:
            row = per_rule.loc[rule]
            figures[f"line_1000_spans_{rule}_wall_s"] = float(row["total_wall_s"])
            figures[f"line_1000_spans_{rule}_longest_job_s"] = float(row["max_wall_s"])
            figures[f"line_1000_spans_{rule}_peak_rss_mb"] = float(row["peak_rss_mb"])
    record(figures)
    print(per_rule.to_string())
    for key, value in figures.items():
        print(f"{key}: {value:.4g}")


if __name__ == "__main__":
    main()
