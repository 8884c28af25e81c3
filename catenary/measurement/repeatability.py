"""The measurement's repeatability, from spans measured by several runs.

A span measured ``k`` times (runs on both tracks, in both directions, on other days) gives ``k``
corrected W vectors of the same static geometry; what they differ by is the measurement's own
error — the sensor, the projection's local fits, what the correction leaves — whatever its
source. Pooled over the spans of a type, the within-span scatter

    R = Σ_spans Σ_runs (W_r − W̄)(W_r − W̄)ᵀ / Σ_spans (k − 1)

is an unbiased estimate of the covariance of one run's W error (9 × 9: the droppers of a span
share the two chord points, so their errors correlate). It replaces an assumed noise in the
identification: a span's averaged W carries ``R / k`` (:mod:`catenary.stages.identification.likelihood`).

That scatter also holds how the runs' corrections differ: runs in opposite directions are
corrected by different passes, and where a dropper hangs slack the measured height hardly sees
it, so that each direction's correction stops at another W there. The measurement's own
repeatability is therefore also estimated where the runs were measured: each run's measured W
minus what its own measuring pass gives over the runs' mean corrected W (the correction's
``residual_w*_m``), whose within-span scatter, pooled the same way, is ``M`` — the sensor, the
projection's local fits and nothing of the correction's inverse. On two runs in opposite
directions of 20 N2 and 20 N3 spans with 1 mm sensor noise, R gave 0.549 / 0.568 mm and M
0.478 / 0.458 mm, against 0.463 / 0.436 mm of planted noise as it reaches W. The
identification keeps R: the corrected W it fits carries the corrections' disagreement.

A span whose runs disagree beyond it — its ``Q = Σ_r (W_r − W̄)ᵀ R⁻¹ (W_r − W̄)``, χ² with
``(k − 1) n`` degrees of freedom, beyond the ``level`` Bonferroni-corrected over the spans — is
reported and left out of the identification (its geometry changed between runs, a run is wrong
there, or something the noise does not explain). R is estimated again without such spans until
the set settles, so that one bad span does not inflate it.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

__all__ = ["Repeatability", "estimate_repeatability", "read_noise", "w_columns"]

#: Fewer pooled degrees of freedom than this many per dropper: the full covariance is not
#: estimated, only its diagonal (each dropper's variance).
MIN_DOF_PER_DROPPER = 2


def w_columns(table: pd.DataFrame) -> list[str]:
    """The ``w1_m`` … ``wn_m`` columns of a table, in order."""
    cols = [c for c in table.columns if c.startswith("w") and c.endswith("_m") and c[1:-2].isdigit()]
    return sorted(cols, key=lambda c: int(c[1:-2]))


@dataclass
class Repeatability:
    """The repeatability of one span type's corrected W.

    Attributes
    ----------
    covariance_m2 : numpy.ndarray or None
        R, the covariance of one run's W error (n × n) [m²]; None when no span was measured twice.
    dof : int
        Pooled degrees of freedom Σ (k − 1).
    n_spans : int
        Spans with at least two converged runs that entered R.
    full : bool
        R is the full covariance (False: its diagonal only, too few degrees of freedom).
    spans : pandas.DataFrame
        One row per span with a converged run: ``span_id``, ``n_runs``, ``statistic`` (Q),
        ``dof``, ``p_value``, ``flagged`` (the runs disagree beyond the repeatability),
        ``max_difference_m`` (largest difference between two runs at a dropper).
    level : float
        Family-wise level of the flag.
    measured_covariance_m2 : numpy.ndarray or None
        M, the covariance of one run's measured W error (n × n) from the correction's
        ``residual_w*_m`` [m²]; None without two runs' residuals on a span.
    measured_dof : int
        Pooled degrees of freedom of M.
    """

    covariance_m2: np.ndarray | None
    dof: int
    n_spans: int
    full: bool
    spans: pd.DataFrame
    level: float
    measured_covariance_m2: np.ndarray | None = None
    measured_dof: int = 0

    @property
    def measured_std_m(self) -> np.ndarray | None:
        """Per-dropper standard deviation of one run's measured W error, M's diagonal [m]."""
        return None if self.measured_covariance_m2 is None else np.sqrt(np.diag(self.measured_covariance_m2))

    @property
    def measured_rms_m(self) -> float:
        """RMS over the droppers of one run's measured W error [m] (NaN without residuals)."""
        return (float("nan") if self.measured_covariance_m2 is None
                else float(np.sqrt(np.mean(np.diag(self.measured_covariance_m2)))))

    @property
    def std_m(self) -> np.ndarray | None:
        """Per-dropper standard deviation of one run's W error [m]."""
        return None if self.covariance_m2 is None else np.sqrt(np.diag(self.covariance_m2))

    @property
    def rms_m(self) -> float:
        """RMS over the droppers of one run's W error [m]."""
        return float("nan") if self.covariance_m2 is None else float(np.sqrt(np.mean(np.diag(self.covariance_m2))))

    def flagged(self) -> dict[str, str]:
        """span id → why its runs are not averaged (the flagged spans)."""
        out = {}
        for r in self.spans[self.spans["flagged"]].itertuples():
            out[str(r.span_id)] = (f"its {r.n_runs} runs disagree beyond the repeatability (Q = {r.statistic:.1f} for "
                                   f"{r.dof} degrees of freedom, p = {r.p_value:.2g} < {self.level:g} / "
                                   f"{len(self.spans)} spans; largest difference {1e3 * r.max_difference_m:.1f} mm)")
        return out

    def summary(self) -> pd.DataFrame:
        """Per dropper and for all droppers: the standard deviation of one run's corrected W error
        (``std_m``, R) and of its measured W error (``measured_std_m``, M) [m]."""
        n = 0 if self.covariance_m2 is None else self.covariance_m2.shape[0]
        measured = self.measured_std_m
        rows = [{"dropper": str(i + 1), "std_m": float(self.std_m[i]),
                 "measured_std_m": float("nan") if measured is None else float(measured[i])} for i in range(n)]
        rows.append({"dropper": "all", "std_m": self.rms_m, "measured_std_m": self.measured_rms_m})
        out = pd.DataFrame(rows, columns=["dropper", "std_m", "measured_std_m"])
        out["measured_dof"] = self.measured_dof
        out["n_spans"], out["dof"], out["full_covariance"] = self.n_spans, self.dof, self.full
        out["n_flagged"] = int(self.spans["flagged"].sum()) if len(self.spans) else 0
        return out

    def write(self, summary_path: str | Path, spans_path: str | Path, noise_path: str | Path) -> None:
        """``summary.csv``, ``spans.csv`` and ``noise.json`` (R, its degrees of freedom, its spans)."""
        for path in (summary_path, spans_path, noise_path):
            Path(path).parent.mkdir(parents=True, exist_ok=True)
        self.summary().to_csv(summary_path, index=False, float_format="%.6g")
        self.spans.to_csv(spans_path, index=False, float_format="%.6g")
        Path(noise_path).write_text(json.dumps({
            "covariance_m2": None if self.covariance_m2 is None else self.covariance_m2.tolist(),
            "dof": self.dof, "n_spans": self.n_spans, "full_covariance": self.full,
            "measured_covariance_m2": (None if self.measured_covariance_m2 is None
                                       else self.measured_covariance_m2.tolist()),
            "measured_dof": self.measured_dof,
            "flagged": self.flagged()}, indent=1) + "\n")


