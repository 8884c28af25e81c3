"""One BLAS thread per process, set before NumPy loads.

The linear algebra of this package is on 9 × 9 covariances and N × 9 samples: BLAS's own
threads buy nothing there and spin against the worker processes the diagnosis and the tests
start (measured on 2 cores: the diagnosis's workers test 59.5 s with OpenBLAS's default
threads, 10.8 s with one; the small profile's diagnosis 4× slower with 2 threads in each of its
3 processes). This module imports nothing but :mod:`os`, so that it can run first.
"""

from __future__ import annotations

import os

__all__ = ["BLAS_THREAD_VARIABLES", "one_blas_thread"]

#: The environment variables through which the BLAS and OpenMP libraries read their thread count.
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "GOTO_NUM_THREADS",
                         "NUMEXPR_NUM_THREADS", "VECLIB_MAXIMUM_THREADS")


def one_blas_thread(*, override: bool) -> None:
    """Set every variable of :data:`BLAS_THREAD_VARIABLES` to 1; with ``override=False`` a value
    the user set is kept. Effective only before NumPy (or SciPy) is first imported."""
    for name in BLAS_THREAD_VARIABLES:
        if override:
            os.environ[name] = "1"
        else:
            os.environ.setdefault(name, "1")
