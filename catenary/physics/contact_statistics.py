"""Contact-force statistics of a high-speed run, as EN 50318 reports them.

The contact force is low-pass filtered at 20 Hz (zero-phase 4th-order Butterworth, applied to
the whole run before windowing), then over the analysis window (the central spans, away from
the section ends): mean Fm, standard deviation σ, statistical maximum and minimum Fm ± 3σ,
actual maximum and minimum of the filtered force, the largest uplift of a steady arm inside the
window, and the share of time without contact (unfiltered force = 0).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

from pathlib import Path

import numpy as np
from scipy.signal import butter, sosfiltfilt

from catenary.plumbing.plots import save_figure, subplots

from .dynamics import RunResult


@dataclass(frozen=True)
class ContactStatistics:
    """EN 50318-style figures of one run, forces in [N], uplift in [m], loss in [%]."""

    mean_force_n: float
    std_force_n: float
    statistical_max_n: float
    statistical_min_n: float
    max_force_n: float
    min_force_n: float
    max_support_uplift_m: float
    contact_loss_percent: float

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


def lowpass(force_n: np.ndarray, time_step_s: float, cutoff_hz: float = 20.0, order: int = 4) -> np.ndarray:
    """Zero-phase Butterworth low-pass of a uniformly sampled signal."""
    sos = butter(order, cutoff_hz, btype="low", fs=1.0 / time_step_s, output="sos")
    return sosfiltfilt(sos, force_n)


def filtered_window(run: RunResult, start_m: float, end_m: float, cutoff_hz: float = 20.0) -> np.ndarray:
    """The contact force of ``run`` filtered at ``cutoff_hz`` (over the whole run), at the time
    steps whose contact point lies in ``[start_m, end_m]`` [N]."""
    dt = float(run.time_s[1] - run.time_s[0])
    filtered = lowpass(run.contact_force_n, dt, cutoff_hz)
    window = (run.chainage_m >= start_m) & (run.chainage_m <= end_m)
    if not np.any(window):
        raise ValueError(f"no time step in the analysis window [{start_m}, {end_m}] m")
    return filtered[window]


def analysis_stop_m(mast_chainage_m: np.ndarray, last_mast: int) -> float:
    """Where a run whose statistics end at mast ``last_mast`` may stop: one span after that mast
    (the last mast of the section if there is none) [m]; pass it as ``stop_m`` to
    :func:`~catenary.physics.dynamics.run_pantograph`.

    The section keeps its run-out spans (the waves they reflect reach the window while the
    pantograph is still in it); only the simulated time after the pantograph has left the window
    is saved. Nothing after a step changes it, and the statistics read the window's steps
    through two things that look ahead: the zero-phase filter, whose backward pass forgets the
    run's end within ≈ 0.1 s at 20 Hz (a span takes ≈ 0.7 s at 300 km/h, ≈ 1e-15 of it is left);
    and the window's largest steady-arm uplift, which a mast reaches as the pantograph passes it
    (measured: ≈ 0.2 m after the mast), not a span later. On a 10-span section analysed
    between masts 3 and 7 it saves 20 % of the steps.
    """
    masts = np.asarray(mast_chainage_m, dtype=float)
    return float(masts[min(last_mast + 1, masts.size - 1)])


def contact_statistics(run: RunResult, start_m: float, end_m: float, mast_chainage_m: np.ndarray,
                       cutoff_hz: float = 20.0) -> ContactStatistics:
    """Statistics of ``run`` over chainages [start_m, end_m] (filtered at ``cutoff_hz``)."""
    f = filtered_window(run, start_m, end_m, cutoff_hz)
    window = (run.chainage_m >= start_m) & (run.chainage_m <= end_m)
    mean, std = float(f.mean()), float(f.std())
    masts = (mast_chainage_m >= start_m) & (mast_chainage_m <= end_m)
    uplift = float(run.support_uplift_m[:, masts].max()) if np.any(masts) else float("nan")
    return ContactStatistics(
        mean_force_n=mean, std_force_n=std, statistical_max_n=mean + 3 * std, statistical_min_n=mean - 3 * std,
        max_force_n=float(f.max()), min_force_n=float(f.min()), max_support_uplift_m=uplift,
        contact_loss_percent=100.0 * float(np.mean(run.contact_force_n[window] <= 0.0)),
    )


def en50318_table(stats: dict[int, ContactStatistics], ranges: dict[int, dict[str, list[float]]],
                  tolerance: float = 0.15):
    """Long table of every statistic beside its EN 50318 range, one row per (speed, quantity).

    ``within_range`` says whether the value lies in [min, max]; ``within_tolerance`` whether it
    lies within ``tolerance`` × the range's upper magnitude of it (the issue's 15 % plausibility
    band for a model whose reference inputs are not verified). Quantities without a range
    for that speed get empty range columns.
    """
    import pandas as pd

    rows = []
    for speed, stat in stats.items():
        limits = ranges.get(speed, {})
        for quantity, value in stat.as_dict().items():
            lo, hi = limits.get(quantity, (np.nan, np.nan))
            margin = tolerance * max(abs(lo), abs(hi)) if np.isfinite(hi) else np.nan
            rows.append({
                "speed_kmh": speed, "quantity": quantity, "value": value,
                "en50318_min": lo, "en50318_max": hi,
                "within_range": bool(lo <= value <= hi) if np.isfinite(hi) else None,
                "within_tolerance": bool(lo - margin <= value <= hi + margin) if np.isfinite(hi) else None,
            })
    return pd.DataFrame(rows)


def dynamics_figure(runs: dict, mast_chainage_m, window_m: tuple[float, float], title: str,
                    path: str | Path, cutoff_hz: float = 20.0) -> Path:
    """Contact force (raw and low-passed) and steady-arm uplift versus chainage, one colour
    per speed; ``runs`` maps a label (e.g. "300 km/h") to a RunResult."""
    fig, (ax_f, ax_u) = subplots(2, 1, figsize=(11, 7), sharex=True)
    for label, run in runs.items():
        dt = float(run.time_s[1] - run.time_s[0])
        line, = ax_f.plot(run.chainage_m, run.contact_force_n, lw=0.5, alpha=0.35, label=f"{label} (raw)")
        ax_f.plot(run.chainage_m, lowpass(run.contact_force_n, dt, cutoff_hz), lw=1.2, color=line.get_color(),
                  label=f"{label} (0–{cutoff_hz:g} Hz)")
        uplift = 1e3 * run.support_uplift_m
        nearest = np.argmin(np.abs(run.chainage_m[:, None] - np.asarray(mast_chainage_m)[None, :]), axis=1)
        ax_u.plot(run.chainage_m, uplift[np.arange(uplift.shape[0]), nearest], color=line.get_color(), label=label)
    for ax in (ax_f, ax_u):
        for k, x in enumerate(mast_chainage_m):
            ax.axvline(x, color="0.85", lw=0.6, zorder=0, label="masts" if k == 0 else None)
        ax.axvspan(*window_m, color="0.95", zorder=-1, label="analysis window")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    ax_f.set_ylabel("contact force [N]")
    ax_u.set_ylabel("uplift of the nearest steady arm [mm]")
    ax_u.set_xlabel("chainage [m] (shaded: analysis window)")
    ax_f.set_title(title)
    return save_figure(fig, Path(path))
