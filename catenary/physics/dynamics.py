"""Dynamic pantograph–catenary model.

Catenary
    The static model's mesh and exact tensioned-beam stiffness (:mod:`catenary.physics.static`), with
    Hermite consistent mass of both wires, lumped clamp masses, half of each dropper's mass at
    each end, and optional steady arms: at a mast with a steady arm the CW is free vertically,
    held by a spring of stiffness ``steady_arm.stiffness_n_m`` about its static height plus a
    constant holding force equal to the static reaction, and carries ``steady_arm.mass_kg``.
    The MW is fixed at the masts.
Damping
    Rayleigh, ``C = α M + β K₀``, with α, β chosen so the damping ratio equals
    ``damping_ratio`` at the two frequencies ``damping_frequencies_hz`` (default 1 % at 1 and
    20 Hz, hence ≥ 0.43 % in between and rising outside); ``K₀`` has every dropper taut.
Nonlinearities
    Droppers are tension-only and the pantograph head touches the CW through a penalty spring
    (``contact_stiffness_n_m``) that only pushes. Both are written as pseudo-forces on the
    linear all-taut model: a slack dropper ``j`` adds ``g_j λ_j`` with ``λ_j = min(k_j e_j, 0)``
    (``e_j`` its elongation, ``g_j`` its unit pair of nodal forces), and the contact adds
    ``N(x_p) F_c`` with the beam shape functions at the contact point. Each step solves a small
    active-set system for the slack droppers and the contact, using Green's functions of the
    factorised effective stiffness (precomputed per dropper, one back-substitution per step for
    the moving contact point). The linear operator is factorised once (banded Cholesky).
Time integration
    Newmark average acceleration (β = 1/4, γ = 1/2): implicit, unconditionally stable and
    energy-conserving for the linear undamped system; fixed step. It starts from the static
    equilibrium of catenary and pantograph at the start position.

One module, one concern: the dynamic model of one pantograph run over one section — its
matrices, damping, initial equilibrium and run. The compiled time-stepping kernel is
:mod:`catenary.physics.dynamics_kernel`, the pantograph :mod:`catenary.physics.pantograph`, the measuring car's
pass :mod:`catenary.physics.measuring`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.linalg import cholesky_banded
from scipy.linalg.lapack import dpbtrs

from . import beam
from .config import Catenary, DynamicSettings
from catenary.plumbing.errors import ConvergenceError
from .pantograph import Pantograph
from .section import Section
from .dynamics_kernel import SINGULAR, band_rows, band_solve, mass_band, newmark_contact_loop
from .static import CW, DOFS_PER_NODE, MW, StaticModel, assemble_matrix, element_dofs

BANDWIDTH = 5  # interleaved [cw_w, cw_θ, mw_w, mw_θ]: farthest coupling is node n ↔ θ of node n+1
NEWMARK_BETA, NEWMARK_GAMMA = 0.25, 0.5


def rayleigh_coefficients(ratio: float, f1_hz: float, f2_hz: float) -> tuple[float, float]:
    """(α [1/s], β [s]) giving damping ratio ``ratio`` at f1 and f2."""
    w1, w2 = 2 * np.pi * f1_hz, 2 * np.pi * f2_hz
    return 2 * ratio * w1 * w2 / (w1 + w2), 2 * ratio / (w1 + w2)


def _banded(matrix: sp.spmatrix) -> np.ndarray:
    """Upper banded storage of a symmetric matrix for :func:`scipy.linalg.cholesky_banded`.

    The bandwidth is ``BANDWIDTH`` for vertical droppers; an inclined dropper couples the MW
    at one node with the CW at a neighbouring one and widens it.
    """
    m = matrix.tocoo()
    n = m.shape[0]
    nonzero = m.data != 0
    width = max(BANDWIDTH, int(np.max(m.col[nonzero] - m.row[nonzero], initial=0)))
    ab = np.zeros((width + 1, n))
    m = m.tocsr()
    for d in range(width + 1):
        ab[width - d, d:] = m.diagonal(d)
    return ab


class CatenaryDynamics:
    """Assembled linear operators of a section for dynamics and quasi-statics.

    Parameters
    ----------
    section : Section
    catenary : Catenary
        Uses ``catenary.steady_arm`` and ``catenary.dynamics``.
    damping : bool
        False gives the undamped system (energy checks).
    """

    def __init__(self, section: Section, catenary: Catenary, *, damping: bool = True):
        self.section = section
        self.catenary = catenary
        self.settings: DynamicSettings = catenary.dynamics
        static = StaticModel(section, catenary)
        self.static_model = static
        self.mesh = mesh = static.mesh
        gravity_state = static.solve()
        self.gravity_state = gravity_state
        n = static.n_dofs
        masts = mesh.mast_nodes
        sa = catenary.steady_arm
        mw_fixed = DOFS_PER_NODE * masts + MW
        cw_mast = DOFS_PER_NODE * masts + CW
        fixed = mw_fixed if sa.stiffness_n_m is not None else np.concatenate([mw_fixed, cw_mast])
        fixed_values = gravity_state.dofs[fixed]
        free_mask = np.ones(n, dtype=bool)
        free_mask[fixed] = False
        self.free = free = np.flatnonzero(free_mask)
        self.n_free = free.size
        index = -np.ones(n, dtype=int)
        index[free] = np.arange(free.size)
        self.index = index  # global DOF → free-DOF position (−1 if fixed)

        # Stiffness with every dropper taut, plus steady-arm springs.
        k_d, f_d = static.dropper_matrices(np.ones(section.dropper_lengths_m.size, dtype=bool))
        k0 = (static.k_wires + k_d).tolil()
        f = static.f_gravity + f_d
        if sa.stiffness_n_m is not None:
            for dof, reaction in zip(cw_mast, gravity_state.cw_reaction_n):
                k0[dof, dof] += sa.stiffness_n_m
                f[dof] += reaction + sa.stiffness_n_m * gravity_state.dofs[dof]
        k0 = k0.tocsr()
        self.k0 = k0[free][:, free].tocsr()
        self.f_const = f[free] - k0[free][:, fixed] @ fixed_values

        # Mass: consistent for the wires, lumped for clamps, droppers and steady arms.
        h = mesh.element_length_m
        cw_mass = beam.consistent_mass(h, catenary.contact.mass_per_length_kg_m) \
            * section.cw_mass_factor_by_span[mesh.element_span][:, None, None]
        mass = (assemble_matrix(element_dofs(mesh, CW), cw_mass, n)
                + assemble_matrix(element_dofs(mesh, MW), beam.consistent_mass(h, catenary.messenger.mass_per_length_kg_m), n))
        lumped = np.zeros(n)
        d = catenary.droppers
        half = 0.5 * d.mass_per_length_kg_m * section.dropper_lengths_m
        np.add.at(lumped, static.dropper_cw_dof, d.clamp_mass_contact_kg + half)
        np.add.at(lumped, static.dropper_mw_dof, d.clamp_mass_messenger_kg + half)
        np.add.at(lumped, DOFS_PER_NODE * mesh.cw_point_mass_nodes + CW, section.cw_point_mass_kg)
        if sa.stiffness_n_m is not None:
            lumped[cw_mast] += sa.mass_kg
        mass = (mass + sp.diags(lumped)).tocsr()
        self.mass = mass[free][:, free].tocsr()
        if damping:
            alpha, beta = rayleigh_coefficients(self.settings.damping_ratio, *self.settings.damping_frequencies_hz)
        else:
            alpha = beta = 0.0
        self.rayleigh = (alpha, beta)
        self.damping = (alpha * self.mass + beta * self.k0).tocsr()

        self.dropper_cw = index[static.dropper_cw_dof]
        self.dropper_mw = index[static.dropper_mw_dof]
        self.dropper_k = static.dropper_stiffness_n_m
        self.dropper_l = static.dropper_rest_length_m
        self.fixed, self.fixed_values = fixed, fixed_values

        # Contact interpolation: exact shape functions, their basis inverse cached per element.
        cw = catenary.contact
        self._element_free_dofs = index[element_dofs(mesh, CW)]
        self._lam = None
        if cw.bending_stiffness_n_m2:
            self._lam = np.sqrt(section.contact_tension_by_span_n[mesh.element_span] / cw.bending_stiffness_n_m2)
            pairs = np.column_stack([np.round(h, 12), self._lam])
            unique, inverse = np.unique(pairs, axis=0, return_inverse=True)
            c, _ = beam.exact_basis_matrix(unique[:, 0], unique[:, 1])
            self._basis_inverse = np.linalg.inv(c)[inverse.ravel()]

        self._solvers: dict[tuple[float, float], PseudoForceSolver] = {}

    def solver(self, mass_factor: float = 0.0, damping_factor: float = 0.0) -> "PseudoForceSolver":
        """The :class:`PseudoForceSolver` of ``K₀ + mass_factor·M + damping_factor·C`` (both 0: the
        static one), factorised once per pair and kept: the runs over a section at several speeds
        with one time step share their static and their Newmark matrices."""
        key = (float(mass_factor), float(damping_factor))
        if key not in self._solvers:
            k = self.k0 if key == (0.0, 0.0) else self.k0 + key[0] * self.mass + key[1] * self.damping
            self._solvers[key] = PseudoForceSolver(self, k)
        return self._solvers[key]

    def contact_vector(self, chainage_m: float) -> tuple[np.ndarray, np.ndarray]:
        """Free-DOF indices and exact shape-function values of the CW at ``chainage_m``."""
        x_nodes = self.mesh.x_m
        if not x_nodes[0] - 1e-9 <= chainage_m <= x_nodes[-1] + 1e-9:
            raise ValueError(f"chainage {chainage_m} m outside the section [{x_nodes[0]}, {x_nodes[-1]}] m")
        e = min(max(int(np.searchsorted(x_nodes, chainage_m, side="right")) - 1, 0), x_nodes.size - 2)
        h = x_nodes[e + 1] - x_nodes[e]
        x = min(max(chainage_m - x_nodes[e], 0.0), h)
        if self._lam is None:
            n = beam.shape_functions(np.array(x / h), np.array(h))
        else:
            lam = self._lam[e]
            n = np.array([1.0, x, np.exp(-lam * x), np.exp(-lam * (h - x))]) @ self._basis_inverse[e]
        dofs = self._element_free_dofs[e]
        keep = dofs >= 0
        return dofs[keep], n[keep]



class PseudoForceSolver:
    """Solves ``K u = r + Σ_slack g_j λ_j + N_p F_c`` with tension-only droppers and
    penalty contact, for a fixed symmetric positive-definite ``K`` (banded Cholesky)."""

    def __init__(self, ops: CatenaryDynamics, k_eff: sp.spmatrix, max_iterations: int = 50):
        self.ops = ops
        self.factor = cholesky_banded(_banded(k_eff), lower=False)
        # the factor as the compiled solve reads it (:func:`.dynamics_kernel.band_rows`)
        self.rows, self.inv_diag_sq = band_rows(self.factor)
        n_d = ops.dropper_k.size
        g = np.zeros((ops.n_free, n_d))
        cols = np.arange(n_d)
        g[ops.dropper_mw, cols] = 1.0
        g[ops.dropper_cw, cols] = -1.0
        self.z = self.solve(g)
        self.d = self.z[ops.dropper_mw] - self.z[ops.dropper_cw]  # g_iᵀ K⁻¹ g_j
        self.max_iterations = max_iterations
        self._unit_key: tuple = ()
        self._unit = np.zeros((ops.n_free, 0))

    def unit_responses(self, dofs: np.ndarray) -> np.ndarray:
        """``K⁻¹ e_j`` for the free DOFs ``dofs`` (the element under the contact), shape (n, len(dofs)).

        The contact stays on one element for many steps: the last element's responses are kept.
        """
        key = tuple(int(d) for d in dofs)
        if key != self._unit_key:
            columns = []
            for d in key:
                e = np.zeros(self.ops.n_free)
                e[d] = 1.0
                columns.append(self.solve(e))
            self._unit_key = key
            self._unit = np.column_stack(columns) if columns else np.zeros((self.ops.n_free, 0))
        return self._unit

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """``K⁻¹ rhs`` for one right-hand side (the compiled banded solve: at the half-bandwidth 5
        of a section's 9 131 unknowns 33 µs, against 228 µs for LAPACK's ``dpbtrs``, whose
        generic loops and call dominate at so narrow a band; one-off measurements, 2026-11-28) or several (``dpbtrs``)."""
        rhs = np.asarray(rhs, dtype=float)
        if rhs.shape[0] != self.rows.shape[0]:
            raise ValueError(f"rhs: expected {self.rows.shape[0]} rows (the free DOFs), got {rhs.shape[0]}")
        if rhs.ndim == 1:
            return band_solve(self.rows, self.inv_diag_sq, np.ascontiguousarray(rhs), np.empty_like(rhs))
        x, info = dpbtrs(self.factor, rhs, lower=0)
        if info != 0:
            raise ValueError(f"banded back-substitution failed (LAPACK info {info})")
        return x

    def equilibrium(self, rhs: np.ndarray, slack: np.ndarray, contact: "ContactState | None" = None,
                    u_star: np.ndarray | None = None):
        """Solve with pseudo-forces; returns (u, dropper forces, slack mask, contact force, in_contact).

        ``contact`` carries the contact point (dofs, shape values), the penalty stiffness and
        the head's predicted height and compliance (``head_free_m``, ``head_flex_m_n``); with
        ``head_flex_m_n = None`` the contact force is prescribed as ``force_n`` instead.
        ``u_star``: ``K⁻¹ rhs`` where the caller already has it (a quasi-static pass solves the
        same gravity loads at every point).
        """
        ops = self.ops
        k, length = ops.dropper_k, ops.dropper_l
        if u_star is None:
            u_star = self.solve(rhs)
        if contact is not None:
            # the contact column comes from the cached element responses
            zp = self.unit_responses(contact.dofs) @ contact.shape
            zp_g = zp[ops.dropper_mw] - zp[ops.dropper_cw]
            w_star = contact.shape @ u_star[contact.dofs]
            cz = contact.shape @ zp[contact.dofs]
        else:
            zp_g = np.zeros(k.size)
        e_star = u_star[ops.dropper_mw] - u_star[ops.dropper_cw] - length
        slack = slack.copy()
        touching = contact is not None and (contact.head_flex_m_n is None or contact.touching)
        for _ in range(self.max_iterations):
            s_idx = np.flatnonzero(slack)
            ns = s_idx.size
            a = np.zeros((ns + 1, ns + 1))
            b = np.zeros(ns + 1)
            a[:ns, :ns] = np.eye(ns) - k[s_idx, None] * self.d[np.ix_(s_idx, s_idx)]
            b[:ns] = k[s_idx] * e_star[s_idx]
            if touching and contact.head_flex_m_n is not None:
                a[:ns, ns] = -k[s_idx] * zp_g[s_idx]
                a[ns, :ns] = contact.stiffness_n_m * zp_g[s_idx]
                a[ns, ns] = 1.0 - contact.stiffness_n_m * contact.head_flex_m_n + contact.stiffness_n_m * cz
                b[ns] = contact.stiffness_n_m * (contact.head_free_m - w_star)
                x = np.linalg.solve(a, b)
            else:
                force_c = contact.force_n if (touching and contact.head_flex_m_n is None) else 0.0
                b[:ns] += k[s_idx] * zp_g[s_idx] * force_c
                x = np.append(np.linalg.solve(a[:ns, :ns], b[:ns]) if ns else np.zeros(0), force_c)
            lam, f_c = x[:ns], x[ns]
            elongation = e_star + self.d[:, s_idx] @ lam + zp_g * f_c
            new_slack = k * elongation < 0.0
            new_touching = touching
            if contact is not None and contact.head_flex_m_n is not None:
                w = w_star + zp_g[s_idx] @ lam + cz * f_c
                gap = contact.head_free_m + contact.head_flex_m_n * f_c - w
                new_touching = (f_c > 0.0) if touching else (gap > 0.0)
            if np.array_equal(new_slack, slack) and new_touching == touching:
                break
            slack, touching = new_slack, new_touching
        else:
            raise ConvergenceError(f"dropper/contact states did not settle in {self.max_iterations} iterations")
        u = u_star + self.z[:, s_idx] @ lam
        if contact is not None:
            u = u + zp * f_c
        forces = np.where(slack, 0.0, k * elongation)
        return u, forces, slack, f_c, touching


@dataclass
class ContactState:
    """Contact point data for :meth:`PseudoForceSolver.equilibrium`."""

    dofs: np.ndarray
    shape: np.ndarray
    stiffness_n_m: float = 0.0
    head_free_m: float = 0.0
    head_flex_m_n: float | None = None
    touching: bool = True
    force_n: float = 0.0


def quasi_static_heights(ops: CatenaryDynamics, chainage_m: np.ndarray, force_n: float | np.ndarray) -> np.ndarray:
    """CW height under an upward point force ``force_n`` [N] (one, or one per point) at each
    chainage, each a static solve of the same catenary (dropper slackening and steady arms
    included) [m]."""
    solver = ops.solver()
    slack = np.zeros(ops.dropper_k.size, dtype=bool)
    out = np.empty(len(chainage_m))
    forces = np.broadcast_to(np.asarray(force_n, dtype=float), out.shape)
    gravity = solver.solve(ops.f_const)         # K⁻¹ f, the same at every point
    for i, s in enumerate(np.asarray(chainage_m, dtype=float)):
        dofs, shape = ops.contact_vector(s)
        contact = ContactState(dofs, shape, force_n=float(forces[i]))
        u, _, slack, _, _ = solver.equilibrium(ops.f_const, slack, contact, u_star=gravity)
        out[i] = shape @ u[dofs]
    return out


def _initial_equilibrium(ops: CatenaryDynamics, solver: "PseudoForceSolver", pantograph: Pantograph,
                         start_m: float, f_mean: float, reference_m: float, k_c: float):
    """Static equilibrium of catenary and pantograph with the head at ``start_m``.

    The contact force ``f`` solves ``reference + flex·(f_mean − f) = w(start; f) + f/k_c`` (head
    height from the pantograph side equals the CW height plus the penalty penetration); with
    a constant-force pantograph (flex = ∞), ``f = f_mean``. Secant iteration on ``f``: the
    catenary response is piecewise linear in ``f``.
    Returns (u, slack droppers, contact force, head height).
    """
    dofs, shape = ops.contact_vector(start_m)
    no_slack = np.zeros(ops.dropper_k.size, dtype=bool)

    def cw_height(force):
        u, _, slack, _, _ = solver.equilibrium(ops.f_const, no_slack, ContactState(dofs, shape, force_n=force))
        return shape @ u[dofs], u, slack

    flex = pantograph.head_flexibility_m_n
    if np.isinf(flex):
        w, u, slack = cw_height(f_mean)
        return u, slack, f_mean, w + f_mean / k_c

    def residual(force):
        w, u, slack = cw_height(force)
        return reference_m + flex * (f_mean - force) - w - force / k_c, u, slack

    f_a, f_b = f_mean, 0.5 * f_mean
    r_a, u, slack = residual(f_a)
    for _ in range(20):
        r_b, u, slack = residual(f_b)
        if abs(r_b) < 1e-12:
            break
        f_a, f_b, r_a = f_b, f_b - r_b * (f_b - f_a) / (r_b - r_a), r_b
    else:
        raise ConvergenceError("initial pantograph–catenary equilibrium did not converge")
    w = shape @ u[dofs]
    return u, slack, f_b, w + f_b / k_c


@dataclass(frozen=True)
class RunResult:
    """Time histories of a pantograph run, one row per time step.

    Attributes
    ----------
    time_s, chainage_m : numpy.ndarray
        Time and contact-point chainage.
    contact_force_n : numpy.ndarray
        Penalty contact force [N] (0 when contact is lost).
    cw_height_m : numpy.ndarray
        CW height at the contact point [m] (what a recording car measures).
    head_height_m : numpy.ndarray
        Pantograph head height [m].
    support_uplift_m : numpy.ndarray
        CW height at each steady arm minus its static height, shape (n_steps, n_masts) [m].
    slack_droppers : numpy.ndarray
        Number of slack droppers at each step.
    """

    time_s: np.ndarray
    chainage_m: np.ndarray
    contact_force_n: np.ndarray
    cw_height_m: np.ndarray
    head_height_m: np.ndarray
    support_uplift_m: np.ndarray
    slack_droppers: np.ndarray


def _profile_values(profile: tuple[np.ndarray, np.ndarray], name: str) -> tuple[np.ndarray, np.ndarray]:
    knots, values = (np.asarray(a, dtype=float) for a in profile)
    if knots.ndim != 1 or knots.shape != values.shape or knots.size < 2 or np.any(np.diff(knots) <= 0):
        raise ValueError(f"{name}: expected (chainage_m, values) of equal length ≥ 2 with increasing chainages")
    if np.any(~np.isfinite(values)):
        raise ValueError(f"{name}: expected finite values")
    return knots, values


def contact_path(start_m: float, end_m: float, speed_m_s: float, time_step_s: float,
                 speed_profile: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Chainage of the contact point at each time step from ``start_m`` to ``end_m`` [m].

    At constant speed ``x_k = start + v k Δt``. With ``speed_profile = (chainage_m, speed_m_s)``
    the speed varies along the line (linear between the knots, held beyond them): the time to
    reach ``x`` is ``t(x) = ∫ dx / v(x)`` (trapezoidal on a grid of ≤ 0.05 m, far finer than the
    10 m or more over which a train's speed changes) and ``x_k`` is read off ``t(x)`` at
    ``k Δt``.
    """
    if speed_profile is None:
        n_steps = int(np.floor((end_m - start_m) / (speed_m_s * time_step_s))) + 1
        return start_m + speed_m_s * (np.arange(n_steps) * time_step_s)
    knots, v = _profile_values(speed_profile, "speed_profile")
    if np.any(v <= 0):
        raise ValueError(f"speed_profile: expected speeds > 0 [m/s], got a minimum of {v.min()}")
    grid = np.linspace(start_m, end_m, int(np.ceil((end_m - start_m) / 0.05)) + 1)
    slowness = 1.0 / np.interp(grid, knots, v)
    t = np.concatenate([[0.0], np.cumsum(0.5 * (slowness[1:] + slowness[:-1]) * np.diff(grid))])
    n_steps = int(np.floor(t[-1] / time_step_s + 1e-9)) + 1   # 1e-9: the round-off of t(x)
    return np.interp(np.arange(n_steps) * time_step_s, t, grid)


