"""Compare every result file of a cluster run with the local run's, byte for byte.

Usage: python tests/cluster/compare.py LOCAL_DIR CLUSTER_DIR REQUIRED...

Every file under CLUSTER_DIR is compared with the same path under LOCAL_DIR, except `logs/` and
`benchmarks/` (time stamps, host names, wall times and memory: they differ by nature). One
exception inside the results: the Markdown reports (`identification.md`) state their own wall
times, so their numbers of seconds are masked before the comparison; every other byte must match.
REQUIRED paths (relative) must be among the files compared. A Parquet file that differs is also
compared by content, so the message tells a metadata difference from a numerical one. Exit
status 0 when everything matches, 1 otherwise.
"""

from __future__ import annotations

import hashlib
import re
import sys
from pathlib import Path

SKIPPED = ("logs", "benchmarks")
#: "61.4 s", "3.6 s optimisation": a wall time in a report
SECONDS = re.compile(rb"\d+(?:\.\d+)? s\b")


def _content(path: Path) -> bytes:
    data = path.read_bytes()
    return SECONDS.sub(b"<wall time> s", data) if path.suffix == ".md" else data


def _parquet_detail(local: Path, cluster: Path) -> str:
    import pyarrow.parquet as pq

    a, b = pq.read_table(local), pq.read_table(cluster)
    if not a.equals(b):
        return "the tables' values differ"
    meta_a, meta_b = a.schema.metadata or {}, b.schema.metadata or {}
    keys = sorted(k.decode() for k in set(meta_a) | set(meta_b) if meta_a.get(k) != meta_b.get(k))
    return f"same values, metadata keys differ: {keys}"


def compare(local_dir: Path, cluster_dir: Path, required: list[str]) -> bool:
    names = sorted(p.relative_to(cluster_dir).as_posix() for p in cluster_dir.rglob("*")
                   if p.is_file() and p.relative_to(cluster_dir).parts[0] not in SKIPPED)
    same = True
    for name in sorted(set(required) - set(names)):
        print(f"MISSING   {name} in {cluster_dir}")
        same = False
    for name in names:
        local, cluster = local_dir / name, cluster_dir / name
        if not local.is_file():
            print(f"MISSING   {name} in {local_dir}")
            same = False
            continue
        a, b = _content(local), _content(cluster)
        if a == b:
            masked = " (wall times masked)" if local.suffix == ".md" else ""
            print(f"identical {name} ({len(a)} bytes, sha256 {hashlib.sha256(a).hexdigest()[:12]}){masked}")
        else:
            detail = _parquet_detail(local, cluster) if name.endswith(".parquet") else "bytes differ"
            print(f"DIFFERENT {name}: {detail}")
            same = False
    print(f"{len(names)} files compared, {'all identical' if same else 'NOT all identical'}")
    return same


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    sys.exit(0 if compare(Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3:]) else 1)
