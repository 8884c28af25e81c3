"""Tables of the contact-force replicates: per-criterion statistics and violation probabilities.

Probabilities of exceeding a limit are proportions of replicates with their exact
(Clopper–Pearson) 95 % binomial confidence interval: with k violations in n sections the
interval is [B(0.025; k, n − k + 1), B(0.975; k + 1, n − k)] (B the Beta quantile), which
never excludes what the replicates cannot exclude (0 of 20 gives [0, 17 %]).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import stats

from .runs import CRITERIA, VIOLATIONS
from .settings import Limits

__all__ = ["clopper_pearson", "criteria_summary", "quantile_interval", "tolerance_table",
           "violation_labels"]


def violation_labels(limits: Limits, speed_kmh: float) -> dict[str, str]:
    """What each limit violation of :data:`VIOLATIONS` is at ``speed_kmh``, in words and
    EN 50367's terms ("σ_F above 0.3 F_m")."""
    return {"mean_force_above_target": f"F_m above the target {limits.mean_force_target_n(speed_kmh):.0f} N",
            "std_above_limit": f"σ_F above {limits.max_std_fraction:g} F_m",
            "statistical_min_below_limit": f"F_m − 3σ_F at or below {limits.min_statistical_n:g} N",
            "uplift_above_limit": f"steady-arm uplift above {1e3 * limits.max_uplift_m:.0f} mm",
            "contact_lost": "contact lost"}


def clopper_pearson(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """Exact binomial confidence interval of a proportion k/n."""
    alpha = 1.0 - level
    low = 0.0 if k == 0 else float(stats.beta.ppf(alpha / 2, k, n - k + 1))
    high = 1.0 if k == n else float(stats.beta.ppf(1 - alpha / 2, k + 1, n - k))
    return low, high


def quantile_interval(values: np.ndarray, p: float, level: float = 0.95) -> tuple[float, float]:
    """Distribution-free confidence interval of the p-quantile: order statistics X(l) ≤ X(u)
    with P(l ≤ B < u) ≥ level for B ~ Binomial(n, p), as symmetric in the tails as possible;
    an end is ±inf when n is too small for it (the 95 % quantile of 20 values has no upper end
    above the maximum: reported as the maximum's limit, +inf)."""
    x = np.sort(np.asarray(values, dtype=float))
    n = x.size
    alpha = 1.0 - level
    cdf = stats.binom.cdf(np.arange(n + 1), n, p)            # P(B ≤ j)
    lower = int(np.searchsorted(cdf, alpha / 2, side="right"))           # smallest l with P(B < l) ≤ α/2
    upper = int(np.searchsorted(cdf, 1.0 - alpha / 2, side="left")) + 1   # smallest u with P(B ≥ u) ≤ α/2
    low = x[lower - 1] if lower >= 1 else -np.inf
    high = x[upper - 1] if upper <= n else np.inf
    return float(low), float(high)


def criteria_summary(replicates: pd.DataFrame) -> pd.DataFrame:
    """Per speed and criterion: mean, σ, 5/50/95 % quantiles over the replicates; per speed and
    limit: the probability of violating it with its 95 % interval."""
    rows = []
    for speed, group in replicates.groupby("speed_kmh"):
        n = len(group)
        for c in CRITERIA:
            v = group[c].to_numpy(float)
            q = np.quantile(v, [0.05, 0.5, 0.95])
            q95_low, q95_high = quantile_interval(v, 0.95)
            rows.append(dict(speed_kmh=speed, quantity=c, n_replicates=n, mean=v.mean(), std=v.std(ddof=1),
                             q05=q[0], q50=q[1], q95=q[2], q95_low=q95_low, q95_high=q95_high, probability=np.nan,
                             probability_low=np.nan, probability_high=np.nan))
        for name in VIOLATIONS:
            k = int(group[name].sum())
            low, high = clopper_pearson(k, n)
            rows.append(dict(speed_kmh=speed, quantity=name, n_replicates=n, mean=np.nan, std=np.nan, q05=np.nan,
                             q50=np.nan, q95=np.nan, q95_low=np.nan, q95_high=np.nan, probability=k / n,
                             probability_low=low, probability_high=high))
    return pd.DataFrame(rows)


def tolerance_table(replicates: pd.DataFrame, sigma_per_tolerance: float) -> pd.DataFrame:
    """Per tolerance case: the dropper tolerance and T_MW spread, σ_F statistics and each
    limit's violation probability with its 95 % interval."""
    rows = []
    for case, group in replicates.groupby("case", sort=False):
        if not case.startswith("tol_"):
            continue
        tol_mm, sigma_n = case[4:].split("_")
        n = len(group)
        row = dict(case=case, dropper_tolerance_mm=float(tol_mm.removesuffix("mm")),
                   dropper_sigma_mm=float(tol_mm.removesuffix("mm")) / sigma_per_tolerance,
                   messenger_tension_sigma_n=float(sigma_n.removesuffix("N")), speed_kmh=float(group["speed_kmh"].iloc[0]),
                   n_replicates=n, std_force_mean_n=group["std_force_n"].mean(),
                   std_force_q95_n=group["std_force_n"].quantile(0.95),
                   statistical_min_q05_n=group["statistical_min_n"].quantile(0.05))
        for name in VIOLATIONS:
            k = int(group[name].sum())
            low, high = clopper_pearson(k, n)
            row[f"p_{name}"], row[f"p_{name}_low"], row[f"p_{name}_high"] = k / n, low, high
        rows.append(row)
    return pd.DataFrame(rows).sort_values(["messenger_tension_sigma_n", "dropper_tolerance_mm"]).reset_index(drop=True)
