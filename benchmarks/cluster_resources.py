"""Per-rule peak memory and wall time of runs, and the SLURM profile's requests scaled from them.

Usage: python benchmarks/cluster_resources.py RESULTS_DIR [RESULTS_DIR ...] [--write]

Reads the `benchmark:` files every rule writes (RESULTS_DIR/benchmarks/**.tsv: Snakemake's
`s` wall time and `max_rss` in MB of each job) and, from Snakemake's record of each job
(.snakemake/metadata: its rule, inputs and log), the size of each job's inputs [MiB, as
Snakemake's `input.size_mb`]. Prints per rule the jobs, the largest peak RSS and wall time beside
what workflow/profiles/slurm/config.yaml requests for that job's inputs. A request may be a number
or an expression in `input.size_mb` (Snakemake evaluates it when the job is ready to run), so that
a rule whose cost grows with the line asks for more on a longer one. With --write it stores
every job's measurement in workflow/profiles/slurm/measured.csv (the file
tests/test_cluster_checks.py holds the profile to) and writes the scaled requests into the
profile between its `# scaled requests` markers: per rule the line `a + b · size` fitted to its
jobs (least squares, b ≥ 0, then raised until it covers every job), times the margins (memory
1.5 ×, time 3 ×), at least the profile's defaults. Exit status 1 when a request does not cover
its measurement with those margins.
"""

from __future__ import annotations

import argparse
import base64
import json
import math
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import yaml

ROOT = Path(__file__).resolve().parents[1]
PROFILE = ROOT / "workflow" / "profiles" / "slurm" / "config.yaml"
MEASURED = ROOT / "workflow" / "profiles" / "slurm" / "measured.csv"
METADATA = ROOT / ".snakemake" / "metadata"
MEMORY_MARGIN = 1.5        # peak RSS varies with the data and the library versions
TIME_MARGIN = 3.0          # a cluster core may be slower than this machine's, and shared
#: A rule's request is scaled with its inputs when the fitted growth adds at least this to the
#: request over the measured range (else the largest figure, as a plain number) [fraction].
SCALING_THRESHOLD = 0.1
BEGIN, END = "  # scaled requests: begin", "  # scaled requests: end"


def job_input_sizes(results: Path, metadata: Path = METADATA) -> dict[str, float]:
    """Size of each job's inputs [MiB] (Snakemake's ``input.size_mb``), keyed by the job's
    benchmark file relative to the repository: from Snakemake's record of each output file, which
    names its job's inputs and log (a rule's log ``logs/R/X.log`` and benchmark
    ``benchmarks/R/X.tsv`` share their path). The inputs' sizes are read now: run it on the
    results it measures, untouched since."""
    sizes = {}
    results = Path(results).resolve()
    if results.is_relative_to(ROOT):
        results = results.relative_to(ROOT)       # Snakemake records the paths it was given: relative ones
    logs = str(results).rstrip("/") + "/logs/"
    for record in metadata.rglob("*") if metadata.is_dir() else ():
        if not record.is_file():
            continue
        # the output's path, base64-encoded, cut into folders "@…" where longer than a file name
        encoded = "".join(part.removeprefix("@") for part in record.relative_to(metadata).parts)
        try:
            name = base64.urlsafe_b64decode(encoded).decode()
        except (ValueError, UnicodeDecodeError):
            continue
        if not name.startswith(str(results).rstrip("/") + "/"):
            continue
        data = json.loads(record.read_text())
        log = next((entry for entry in data.get("log") or [] if entry.startswith(logs)), None)
        if log is None:
            continue
        bench = log.replace("/logs/", "/benchmarks/", 1).removesuffix(".log") + ".tsv"
        if bench not in sizes:
            inputs = data.get("input") or []
            sizes[bench] = sum((ROOT / f).stat().st_size for f in inputs if (ROOT / f).is_file()) / 1024 ** 2
    return sizes


