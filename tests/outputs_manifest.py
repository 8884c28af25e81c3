"""The machine-readable outputs of a run: every CSV and Parquet file under a results folder, with
its columns (a CSV's header, a Parquet file's schema).

``python -m tests.outputs_manifest RESULTS`` prints it as JSON, ``python -m tests.outputs_manifest
RESULTS FIXTURE`` compares a run with a manifest (files gone, columns changed, files added; exit
status 1 on the first two); the fixtures under
``tests/fixtures/outputs/`` hold the manifests of the tree before issue [19] moved the package
into layers (commit 8ebe823): the small profile's (``make test-pipeline``, results/ci) and the
default run's (``make run``, results). tests/test_outputs_kept.py compares a run with them.
"""

from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

import pyarrow.parquet as pq

#: Folders of a results tree that hold no output a program reads: timings, logs, the report's
#: own copies for people, and the other runs a results folder may hold (results/ci, validate).
SKIPPED = ("benchmarks", "logs", "report", "ci", "validate", "default_data")


def manifest(results: str | Path) -> dict[str, list[str]]:
    """``{relative path: columns}`` of every CSV and Parquet file under ``results``."""
    results = Path(results)
    out = {}
    for path in sorted(results.rglob("*")):
        relative = path.relative_to(results)
        if relative.parts[0] in SKIPPED or path.suffix not in (".csv", ".parquet") or not path.is_file():
            continue
        if path.suffix == ".parquet":
            columns = list(pq.read_schema(path).names)
        else:
            with open(path, newline="", encoding="utf-8") as f:
                columns = next(csv.reader(f), [])
        out[str(relative)] = columns
    return out


def differences(before: dict[str, list[str]], after: dict[str, list[str]]) -> tuple[list[str], list[str], list[str]]:
    """Files gone, files whose columns changed (said with both lists), files added."""
    gone = sorted(set(before) - set(after))
    changed = [f"{name}: {before[name]} -> {after[name]}" for name in sorted(set(before) & set(after))
               if before[name] != after[name]]
    added = sorted(set(after) - set(before))
    return gone, changed, added


if __name__ == "__main__":
    if len(sys.argv) == 2:
        json.dump(manifest(sys.argv[1]), sys.stdout, indent=1, sort_keys=True)
        sys.stdout.write("\n")
    else:
        before = json.loads(Path(sys.argv[2]).read_text())
        gone, changed, added = differences(before, manifest(sys.argv[1]))
        print(f"{len(before)} files in {sys.argv[2]}: {len(gone)} gone, {len(changed)} with other columns, "
              f"{len(added)} added")
        for line in [f"gone: {g}" for g in gone] + [f"changed: {c}" for c in changed] + [f"added: {a}" for a in added]:
            print(line)
        sys.exit(1 if gone or changed else 0)