def run_pantograph(ops: CatenaryDynamics, pantograph: Pantograph, speed_m_s: float, *,
                   start_m: float | None = None, end_m: float | None = None,
                   time_step_s: float | None = None,
                   speed_profile: tuple[np.ndarray, np.ndarray] | None = None,
                   force_profile: tuple[np.ndarray, np.ndarray] | None = None,
                   stop_m: float | None = None) -> RunResult:
    """Run ``pantograph`` over the section from ``start_m`` to ``end_m``.

    The run starts from the static equilibrium of catenary and pantograph with the uplift
    force at ``start_m`` (default: the first mast); ``time_step_s`` defaults to the
    catenary's dynamics settings.

    Parameters
    ----------
    speed_m_s : float
        Train speed [m/s]; constant unless ``speed_profile`` is given.
    speed_profile : (numpy.ndarray, numpy.ndarray), optional
        ``(chainage_m, speed_m_s)``: the speed along the line [m/s] (see :func:`contact_path`).
        The uplift force then follows the local speed's aerodynamic part.
    force_profile : (numpy.ndarray, numpy.ndarray), optional
        ``(chainage_m, delta_force_n)``: a fluctuation of the regulated uplift force along the
        line [N], added to the mean force (linear between the knots, held beyond them).
    stop_m : float, optional
        Simulate only the steps whose contact point lies at or before this chainage [m]. The
        run is still the one from ``start_m`` to ``end_m`` (the same steps, the pantograph's
        reference height that of the whole run); a step cannot depend on later ones, so the
        result is the first steps of the whole run's, exactly. Default: ``end_m``.
    """
    settings = ops.settings
    dt = settings.time_step_s if time_step_s is None else time_step_s
    masts = ops.section.mast_chainage_m
    start = masts[0] if start_m is None else start_m
    end = masts[-1] if end_m is None else end_m
    x_steps = contact_path(start, end, speed_m_s, dt, speed_profile)
    if stop_m is not None:
        x_steps = x_steps[:max(int(np.searchsorted(x_steps, stop_m, side="right")), 1)]
    n_steps = x_steps.size
    f_mean = pantograph.mean_force_n(speed_m_s)
    if speed_profile is None:
        force_steps = np.full(n_steps, f_mean)
    else:
        knots, v = _profile_values(speed_profile, "speed_profile")
        force_steps = pantograph.mean_force_n(np.interp(x_steps, knots, v))
    if force_profile is not None:
        knots, delta = _profile_values(force_profile, "force_profile")
        force_steps = force_steps + np.interp(x_steps, knots, delta)
    f_start = float(force_steps[0])
    beta, gamma = NEWMARK_BETA, NEWMARK_GAMMA
    a0, a1 = 1 / (beta * dt**2), gamma / (beta * dt)
    a2, a3 = 1 / (beta * dt), 1 / (2 * beta) - 1
    a4, a5 = gamma / beta - 1, dt / 2 * (gamma / beta - 2)
    k_c = settings.contact_stiffness_n_m

    # Initial static equilibrium of catenary and pantograph at the start.
    static_solver = ops.solver()
    reference = float(np.mean(ops.gravity_state.cw_height_at(np.linspace(start, end, 201))))
    u, slack, f0, head0 = _initial_equilibrium(ops, static_solver, pantograph, start, f_start, reference, k_c)
    v = np.zeros_like(u)
    acc = np.zeros_like(u)

    m_p, c_p, k_p = pantograph.matrices()
    k_eff_p = k_p + a0 * m_p + a1 * c_p
    e_h = np.zeros(pantograph.n_masses)
    e_h[0] = 1.0
    k_eff_p_inv = np.linalg.inv(k_eff_p)
    p_flex = -k_eff_p_inv[:, 0]  # response to a unit downward force on the head
    # Pantograph DOFs: displacements from the reference configuration (head at ``reference``,
    # springs carrying the starting force); static start: K y = e_h (f_start − f0).
    if np.isinf(pantograph.head_flexibility_m_n):
        y = np.full(pantograph.n_masses, head0 - reference)  # constant force: rigid shift
    else:
        y = np.linalg.solve(k_p, e_h * (f_start - f0))
    yv, ya = np.zeros_like(y), np.zeros_like(y)

    solver = ops.solver(a0, a1)
    mast_dofs = ops.index[DOFS_PER_NODE * ops.mesh.mast_nodes + CW]
    static_mast = ops.gravity_state.cw_height_m[ops.mesh.mast_nodes]
    out = {k: np.empty(n_steps) for k in ("f", "w", "head", "slack")}
    uplift = np.zeros((n_steps, masts.size))
    # The time loop, compiled (catenary.physics.dynamics_kernel): the same steps as the equations above.
    rows, inv_diag_sq = solver.rows, solver.inv_diag_sq
    kd = rows.shape[1] - 1                    # K_eff's half-bandwidth, which M and C share
    exact = ops._lam is not None
    status, bad_step = newmark_contact_loop(
        n_steps, dt, x_steps, force_steps, np.array([a0, a1, a2, a3, a4, a5, gamma]), np.array(ops.rayleigh),
        ops.f_const, mass_band(ops.mass, kd), rows, inv_diag_sq,
        np.ascontiguousarray(solver.z.T), solver.d, ops.dropper_mw.astype(np.int64), ops.dropper_cw.astype(np.int64),
        ops.dropper_k.astype(float), ops.dropper_l.astype(float), ops.mesh.x_m.astype(float),
        ops._lam if exact else np.zeros(1), ops._basis_inverse if exact else np.zeros((1, 4, 4)), exact,
        ops._element_free_dofs.astype(np.int64), m_p, c_p, k_eff_p_inv, p_flex, reference, k_c,
        mast_dofs.astype(np.int64), static_mast, u, v, acc, y, yv, ya, np.asarray(slack, dtype=np.bool_),
        True, f0, solver.max_iterations, out["f"], out["w"], out["head"], out["slack"], uplift)
    if status == SINGULAR:      # as np.linalg.solve would raise: not a physics outcome
        raise np.linalg.LinAlgError(f"singular dropper/contact system at step {bad_step} "
                                    f"(chainage {x_steps[bad_step]:.2f} m)")
    if status != 0:
        raise ConvergenceError(f"dropper/contact states did not settle in {solver.max_iterations} iterations "
                               f"at step {bad_step} (chainage {x_steps[bad_step]:.2f} m)")
    out["t"] = np.arange(n_steps) * dt
    out["x"] = x_steps
    return RunResult(time_s=out["t"], chainage_m=out["x"], contact_force_n=out["f"], cw_height_m=out["w"],
                     head_height_m=out["head"], support_uplift_m=uplift, slack_droppers=out["slack"].astype(int))


