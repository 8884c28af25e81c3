"""Shared helpers of the benchmark scripts: one-core timing and the flat results file.

Every benchmark merges its figures into ``results/benchmarks.json``, a flat JSON object whose
keys carry their units (``fe_solve_one_span_ms``). Pin BLAS to one thread before NumPy loads,
so figures are per core.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from catenary.plumbing.blas import one_blas_thread
from catenary.plumbing.heap import steady_heap

one_blas_thread(override=False)
steady_heap()       # as every rule script does (catenary.plumbing.heap)

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results" / "benchmarks.json"


def best_time_s(fn, repeat: int = 5, number: int = 1) -> float:
    """Best wall time of ``number`` calls of ``fn`` over ``repeat`` rounds [s per call]."""
    fn()  # warm-up (imports, caches)
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        for _ in range(number):
            fn()
        best = min(best, (time.perf_counter() - start) / number)
    return best


def record(figures: dict[str, float]) -> dict[str, float]:
    """Merge ``figures`` into results/benchmarks.json and return the whole object."""
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    data = json.loads(RESULTS.read_text()) if RESULTS.exists() else {}
    data.update({k: float(v) for k, v in figures.items()})
    RESULTS.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")
    return data
