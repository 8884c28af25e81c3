"""Effects of one's own that act on a few spans: fitted span by span where the model fails.

A local anomaly (equipment clamped on the CW, a kinked wire) is in a few spans, at one point of
each: the law of W over the whole line hardly changes, but the profile of each span that holds
one departs from the model between its droppers (:mod:`.profile_check`). An effect of
``scope="span"`` (:mod:`catenary.physics.effects`, a user's module) is therefore tested where the check
found such spans, as the built-ins are on the line (screen, refit, test, add, show the gap):

1. **screen**: the spans the final model does not explain, alone (not a section's group);
2. **refit**: the effect's magnitudes fitted to the span's whole profile: the span hangs in the
   line at its type's design (:func:`span_in_line`), the effect is applied to it by its own
   function, and the static FE model gives the change it makes to the CW along the span; the
   change's part the correction absorbs (its heights at the masts and droppers, then what the
   base holds) is removed, as from the residual, and the rest fitted by least squares to the
   whitened residual: a coarse grid over a ``position`` parameter with the other magnitudes
   scaled linearly, then Nelder–Mead on all of them; then the same through the correction's
   measuring pass (its change with the effect), polished from there;
3. **test**: ``LR = (RSS₀ − RSS₁)/σ²``, χ² with the magnitudes' count as degrees of freedom (a
   searched position makes it liberal; the decision reads the next point too), standard errors
   from the Gauss–Newton information;
4. **add**: the span is *explained by the effect* when the effect is significant at the
   diagnosis' level and the profile left with it is within the model (its global and local
   p-values both above the level): the gap — the spans unexplained — shrinks by those spans.

One module, one concern: the per-span fit of a user's local effect.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import optimize, stats

from catenary.physics.config import Catenary, SpanType
from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.physics.effects import EFFECTS, Effect, SpanParameters
from catenary.physics.measuring import measuring_pass
from catenary.physics.section import Section, uniform_section
from catenary.physics.static import solve_static
from .profile_check import (Influence, ProfileNoise, ProfileSettings, _fit_span, _scan, _span_data,
                            hunter_max_normal_sf, knots_of, prewhiten, scan_positions)

__all__ = ["SPAN_EFFECT_COLUMNS", "MeasuringSetup", "SpanEffectFit", "fit_span_effect", "span_candidates",
           "span_effect_fitter", "span_in_line", "test_span_effects"]

#: Columns of ``diagnosis/span_effects.csv``.
SPAN_EFFECT_COLUMNS = ("span_id", "effect", "parameters", "lr_statistic", "p_value", "p_global_after",
                       "p_local_after", "explained", "converged", "n_evaluations")


def span_candidates(names) -> tuple[str, ...]:
    """The configured candidates that are effects of ``scope="span"``."""
    return tuple(n for n in names if n in EFFECTS and EFFECTS[n].scope == "span")


def span_in_line(span_type: SpanType, catenary: Catenary, p: SpanParameters, neighbours: int = 1) -> Section:
    """The FE section of one span as it hangs in the line: the central span of ``2 neighbours + 1``
    at its type's design, with the parameters of ``p`` (one span) — dropper lengths, tensions,
    system heights at its masts, clamp offset, wear, concentrated masses."""
    nominal = nominal_dropper_lengths(span_type, catenary).dropper_lengths_m
    n_spans = 2 * neighbours + 1
    n = span_type.n_droppers
    section = uniform_section(span_type, n_spans, nominal)
    lengths = section.dropper_lengths_m.copy()
    lengths[neighbours * n:(neighbours + 1) * n] = p.dropper_lengths_m[0, :n]
    t_mw = np.full(n_spans, span_type.messenger_tension_n)
    t_cw = np.full(n_spans, span_type.contact_tension_n)
    t_mw[neighbours] = p.messenger_tension_n[0]
    t_cw[neighbours] = p.contact_tension_n[0]
    dh = section.system_heights_m.copy()
    dh[neighbours], dh[neighbours + 1] = p.system_height_left_m[0], p.system_height_right_m[0]
    offsets = np.zeros(lengths.size)
    offsets[neighbours * n:(neighbours + 1) * n] = p.cw_offset_m[0]
    factor = np.ones(n_spans)
    factor[neighbours] = 1.0 - p.cw_wear_fraction[0]
    carried = p.cw_point_mass_kg[0] > 0
    fields = {k: getattr(section, k) for k in Section.__dataclass_fields__}
    fields.update(dropper_lengths_m=lengths, messenger_tension_n=t_mw, contact_tension_n=t_cw, system_heights_m=dh,
                  dropper_offset_m=offsets, cw_mass_factor=factor,
                  cw_point_mass_x_m=neighbours * span_type.length_m + p.cw_point_mass_x_m[0, carried],
                  cw_point_mass_kg=p.cw_point_mass_kg[0, carried])
    return Section(**fields)


def _design_span(span_type: SpanType, catenary: Catenary) -> SpanParameters:
    nominal = nominal_dropper_lengths(span_type, catenary).dropper_lengths_m
    return SpanParameters.independent_spans(
        nominal[None, :], [span_type.messenger_tension_n], [span_type.system_height_m], [span_type.system_height_m],
        system_height_mean_m=span_type.system_height_m, contact_tension_n=span_type.contact_tension_n,
        measuring_force_n=0.0, span_length_m=span_type.length_m, dropper_x_m=span_type.dropper_positions_m)


@dataclass(frozen=True)
class MeasuringSetup:
    """The correction's measuring pass: pantograph (at the recording's force), speed [m/s],
    mode, integration step [s] and direction of travel."""

    pantograph: object
    speed_m_s: float
    mode: str
    time_step_s: float | None
    direction: int = 1


class _Change:
    """The change an effect makes to the CW along one span that the correction leaves in the
    residual [m]: the static FE change — or, with a measuring setup, the measuring pass's change —
    less its straight interpolation through the masts and droppers. The correction moves the
    span's static CW there to the measured heights, so only what the effect does between them is
    left (a pass's response to the moves at the droppers is in the base; read through it instead,
    a change of W by millimetres would leave the pass's dynamic ripple of a fifth of it in the
    fit). The pass matters for a load: the pantograph meeting the kink it makes rings after it,
    which moves a static tent's best fit ≈ 1–1.5 m forward and its load 20 % low (measured on
    campaign o_local)."""

    def __init__(self, effect: Effect, span_type: SpanType, catenary: Catenary, x_m: np.ndarray,
                 measuring: MeasuringSetup | None = None):
        self.effect, self.span_type, self.catenary, self.x_m = effect, span_type, catenary, x_m
        self.measuring = measuring
        self.knots = knots_of(span_type.length_m, span_type.dropper_positions_m)
        self.at = span_type.length_m + np.concatenate([x_m, self.knots])
        self.base = self._profile(_design_span(span_type, catenary))
        self.n_evaluations = 0

    def _profile(self, p: SpanParameters) -> np.ndarray:
        section = span_in_line(self.span_type, self.catenary, p)
        if self.measuring is None:
            return solve_static(section, self.catenary).cw_deflection_at(self.at)
        m = self.measuring
        return measuring_pass(section, self.catenary, m.pantograph, speed_m_s=m.speed_m_s, mode=m.mode,
                              time_step_s=m.time_step_s, chainage_m=self.at, direction=m.direction).height_m

    def __call__(self, magnitudes: dict) -> np.ndarray:
        p = _design_span(self.span_type, self.catenary)
        z = (None if self.effect.draw is None
             else np.zeros(1 if self.effect.n_draws == 1 else (1, self.effect.n_draws)))
        self.effect.apply(p, z, **magnitudes)
        self.n_evaluations += 1
        change = self._profile(p) - self.base
        n = self.x_m.size
        return change[:n] - np.interp(self.x_m, self.knots, change[n:])


@dataclass(frozen=True)
class SpanEffectFit:
    """One span's fit of one effect (module docs)."""

    span_id: str
    effect: str
    estimates: dict
    lr_statistic: float
    p_value: float
    p_global_after: float
    p_local_after: float
    explained: bool
    converged: bool
    n_evaluations: int

    def row(self) -> dict:
        import json
        return {"span_id": self.span_id, "effect": self.effect,
                "parameters": json.dumps({k: [float(v), float(s)] for k, (v, s) in self.estimates.items()}),
                "lr_statistic": self.lr_statistic, "p_value": self.p_value, "p_global_after": self.p_global_after,
                "p_local_after": self.p_local_after, "explained": self.explained, "converged": self.converged,
                "n_evaluations": self.n_evaluations}


