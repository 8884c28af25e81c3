"""Per span: explained by the final model, or not — and sections whose spans depart together.

The diagnosis names effects from its list; a real line holds things no list foresees, mostly
local (equipment clamped on the CW, a kinked wire, a hard spot) or shared by a section (a
tensioning device's weights misadjusted). Nine free dropper lengths absorb almost any shape seen
at nine points, so a span is judged on all its data under the final model (the identified laws,
the named effects, the measurement's noise and the correction's model error):

* **W at the droppers** against the final model's law of W (the Gaussian of its model sample,
  mean m and covariance Σ, plus the correction's model-error budget of the span): the
  Mahalanobis distance of ``W − m`` after up to ``max_faulty_droppers`` droppers are set free,
  each at the cost of its prior log-odds (a dropper made or fitted wrong is in the model — the
  maintenance stage's fault component — and must stay actionable as "shorten dropper i", not
  become unexplained; :func:`w_tests`). Its law under the model is simulated (``w_draws`` draws
  of ``N(m, Σ)``); beyond the simulation's reach, a χ² bound (conservative, valid);
* **the profile between the droppers** (:mod:`.profile_check`);
* the two, independent under the model, combine as ``1 − (1 − min)²`` (Šidák: uniform).

**Sections.** A fault shared by a section (its tensioning device) moves every span a little,
none enough alone. The mean residual ``r̄`` of a section's spans (the individually unexplained
ones left out, clear dropper faults removed) is tested against its law under the model,
``V = (n Σ + P (C + Cᵀ)) / n² · (1 − n/ν)``, P the section's pairs of spans sharing a mast and C
the covariance their shared ΔH gives (``σ²_ΔH ∂W/∂ΔH_right ∂W/∂ΔH_leftᵀ``): ``r̄ᵀ V⁻¹ r̄ ~ χ²_n``.
Its T_MW offset is the generalised least-squares fit of ``∂m/∂T_MW`` to ``r̄``, with its standard
error; when what remains is within the model (χ²_{n−1} at the diagnosis' level) the section's
departure *is* a tension offset, and the maintenance list names its tensioning device once.

**False-discovery rate.** The spans' and the sections' p-values enter one Benjamini–Hochberg
procedure at ``fdr`` (its q-values): on a line where the model holds, the chance that anything
at all is flagged is at most ``fdr``. A span is *unexplained* when its own q-value or its
section's is below ``fdr``.

One module, one concern: the per-span verdict (its W test, the sections, the FDR and the table
the diagnosis writes); the profile test is :mod:`.profile_check`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import combinations

import numpy as np
import pandas as pd
from scipy import stats

from .profile_check import ProfileSettings

__all__ = ["SECTION_COLUMNS", "SPAN_COLUMNS", "SpanCheck", "SpanCheckSettings", "WLaw", "benjamini_hochberg",
           "check_spans", "fault_subsets", "section_tests", "w_law", "w_tests"]

#: Columns of ``diagnosis/spans.csv``.
SPAN_COLUMNS = ("span_id", "section_id", "start_chainage_m", "end_chainage_m", "p_value", "q_value", "unexplained",
                "group", "p_w", "p_profile", "p_global", "p_local", "peak_chainage_m", "peak_size_mm",
                "peak_load_n", "bays_not_scanned", "why", "explained_by")
#: Columns of ``diagnosis/sections.csv``.
SECTION_COLUMNS = ("section_id", "n_spans", "statistic", "p_value", "q_value", "unexplained",
                   "messenger_tension_offset_n", "messenger_tension_offset_se_n", "p_rest", "tension_offset")


@dataclass(frozen=True)
class SpanCheckSettings:
    """Settings of the per-span check (config ``diagnosis.spans`` with ``diagnosis.fdr``).

    Attributes
    ----------
    fdr : float
        False-discovery rate of the Benjamini–Hochberg procedure.
    max_faulty_droppers : int
        Droppers per span set free before W is tested (faults the maintenance stage acts on).
    fault_probability : float
        Prior probability that a dropper was made or fitted wrong (the maintenance stage's): its
        log-odds are what setting a dropper free costs.
    w_draws : int
        Draws of the model's law of W for the W test's null law.
    min_section_spans : int
        Sections with fewer tested spans are not tested as a group.
    level : float
        Level at which a section's departure left after its T_MW offset is still a departure.
    seed : int
    profile : ProfileSettings
    """

    fdr: float = 0.05
    max_faulty_droppers: int = 2
    fault_probability: float = 0.01
    w_draws: int = 20000
    min_section_spans: int = 3
    level: float = 0.01
    seed: int = 23
    profile: ProfileSettings = field(default_factory=ProfileSettings)


@dataclass(frozen=True)
class WLaw:
    """The final model's law of one span type's W and its sensitivities at the laws' means.

    Attributes
    ----------
    mean_m : numpy.ndarray, shape (n,)
    covariance_m2 : numpy.ndarray, shape (n, n)
        Of the model's W plus the measurement error the data carry (noise, model-error budget).
    dropper_m_m : numpy.ndarray, shape (n, n)
        ∂W/∂L_i, one column per dropper [m/m].
    tension_m_n : numpy.ndarray, shape (n,)
        ∂m/∂T_MW [m/N].
    system_height_left_m_m, system_height_right_m_m : numpy.ndarray, shape (n,)
        ∂W/∂ΔH at the span's left and right mast [m/m].
    system_height_std_m : float
        σ of the ΔH law [m].
    """

    mean_m: np.ndarray
    covariance_m2: np.ndarray
    dropper_m_m: np.ndarray
    tension_m_n: np.ndarray
    system_height_left_m_m: np.ndarray
    system_height_right_m_m: np.ndarray
    system_height_std_m: float


def w_law(model, means: np.ndarray, sigmas: np.ndarray, mean_m: np.ndarray, covariance_m2: np.ndarray) -> WLaw:
    """A :class:`WLaw` from a fitted law of W (``mean_m``, ``covariance_m2``: the model sample's
    Gaussian plus the data's measurement error) and the laws' ``means`` / ``sigmas`` (design
    order: droppers, T_MW, ΔH), the sensitivities by central differences of the fast span
    ``model`` (:class:`~catenary.physics.fast.FastSpanModel`) at the means (W is linear in the lengths
    and ΔH; the T_MW step, 50 N, is 2.5e-3 of the tension)."""
    n = model.n_droppers
    lengths, t_mw, dh = means[:n], float(means[n]), float(means[n + 1])

    def w(l_m=lengths, t=t_mw, left=dh, right=dh) -> np.ndarray:
        return model.evaluate(np.atleast_2d(l_m), [t], [left], [right]).w_m[0]

    h = 1e-3
    droppers = np.column_stack([(w(lengths + h * e) - w(lengths - h * e)) / (2 * h) for e in np.eye(n)])
    return WLaw(mean_m=np.asarray(mean_m, dtype=float), covariance_m2=np.asarray(covariance_m2, dtype=float),
                dropper_m_m=droppers, tension_m_n=(w(t=t_mw + 50.0) - w(t=t_mw - 50.0)) / 100.0,
                system_height_left_m_m=(w(left=dh + h) - w(left=dh - h)) / (2 * h),
                system_height_right_m_m=(w(right=dh + h) - w(right=dh - h)) / (2 * h),
                system_height_std_m=float(sigmas[n + 1]))


def fault_subsets(n: int, max_faults: int) -> list[tuple[int, ...]]:
    """Every set of at most ``max_faults`` of ``n`` droppers, the empty one first."""
    return [s for k in range(max_faults + 1) for s in combinations(range(n), k)]


def _whitened_projectors(law: WLaw, subsets: list) -> tuple[np.ndarray, list]:
    """``L⁻¹`` (Σ = L Lᵀ) and, per subset, an orthonormal basis of its whitened fault directions."""
    chol = np.linalg.cholesky(law.covariance_m2)
    inv = np.linalg.inv(chol)
    g = inv @ law.dropper_m_m
    bases = [np.linalg.qr(g[:, list(s)])[0] if s else np.zeros((g.shape[0], 0)) for s in subsets]
    return inv, bases


def _min_distance(z: np.ndarray, bases: list, penalty: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per whitened residual row of ``z``: the smallest penalised squared distance after removing
    each subset's directions, and which subset gave it."""
    total = np.einsum("ij,ij->i", z, z)
    d = np.stack([total - (np.einsum("ij,jk->ik", z, q) ** 2).sum(axis=1) if q.shape[1] else total
                  for q in bases], axis=1) + penalty[None, :]
    return d.min(axis=1), d.argmin(axis=1)


def w_tests(data_w_m: np.ndarray, law: WLaw, settings: SpanCheckSettings) -> tuple[np.ndarray, np.ndarray]:
    """The W test of every span (module docs): p-value, and the residual with its faults removed,
    shape (K,) and (K, n).

    The statistic is the squared Mahalanobis distance after the best set of at most
    ``max_faulty_droppers`` droppers is set free, each free dropper costing its prior log-odds
    ``2 ln((1 − f)/f)`` (f the fault probability: 9.2 at 1 %) — a dropper is taken as faulty
    when that explains more than the model expects a fault to be rare. Its law under the model is
    simulated (no fault: the p-value is exactly uniform on spans of the law; a span with one or
    two faults of a few centimetres gets p ≈ 0.05 or 0.005, far from a false-discovery line).
    Beyond the simulation's reach, the χ² bound with ``n − max_faulty_droppers`` degrees of
    freedom of the penalised statistic less its largest penalty (valid, conservative)."""
    n = law.mean_m.size
    subsets = fault_subsets(n, settings.max_faulty_droppers)
    inv, bases = _whitened_projectors(law, subsets)
    penalty = 2.0 * np.log((1.0 - settings.fault_probability) / settings.fault_probability) * np.array(
        [len(q) for q in subsets], dtype=float)
    r = np.asarray(data_w_m, dtype=float) - law.mean_m
    d_obs, best = _min_distance(r @ inv.T, bases, penalty)
    rng = np.random.default_rng(settings.seed)
    null = np.sort(_min_distance(rng.standard_normal((settings.w_draws, n)), bases, penalty)[0])
    count = null.size - np.searchsorted(null, d_obs, side="left")
    bound = stats.chi2.sf(d_obs - penalty.max(), n - settings.max_faulty_droppers)
    p = np.where(count >= 10, (count + 1) / (null.size + 1), np.minimum(bound, 1.0))
    cleaned = r.copy()
    w_inv = np.linalg.inv(law.covariance_m2)
    for k in range(r.shape[0]):
        s = subsets[best[k]]
        if s:
            g = law.dropper_m_m[:, list(s)]
            cleaned[k] = r[k] - g @ np.linalg.solve(g.T @ w_inv @ g, g.T @ w_inv @ r[k])
    return p, cleaned


def section_tests(residual_m: np.ndarray, section_ids: np.ndarray, pairs: np.ndarray, law: WLaw, n_total: int,
                  settings: SpanCheckSettings, use: np.ndarray | None = None) -> pd.DataFrame:
    """The sections' shared departure (module docs), one row per tested section.

    Parameters
    ----------
    residual_m : numpy.ndarray, shape (K, n)
        ``W − m`` of every span, clear faults removed [m].
    section_ids : numpy.ndarray, shape (K,)
    pairs : numpy.ndarray, shape (P, 2)
        Rows sharing a mast, the left span first.
    n_total : int
        Spans the law was fitted to (a section holding more than half of them is not tested: the
        law's free means are fitted to its spans' mean).
    use : numpy.ndarray of bool, optional
        Spans a section's mean reads (default all).
    """
    use = np.ones(residual_m.shape[0], dtype=bool) if use is None else np.asarray(use, dtype=bool)
    sigma = law.covariance_m2
    c = law.system_height_std_m ** 2 * np.outer(law.system_height_right_m_m, law.system_height_left_m_m)
    pairs = np.asarray(pairs, dtype=int).reshape(-1, 2)
    rows = []
    for section in pd.unique(section_ids):
        members = np.flatnonzero((section_ids == section) & use)
        n = members.size
        if n < settings.min_section_spans or n > 0.5 * n_total:
            continue          # too few spans, or half the line or more: its mean is the line's, fitted
        inside = np.isin(pairs, members).all(axis=1).sum() if pairs.size else 0
        v = (n * sigma + inside * (c + c.T)) / n ** 2 * max(1.0 - n / max(n_total, 1), 1e-3)
        mean = residual_m[members].mean(axis=0)
        v_inv = np.linalg.inv(v)
        q = float(mean @ v_inv @ mean)
        g = law.tension_m_n
        info = float(g @ v_inv @ g)
        offset = float(g @ v_inv @ mean) / info
        rest = q - offset ** 2 * info
        p_rest = float(stats.chi2.sf(rest, mean.size - 1))
        rows.append({"section_id": section, "n_spans": n, "statistic": q,
                     "p_value": float(stats.chi2.sf(q, mean.size)), "messenger_tension_offset_n": offset,
                     "messenger_tension_offset_se_n": 1.0 / np.sqrt(info), "p_rest": p_rest,
                     "tension_offset": bool(p_rest > settings.level)})
    return pd.DataFrame(rows, columns=[c for c in SECTION_COLUMNS if c not in ("q_value", "unexplained")])


def benjamini_hochberg(p_values: np.ndarray) -> np.ndarray:
    """Benjamini–Hochberg adjusted p-values (q-values) of independent or positively dependent tests."""
    p = np.asarray(p_values, dtype=float)
    m = p.size
    if m == 0:
        return p.copy()
    order = np.argsort(p)
    ranked = p[order] * m / np.arange(1, m + 1)
    q = np.minimum.accumulate(ranked[::-1])[::-1]
    out = np.empty(m)
    out[order] = np.minimum(q, 1.0)
    return out


@dataclass
class SpanCheck:
    """The per-span check of one span type: ``spans`` (:data:`SPAN_COLUMNS`), ``sections``
    (:data:`SECTION_COLUMNS`) and the noise the profile test read."""

    spans: pd.DataFrame
    sections: pd.DataFrame
    noise: object = None

    @property
    def unexplained(self) -> np.ndarray:
        return self.spans["unexplained"].to_numpy(dtype=bool)

    @property
    def n_unexplained(self) -> int:
        return int(self.unexplained.sum())

    @property
    def departing(self) -> np.ndarray:
        """Spans the final model does not explain, or only with a local effect of one's own: left
        out of the laws and of the diagnosis' verdicts."""
        by = self.spans["explained_by"].fillna("").astype(str) if "explained_by" in self.spans else ""
        return self.unexplained | (np.asarray(by) != "")


def _why(row, section_row) -> str:
    reasons = []
    if row["q_span"] < row["fdr"]:
        if row["p_profile"] <= row["p_w"]:
            reasons.append(f"its profile departs from the model at chainage {row['peak_chainage_m']:.1f} m "
                           f"({row['peak_size_mm']:+.1f} mm; a point load of {row['peak_load_n']:.0f} N would "
                           "bend the CW so)")
        else:
            reasons.append("its W at the droppers lies beyond the model's law, even with two droppers set free")
    if section_row is not None:
        what = (f"a T_MW offset of {section_row['messenger_tension_offset_n']:+.0f} ± "
                f"{section_row['messenger_tension_offset_se_n']:.0f} N"
                if section_row["tension_offset"] else "a shared departure that is not a T_MW offset")
        reasons.append(f"section {section_row['section_id']}'s spans depart together: {what}")
    return "; ".join(reasons)


def check_spans(spans: pd.DataFrame, data_w_m: np.ndarray, law: WLaw, profile: pd.DataFrame | None,
                pairs: np.ndarray, settings: SpanCheckSettings) -> SpanCheck:
    """The per-span check (module docs).

    Parameters
    ----------
    spans : pandas.DataFrame
        One row per span, in the rows' order of ``data_w_m``: ``span_id``, ``section_id``,
        ``start_chainage_m``, ``end_chainage_m``.
    data_w_m : numpy.ndarray, shape (K, n)
        The spans' corrected W [m].
    law : WLaw
        The final model's law of W.
    profile : pandas.DataFrame or None
        :func:`.profile_check.profile_tests`' table (any order; spans missing from it have no
        profile test).
    pairs : numpy.ndarray, shape (P, 2)
        Rows of ``data_w_m`` sharing a mast, left span first.
    settings : SpanCheckSettings
    """
    k = data_w_m.shape[0]
    p_w, cleaned = w_tests(data_w_m, law, settings)
    table = spans[["span_id", "section_id", "start_chainage_m", "end_chainage_m"]].reset_index(drop=True).copy()
    table["p_w"] = p_w
    prof = (profile.set_index("span_id").reindex(table["span_id"]) if profile is not None and len(profile)
            else pd.DataFrame(index=table["span_id"], columns=["p_profile", "p_global", "p_local", "peak_x_m",
                                                               "peak_height_m", "peak_load_n", "bays_not_scanned"]))
    for column in ("p_profile", "p_global", "p_local", "peak_load_n", "bays_not_scanned"):
        table[column] = prof[column].to_numpy(dtype=float)
    table["peak_chainage_m"] = table["start_chainage_m"] + prof["peak_x_m"].to_numpy(dtype=float)
    table["peak_size_mm"] = 1e3 * prof["peak_height_m"].to_numpy(dtype=float)
    p_min = np.fmin(table["p_w"].to_numpy(), table["p_profile"].to_numpy())
    tested = np.isfinite(table["p_profile"].to_numpy())
    table["p_value"] = np.where(tested, 1.0 - (1.0 - p_min) ** 2, table["p_w"])
    # Sections: their spans' mean residual, spans alone already beyond the model left out (a
    # first BH pass over the spans alone decides which), clear faults removed.
    alone = benjamini_hochberg(table["p_value"].to_numpy()) < settings.fdr
    sections = section_tests(cleaned, table["section_id"].to_numpy(dtype=object), pairs, law, k, settings,
                             use=~alone)
    q = benjamini_hochberg(np.r_[table["p_value"].to_numpy(), sections["p_value"].to_numpy()])
    table["q_value"] = q[:k]
    sections["q_value"] = q[k:]
    sections["unexplained"] = sections["q_value"] < settings.fdr
    flagged = set(sections.loc[sections["unexplained"], "section_id"])
    table["group"] = np.where(table["section_id"].isin(flagged), table["section_id"], "")
    table["unexplained"] = (table["q_value"] < settings.fdr) | table["section_id"].isin(flagged)
    table["explained_by"] = ""
    by_section = sections.set_index("section_id")
    table["why"] = [_why({**row, "q_span": row["q_value"], "fdr": settings.fdr},
                         by_section.loc[row["section_id"]].to_dict() | {"section_id": row["section_id"]}
                         if row["section_id"] in flagged else None) if row["unexplained"] else ""
                    for row in table.to_dict("records")]
    return SpanCheck(table.reindex(columns=list(SPAN_COLUMNS)), sections.reindex(columns=list(SECTION_COLUMNS)))
