"""Figures of the identification (matplotlib, :func:`catenary.plumbing.plots.subplots`): plotting only, the numbers come from
:mod:`.report` and :mod:`.band`.

* :func:`estimators_figure` — Gaussian (dashed) against kernel (solid) marginals of W at the
  droppers for several sample sizes N (paper Fig. 7), the corrected static W as a rug;
* :func:`band_figure` — the band of the CW deflection along the span under s_opt with the
  corrected static W at the droppers (paper Fig. 10).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np

from catenary.plumbing.plots import save_figure, subplots
from .band import DeflectionBand
from .runner import MarginalDensities

__all__ = ["band_figure", "estimators_figure"]

MM = 1e3


def estimators_figure(marginals: list[MarginalDensities], data_w_m: np.ndarray, path: str | Path,
                      title: str) -> Path:
    """Marginal densities of W at each dropper: Gaussian (dashed) and kernel (solid), one colour per N.

    Parameters
    ----------
    marginals : list of MarginalDensities
        One per sample size, on a common grid.
    data_w_m : numpy.ndarray, shape (K, n)
        Measured W [m], drawn as a rug.
    path : str or pathlib.Path
        PNG file written.
    title : str
    """
    n = marginals[0].grid_m.shape[1]
    ncols = 3
    nrows = int(np.ceil(n / ncols))
    fig, axes = subplots(nrows, ncols, figsize=(12, 3.0 * nrows + 0.6), squeeze=False)
    colours = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    data = np.atleast_2d(np.asarray(data_w_m, dtype=float))
    for i in range(nrows * ncols):
        ax = axes.flat[i]
        if i >= n:
            ax.axis("off")
            continue
        for k, m in enumerate(marginals):
            c = colours[k % len(colours)]
            x = MM * m.grid_m[:, i]
            ax.plot(x, m.gaussian[:, i] / MM, "--", color=c, lw=1.0)
            ax.plot(x, m.kernel[:, i] / MM, "-", color=c, lw=1.2, label=f"N = {m.n_samples:g}")
        top = ax.get_ylim()[1]
        ax.plot(MM * data[:, i], np.full(data.shape[0], 0.02 * top), "|", color="k", ms=6, alpha=0.5,
                label=f"corrected static W ({data.shape[0]} spans)" if i == 0 else None)
        ax.set_title(f"dropper {i + 1}", fontsize=9)
        ax.set_xlabel("W [mm]", fontsize=8)
        ax.set_ylabel("density [1/mm]", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    axes.flat[0].legend(fontsize=7, title="solid: kernel, dashed: Gaussian", title_fontsize=7)
    fig.suptitle(title)
    return save_figure(fig, path)


def band_figure(band: DeflectionBand, data_w_m: np.ndarray, dropper_positions_m: np.ndarray,
                path: str | Path, title: str) -> Path:
    """The band of the CW deflection along the span with the corrected static W at the droppers.

    Parameters
    ----------
    band : DeflectionBand
    data_w_m : numpy.ndarray, shape (K, n)
        Measured W [m].
    dropper_positions_m : numpy.ndarray, shape (n,)
        Dropper abscissae [m].
    path : str or pathlib.Path
    title : str
    """
    data = np.atleast_2d(np.asarray(data_w_m, dtype=float))
    x_d = np.asarray(dropper_positions_m, dtype=float)
    fig, ax = subplots(figsize=(11, 5))
    for x in x_d:
        ax.axvline(x, color="0.85", lw=0.6, zorder=0)
    lo, hi = 50 * (1 - band.level), 50 * (1 + band.level)
    ax.fill_between(band.x_m, MM * band.lower_m, MM * band.upper_m, color="tab:blue", alpha=0.25,
                    label=f"{100 * band.level:.0f} % band (quantiles {lo:g} %–{hi:g} %) under s_opt")
    ax.plot(band.x_m, MM * band.median_m, color="tab:blue", lw=1.2, label="median")
    ax.plot(np.broadcast_to(x_d, data.shape).ravel(), MM * data.ravel(), "o", ms=2.5, color="k", alpha=0.45,
            label=f"corrected static W ({data.shape[0]} spans)")
    ax.axhline(0.0, color="0.5", lw=0.6)
    ax.set_xlabel("x along the span [m]")
    ax.set_ylabel("CW deflection from the chord [mm]")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    return save_figure(fig, path)