def fit_span_effect(effect: Effect, span_id: str, profiles: pd.DataFrame, span_type: SpanType, catenary: Catenary,
                    noise: ProfileNoise, settings: ProfileSettings, level: float,
                    influences: dict | None = None, directions: dict | None = None,
                    measuring: MeasuringSetup | None = None, grid_step_m: float = 0.5,
                    max_evaluations: int = 200, max_pass_evaluations: int = 40) -> SpanEffectFit:
    """Fit ``effect``'s magnitudes to one span's whole profile and test it (module docs): on the
    static change first (a grid over a position, then Nelder–Mead), then — with ``measuring``,
    the correction's pass — polished on the pass's change (at most ``max_pass_evaluations``
    passes), from which the test and the standard errors are taken."""
    knots = knots_of(span_type.length_m, span_type.dropper_positions_m)
    rows = profiles[profiles["span_id"].astype(str) == str(span_id)]
    data = _span_data(rows, influences, directions)[0]
    fit = _fit_span(data, knots, noise.ar1, noise.step_m)
    xs = np.concatenate([x for x, _, _ in data.runs])
    change = _Change(effect, span_type, catenary, xs)
    sigma = noise.std_m

    def whitened(d: np.ndarray) -> np.ndarray:
        out, start = [], 0
        for x, c in zip(fit.x, fit.cont):
            out.append(prewhiten(d[start:start + x.size], c, noise.ar1))
            start += x.size
        w = np.concatenate(out)
        return w - fit.q @ (fit.q.T @ w)

    ry = fit.y - fit.q @ (fit.q.T @ fit.y)
    params = [q for q in effect.parameters if q.kind != "position"]
    positions = [q for q in effect.parameters if q.kind == "position"]
    if len(positions) > 1:
        raise ValueError(f"effect {effect.name}: at most one position parameter can be fitted span by span")

    def magnitudes(theta: np.ndarray) -> dict:
        out = {q.name: float(np.clip(t * q.scale, *q.bounds)) for q, t in zip(params + positions, theta)}
        if positions:
            out[positions[0].name] = float(np.clip(out[positions[0].name], 0.0, span_type.length_m))
        return out

    def rss(theta: np.ndarray) -> float:
        e = ry - whitened(change(magnitudes(theta)))
        return float(e @ e)

    # Coarse: along the position (others at their realistic sizes), the best amplitude by least squares.
    unit = np.array([q.realistic / q.scale for q in params])
    if positions:
        q = positions[0]
        lo, hi = max(q.bounds[0], 0.0), min(q.bounds[1], span_type.length_m)
        grid = np.arange(lo + 0.5 * grid_step_m, hi, grid_step_m)
    else:
        grid = np.array([np.nan])
    best = (np.inf, None)
    for x0 in grid:
        theta = np.r_[unit, [x0 / positions[0].scale] if positions else []]
        d = whitened(change(magnitudes(theta)))
        dd = float(d @ d)
        a = float(d @ ry) / dd if dd > 0 else 0.0
        value = float((ry - a * d) @ (ry - a * d))
        if value < best[0]:
            best = (value, np.r_[a * unit, [x0 / positions[0].scale] if positions else []])
    theta0 = best[1]
    res = optimize.minimize(rss, theta0, method="Nelder-Mead",
                            options={"maxfev": max_evaluations, "xatol": 1e-3, "fatol": 1e-3 * sigma ** 2})
    converged = bool(res.success)
    if measuring is not None:           # the pass's change, polished from the static optimum
        if directions:
            run_id = str(rows["run_id"].iloc[0])
            measuring = dataclasses.replace(measuring, direction=int(directions.get((str(span_id), run_id), 1)))
        static_evaluations = change.n_evaluations
        change = _Change(effect, span_type, catenary, xs, measuring)
        change.n_evaluations += static_evaluations
        res = optimize.minimize(rss, res.x, method="Nelder-Mead",
                                options={"maxfev": max_pass_evaluations, "xatol": 1e-2, "fatol": 1e-2 * sigma ** 2})
    theta = res.x
    rss1 = float(res.fun)
    # Standard errors: Gauss–Newton information of the whitened change.
    d0 = whitened(change(magnitudes(theta)))
    jac = []
    for i in range(theta.size):
        h = 1e-3 * max(1.0, abs(theta[i]))
        t = theta.copy()
        t[i] += h
        jac.append((whitened(change(magnitudes(t))) - d0) / h)
    jac = np.column_stack(jac)
    try:
        cov = np.linalg.inv(jac.T @ jac) * sigma ** 2
        se_theta = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    except np.linalg.LinAlgError:
        se_theta = np.full(theta.size, np.nan)
    mags = magnitudes(theta)
    scales = [q.scale for q in params + positions]
    estimates = {q.name: (mags[q.name], s * sc) for q, s, sc in zip(params + positions, se_theta, scales)}
    lr = (fit.rss - rss1) / sigma ** 2
    p_value = float(stats.chi2.sf(lr, max(len(params) + len(positions), 1)))
    # The profile left with the effect in: its global χ² and its largest point-load statistic.
    left = ry - d0
    p_global = float(stats.chi2.sf(float(left @ left) / sigma ** 2, max(fit.dof - theta.size, 1)))
    after = type(fit)(fit.q, fit.q @ (fit.q.T @ fit.y) + left, fit.x, fit.cont, float(left @ left), fit.dof)
    centres = scan_positions(knots, settings.grid_step_m, settings.knot_clearance_m)
    scan = _scan(after, knots, centres, noise.ar1, sigma)
    t = np.where(scan.scanned, scan.t, np.nan)
    finite = np.isfinite(t)
    p_local = (hunter_max_normal_sf(float(np.nanmax(np.abs(t))), scan.rho_chain, int(finite.sum()),
                                    scan.links & finite & np.r_[False, finite[:-1]]) if finite.any() else 1.0)
    explained = bool(p_value < level and p_global > level and p_local > level)
    return SpanEffectFit(str(span_id), effect.name, estimates, float(lr), p_value, p_global, p_local, explained,
                         converged, change.n_evaluations)


