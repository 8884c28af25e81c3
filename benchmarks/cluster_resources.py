"""Per-rule peak memory and wall time of a run, for the SLURM profile's requests.

Usage: python benchmarks/cluster_resources.py RESULTS_DIR [--write]

Reads the `benchmark:` files every rule writes (RESULTS_DIR/benchmarks/**.tsv: Snakemake's
`s` wall time and `max_rss` in MB of each job), prints per rule the jobs, the largest peak RSS and
wall time beside what workflow/profiles/slurm/config.yaml requests, and with --write stores the
measurement in workflow/profiles/slurm/measured.csv (the file tests/test_cluster_checks.py holds the
profile to). Exit status 1 when a request does not cover its measurement with the profile's
margins (memory 1.5 ×, time 3 ×).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd
import yaml

ROOT = Path(__file__).resolve().parents[1]
PROFILE = ROOT / "workflow" / "profiles" / "slurm" / "config.yaml"
MEASURED = ROOT / "workflow" / "profiles" / "slurm" / "measured.csv"
MEMORY_MARGIN = 1.5        # peak RSS varies with the data and the library versions
TIME_MARGIN = 3.0          # a cluster core may be slower than this machine's, and shared


def measure(results: Path) -> pd.DataFrame:
    """One row per rule: `rule`, `jobs`, `peak_rss_mb`, `peak_pss_mb`, `max_wall_s`, `total_wall_s`.

    A job's RSS is its processes' resident sets summed: a job that forks workers counts the pages
    they share with it once per process. Its PSS shares each page among the processes that map it
    (what the kernel's cgroup, and so SLURM, holds the job to is closer to it)."""
    rows = []
    bench = results / "benchmarks"
    for path in sorted(bench.rglob("*.tsv")):
        rel = path.relative_to(bench)
        rule = rel.parts[0] if len(rel.parts) > 1 else rel.stem
        row = pd.read_csv(path, sep="\t").iloc[-1]
        rows.append({"rule": rule, "s": float(row["s"]), "max_rss": float(row["max_rss"]),
                     "max_pss": float(row["max_pss"])})
    if not rows:
        raise SystemExit(f"{bench}: no benchmark files (run the workflow into {results} first)")
    jobs = pd.DataFrame(rows)
    return (jobs.groupby("rule")
            .agg(jobs=("s", "size"), peak_rss_mb=("max_rss", "max"), peak_pss_mb=("max_pss", "max"),
                 max_wall_s=("s", "max"),
                 total_wall_s=("s", "sum"))
            .reset_index().round(1))


def requests(profile: Path = PROFILE) -> dict[str, dict]:
    """{rule: {mem_mb, runtime, cpus_per_task}} the SLURM profile asks for (defaults filled in)."""
    raw = yaml.safe_load(profile.read_text())
    default = {k: raw["default-resources"][k] for k in ("mem_mb", "runtime", "cpus_per_task")}
    return {rule: {**default, **values} for rule, values in (raw.get("set-resources") or {}).items()} | \
        {"*": default}


def table(measured: pd.DataFrame, asked: dict[str, dict]) -> tuple[str, list[str]]:
    lines = ["| rule | jobs | measured peak RSS [MB] | requested `mem_mb` | measured wall time, longest job [s] "
             "| requested `runtime` [min] | `cpus_per_task` |",
             "|---|---|---|---|---|---|---|"]
    short = []
    for row in measured.itertuples():
        req = asked.get(row.rule, asked["*"])
        lines.append(f"| `{row.rule}` | {row.jobs} | {row.peak_rss_mb:.0f} | {req['mem_mb']} | {row.max_wall_s:.0f} "
                     f"| {req['runtime']} | {req['cpus_per_task']} |")
        if req["mem_mb"] < MEMORY_MARGIN * row.peak_rss_mb:
            short.append(f"{row.rule}: mem_mb {req['mem_mb']} < {MEMORY_MARGIN} × {row.peak_rss_mb:.0f} MB")
        if 60 * req["runtime"] < TIME_MARGIN * row.max_wall_s:
            short.append(f"{row.rule}: runtime {req['runtime']} min < {TIME_MARGIN} × {row.max_wall_s:.0f} s")
    return "\n".join(lines), short


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", type=Path)
    parser.add_argument("--write", action="store_true", help=f"store the measurement in {MEASURED.name}")
    args = parser.parse_args()
    measured = measure(args.results)
    text, short = table(measured, requests())
    print(text)
    if args.write:
        measured.to_csv(MEASURED, index=False)
        print(f"written {MEASURED.relative_to(ROOT)}")
    for problem in short:
        print(f"too small: {problem}", file=sys.stderr)
    return 1 if short else 0


if __name__ == "__main__":
    sys.exit(main())
