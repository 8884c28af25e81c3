"""Figures for people: matplotlib, one function per figure, files written as PNG.

Plotting only; every number drawn here is computed elsewhere in the package. Figures are
:class:`matplotlib.figure.Figure` objects made by :func:`subplots`, never through pyplot: no
backend is chosen and no global figure registry touched, so importing the package (or drawing
with it) leaves a caller's Matplotlib as it was; ``savefig`` writes a PNG through the Agg canvas
whatever the caller's backend.
"""

from __future__ import annotations

from pathlib import Path

from matplotlib.figure import Figure

__all__ = ["save_figure", "subplots"]


def subplots(nrows: int = 1, ncols: int = 1, *, figsize=None, **kwargs):
    """A figure and its axes, as :func:`matplotlib.pyplot.subplots` gives them, without pyplot."""
    fig = Figure(figsize=figsize)
    return fig, fig.subplots(nrows, ncols, **kwargs)


def save_figure(fig, path: str | Path, dpi: int = 110) -> Path:
    """Lay out ``fig`` and write it as PNG at ``path`` (creating its folder)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    return path

