"""A steady heap: freed arrays' memory kept for the next ones instead of returned to the system.

The fast model and the likelihood allocate and free arrays of 0.1–10 MB at every J evaluation,
hundreds of evaluations per second. glibc's ``malloc`` serves a block above its *mmap
threshold* by a fresh ``mmap`` and gives the heap's free top back to the system above its
*trim threshold*; both start at 128 kB and the first moves with the sizes freed, so whether an
array costs a fresh mapping (a page fault and a zeroed page per 4 kB on its first write) depends
on the order of earlier allocations. Measured on this 2-core machine (2026-11-27, the default
run's N2 identification, 677 + 365 + 2 356 J evaluations): 34–38 s with glibc's defaults against
20–23 s with the thresholds below, and the same numbers; a one-line change of how one array was
allocated had moved it from 26 to 36 s.

:func:`steady_heap` fixes the mmap threshold at 32 MB (glibc's largest) and the trim threshold
at 256 MB: arrays below 32 MB are carved from the heap and its freed memory is reused. The
price is a process's resident memory staying near its peak: on the 1 000-span line of ``make
bench-line`` a job's peak resident memory rose by 4–17 % (the diagnosis 1 190 → 1 279 MB, the
registration 454 → 531 MB; 2026-11-27, one run with it and one without). It is a choice for a
whole process, so a process makes it where it starts — every rule script, the benchmarks
(``benchmarks/record.py``) and the tests (``tests/conftest.py``) — never ``import catenary``: a
library must leave its caller's allocator as it found it. Elsewhere than glibc (macOS, musl,
Windows) it does nothing.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import sys

__all__ = ["MMAP_THRESHOLD_BYTES", "TRIM_THRESHOLD_BYTES", "steady_heap"]

#: glibc's ``M_TRIM_THRESHOLD`` and ``M_MMAP_THRESHOLD`` parameters of ``mallopt``.
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
#: Blocks below this size come from the heap [bytes] (glibc accepts at most 32 MB on 64 bits).
MMAP_THRESHOLD_BYTES = 32 * 2**20
#: Free memory at the heap's top kept, not returned to the system, below this size [bytes].
TRIM_THRESHOLD_BYTES = 256 * 2**20


def steady_heap() -> bool:
    """Set glibc's mmap and trim thresholds (module docstring); True if both were set."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):       # not glibc (musl has no mallopt): nothing to tune
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    return bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)) and bool(mallopt(_M_TRIM_THRESHOLD,
                                                                                  TRIM_THRESHOLD_BYTES))