def estimate_repeatability(corrected: pd.DataFrame, *, level: float = 0.01, max_iterations: int = 10) -> Repeatability:
    """R and the per-span test from the converged runs of ``corrected`` (module docs).

    Parameters
    ----------
    corrected : pandas.DataFrame
        A span type's ``corrected.parquet``: ``span_id``, ``converged``, ``w1_m`` … (one row per
        span and run).
    level : float
        Family-wise level of the flag (Bonferroni over the spans measured twice or more).
    max_iterations : int
        Re-estimations of R without the flagged spans.
    """
    cols = w_columns(corrected)
    ok = corrected[corrected["converged"].astype(bool)]
    groups = {str(k): g[cols].to_numpy(dtype=float) for k, g in ok.groupby("span_id", sort=False)}
    repeated = {k: w for k, w in groups.items() if w.shape[0] >= 2}
    n = len(cols)
    rows = []
    if not repeated:
        spans = pd.DataFrame({"span_id": list(groups), "n_runs": [w.shape[0] for w in groups.values()],
                              "statistic": np.nan, "dof": 0, "p_value": np.nan, "flagged": False,
                              "max_difference_m": np.nan})
        return Repeatability(None, 0, 0, False, spans, level)
    flagged: set[str] = set()
    for _ in range(max_iterations):
        used = {k: w for k, w in repeated.items() if k not in flagged}
        dof = sum(w.shape[0] - 1 for w in used.values())
        scatter = sum((w - w.mean(axis=0)).T @ (w - w.mean(axis=0)) for w in used.values())
        covariance = scatter / max(dof, 1)
        full = dof >= MIN_DOF_PER_DROPPER * n
        if not full:
            covariance = np.diag(np.diag(covariance))
        inverse = np.linalg.inv(covariance)
        threshold = level / len(repeated)
        rows = []
        for k, w in groups.items():
            if w.shape[0] < 2:
                rows.append({"span_id": k, "n_runs": 1, "statistic": np.nan, "dof": 0, "p_value": np.nan,
                             "flagged": False, "max_difference_m": np.nan})
                continue
            d = w - w.mean(axis=0)
            q = float(np.einsum("ri,ij,rj->", d, inverse, d))
            df = (w.shape[0] - 1) * n
            p = float(stats.chi2.sf(q, df))
            rows.append({"span_id": k, "n_runs": w.shape[0], "statistic": q, "dof": df, "p_value": p,
                         "flagged": p < threshold, "max_difference_m": float(np.max(np.ptp(w, axis=0)))})
        new = {r["span_id"] for r in rows if r["flagged"]}
        if new == flagged:
            break
        flagged = new
    spans = pd.DataFrame(rows, columns=["span_id", "n_runs", "statistic", "dof", "p_value", "flagged",
                                        "max_difference_m"])
    measured, measured_dof = _measured_scatter(ok, n, flagged)
    return Repeatability(covariance, dof, len(used), full, spans, level, measured, measured_dof)


