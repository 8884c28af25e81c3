"""catenary: statistical identification of railway catenary geometry.

Physics (static and dynamic finite-element models of contact wire and messenger wire) and
statistics (maximum-likelihood identification of the random inputs) live here, importable
and testable without Snakemake. SI units throughout.

Importing it, or any of its modules, changes nothing in the caller's process: the allocator
(:mod:`catenary.plumbing.heap`) and the BLAS threads (:mod:`catenary.plumbing.blas`) are tuned where a process
starts — the rule scripts, the benchmarks, the tests — and figures never choose Matplotlib's
backend (:mod:`catenary.plumbing.plots`).
"""

__version__ = "0.1.0"
