"""The identification model extended by candidate effects: design rows → model W.

A model is the base of the identification (Gamma laws of the dropper lengths, T_MW and ΔH,
:mod:`catenary.stages.identification.design`) plus an ordered set of active effects with their
magnitudes. For a block of design rows, :class:`EffectSampler` maps the base columns to the
inputs of N model spans, builds their :class:`~catenary.physics.effects.SpanParameters` (each span a
section of its own with masts of its own), applies every active effect with the standard
normal scores of its own design columns — the very functions the campaign plants the effects
with — and evaluates the fast model (:class:`~catenary.physics.fast.FastSpanModel`) built with what the
effects need (a per-sample T_CW, a per-sample CW clamp offset, worn-CW and steady-arm loads).
Two effects act after the static solve: ``measuring_force_offset`` adds the force excess times
the measuring pass's influence (:func:`catenary.physics.measuring.force_influence`), and
``wire_continuity`` blends the pinned and the in-line span.

The design is drawn once with the base columns first and then the columns of every candidate
(:func:`design_columns`), so every model of a diagnosis — with or without a candidate — uses
the same random numbers: J differences between models are not Monte Carlo noise.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from catenary.measurement.channels.quantities import observe as observe_quantities
from catenary.physics.config import Catenary, SpanType
from catenary.physics.effects import EFFECTS, SpanParameters
from catenary.physics.fast import SAMPLING_DEGREE, FastSpanModel, row_minimum
from catenary.plumbing.errors import OutOfModelRangeError
from catenary.plumbing.workers import map_each
from catenary.stages.identification.design import map_inputs
from .candidates import CANDIDATES

__all__ = ["EffectSampler", "ModelSet", "design_columns", "relative_cost", "simulate_spans"]

#: T_CW range served when a candidate varies it: ±10 % of the design tension.
CONTACT_TENSION_RANGE = 0.10
#: CW clamp offsets served when a candidate varies them [m]: the allowed mean ± 6 allowed σ
#: would reach 0.8 m, but the design's scores stay within ±4.5 at N ≤ 1e5, so ±0.5 m serves
#: the realistic sizes (0.15 ± 0.05 m) with room; a sample beyond it makes J = −inf.
OFFSET_BOUNDS_M = (-0.5, 0.5)
#: Chebyshev degrees in 1/T_CW and in the offset: within 5e-7 m and 3.3e-5 m of exact
#: condensations (measured; the data's correction residual is ≈ 6e-4 m RMS), at a J cost of
#: 1.5× and 1.8× the base model's (:data:`COST_FACTORS`).
CONTACT_DEGREE, OFFSET_DEGREE = 2, 6


#: Cost of one J evaluation relative to the base model's, per need of the fast model: measured in
#: the default run's N2 diagnosis (117 spans, N = 10⁴, one BLAS thread, 2026-11-27: 7.4 ms per
#: evaluation for the base, 10.9 ms with a per-sample T_CW, 13.5 ms with a CW clamp offset; 18
#: and 30 ms before the 2-D maps were pruned and applied basis-first); two span models for
#: ``continuity``. Only the order in which parallel workers take the refits reads it.
COST_FACTORS = {"offset": 1.8, "contact_tension": 1.5, "continuity": 2.0}


def relative_cost(needs) -> float:
    """Cost of a J evaluation of a model with ``needs`` relative to the base model's (the
    largest factor of :data:`COST_FACTORS` among them, 1 without any)."""
    return max([1.0] + [COST_FACTORS[n] for n in needs if n in COST_FACTORS])


def design_columns(base_dimension: int, candidates) -> dict[str, int]:
    """First design column of each candidate that draws (base columns first, then in order)."""
    out, col = {}, base_dimension
    for name in candidates:
        c = CANDIDATES[name]
        if c.design_columns:
            out[name] = col
            col += c.design_columns
    return out


@dataclass
class ModelSet:
    """Fast span models of one span type, built once per set of needs and shared.

    Attributes
    ----------
    span_type, catenary
    messenger_tension_bounds_n : (float, float)
        T_MW range of every model [N] (the identification's box).
    neighbours : int
        Span model of the base (0 pinned, k > 0 in the line).
    degree : int
        Chebyshev degree in 1/T_MW.
    force_influence_m_n : numpy.ndarray or None
        ∂W/∂F of the measuring pass [m/N] (needed by ``measuring_force_offset``).
    """

    span_type: SpanType
    catenary: Catenary
    messenger_tension_bounds_n: tuple[float, float]
    neighbours: int
    degree: int = SAMPLING_DEGREE
    force_influence_m_n: np.ndarray | None = None
    _cache: dict = field(default_factory=dict, repr=False)

    def model(self, needs: frozenset[str], neighbours: int | None = None) -> FastSpanModel:
        """The fast model carrying ``needs`` (``contact_tension``, ``offset``, ``extended``)."""
        key = self._key(needs, neighbours)
        if key not in self._cache:
            self._cache[key] = self._build(key)
        return self._cache[key]

    def prepare(self, needs: list[tuple[frozenset[str], int | None]], workers: int = 1) -> None:
        """Build the models of ``needs`` (pairs of needs and neighbours, as :meth:`model` takes
        them) not built yet, in ``workers`` processes (:func:`catenary.plumbing.workers.map_each`;
        a model is the same computation in any process): the processes forked after (a step's
        candidates) inherit them instead of each building its own."""
        keys = list(dict.fromkeys(k for k in (self._key(*n) for n in needs) if k not in self._cache))
        self._cache.update(zip(keys, map_each(lambda i: self._build(keys[i]), len(keys), workers, 1)))

    def _key(self, needs: frozenset[str], neighbours: int | None = None) -> tuple:
        return (frozenset(needs) & {"contact_tension", "offset", "extended"},
                self.neighbours if neighbours is None else neighbours)

    def _build(self, key: tuple) -> FastSpanModel:
        needs, k = key
        t_cw = self.span_type.contact_tension_n
        return FastSpanModel(
            self.span_type, self.catenary, messenger_tension_bounds_n=self.messenger_tension_bounds_n,
            degree=self.degree, neighbours=k,
            contact_tension_bounds_n=((1 - CONTACT_TENSION_RANGE) * t_cw, (1 + CONTACT_TENSION_RANGE) * t_cw)
            if "contact_tension" in needs else None, contact_degree=CONTACT_DEGREE,
            cw_clamp_offset_bounds_m=OFFSET_BOUNDS_M if "offset" in needs else None, offset_degree=OFFSET_DEGREE,
            extended="extended" in needs)


class EffectSampler:
    """``sampler(z, means, sigmas, magnitudes)`` of :class:`~catenary.stages.identification.likelihood.Likelihood`.

    Parameters
    ----------
    models : ModelSet
    base_dimension : int
        Design columns of the base inputs (:func:`~catenary.stages.identification.design.design_dimension`).
    system_height_mode : {"shared", "independent"}
    columns : dict
        First design column of each drawing candidate (:func:`design_columns`); its size is
        the design's dimension.
    active : tuple of str
        Effects of the model, in the order they are applied.
    declared_force_n : float
        Measuring force the correction assumed [N].
    dimension : int
        Columns of the whole design.

    Notes
    -----
    ``magnitudes`` maps each active effect to its magnitudes (``{"std_n": 800.0}``). Returns
    ``(W, F_min)`` or None when a sample leaves the fast model's range (J = −inf); with
    ``observe`` (quantities of :mod:`catenary.measurement.channels.quantities`), ``(W, F_min, Y)``: Y their
    values for each sample, effects applied.
    """

    def __init__(self, models: ModelSet, *, base_dimension: int, system_height_mode: str, columns: dict[str, int],
                 active: tuple[str, ...], declared_force_n: float, dimension: int):
        unknown = [a for a in active if a not in CANDIDATES]
        if unknown:
            raise ValueError(f"active effects: unknown {unknown}; known: {', '.join(CANDIDATES)}")
        self.models = models
        self.base_dimension = int(base_dimension)
        self.system_height_mode = system_height_mode
        self.columns = dict(columns)
        self.active = tuple(active)
        self.declared_force_n = float(declared_force_n)
        self.dimension = int(dimension)
        self.needs = frozenset().union(*(CANDIDATES[a].needs for a in self.active))
        if "force_influence" in self.needs and models.force_influence_m_n is None:
            raise ValueError("measuring_force_offset: the model set has no force influence")
        if "continuity" in self.needs and models.neighbours != 0:
            raise ValueError("wire_continuity: a candidate only for a pinned base span (neighbours 0)")
        self.model = models.model(self.needs)
        self.inline = models.model(self.needs, neighbours=1) if "continuity" in self.needs else None

    def span_parameters(self, z: np.ndarray, means: np.ndarray, sigmas: np.ndarray,
                        magnitudes: dict | None) -> SpanParameters:
        """The model spans of the design rows ``z`` with every active effect applied."""
        x = map_inputs(z[:, :self.base_dimension], means, sigmas, self.system_height_mode)
        p = SpanParameters.independent_spans(
            x.dropper_lengths_m, x.messenger_tension_n, x.system_height_left_m, x.system_height_right_m,
            system_height_mean_m=float(means[-1]), contact_tension_n=self.models.span_type.contact_tension_n,
            measuring_force_n=self.declared_force_n, span_length_m=self.models.span_type.length_m,
            dropper_x_m=self.models.span_type.dropper_positions_m)
        magnitudes = magnitudes or {}
        for name in self.active:
            if name not in EFFECTS:
                continue
            effect = EFFECTS[name]
            draws = None
            if effect.draw is not None:
                c = self.columns[name]
                # a mast draw: the span's left and right masts (2k, 2k + 1); several draws per item
                per = effect.n_draws
                draws = (z[:, c:c + 2].ravel() if effect.draw == "mast" else z[:, c]) if per == 1 else (
                    z[:, c:c + 2 * per].reshape(-1, per) if effect.draw == "mast" else z[:, c:c + per])
            effect.apply(p, draws, **magnitudes[name])
        return p

    def __call__(self, z: np.ndarray, means: np.ndarray, sigmas: np.ndarray, magnitudes: dict | None,
                 observe: tuple[str, ...] = ()):
        p = self.span_parameters(z, means, sigmas, magnitudes)
        try:
            w, force = self._solve(self.model, p)
            if self.inline is not None:
                fraction = magnitudes["wire_continuity"]["fraction"]
                w_line, force_line = self._solve(self.inline, p)
                w = w + fraction * (w_line - w)
                force = force + fraction * (force_line - force)
        except OutOfModelRangeError:
            return None
        if "force_influence" in self.needs:
            w = w + (p.measuring_force_n - self.declared_force_n) * self.models.force_influence_m_n
        if observe:
            return w, row_minimum(force), observe_quantities(p, self.models.catenary, observe)
        return w, row_minimum(force)

    def _solve(self, model: FastSpanModel, p: SpanParameters):
        kwargs = {}
        if "contact_tension" in self.needs:
            kwargs["contact_tension_n"] = p.contact_tension_n
        if "offset" in self.needs:
            kwargs["cw_offset_m"] = p.cw_offset_m
        if "extended" in self.needs:
            kwargs.update(cw_wear_fraction=p.cw_wear_fraction, cw_height_offset_left_m=p.cw_height_offset_left_m,
                          cw_height_offset_right_m=p.cw_height_offset_right_m)
        res = model.evaluate(p.dropper_lengths_m, p.messenger_tension_n, p.system_height_left_m,
                             p.system_height_right_m, chunk_size=max(1, p.n_spans), **kwargs)
        return res.w_m, res.dropper_force_n


def simulate_spans(sampler: EffectSampler, means: np.ndarray, sigmas: np.ndarray, magnitudes: dict | None,
                   n_spans: int, *, seed: int, noise_std_m: float = 0.0, max_draws: int = 100,
                   observe: tuple[str, ...] = ()):
    """W of ``n_spans`` independent model spans with every dropper taut [m], shape (n_spans, n).

    Plain Monte Carlo (i.i.d. normal scores, not the design) through the sampler — the
    campaign's effect functions and the fast model — with spans having a slack dropper drawn
    again, plus independent Gaussian noise of ``noise_std_m`` per dropper (the correction's
    residual). Raises ``RuntimeError`` after ``max_draws × n_spans`` draws. With ``observe``
    (quantities of :mod:`catenary.measurement.channels.quantities`), returns ``(W, Y)``: Y their true
    values for the same spans (no measurement error).
    """
    rng = np.random.default_rng(seed)
    out, ys, have = [], [], 0
    for _ in range(max_draws):
        z = np.clip(rng.standard_normal((2 * n_spans, sampler.dimension)), -6.0, 6.0)
        res = sampler(z, np.asarray(means, dtype=float), np.asarray(sigmas, dtype=float), magnitudes,
                      **({"observe": tuple(observe)} if observe else {}))
        if res is None:
            raise RuntimeError("simulate_spans: a sample left the fast model's range; narrower laws needed")
        w, f_min = res[:2]
        out.append(w[f_min > 0.0])
        if observe:
            ys.append(res[2][f_min > 0.0])
        have += out[-1].shape[0]
        if have >= n_spans:
            w = np.concatenate(out)[:n_spans]
            w = w + noise_std_m * rng.standard_normal(w.shape)
            return (w, np.concatenate(ys)[:n_spans]) if observe else w
    raise RuntimeError(f"simulate_spans: fewer than {n_spans} taut spans in {max_draws * 2 * n_spans} draws")
