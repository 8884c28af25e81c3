"""The per-type jobs of a long line on 1 core and on 2: wall time, speed-up and the same answers.

Usage: ``python benchmarks/line_cores.py [--spans N] [--span-type N2] [--results DIR]`` after
``make bench-line SPANS=N`` has run the line into ``results/line_<N>/`` (its N / 2 spans of each
type: 5 000 of N2 on the 10 000-span line). ``--results DIR`` reads another line's folder laid out
the same way (its ``config.yaml`` naming it as ``results``); the keys are then named after the
folder (``<folder name>_spans_<type>_<rule>_...``). ``--repeat R`` runs each rule R times on 1
core and R times on 2, alternately, and records the medians (a shared machine's speed drifts by
a quarter within minutes: one pair of runs is not a figure); every run's answers must be the first's.

Each of ``identify``, ``diagnose`` and ``maintenance`` of that span type is run again alone
(``--forcerun R --allowed-rules R``: nothing upstream or downstream), with ``--set-threads R=1``
then ``R=2``; its wall time is its Snakemake ``benchmark:`` record. The answers of the two runs
are compared file by file — every output Parquet and CSV of the job must be the same, bit for
bit; where a file holds the job's own wall times (the diagnosis' ``candidates.csv``,
``steps.json``) those columns are left out. Into ``results/benchmarks.json``, per rule:
``line_<N>_spans_<type>_<rule>_1_core_wall_s``, ``..._2_cores_wall_s``, ``..._speedup`` and
``..._same_answers`` (1 or 0).
"""

from record import ROOT, record  # noqa: I001  (sets one BLAS thread first)

import argparse
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

RULES = {
    "identify": ("identification", ["s_opt.csv", "model_error.csv", "trace.parquet"]),
    "diagnose": ("diagnosis", ["findings.csv", "candidates.csv", "spans.csv", "sections.csv",
                               "recommendations.csv"]),
    "maintenance": ("maintenance", ["posterior.parquet", "maintenance.csv", "population_band.csv",
                                    "population_coverage.csv"]),
}
#: Columns that hold a job's own timing, not its answer.
TIMING_COLUMNS = ("wall_time_s", "time_s", "elapsed_s", "seconds")


def run(results: str, rule: str, span_type: str, threads: int) -> float:
    """Run ``rule`` of ``span_type`` in the line folder ``results`` alone with ``threads``; its
    benchmarked wall time [s]."""
    stage, files = RULES[rule]
    exe = ROOT / ".venv" / "bin" / "snakemake"
    target = f"{results}/{span_type}/{stage}/{files[0]}"
    cmd = [str(exe) if exe.exists() else "snakemake", "--workflow-profile", "workflow/profiles/default",
           "--cores", "2", "--configfile", "config/config.yaml", f"{results}/config.yaml", "--forcerun", rule,
           "--allowed-rules", rule, "--set-threads", f"{rule}={threads}", "--", target]
    print("+", " ".join(cmd), flush=True)
    subprocess.run(cmd, cwd=ROOT, check=True)
    bench = ROOT / results / "benchmarks" / rule / f"{span_type}.tsv"
    return float(pd.read_csv(bench, sep="\t").iloc[-1]["s"])


def _table(path: Path) -> pd.DataFrame:
    frame = pd.read_parquet(path) if path.suffix == ".parquet" else pd.read_csv(path)
    return frame.drop(columns=[c for c in frame.columns if any(c.endswith(t) for t in TIMING_COLUMNS)])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spans", type=int, default=10000)
    parser.add_argument("--span-type", default="N2")
    parser.add_argument("--rules", nargs="+", default=list(RULES))
    parser.add_argument("--results", help="the line's folder (default results/line_<N>)")
    parser.add_argument("--repeat", type=int, default=1,
                        help="runs on 1 core and on 2, alternately, each (the figures are their medians)")
    args = parser.parse_args()
    results = args.results or f"results/line_{args.spans}"
    folder = ROOT / results / args.span_type
    figures = {}
    for rule in args.rules:
        stage, files = RULES[rule]
        kept = Path(tempfile.mkdtemp(prefix=f"{rule}_1core_"))
        ones, twos, same = [], [], True
        for repeat in range(args.repeat):
            ones.append(run(results, rule, args.span_type, 1))
            if repeat == 0:                  # the first run's answers, which every later run's must be
                for name in files:
                    shutil.copy(folder / stage / name, kept / name)
            else:
                same &= all(_table(kept / name).equals(_table(folder / stage / name)) for name in files)
            twos.append(run(results, rule, args.span_type, 2))
            same &= all(_table(kept / name).equals(_table(folder / stage / name)) for name in files)
        one, two = float(np.median(ones)), float(np.median(twos))
        key = f"{Path(results).name}_spans_{args.span_type}_{rule}"
        figures.update({f"{key}_1_core_wall_s": one, f"{key}_2_cores_wall_s": two, f"{key}_speedup": one / two,
                        f"{key}_same_answers": float(same)})
        print(f"{rule}: 1 core {one:.1f} s, 2 cores {two:.1f} s, speed-up {one / two:.2f}, same answers {same}"
              + (f" (medians of {args.repeat}: 1 core {', '.join(f'{t:.1f}' for t in ones)}; 2 cores "
                 f"{', '.join(f'{t:.1f}' for t in twos)})" if args.repeat > 1 else ""), flush=True)
        shutil.rmtree(kept)
    record(figures)


if __name__ == "__main__":
    main()
