"""The steady heap (catenary.plumbing.heap), set where a process starts; and a library that behaves:
importing catenary and every one of its modules leaves the caller's allocator and Matplotlib
as they were."""

import platform
import subprocess
import sys
import textwrap

import pytest

from catenary.plumbing.heap import steady_heap


@pytest.mark.skipif(not sys.platform.startswith("linux") or platform.libc_ver()[0] != "glibc",
                    reason="mallopt's thresholds are glibc's")
def test_glibc_takes_both_thresholds():
    # mallopt returns 0 for a parameter or a value it refuses (above 32 MB for the mmap
    # threshold on 64 bits): both settings must be accepted for the heap to stay steady.
    assert steady_heap()


def test_importing_every_module_changes_nothing_in_the_process():
    # In a fresh interpreter with a backend of the caller's choosing (svg: not what a figure of
    # the package would pick), import the package and every module, and record any lookup of
    # glibc's mallopt through ctypes: none may happen, the backend must stay, pyplot stay unloaded.
    code = textwrap.dedent("""
        import ctypes, importlib, pkgutil, sys
        calls = []
        class Watched(ctypes.CDLL):
            def __getattr__(self, name):
                if name == "mallopt":
                    calls.append(name)
                return super().__getattr__(name)
        ctypes.CDLL = Watched
        import matplotlib
        matplotlib.use("svg")
        import catenary
        for m in pkgutil.walk_packages(catenary.__path__, "catenary."):
            importlib.import_module(m.name)
        from catenary.plumbing.plots import save_figure, subplots
        fig, ax = subplots()
        ax.plot([0, 1], [0, 1])
        import tempfile, pathlib
        save_figure(fig, pathlib.Path(tempfile.mkdtemp()) / "f.png")
        print(len(calls), matplotlib.get_backend(), "matplotlib.pyplot" in sys.modules)
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["0", "svg", "False"], out
