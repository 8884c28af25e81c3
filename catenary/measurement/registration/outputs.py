"""What the registration writes and what the projection reads back.

``registration/masts.csv`` (:data:`~.runner.MAST_COLUMNS`: one row per run and mast, with its
status and residual), ``registration/sections.csv`` (:data:`~.runner.SECTION_COLUMNS`: per run
and section, the map, the counts, the status and the reason of a refusal),
``registration/masts_table.csv`` (the mast table registered onto: the user's, or the one found
from the trace when none is given) and ``registration/residuals.png`` (each matched mast's
residual along the line, per run: a mast table's errors, or a drift the map does not follow).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from .mapping import ChainageMap
from .runner import MAST_COLUMNS, SECTION_COLUMNS, RunRegistration

__all__ = ["read_registration", "registration_figure", "write_registration"]


def write_registration(runs: list[RunRegistration], masts_path: str | Path, sections_path: str | Path) -> None:
    """Write every run's registered masts and sections (CSV, one row per run and mast / section)."""
    masts = pd.concat([r.masts for r in runs], ignore_index=True) if runs else pd.DataFrame(columns=MAST_COLUMNS)
    sections = (pd.concat([r.sections for r in runs], ignore_index=True) if runs
                else pd.DataFrame(columns=SECTION_COLUMNS))
    for frame, path in ((masts, masts_path), (sections, sections_path)):
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        frame.to_csv(path, index=False, lineterminator="\n", float_format="%.6f")


def read_registration(masts_path: str | Path, sections_path: str | Path, directions: dict) -> dict[str, RunRegistration]:
    """The runs' registrations as :func:`write_registration` wrote them, keyed by run id
    (``directions``: run id → direction of travel)."""
    masts = pd.read_csv(masts_path, dtype={"run_id": str, "section_id": str, "mast_id": str, "span_type": str},
                        keep_default_na=False,
                        na_values={c: [""] for c in MAST_COLUMNS if c.endswith("_m") or c == "corr_next"})
    sections = pd.read_csv(sections_path, dtype={"run_id": str, "section_id": str, "reason": str,
                                                 "coefficients": str}, keep_default_na=False,
                           na_values={c: [""] for c in SECTION_COLUMNS if c.endswith("_m") or c == "scale"})
    out = {}
    for run_id, rows in sections.groupby("run_id", sort=False):
        maps = {}
        for r in rows.itertuples():
            if r.coefficients:
                coefficients = np.array([float(v) for v in str(r.coefficients).split()])
                maps[r.section_id] = ChainageMap(coefficients, float(r.reference_m))
        out[str(run_id)] = RunRegistration(str(run_id), int(directions[run_id]),
                                           masts[masts["run_id"] == run_id].reset_index(drop=True),
                                           rows.reset_index(drop=True), maps)
    return out


def registration_figure(masts: pd.DataFrame, path: str | Path) -> None:
    """Residual of each matched mast along the line, one panel row per run; masts missing from or
    extra in the table marked."""
    from catenary.plumbing.plots import save_figure, subplots

    runs = list(dict.fromkeys(masts["run_id"]))
    fig, axes = subplots(max(len(runs), 1), 1, figsize=(10, 2.4 * max(len(runs), 1)), squeeze=False, sharex=True)
    for ax, run in zip(axes[:, 0], runs):
        part = masts[masts["run_id"] == run]
        matched = part[part["status"] == "matched"]
        ax.plot(matched["table_chainage_m"], 1e2 * matched["residual_m"], "o", ms=3, label="matched (trace − map)")
        for status, marker in (("missing_from_table", "v"), ("extra_in_table", "x"), ("table_only", "s")):
            rows = part[part["status"] == status]
            if len(rows):
                x = rows["chainage_m"].where(rows["chainage_m"].notna(), rows["table_chainage_m"])
                ax.plot(x, np.zeros(len(rows)), marker, ms=6, label=status.replace("_", " "))
        ax.axhline(0.0, color="0.6", lw=0.8)
        ax.set_ylabel(f"{run}\nresidual [cm]")
        ax.legend(fontsize=7, loc="upper right", ncols=4)
    axes[-1, 0].set_xlabel("chainage of the mast table [m]")
    fig.suptitle("Registration of the mast table onto each run's trace")
    save_figure(fig, path)