def _measured_scatter(ok: pd.DataFrame, n: int, flagged: set[str]) -> tuple[np.ndarray | None, int]:
    """M, the pooled within-span scatter of the runs' ``residual_w*_m`` (module docs), and its
    degrees of freedom; (None, 0) without two runs' residuals on any span. Flagged spans are
    left out, as from R."""
    cols = [f"residual_w{i + 1}_m" for i in range(n)]
    if not set(cols) <= set(ok.columns):
        return None, 0
    scatter, dof = np.zeros((n, n)), 0
    for k, g in ok.groupby("span_id", sort=False):
        e = g[cols].to_numpy(dtype=float)
        e = e[np.all(np.isfinite(e), axis=1)]
        if str(k) in flagged or e.shape[0] < 2:
            continue
        d = e - e.mean(axis=0)
        scatter += d.T @ d
        dof += e.shape[0] - 1
    return (scatter / dof, dof) if dof else (None, 0)


def read_noise(path: str | Path) -> tuple[np.ndarray | None, dict[str, str]]:
    """R [m²] (None when no span was measured twice) and the flagged spans from ``noise.json``."""
    raw = json.loads(Path(path).read_text())
    cov = raw.get("covariance_m2")
    return (None if cov is None else np.asarray(cov, dtype=float)), dict(raw.get("flagged") or {})