def measure_jobs(results: Path) -> pd.DataFrame:
    """One row per job of ``results``: `rule`, `job`, `input_size_mb`, `rss_mb`, `pss_mb`, `wall_s`
    (``input_size_mb`` NaN where Snakemake kept no record of the job)."""
    rows = []
    bench = results / "benchmarks"
    sizes = job_input_sizes(results)
    for path in sorted(bench.rglob("*.tsv")):
        rel = path.relative_to(bench)
        rule = rel.parts[0] if len(rel.parts) > 1 else rel.stem
        row = pd.read_csv(path, sep="\t").iloc[-1]
        key = str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else str(path)
        rows.append({"rule": rule, "job": str(rel.with_suffix("")), "input_size_mb": sizes.get(key, np.nan),
                     "rss_mb": float(row["max_rss"]), "pss_mb": float(row["max_pss"]), "wall_s": float(row["s"])})
    if not rows:
        raise SystemExit(f"{bench}: no benchmark files (run the workflow into {results} first)")
    if not sizes:
        raise SystemExit(f"{results}: Snakemake keeps no record of its jobs in {METADATA} (run the workflow "
                         "from this repository, with its relative results folder)")
    return pd.DataFrame(rows)


def measure(results: Path) -> pd.DataFrame:
    """One row per rule: `rule`, `jobs`, `peak_rss_mb`, `peak_pss_mb`, `max_wall_s`, `total_wall_s`.

    A job's RSS is its processes' resident sets summed: a job that forks workers counts the pages
    they share with it once per process. Its PSS shares each page among the processes that map it
    (what the kernel's cgroup, and so SLURM, holds the job to is closer to it)."""
    jobs = measure_jobs(results)
    return (jobs.groupby("rule")
            .agg(jobs=("wall_s", "size"), peak_rss_mb=("rss_mb", "max"), peak_pss_mb=("pss_mb", "max"),
                 max_wall_s=("wall_s", "max"), total_wall_s=("wall_s", "sum"))
            .reset_index().round(1))


def requests(profile: Path = PROFILE) -> dict[str, dict]:
    """{rule: {mem_mb, runtime, cpus_per_task}} the SLURM profile asks for (defaults filled in):
    a number, or an expression in ``input.size_mb`` (:func:`evaluate`)."""
    raw = yaml.safe_load(profile.read_text())
    default = {k: raw["default-resources"][k] for k in ("mem_mb", "runtime", "cpus_per_task")}
    return {rule: {**default, **values} for rule, values in (raw.get("set-resources") or {}).items()} | \
        {"*": default}


def evaluate(request, input_size_mb: float) -> float:
    """A request for a job whose inputs weigh ``input_size_mb`` [MiB]: a number as it is, an
    expression by Snakemake's own evaluator of profile resources (``input.size_mb`` and Python's
    builtins in reach; anything else, ``math`` for one, is a NameError there, which Snakemake
    answers by passing the expression on as a string: refused here)."""
    if not isinstance(request, str):
        return float(request)
    from snakemake.resources import Resource

    value = Resource.cli_evaluator("request", request, wildcards=None, input=SimpleNamespace(size_mb=input_size_mb),
                                   attempt=1, async_run=None)
    if not isinstance(value, (int, float)):
        raise ValueError(f"request {request!r}: Snakemake evaluates it to {value!r}, not a number")
    return float(value)


def scaled(sizes: np.ndarray, values: np.ndarray, margin: float, floor: float, unit: float = 1.0):
    """The request ``⌈margin (a + b · size) / unit⌉`` (as ``int(…) + 1``) for jobs of ``sizes`` [MiB] that measured
    ``values``: ``a + b · size`` fitted by least squares (b ≥ 0), then ``a`` raised until the line
    covers every job; at least ``floor``. A plain number (the largest job's) where the growth adds
    less than :data:`SCALING_THRESHOLD` of it over the measured sizes, where the sizes do not
    vary, or where the request would stay at the floor even for inputs 10 × the largest
    measured."""
    ok = np.isfinite(sizes)
    x, y = sizes[ok], values[ok]
    peak = math.ceil(margin * float(values.max()) / unit)
    if x.size < 2 or np.ptp(x) <= 0:
        return max(int(floor), peak)
    b = max(float(np.polyfit(x, y, 1)[0]), 0.0)
    a = float(np.max(y - b * x))
    if b * np.ptp(x) < SCALING_THRESHOLD * y.max() or a + b * x.min() < 0:
        return max(int(floor), peak)
    a_req, b_req = margin * a / unit, margin * b / unit
    if a_req + b_req * 10 * x.max() <= floor:     # at the floor even on inputs 10 × the largest measured
        return max(int(floor), peak)
    return f"max({int(floor)}, int({a_req:.6g} + {b_req:.6g} * input.size_mb) + 1)"   # int + 1 ≥ ceil


