"""The per-type jobs of a long line on 1 core and on 2: wall time, speed-up and the same answers.

Usage: ``python benchmarks/line_cores.py [--spans N] [--span-type N2]`` after ``make bench-line
SPANS=N`` has run the line into ``results/line_<N>/`` (its N / 2 spans of each type: 5 000 of
N2 on the 10 000-span line).

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


def run(spans: int, rule: str, span_type: str, threads: int) -> float:
    """Run ``rule`` of ``span_type`` alone with ``threads``; its benchmarked wall time [s]."""
    results = f"results/line_{spans}"
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
    args = parser.parse_args()
    folder = ROOT / f"results/line_{args.spans}" / args.span_type
    figures = {}
    for rule in args.rules:
        stage, files = RULES[rule]
        kept = Path(tempfile.mkdtemp(prefix=f"{rule}_1core_"))
        one = run(args.spans, rule, args.span_type, 1)
        for name in files:
            shutil.copy(folder / stage / name, kept / name)
        two = run(args.spans, rule, args.span_type, 2)
        same = all(_table(kept / name).equals(_table(folder / stage / name)) for name in files)
        key = f"line_{args.spans}_spans_{args.span_type}_{rule}"
        figures.update({f"{key}_1_core_wall_s": one, f"{key}_2_cores_wall_s": two, f"{key}_speedup": one / two,
                        f"{key}_same_answers": float(same)})
        print(f"{rule}: 1 core {one:.1f} s, 2 cores {two:.1f} s, speed-up {one / two:.2f}, same answers {same}",
              flush=True)
        shutil.rmtree(kept)
    record(figures)


if __name__ == "__main__":
    main()
