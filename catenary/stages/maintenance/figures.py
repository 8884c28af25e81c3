"""Figure of the maintenance stage (matplotlib, :func:`catenary.plumbing.plots.subplots`): plotting only.

:func:`chainage_figure` — along the chainage, each span's most likely deviation (the dropper
most likely out of tolerance: its posterior mean less nominal, with the 90 % interval), the
tolerance band, and the listed droppers marked.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from catenary.plumbing.plots import save_figure, subplots

__all__ = ["chainage_figure", "population_band_figure"]

MM = 1e3


def chainage_figure(posterior: pd.DataFrame, threshold: float, path: str | Path, title: str) -> Path:
    """Per span, the dropper most likely out of tolerance against its span's start chainage.

    Parameters
    ----------
    posterior : pandas.DataFrame
        ``posterior.parquet`` of one span type (:data:`~.runner.POSTERIOR_COLUMNS`).
    threshold : float
        The list's probability threshold (listed droppers drawn in red).
    path : str or pathlib.Path
        PNG file written.
    """
    droppers = posterior[posterior["input"].str.startswith("dropper_")]
    top = droppers.sort_values("p_out_of_tolerance", ascending=False, kind="stable").groupby("span_id").head(1)
    top = top.sort_values("start_chainage_m")
    x = top["start_chainage_m"].to_numpy(dtype=float)
    if not np.all(np.isfinite(x)):
        x = np.arange(len(top), dtype=float)
    dev = MM * (top["mean"] - top["nominal"]).to_numpy()
    lo = MM * (top["q05"] - top["nominal"]).to_numpy()
    hi = MM * (top["q95"] - top["nominal"]).to_numpy()
    listed = top["p_out_of_tolerance"].to_numpy() > threshold
    half = MM * float((top["upper"] - top["nominal"]).iloc[0]) if len(top) else np.nan
    fig, ax = subplots(figsize=(10, 4))
    for mask, colour, label in ((~listed, "0.35", "most likely deviation of the span, 90 % interval"),
                                (listed, "tab:red", f"listed: P(out of tolerance) > {threshold:g}")):
        if mask.any():
            # the interval drawn on its own: a skewed posterior's mean may lie outside its 5–95 % quantiles
            ax.vlines(x[mask], lo[mask], hi[mask], color=colour, lw=0.8)
            ax.plot(x[mask], dev[mask], "o", ms=3, color=colour, label=label)
    if np.isfinite(half):
        ax.axhspan(-half, half, color="tab:green", alpha=0.1, label=f"tolerance ±{half:g} mm")
    ax.axhline(0.0, color="k", lw=0.5)
    for row, xi, d in zip(top.itertuples(), x, dev):
        if row.p_out_of_tolerance > threshold:
            ax.annotate(row.input.split("_")[1], (xi, d), textcoords="offset points", xytext=(4, 4), fontsize=7,
                        color="tab:red")
    ax.set_xlabel("span start chainage [m]")
    ax.set_ylabel("dropper length − nominal [mm]")
    ax.set_title(title)
    ax.legend(loc="upper right", fontsize=8)
    return save_figure(fig, path)


def population_band_figure(bands, w_obs_m: np.ndarray, dropper_positions_m: np.ndarray, path: str | Path,
                           title: str) -> Path:
    """The prior band (Fig. 10) and the posterior band along the span, the measured W over them.

    Parameters
    ----------
    bands : PopulationBands or None
        :func:`~.population.population_bands`' output (None: a figure saying no band was asked for).
    w_obs_m : numpy.ndarray, shape (K, n)
        Measured W [m].
    dropper_positions_m : numpy.ndarray, shape (n,)
    path : str or pathlib.Path
    """
    fig, ax = subplots(figsize=(9, 4))
    if bands is None:
        ax.text(0.5, 0.5, "no posterior band: maintenance.band_draws_per_span is 0", ha="center", va="center")
        ax.set_axis_off()
        return save_figure(fig, path)
    p, q = bands.prior, bands.posterior
    ax.fill_between(p.x_m, MM * p.lower_m, MM * p.upper_m, color="tab:blue", alpha=0.2,
                    label=f"prior band {100 * p.level:.0f} % (identified laws, Fig. 10)")
    ax.fill_between(q.x_m, MM * q.lower_m, MM * q.upper_m, color="tab:orange", alpha=0.45,
                    label=f"posterior band {100 * q.level:.0f} % (the spans' posteriors)")
    ax.plot(q.x_m, MM * q.median_m, color="tab:orange", lw=1)
    xs = np.broadcast_to(dropper_positions_m, w_obs_m.shape)
    ax.plot(xs.ravel(), MM * w_obs_m.ravel(), ".", ms=2, color="k", label="measured W")
    cov = bands.coverage
    text = (f"width at the droppers: posterior / prior {cov['width_ratio'].min():.2f}–{cov['width_ratio'].max():.2f}\n"
            f"leave-one-out coverage {100 * cov['posterior_coverage_loo'].mean():.1f} % "
            f"(prior band {100 * cov['prior_coverage'].mean():.1f} %, nominal {100 * q.level:.0f} %)")
    ax.text(0.01, 0.02, text, transform=ax.transAxes, fontsize=8, va="bottom")
    ax.set_xlabel("abscissa from the left mast [m]")
    ax.set_ylabel("CW deflection from the chord [mm]")
    ax.set_title(title)
    ax.legend(loc="lower right", fontsize=8)
    return save_figure(fig, path)