def table(measured: pd.DataFrame, asked: dict[str, dict]) -> tuple[str, list[str]]:
    """Per rule: the largest measured peak and wall time against the request for the job that
    measured it, and every job whose request falls short of its margins."""
    lines = ["| rule | jobs | measured peak RSS [MB] | requested `mem_mb` | measured wall time, longest job [s] "
             "| requested `runtime` [min] | `cpus_per_task` |",
             "|---|---|---|---|---|---|---|"]
    short = []
    for rule, jobs in measured.groupby("rule", sort=True):
        req = asked.get(rule, asked["*"])
        size = jobs["input_size_mb"].fillna(0.0).to_numpy()
        mem = np.array([evaluate(req["mem_mb"], s) for s in size])
        time = np.array([evaluate(req["runtime"], s) for s in size])
        top, slow = int(jobs["rss_mb"].to_numpy().argmax()), int(jobs["wall_s"].to_numpy().argmax())
        shown = [req[k] if not isinstance(req[k], str) else f"{v:.0f} (scaled)"
                 for k, v in (("mem_mb", mem[top]), ("runtime", time[slow]))]
        lines.append(f"| `{rule}` | {len(jobs)} | {jobs['rss_mb'].iloc[top]:.0f} | {shown[0]} "
                     f"| {jobs['wall_s'].iloc[slow]:.0f} | {shown[1]} | {req['cpus_per_task']} |")
        for k, job in enumerate(jobs.itertuples()):
            if mem[k] < MEMORY_MARGIN * job.rss_mb:
                short.append(f"{rule} ({job.job}): mem_mb {mem[k]:.0f} < {MEMORY_MARGIN} × {job.rss_mb:.0f} MB")
            if 60 * time[k] < TIME_MARGIN * job.wall_s:
                short.append(f"{rule} ({job.job}): runtime {time[k]:.0f} min < {TIME_MARGIN} × {job.wall_s:.0f} s")
    return "\n".join(lines), short


def write_requests(measured: pd.DataFrame, profile: Path = PROFILE) -> None:
    """Write each measured rule's scaled ``mem_mb`` and ``runtime`` (:func:`scaled`) into the
    profile's ``set-resources``, between its ``# scaled requests`` markers; its other keys
    (``cpus_per_task``) and the default resources stay as they are."""
    text = profile.read_text()
    raw = yaml.safe_load(text)
    defaults = raw["default-resources"]
    others = {rule: {k: v for k, v in values.items() if k not in ("mem_mb", "runtime")}
              for rule, values in (raw.get("set-resources") or {}).items()}
    lines = []
    for rule, jobs in measured.groupby("rule", sort=True):
        size = jobs["input_size_mb"].to_numpy(dtype=float)
        mem = scaled(size, jobs["rss_mb"].to_numpy(), MEMORY_MARGIN, defaults["mem_mb"])
        run = scaled(size, jobs["wall_s"].to_numpy(), TIME_MARGIN, defaults["runtime"], unit=60.0)
        values = {**({"mem_mb": mem} if mem != defaults["mem_mb"] else {}),
                  **({"runtime": run} if run != defaults["runtime"] else {}), **others.pop(rule, {})}
        if values:
            lines.append(f"  {rule}: " + yaml.safe_dump(values, default_flow_style=True, width=1000).strip())
    lines += [f"  {rule}: " + yaml.safe_dump(values, default_flow_style=True, width=1000).strip()
              for rule, values in sorted(others.items()) if values]
    head, rest = text.split(BEGIN + "\n", 1)
    _, tail = rest.split(END + "\n", 1)
    profile.write_text(head + BEGIN + "\n" + "\n".join(lines) + "\n" + END + "\n" + tail)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", type=Path, nargs="+", help="results folders of runs (the default run, long lines)")
    parser.add_argument("--write", action="store_true",
                        help=f"store the jobs in {MEASURED.name} and write the scaled requests into the profile")
    args = parser.parse_args()
    measured = pd.concat([measure_jobs(r).assign(run=str(r)) for r in args.results], ignore_index=True)
    if args.write:
        measured.round(3).to_csv(MEASURED, index=False)
        write_requests(measured)
        print(f"written {MEASURED.relative_to(ROOT)} and the requests of {PROFILE.relative_to(ROOT)}")
    text, short = table(measured, requests())
    print(text)
    for problem in short:
        print(f"too small: {problem}", file=sys.stderr)
    return 1 if short else 0


if __name__ == "__main__":
    sys.exit(main())
