"""The steady heap of ``import catenary`` (catenary.heap)."""

import platform
import sys

import pytest

from catenary.heap import steady_heap


@pytest.mark.skipif(not sys.platform.startswith("linux") or platform.libc_ver()[0] != "glibc",
                    reason="mallopt's thresholds are glibc's")
def test_glibc_takes_both_thresholds():
    # mallopt returns 0 for a parameter or a value it refuses (above 32 MB for the mmap
    # threshold on 64 bits): both settings must be accepted for the heap to stay steady.
    assert steady_heap()
