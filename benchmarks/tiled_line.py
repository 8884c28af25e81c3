"""A cost proxy of a long line for one span type's jobs: a measured line's inputs of ``identify``,
``diagnose`` and ``maintenance`` repeated K times.

The per-type jobs of the 10 000-span line (5 000 spans of a type) can only be timed after that
line's correction, which takes most of the hour ``make bench-line SPANS=10000`` runs. Their cost
grows with the number of spans, not with what the spans hold, so the 1 000-span line's spans of a
type taken ten times over give the same work on 10 times as many spans: copy ``k`` of a span gets
the span, section and mast names prefixed ``T<k>`` and its chainages shifted by ``k`` × 100 km, so
that no two spans share a name or a mast. It is a proxy for timing, not a line: its identified
laws are the source line's (the same spans repeated), its tests see every span K times.

Usage: ``python benchmarks/tiled_line.py [--source results/line_1000] [--times 10] [--span-type N2]``
writes ``<source>_x<K>/``, a copy of the source folder (its report and the other types left out)
whose ``config.yaml`` names the new folder and whose type's ``corrected.parquet``,
``corrected_profiles.parquet``, ``profiles.parquet``, ``spans.parquet`` and the correction's
``model_error.parquet`` hold the K copies; then ``python benchmarks/line_cores.py --results
<source>_x<K> --repeat 3`` times the jobs on it.
"""

from record import ROOT  # noqa: I001  (sets one BLAS thread first)

import argparse
import shutil

import pandas as pd
import yaml

#: Chainage between two copies [m]: longer than any line the benchmarks build.
SHIFT_M = 100_000.0
#: The files of one type's jobs that hold span, section or mast names and chainages.
TYPE_FILES = ("corrected.parquet", "corrected_profiles.parquet", "profiles.parquet", "spans.parquet")
NAMES = ("span_id", "left_mast_id", "right_mast_id", "mast_id")


def copies(frame: pd.DataFrame, times: int) -> pd.DataFrame:
    """``frame`` ``times`` over, copy k's names prefixed ``T<k>`` and chainages shifted by k × SHIFT_M."""
    out = []
    for k in range(times):
        f = frame.copy()
        for column in NAMES:
            if column in f:        # a span id joins its masts' ids ("M0001-M0002"): each part renamed
                f[column] = f[column].astype(str).str.split("-").map(lambda parts: "-".join(f"T{k}{p}" for p in parts))
        if "section_id" in f:
            f["section_id"] = f"T{k}" + f["section_id"].astype(str)
        for column in f.columns:
            if "chainage" in column and f[column].dtype.kind == "f":
                f[column] = f[column] + k * SHIFT_M
        out.append(f)
    return pd.concat(out, ignore_index=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", default="results/line_1000")
    parser.add_argument("--times", type=int, default=10)
    parser.add_argument("--span-type", default="N2")
    args = parser.parse_args()
    if args.times < 1:
        raise SystemExit(f"--times {args.times}: expected at least 1")
    source = ROOT / args.source
    target_name = f"{args.source.rstrip('/')}_x{args.times}"
    target = ROOT / target_name
    for name in (*(f"{args.span_type}/{f}" for f in TYPE_FILES), "correction/model_error.parquet", "config.yaml"):
        if not (source / name).exists():
            raise SystemExit(f"{source / name} is missing: run the line first (make bench-line)")
    if target.exists():
        shutil.rmtree(target)
    others = [p.name for p in source.iterdir() if p.is_dir() and (p / "corrected.parquet").exists()
              and p.name != args.span_type]
    shutil.copytree(source, target, ignore=shutil.ignore_patterns("report.html", *others))
    config = yaml.safe_load((target / "config.yaml").read_text())
    for key, value in config.items():
        if isinstance(value, str) and value.startswith(args.source.rstrip("/")):
            config[key] = target_name + value[len(args.source.rstrip("/")):]
    (target / "config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    for name in TYPE_FILES:
        copies(pd.read_parquet(source / args.span_type / name), args.times).to_parquet(
            target / args.span_type / name, index=False)
    budget = pd.read_parquet(source / "correction" / "model_error.parquet")
    budget = budget[budget["span_type"] == args.span_type]
    copies(budget, args.times).to_parquet(target / "correction" / "model_error.parquet", index=False)
    n = len(pd.read_parquet(target / args.span_type / "corrected.parquet"))
    print(f"{target_name}: {n} rows of {args.span_type} ({args.times} copies of {args.source})")


if __name__ == "__main__":
    main()