def test_span_effects(names, span_ids, profiles: pd.DataFrame, span_type: SpanType, catenary: Catenary,
                      noise: ProfileNoise, settings: ProfileSettings, level: float, *, influences=None,
                      directions=None, measuring: MeasuringSetup | None = None, log=None) -> pd.DataFrame:
    """Every span-scope effect of ``names`` fitted on every span of ``span_ids``
    (:data:`SPAN_EFFECT_COLUMNS`); a span is explained by the effect that explains it with the
    largest LR."""
    rows = []
    for span_id in span_ids:
        for name in names:
            fit = fit_span_effect(EFFECTS[name], span_id, profiles, span_type, catenary, noise, settings, level,
                                  influences, directions, measuring)
            rows.append(fit.row())
            if log is not None:
                log.info("%s: %s fitted: %s; LR %.1f (p %.2g); left: global p %.2g, local p %.2g: %s", span_id, name,
                         ", ".join(f"{k} = {v:.4g} ± {s:.2g}" for k, (v, s) in fit.estimates.items()),
                         fit.lr_statistic, fit.p_value, fit.p_global_after, fit.p_local_after,
                         "explains it" if fit.explained else "does not explain it")
    return pd.DataFrame(rows, columns=list(SPAN_EFFECT_COLUMNS))


def span_effect_fitter(names, profile_check, span_type: SpanType, catenary: Catenary, settings: ProfileSettings,
                       level: float, measuring: MeasuringSetup, log=None):
    """What the diagnosis calls with the spans its final model does not explain: every span-scope
    effect of ``names`` (the user's own) fitted on them (:func:`test_span_effects`) from the
    whole profiles of ``profile_check`` (:func:`catenary.stages.diagnosis.inputs.profile_check_of`);
    None without such an effect."""
    if not names:
        return None

    def fit(span_ids):
        return test_span_effects(names, span_ids, profile_check.profiles, span_type, catenary, profile_check.noise,
                                 settings, level, influences=profile_check.influences,
                                 directions=profile_check.directions, measuring=measuring, log=log)

    return fit
