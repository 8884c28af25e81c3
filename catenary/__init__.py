"""catenary: statistical identification of railway catenary geometry.

Physics (static and dynamic finite-element models of contact wire and messenger wire) and
statistics (maximum-likelihood identification of the random inputs) live here, importable
and testable without Snakemake. SI units throughout.
"""

__version__ = "0.1.0"

from .heap import steady_heap

steady_heap()       # glibc keeps freed arrays' memory for the next ones (catenary.heap)
