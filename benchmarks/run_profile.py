"""Where a workflow run's time goes: per rule, its jobs' summed CPU and wall time, the longest
job, and when the rule's first job started and its last ended (the run's timeline, from which
the critical path reads).

Usage: ``python benchmarks/run_profile.py [RESULTS_DIR] [--log SNAKEMAKE_LOG] [--prefix NAME]``

Reads the ``benchmark:`` record of every job (``RESULTS_DIR/benchmarks/**.tsv``: Snakemake's
``s``, ``cpu_time``) and the run's Snakemake log (default: the newest under ``.snakemake/log/`` that ran a job),
whose ``[timestamp]`` lines precede each job's ``rule …:`` block and each ``Finished job``. Into
``results/benchmarks.json``: ``<prefix>_wall_s`` (first job start to last job end),
``<prefix>_cpu_s`` (every job's CPU) and per rule ``<prefix>_<rule>_cpu_s``. Run it after
``make run`` (prefix ``make_run``).
"""

from record import ROOT, record  # noqa: I001

import argparse
import re
from datetime import datetime
from pathlib import Path

import pandas as pd

STAMP = re.compile(r"^\[(\w{3} \w{3} +\d+ \d\d:\d\d:\d\d \d{4})\]$")
RULE = re.compile(r"^(?:local)?rule (\w+):$")
JOBID = re.compile(r"^\s+jobid: (\d+)$")
FINISHED = re.compile(r"^Finished jobid: (\d+) \(Rule: (\w+)\)")


def jobs(results: Path) -> pd.DataFrame:
    """One row per job: ``rule``, ``wall_s``, ``cpu_s`` (its benchmark record)."""
    rows = []
    bench = results / "benchmarks"
    for path in sorted(bench.rglob("*.tsv")):
        rel = path.relative_to(bench)
        row = pd.read_csv(path, sep="\t").iloc[-1]
        rows.append({"rule": rel.parts[0] if len(rel.parts) > 1 else rel.stem, "wall_s": float(row["s"]),
                     "cpu_s": float(row["cpu_time"])})
    if not rows:
        raise SystemExit(f"{bench}: no benchmark files (run the workflow into {results} first)")
    return pd.DataFrame(rows)


def timeline(log: Path) -> pd.DataFrame:
    """Per job of the log: ``rule``, ``start``, ``end`` (datetimes). A job id can come again after
    a checkpoint re-evaluates the DAG: each ``Finished jobid: N (Rule: R)`` closes the latest
    start of job N."""
    now, rule, running, rows = None, None, {}, []
    for line in log.read_text().splitlines():
        if m := STAMP.match(line):
            now = datetime.strptime(" ".join(m.group(1).split()), "%a %b %d %H:%M:%S %Y")
        elif m := RULE.match(line):
            rule = m.group(1)
        elif (m := JOBID.match(line)) and rule is not None:
            running[m.group(1)] = (rule, now)
            rule = None
        elif (m := FINISHED.match(line)) and m.group(1) in running:
            started_rule, start = running.pop(m.group(1))
            if started_rule == m.group(2):
                rows.append({"rule": started_rule, "start": start, "end": now})
    if not rows:
        raise SystemExit(f"{log}: no finished job in this Snakemake log")
    return pd.DataFrame(rows)


def newest_run_log(results: Path) -> Path:
    """The newest Snakemake log that ran a job (dry runs and lints write logs too), under the
    ``.snakemake/log/`` of the project holding ``results`` (the nearest folder above it that has
    one: another clone's results are timed by that clone's logs, not this tree's)."""
    results = results.resolve()
    folder = next((f for f in (results, *results.parents) if (f / ".snakemake" / "log").is_dir()), ROOT)
    for path in sorted((folder / ".snakemake" / "log").glob("*.snakemake.log"), reverse=True):
        if "Finished jobid:" in path.read_text():
            return path
    raise SystemExit(f"no Snakemake log with a finished job under {folder / '.snakemake' / 'log'}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", nargs="?", default=str(ROOT / "results"))
    parser.add_argument("--log", default=None)
    parser.add_argument("--prefix", default="make_run")
    args = parser.parse_args()
    log = Path(args.log) if args.log else newest_run_log(Path(args.results))
    per_job = jobs(Path(args.results))
    per_rule = per_job.groupby("rule").agg(jobs=("wall_s", "size"), cpu_s=("cpu_s", "sum"),
                                           wall_s=("wall_s", "sum"), longest_s=("wall_s", "max"))
    times = timeline(log)
    t0 = times["start"].min()
    span = times.groupby("rule").agg(first_start=("start", "min"), last_end=("end", "max"))
    per_rule = per_rule.join((span - t0).apply(lambda c: c.dt.total_seconds()), how="left")
    per_rule = per_rule.sort_values("first_start")
    print(f"log {log.name}; wall {(times['end'].max() - t0).total_seconds():.0f} s, "
          f"CPU {per_job['cpu_s'].sum():.0f} s")
    print(per_rule.round(1).to_string())
    figures = {f"{args.prefix}_wall_s": float((times["end"].max() - t0).total_seconds()),
               f"{args.prefix}_cpu_s": float(per_job["cpu_s"].sum())}
    figures.update({f"{args.prefix}_{rule}_cpu_s": float(row.cpu_s) for rule, row in per_rule.iterrows()})
    record(figures)


if __name__ == "__main__":
    main()
