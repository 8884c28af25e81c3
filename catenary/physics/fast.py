"""Fast static model of one span for sampling.

With every dropper taut, the static FE model of a span (:mod:`catenary.physics.static`) is linear in
the loads, the dropper lengths and the support heights; only the tensions enter its operator.
Condensing it exactly onto the dropper forces ``F`` gives, per tension pair,

    (D(L) + C_cw + C_mw) F = b_mw − b_cw + (G_mw − G_cw − I) L + e_l ΔH_l + e_r ΔH_r
    W = b_cw + C_cw F + G_cw L

with ``C`` the flexibilities of each wire at the dropper points, ``b`` the wire heights under
their own weight and clamps (supports at zero), ``G`` the effect of the half dropper weight
``½ m_d g L`` on each wire, ``e_l, e_r`` the MW response to its support heights and
``D(L) = diag(L / EA)`` the dropper compliances. ``D`` is split into a reference part (at the
nominal lengths) and a small deviation handled by one fixed-point step, whose residual is
below 1e-8 of the dropper stretch.

Inclined droppers (a longitudinal offset ``δ`` of the CW clamps, the ``cw_longitudinal_offset``
effect) enter through :func:`~catenary.physics.section.inclined_dropper`: the condensation puts the CW
clamps at their offset positions and reads W at the design positions; the vertical rest length
``L_v = √(L² − δ²)`` replaces ``L`` in the force equation and the compliance becomes
``L³ / (EA L_v²)``. Only the dropper weight in the force equation then uses ``L_v`` instead of
``L``: ½ m_d g (L − L_v) ≈ 0.01 N for δ = 0.2 m, below 1e-6 m in W (7.5e-7 m against the FE
model at the nominal table with offsets up to 0.2 m; the test allows 2e-6 m).

The condensed operator is computed exactly at Chebyshev nodes in ``1/T_MW`` (and ``1/T_CW``
when the contact-wire tension varies) and interpolated between them; the interpolation error
is checked against exact condensations in the tests (< 1e-8 m). Everything else is whole-array
NumPy: no Python loop over samples. Samples whose dropper forces come out negative would have
slack droppers: they are flagged, and their W is not the static solution — unless
``evaluate(..., slack="solve")``, which then solves them (below).

Slack droppers
--------------
A dropper in compression goes slack: its force is zero and its compatibility equation drops
out. With ``K = (D + C_cw + C_mw)⁻¹`` and the all-taut forces ``F``, the forces with the set S
slack are ``F_T' = F_T − K_TS K_SS⁻¹ F_S`` (the Schur complement of the condensed system) and
``F_S' = 0``; S grows until no taut dropper is in compression. A dropper once slack stays slack:
exact when the slack set only grows (one long dropper, or neighbours unloaded by it), which the
tests check against the FE model's active set (:mod:`catenary.physics.static`).

One module, one concern: the fast static model of a span, from its condensation to its
vectorised evaluation (all-taut and slack-solved) and the CW profile between the droppers that
uses the same condensation; the Chebyshev interpolant it relies on is :mod:`catenary.physics.chebyshev`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse.linalg import splu

from .chebyshev import BasisCache, StackedMap, fit_chebyshev
from .config import Catenary, SpanType
from .dropper_table import nominal_dropper_lengths
from catenary.plumbing.errors import OutOfModelRangeError
from .section import inclined_dropper, single_span, uniform_section
from .static import CW, DOFS_PER_NODE, StaticModel, wire_height_at, wire_weight_loads

#: Loads of the condensation beyond the base ones (:class:`CondensedSpan`), in column order.
EXTRA_COLUMNS = ("cw_weight", "raise_left", "raise_right")

#: Chebyshev degree in 1/T_MW of the models that sample the identified laws (identification,
#: diagnosis, maintenance). Over the widest T_MW range they serve (8.5–37.5 kN, the
#: identification box's quantiles for N2 and N3) degree 10 is within 5e-8 m of exact for taut
#: samples (measured against degree 24: degree 8 1e-6 m, 12 2e-9 m, 14 1e-10 m), four orders
#: below the corrected W's 0.6 mm error, and its maps cost 11 % (17 % with a CW clamp offset)
#: less than degree 14's, which they used until 2026-11-27.
SAMPLING_DEGREE = 10

#: Tensor terms dropped from the maps of a 2-D interpolant (1/T_MW with the CW clamp offset or
#: T_CW; :meth:`~catenary.physics.chebyshev.ChebyshevInterpolant.pruned`): those whose largest
#: coefficients sum to at most this fraction of the largest. On the diagnosis's CW offset
#: model (N2 and N3, 10⁴ samples, T_MW ±20 %, offsets −0.1 ± 0.1 m) it keeps 65 of the force
#: map's 77 terms and 13 of W's 49 and moves W by 5e-10 m and the dropper forces by 5e-8 N,
#: against the offset interpolation's own 3.3e-5 m; the 1-D maps of the base model keep all
#: theirs (their smallest term is 2e-8 of the largest).
PRUNE_RTOL = 1e-10


@dataclass(frozen=True)
class CondensedSpan:
    """Exact condensation of a span's static model onto its droppers at given tensions.

    All heights are for steady arms and MW supports at zero height; arrays are (n,) or (n, n)
    over the n droppers, in [m], [m/N] or [m/m]. The CW rows are at the CW clamps; the ``w_``
    rows give the CW at the droppers' design positions, where W is measured (the same rows for
    vertical droppers). The ``support_*_cw`` and ``w_support_*`` rows, the CW's response to the
    span's MW support heights, vanish for a pinned span; with neighbours the MW supports move
    the neighbours' wires, which the CW feels through its continuity over the masts.
    ``profile`` (p, 2n + 3), when asked for, gives the CW at p abscissae of the span as
    ``profile @ [F, L, ΔH_l, ΔH_r, 1]`` (the FE shape functions between the nodes).

    ``extra_cw``, ``extra_mw`` (n, 3) and ``w_extra`` (n, 3) are the wires' response to the
    loads of :data:`EXTRA_COLUMNS`: the central span's CW weight (its whole weight per metre,
    so a worn wire adds ``−ε`` times this column) and a raise of the central span's left or
    right steady arm with its MW support (ΔH kept); ``w_extra`` is measured from the chord
    between the two steady arms, as W is.
    """

    flex_cw_m_n: np.ndarray
    flex_mw_m_n: np.ndarray
    weight_cw_m: np.ndarray
    weight_mw_m: np.ndarray
    dropper_weight_cw: np.ndarray
    dropper_weight_mw: np.ndarray
    support_left_mw: np.ndarray
    support_right_mw: np.ndarray
    w_flex_m_n: np.ndarray
    w_weight_m: np.ndarray
    w_dropper_weight: np.ndarray
    support_left_cw: np.ndarray
    support_right_cw: np.ndarray
    w_support_left: np.ndarray
    w_support_right: np.ndarray
    extra_cw: np.ndarray
    extra_mw: np.ndarray
    w_extra: np.ndarray
    profile: np.ndarray | None = None


def condense_span(span_type: SpanType, catenary: Catenary, messenger_tension_n: float,
                  contact_tension_n: float, cw_clamp_offset_m: float | np.ndarray = 0.0, *,
                  neighbours: int = 0, neighbour_lengths_m: np.ndarray | None = None,
                  profile_x_m: np.ndarray | None = None) -> CondensedSpan:
    """Condense the FE model of one span of ``span_type`` onto its dropper points.

    Parameters
    ----------
    span_type, catenary
    messenger_tension_n, contact_tension_n : float
        Tensions of the span (and of its neighbours) [N].
    cw_clamp_offset_m : float or array_like
        Puts the span's CW clamps off the droppers' design positions [m] (inclined droppers,
        see :func:`~catenary.physics.section.inclined_dropper`).
    neighbours : int
        0: the span alone, both wires pinned at the masts (the paper's model). k > 0: the span
        as the central one of 2k + 1 identical spans, both wires continuous over its masts; the
        neighbours hang at their nominal geometry (``neighbour_lengths_m``, design system height
        at their outer masts, taut droppers), and their response to the central span is part of
        the condensed operator, which stays exact for the central span's droppers. The central
        span's ΔH_left and ΔH_right are those of the masts it shares with its neighbours.
    neighbour_lengths_m : array_like, optional
        Dropper lengths of every neighbour [m] (required when ``neighbours`` > 0).
    profile_x_m : array_like, optional
        Abscissae from the span's left mast [m] at which to return the CW ``profile`` too.
    """
    n = span_type.n_droppers
    n_spans = 2 * neighbours + 1
    central = np.arange(neighbours * n, (neighbours + 1) * n)
    lengths = np.ones(n_spans * n)
    if neighbours:
        if neighbour_lengths_m is None:
            raise ValueError("neighbour_lengths_m: required when neighbours > 0")
        lengths = np.tile(np.asarray(neighbour_lengths_m, dtype=float), n_spans)
        lengths[central] = 1.0
    offsets = np.zeros(n_spans * n)
    offsets[central] = cw_clamp_offset_m
    section = uniform_section(span_type, n_spans, np.ones(n), contact_tension_n=contact_tension_n,
                              messenger_tension_n=messenger_tension_n, cw_height_m=0.0)
    section = section.with_dropper_lengths(lengths).with_dropper_offsets(offsets)
    model = StaticModel(section, catenary)
    neighbour_droppers = np.ones(n_spans * n, dtype=bool)
    neighbour_droppers[central] = False
    k_droppers, f_droppers = model.dropper_matrices(neighbour_droppers)
    k = (model.k_wires + k_droppers).tocsr()
    free, fixed = model.free, model.fixed
    lu = splu(k[free][:, free].tocsc())
    k_free_fixed = k[free][:, fixed]
    g = catenary.gravity_m_s2
    half_dropper_n = 0.5 * catenary.droppers.mass_per_length_kg_m * g  # per metre of dropper
    c, m = model.dropper_cw_dof[central], model.dropper_mw_dof[central]
    # Loads of the wires, clamps and the neighbours' droppers (their preload from their rest
    # lengths); the central span's dropper wire weight of the unit-length model is removed.
    f_base = model.f_gravity + f_droppers
    f_base[c] += half_dropper_n
    f_base[m] += half_dropper_n
    n_rhs = 1 + 2 * n + 2 + len(EXTRA_COLUMNS)
    loads = np.zeros((model.n_dofs, n_rhs))
    supports = np.zeros((fixed.size, n_rhs))
    loads[:, 0] = f_base
    cols = np.arange(n)
    loads[c, 1 + cols] = 1.0          # unit dropper tension: pulls the CW up ...
    loads[m, 1 + cols] = -1.0         # ... and the MW down
    loads[c, 1 + n + cols] = -half_dropper_n  # weight of one metre of dropper j
    loads[m, 1 + n + cols] = -half_dropper_n
    # Supports (fixed = [CW at every mast, MW at every mast]): CW at 0; the central span's two MW
    # supports by unit columns (ΔH_left, ΔH_right); every other MW support at the design ΔH.
    n_masts = n_spans + 1
    left_mw, right_mw = n_masts + neighbours, n_masts + neighbours + 1
    supports[n_masts:, 0] = span_type.system_height_m
    supports[[left_mw, right_mw], 0] = 0.0
    supports[left_mw, 1 + 2 * n] = 1.0
    supports[right_mw, 2 + 2 * n] = 1.0
    # Extra columns: the central span's CW weight; its left and right steady arms raised with the
    # MW (fixed = [CW at every mast, MW at every mast]).
    central_span = np.zeros(n_spans)
    central_span[neighbours] = 1.0
    extra = 3 + 2 * n
    loads[:, extra] = wire_weight_loads(model.mesh, catenary.contact, section.contact_tension_by_span_n, CW, g,
                                        central_span)
    supports[[neighbours, left_mw], extra + 1] = 1.0
    supports[[neighbours + 1, right_mw], extra + 2] = 1.0
    u = np.zeros((model.n_dofs, n_rhs))
    u[fixed] = supports
    u[free] = lu.solve(loads[free] - k_free_fixed @ supports)
    zc, zm = u[c], u[m]
    zw = u[DOFS_PER_NODE * model.mesh.dropper_nodes[central] + CW]
    # Measured from the chord between the central span's steady arms (only the raises move it).
    frac = span_type.dropper_positions_m / span_type.length_m
    zw[:, extra + 1] -= 1.0 - frac
    zw[:, extra + 2] -= frac
    profile = None
    if profile_x_m is not None:
        at = neighbours * span_type.length_m + np.asarray(profile_x_m, dtype=float)
        columns = np.column_stack([wire_height_at(model.mesh, u[:, j], at, CW) for j in range(n_rhs)])
        # Column order of W: [F, L, ΔH_l, ΔH_r, 1].
        profile = np.column_stack([columns[:, 1:extra], columns[:, :1]])
    return CondensedSpan(
        flex_cw_m_n=zc[:, 1:1 + n], flex_mw_m_n=-zm[:, 1:1 + n],
        weight_cw_m=zc[:, 0], weight_mw_m=zm[:, 0],
        dropper_weight_cw=zc[:, 1 + n:1 + 2 * n], dropper_weight_mw=zm[:, 1 + n:1 + 2 * n],
        support_left_mw=zm[:, 1 + 2 * n], support_right_mw=zm[:, 2 + 2 * n],
        w_flex_m_n=zw[:, 1:1 + n], w_weight_m=zw[:, 0], w_dropper_weight=zw[:, 1 + n:1 + 2 * n],
        support_left_cw=zc[:, 1 + 2 * n], support_right_cw=zc[:, 2 + 2 * n],
        w_support_left=zw[:, 1 + 2 * n], w_support_right=zw[:, 2 + 2 * n],
        extra_cw=zc[:, extra:], extra_mw=zm[:, extra:], w_extra=zw[:, extra:], profile=profile,
    )


@dataclass(frozen=True)
class FastResult:
    """Output of :meth:`FastSpanModel.evaluate`.

    Attributes
    ----------
    w_m : numpy.ndarray
        CW deflection from the chord at each dropper [m], shape (N, n_droppers).
    dropper_force_n : numpy.ndarray
        Dropper tensions [N], shape (N, n_droppers).
    slack : numpy.ndarray of bool
        True where some dropper would be in compression (W is then not the static solution).
    """

    w_m: np.ndarray
    dropper_force_n: np.ndarray
    slack: np.ndarray


def _within(values: np.ndarray, lower: float, upper: float) -> bool:
    """Every value finite and within [lower, upper] (a NaN fails both comparisons); True for
    no values."""
    return values.size == 0 or (bool(values.min() >= lower) and bool(values.max() <= upper))


def _inputs(first: np.ndarray, left: np.ndarray, right: np.ndarray, loads: np.ndarray) -> np.ndarray:
    """The maps' input rows ``[first…, ΔH_left, ΔH_right, 1, loads…]`` (N, k + 3 + extra), written
    into one array instead of stacked from columns."""
    k = first.shape[1]
    out = np.empty((first.shape[0], k + 3 + loads.shape[1]))
    out[:, :k] = first
    out[:, k] = left
    out[:, k + 1] = right
    out[:, k + 2] = 1.0
    out[:, k + 3:] = loads
    return out


def row_minimum(values: np.ndarray) -> np.ndarray:
    """The smallest entry of each row of ``values`` (N, n), for a few columns n: one pass per
    column, the same numbers as ``values.min(axis=1)`` at a fifth of its time (74 against
    380 µs at 10⁴ × 9, 2026-11-27: NumPy reduces a short last axis row by row)."""
    out = values[:, 0].copy()
    for j in range(1, values.shape[1]):
        np.minimum(out, values[:, j], out=out)
    return out


class FastSpanModel:
    """Vectorised static model of one span of a given type, exact to the FE model.

    Parameters
    ----------
    span_type : SpanType
    catenary : Catenary
    messenger_tension_bounds_n : (float, float), optional
        Range of T_MW the model serves [N]; default 0.5–1.5 × the design tension.
    contact_tension_bounds_n : (float, float), optional
        Range of T_CW [N]; default: the design tension only (equal bounds).
    degree : int
        Chebyshev degree per varying tension (in 1/T).
    reference_lengths_m : array_like, optional
        Dropper lengths of the reference compliance (default: the nominal table).
    cw_clamp_offset_m : float or array_like
        Longitudinal offset of the CW clamps from the MW clamps [m], one for all droppers or
        one per dropper (inclined droppers; default 0, vertical).
    neighbours : int
        0: the span alone, pinned at its masts (the paper's identification model). k > 0: the
        span as it hangs in the line, the central one of 2k + 1 identical spans with both wires
        continuous over the masts, the neighbours at the nominal table
        (``reference_lengths_m``) and design system height (:func:`condense_span`).
    cw_clamp_offset_bounds_m : (float, float), optional
        Range of a per-sample offset δ of all the span's CW clamps [m] (the
        ``cw_longitudinal_offset`` effect): the operators are then interpolated in δ too
        (degree ``offset_degree``) and :meth:`evaluate` takes ``cw_offset_m``. Exclusive with a
        non-zero ``cw_clamp_offset_m``.
    contact_degree : int, optional
        Chebyshev degree in 1/T_CW when T_CW varies (default ``degree``; W is nearly linear in
        1/T_CW: over ±10 % degree 2 is within 5e-7 m and degree 4 within 2e-10 m of exact
        condensations, measured).
    offset_degree : int
        Chebyshev degree in δ (default 6: within 1e-5 m of exact condensations over ±0.3 m,
        measured 7.6e-6 m; W is not analytic in δ near 0, where the clamp crosses the point
        where W is read within the CW's 8 cm bending length, so convergence is slow).
    extended : bool
        Carry the loads of :data:`EXTRA_COLUMNS` (a worn CW, raised steady arms), which
        :meth:`evaluate` then takes as ``cw_wear_fraction`` and ``cw_height_offset_*_m``.
    """

    def __init__(self, span_type: SpanType, catenary: Catenary, *,
                 messenger_tension_bounds_n: tuple[float, float] | None = None,
                 contact_tension_bounds_n: tuple[float, float] | None = None,
                 degree: int = 10, reference_lengths_m: np.ndarray | None = None,
                 cw_clamp_offset_m: float | np.ndarray = 0.0, neighbours: int = 0,
                 cw_clamp_offset_bounds_m: tuple[float, float] | None = None, contact_degree: int | None = None,
                 offset_degree: int = 6, extended: bool = False):
        self.span_type = span_type
        self.catenary = catenary
        t_mw = span_type.messenger_tension_n
        t_cw = span_type.contact_tension_n
        mw_lo, mw_hi = messenger_tension_bounds_n or (0.5 * t_mw, 1.5 * t_mw)
        cw_lo, cw_hi = contact_tension_bounds_n or (t_cw, t_cw)
        if not (0 < mw_lo <= mw_hi and 0 < cw_lo <= cw_hi):
            raise ValueError("tension bounds must be positive and ordered (lower ≤ upper) [N]")
        self.messenger_tension_bounds_n = (float(mw_lo), float(mw_hi))
        self.contact_tension_bounds_n = (float(cw_lo), float(cw_hi))
        if reference_lengths_m is None:
            reference_lengths_m = nominal_dropper_lengths(span_type, catenary).dropper_lengths_m
        self.reference_lengths_m = np.asarray(reference_lengths_m, dtype=float)
        n = span_type.n_droppers
        self.n_droppers = n
        if isinstance(neighbours, bool) or int(neighbours) != neighbours or neighbours < 0:
            raise ValueError(f"neighbours: expected an integer ≥ 0, got {neighbours!r}")
        self.neighbours = int(neighbours)
        self.extended = bool(extended)
        around = dict(neighbours=self.neighbours, neighbour_lengths_m=self.reference_lengths_m)
        # Offsets as the FE mesh sees them (sub-millimetre ones are vertical droppers).
        self.cw_clamp_offset_m = single_span(span_type, self.reference_lengths_m).with_dropper_offsets(
            cw_clamp_offset_m).clamp_offset_m
        if cw_clamp_offset_bounds_m is None:
            off_lo = off_hi = 0.0
        else:
            off_lo, off_hi = (float(v) for v in cw_clamp_offset_bounds_m)
            if np.any(self.cw_clamp_offset_m):
                raise ValueError("cw_clamp_offset_bounds_m: exclusive with a fixed non-zero cw_clamp_offset_m")
            if not off_lo <= off_hi:
                raise ValueError(f"cw_clamp_offset_bounds_m: expected lower ≤ upper, got {cw_clamp_offset_bounds_m}")
            # Both ends must be feasible offsets of every dropper (the Section checks them).
            for bound in (off_lo, off_hi):
                single_span(span_type, self.reference_lengths_m).with_dropper_offsets(bound)
        self.cw_clamp_offset_bounds_m = (off_lo, off_hi)
        ea = catenary.droppers.axial_stiffness_n
        self._ea = ea
        d_ref = np.diag(self.reference_lengths_m / ea)
        n_extra = len(EXTRA_COLUMNS) if self.extended else 0

        self._around = around
        self._offset_is_input = cw_clamp_offset_bounds_m is not None
        condensed = self._condensed
        def force_map(p: np.ndarray) -> np.ndarray:
            cond = condensed(p)
            a = np.linalg.inv(d_ref + cond.flex_cw_m_n + cond.flex_mw_m_n)
            r0 = cond.weight_mw_m - cond.weight_cw_m
            r_l = cond.dropper_weight_mw - cond.dropper_weight_cw - np.eye(n)
            # F0 = M @ [L, ΔH_l, ΔH_r, 1 (, extra loads)]; the correction step needs A itself.
            m = np.column_stack([a @ r_l, a @ (cond.support_left_mw - cond.support_left_cw),
                                 a @ (cond.support_right_mw - cond.support_right_cw), a @ r0,
                                 a @ (cond.extra_mw - cond.extra_cw)[:, :n_extra]])
            return np.concatenate([m.ravel(), a.ravel()])

        def deflection_map(p: np.ndarray) -> np.ndarray:
            # A pinned span's CW does not feel T_MW; with neighbours it does, through their droppers.
            cond = condensed(p)
            # W = Q @ [F, L, ΔH_l, ΔH_r, 1 (, extra loads)]
            return np.column_stack([cond.w_flex_m_n, cond.w_dropper_weight, cond.w_support_left,
                                    cond.w_support_right, cond.w_weight_m, cond.w_extra[:, :n_extra]]).ravel()

        # Interpolate in reciprocal tensions (the string part of the operator is linear in 1/T)
        # and in the clamp offset.
        lower, upper = [1.0 / mw_hi, 1.0 / cw_hi, off_lo], [1.0 / mw_lo, 1.0 / cw_lo, off_hi]
        n_force = n * (n + 3 + n_extra)
        cw_degree = degree if contact_degree is None else int(contact_degree)
        force = fit_chebyshev(lambda p: force_map(p)[:n_force], lower, upper, (degree, cw_degree, offset_degree))
        # The compliance step is a 1e-4 relative correction: a low degree is exact enough.
        compliance = fit_chebyshev(lambda p: force_map(p)[n_force:], lower, upper,
                                   (min(degree, 4), min(cw_degree, 4), min(offset_degree, 4)))
        mw_range = (lower[0], upper[0]) if self.neighbours else (1.0 / t_mw, 1.0 / t_mw)
        self._w_box = ([mw_range[0], lower[1], off_lo], [mw_range[1], upper[1], off_hi])
        # W feels T_MW only through the neighbours' droppers: degree 6 in 1/T_MW is exact to the
        # FE model within 1e-9 m (degree 4: 6e-9 m) over 15–26 kN, at half the cost of degree 14.
        self._w_degrees = (min(degree, 6), cw_degree, offset_degree)
        deflection = fit_chebyshev(deflection_map, *self._w_box, self._w_degrees)
        self._force = StackedMap(force.pruned(PRUNE_RTOL), n, n + 3 + n_extra)
        self._compliance = StackedMap(compliance.pruned(PRUNE_RTOL), n, n)
        self._deflection = StackedMap(deflection.pruned(PRUNE_RTOL), n, 2 * n + 3 + n_extra)

    def _condensed(self, p: np.ndarray, **kwargs) -> CondensedSpan:
        """The span condensed at ``p`` = (1/T_MW, 1/T_CW, δ) (δ read when the model was built with
        ``cw_clamp_offset_bounds_m``); a method, not a closure, so that a model is pickled whole
        (built in one process, used in another)."""
        delta = p[2] if self._offset_is_input else self.cw_clamp_offset_m
        return condense_span(self.span_type, self.catenary, 1.0 / p[0], 1.0 / p[1], delta, **self._around, **kwargs)

    @property
    def variable_offset(self) -> bool:
        """True when the CW clamp offset is a per-sample input (``cw_clamp_offset_bounds_m``)."""
        lo, hi = self.cw_clamp_offset_bounds_m
        return hi > lo

    def evaluate(self, dropper_lengths_m: np.ndarray, messenger_tension_n: np.ndarray,
                 system_height_left_m: np.ndarray, system_height_right_m: np.ndarray,
                 contact_tension_n: np.ndarray | float | None = None, *,
                 cw_offset_m: np.ndarray | float | None = None, cw_wear_fraction: np.ndarray | float | None = None,
                 cw_height_offset_left_m: np.ndarray | float | None = None,
                 cw_height_offset_right_m: np.ndarray | float | None = None,
                 chunk_size: int = 8192, slack: str = "flag") -> FastResult:
        """W, dropper forces and slack flags for N samples.

        Parameters
        ----------
        dropper_lengths_m : array_like, shape (N, n_droppers)
            Unstretched dropper lengths [m].
        messenger_tension_n : array_like, shape (N,)
            T_MW [N].
        system_height_left_m, system_height_right_m : array_like, shape (N,)
            ΔH at the left and right masts [m].
        contact_tension_n : array_like or float, optional
            T_CW [N]; default the span type's design tension.
        cw_offset_m : array_like or float, optional
            Offset δ of the span's CW clamps [m] (a model built with
            ``cw_clamp_offset_bounds_m``; default its lower bound if that is 0, else required).
        cw_wear_fraction : array_like or float, optional
            Fraction of the CW section lost by wear (an ``extended`` model; default 0).
        cw_height_offset_left_m, cw_height_offset_right_m : array_like or float, optional
            Raise of the left / right steady arm, MW with it [m] (an ``extended`` model; default 0).
        chunk_size : int
            Samples processed at once (bounds the temporary memory).
        slack : {"flag", "solve"}
            ``"flag"``: a sample with a dropper in compression is flagged and its W is the
            all-taut one (not a static solution). ``"solve"``: its slack droppers are solved
            (module docstring); ``slack`` in the result still marks such samples.

        Raises
        ------
        ValueError
            If shapes disagree, or an input the model was not built for is given.
        OutOfModelRangeError
            If a tension or offset lies outside the model's bounds (a ``ValueError`` too).
        """
        lengths = np.atleast_2d(np.asarray(dropper_lengths_m, dtype=float))
        n_samples = lengths.shape[0]
        if lengths.shape[1] != self.n_droppers:
            raise ValueError(f"dropper_lengths_m: expected shape (N, {self.n_droppers}), got {lengths.shape}")
        if contact_tension_n is None:
            contact_tension_n = self.span_type.contact_tension_n
        extras = (cw_wear_fraction, cw_height_offset_left_m, cw_height_offset_right_m)
        if not self.extended and any(v is not None for v in extras):
            raise ValueError("cw_wear_fraction, cw_height_offset_*_m: build the model with extended=True")
        if cw_offset_m is None:
            cw_offset_m = self.cw_clamp_offset_bounds_m[0]
        elif not self.variable_offset and np.any(np.asarray(cw_offset_m) != self.cw_clamp_offset_bounds_m[0]):
            raise ValueError("cw_offset_m: build the model with cw_clamp_offset_bounds_m")
        columns = [np.broadcast_to(np.asarray(v, dtype=float), (n_samples,)) for v in
                   (messenger_tension_n, system_height_left_m, system_height_right_m, contact_tension_n,
                    cw_offset_m, *(0.0 if v is None else v for v in extras))]
        t_mw, dh_l, dh_r, t_cw, delta = columns[:5]
        # A worn CW carries −ε of the central span's CW weight column (EXTRA_COLUMNS order).
        loads = (np.column_stack([-columns[5], columns[6], columns[7]]) if self.extended
                 else np.empty((n_samples, 0)))
        for name, values, (lo, hi) in (("messenger_tension_n", t_mw, self.messenger_tension_bounds_n),
                                       ("contact_tension_n", t_cw, self.contact_tension_bounds_n)):
            if not _within(values, lo * (1 - 1e-12), hi * (1 + 1e-12)):
                raise OutOfModelRangeError(f"{name}: values must lie in the model's bounds [{lo}, {hi}] N "
                                 f"(got {np.nanmin(values)}…{np.nanmax(values)}); build the model with wider bounds")
        lo, hi = self.cw_clamp_offset_bounds_m
        if not _within(delta, lo - 1e-12, hi + 1e-12):
            raise OutOfModelRangeError(f"cw_offset_m: values must lie in the model's bounds [{lo}, {hi}] m "
                                       f"(got {np.nanmin(delta)}…{np.nanmax(delta)})")
        if slack not in ("flag", "solve"):
            raise ValueError(f"slack: expected 'flag' or 'solve', got {slack!r}")
        w = np.empty((n_samples, self.n_droppers))
        force = np.empty_like(w)
        for start in range(0, n_samples, chunk_size):
            sl = slice(start, min(start + chunk_size, n_samples))
            force[sl], w[sl] = self._evaluate_chunk(lengths[sl], t_mw[sl], dh_l[sl], dh_r[sl], t_cw[sl], delta[sl],
                                                    loads[sl], solve_slack=slack == "solve")
        return FastResult(w_m=w, dropper_force_n=force, slack=row_minimum(force) <= 0.0)

    def profile_map(self, x_m: np.ndarray) -> "ProfileMap":
        """The CW deflection from the chord at abscissae ``x_m`` of the span [m], affine in the
        dropper forces, lengths and ΔH and interpolated in the tensions like W (exact to the FE
        model; at the dropper abscissae it equals W). Not for a model with a variable offset."""
        x = np.asarray(x_m, dtype=float)
        if x.ndim != 1 or np.any(x < 0) or np.any(x > self.span_type.length_m):
            raise ValueError(f"x_m: expected abscissae within the span [0, {self.span_type.length_m}] m")
        if self.variable_offset:
            raise ValueError("profile_map: not available for a model with a variable CW clamp offset")
        t_mw = self.span_type.messenger_tension_n

        def profile(p: np.ndarray) -> np.ndarray:
            point = np.array([p[0] if self.neighbours else 1.0 / t_mw, p[1], p[2]])
            return self._condensed(point, profile_x_m=x).profile.ravel()

        interpolant = fit_chebyshev(profile, *self._w_box, self._w_degrees)
        return ProfileMap(x_m=x, operator=StackedMap(interpolant, x.size, 2 * self.n_droppers + 3))

    def _evaluate_chunk(self, lengths, t_mw, dh_l, dh_r, t_cw, delta, loads, solve_slack=False):
        points = np.empty((lengths.shape[0], 3))
        np.divide(1.0, t_mw, out=points[:, 0])
        np.divide(1.0, t_cw, out=points[:, 1])
        points[:, 2] = delta
        offsets = delta[:, None] if self.variable_offset else self.cw_clamp_offset_m
        if np.any(offsets):
            rest, stiffness = inclined_dropper(lengths, offsets, self._ea)
            compliance_length = self._ea / stiffness
        else:
            rest = compliance_length = lengths
        cache = BasisCache(points)          # the three maps share their bases in 1/T_MW, 1/T_CW, δ
        f0 = self._force(points, _inputs(rest, dh_l, dh_r, loads), cache)
        # One fixed-point step for the dropper compliance deviation from the reference lengths.
        f = f0 - self._compliance(points, (compliance_length - self.reference_lengths_m) / self._ea * f0, cache)
        if solve_slack:
            f = self._slack_forces(points, f)
        w = self._deflection(points, _inputs(np.hstack([f, lengths]), dh_l, dh_r, loads), cache)
        return f, w

    def _slack_forces(self, points: np.ndarray, f: np.ndarray) -> np.ndarray:
        """Forces with the droppers in compression slack (module docstring), rows needing it only."""
        rows = np.flatnonzero(np.any(f <= 0.0, axis=1))
        if rows.size == 0:
            return f
        n = self.n_droppers
        k = np.stack([self._compliance(points[rows], np.broadcast_to(e, (rows.size, n))) for e in np.eye(n)],
                     axis=2)                                                     # (m, n, n): K[:, :, j] = K e_j
        full = f[rows]
        slack = full <= 0.0
        for _ in range(n):
            p = slack.astype(float)
            # (P K P + I − P) y = P F: y_S solves K_SS y_S = F_S, y_T = 0; F' = F − K P y.
            m = p[:, :, None] * k * p[:, None, :] + np.eye(n) * (1.0 - p)[:, None, :]
            y = np.linalg.solve(m, (p * full)[:, :, None])[:, :, 0]
            out = full - np.einsum("mij,mj->mi", k, p * y)
            out[slack] = 0.0
            grow = (out < 0.0) & ~slack
            if not grow.any():
                break
            slack |= grow
        f = f.copy()
        f[rows] = out
        return f


@dataclass(frozen=True)
class ProfileMap:
    """CW deflection from the chord along a span (:meth:`FastSpanModel.profile_map`)."""

    x_m: np.ndarray
    operator: StackedMap

    def deflection(self, result: FastResult, dropper_lengths_m: np.ndarray, messenger_tension_n: np.ndarray,
                   system_height_left_m: np.ndarray, system_height_right_m: np.ndarray,
                   contact_tension_n: np.ndarray) -> np.ndarray:
        """Deflection [m], shape (N, p), of N samples whose dropper forces are ``result``'s."""
        lengths = np.atleast_2d(np.asarray(dropper_lengths_m, dtype=float))
        n_samples = lengths.shape[0]
        t_mw, dh_l, dh_r, t_cw = (np.broadcast_to(np.asarray(v, dtype=float), (n_samples,)) for v in
                                  (messenger_tension_n, system_height_left_m, system_height_right_m,
                                   contact_tension_n))
        points = np.column_stack([1.0 / t_mw, 1.0 / t_cw, np.zeros(n_samples)])
        x = np.column_stack([result.dropper_force_n, lengths, dh_l, dh_r, np.ones(n_samples)])
        return self.operator(points, x)