def free_vibration(ops: CatenaryDynamics, initial_velocity: np.ndarray, duration_s: float,
                   time_step_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Free vibration about the static equilibrium (no pantograph) from an initial velocity
    field on the free DOFs [m/s, rad/s]. Returns (time [s], total energy [J]): kinetic plus
    the strain and gravity energy of the all-taut linear system measured from equilibrium,
    ½ vᵀMv + ½ (u − u₀)ᵀK₀(u − u₀), exact while no dropper slackens."""
    dt = time_step_s
    beta, gamma = NEWMARK_BETA, NEWMARK_GAMMA
    a0, a1 = 1 / (beta * dt**2), gamma / (beta * dt)
    a2, a3 = 1 / (beta * dt), 1 / (2 * beta) - 1
    a4, a5 = gamma / beta - 1, dt / 2 * (gamma / beta - 2)
    static_solver = ops.solver()
    no_slack = np.zeros(ops.dropper_k.size, dtype=bool)
    u0, _, slack, _, _ = static_solver.equilibrium(ops.f_const, no_slack)
    solver = ops.solver(a0, a1)
    u, v = u0.copy(), np.asarray(initial_velocity, dtype=float).copy()
    acc = sp.linalg.spsolve(ops.mass.tocsc(), -(ops.damping @ v))  # K₀(u − u₀) = 0 at start
    n_steps = int(round(duration_s / dt)) + 1
    energy = np.empty(n_steps)
    for step in range(n_steps):
        if step:
            rhs = ops.f_const + ops.mass @ (a0 * u + a2 * v + a3 * acc) + ops.damping @ (a1 * u + a4 * v + a5 * acc)
            u_new, _, slack, _, _ = solver.equilibrium(rhs, slack)
            acc_new = a0 * (u_new - u) - a2 * v - a3 * acc
            v = v + dt * ((1 - gamma) * acc + gamma * acc_new)
            u, acc = u_new, acc_new
        d = u - u0
        energy[step] = 0.5 * v @ (ops.mass @ v) + 0.5 * d @ (ops.k0 @ d)
    return np.arange(n_steps) * dt, energy


def natural_frequencies_hz(ops: CatenaryDynamics, n_modes: int = 6) -> np.ndarray:
    """Lowest natural frequencies of the linear all-taut catenary [Hz]."""
    from scipy.sparse.linalg import eigsh
    values = eigsh(ops.k0.tocsc(), k=n_modes, M=ops.mass.tocsc(), sigma=0.0, which="LM",
                   return_eigenvectors=False)
    return np.sort(np.sqrt(np.abs(values))) / (2 * np.pi)
