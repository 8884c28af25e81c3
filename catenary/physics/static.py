"""Static finite-element model of a catenary section.

Contact wire (CW) and messenger wire (MW) are pre-tensioned Euler–Bernoulli beams on a shared
mesh, with the exact tensioned-beam element of :mod:`catenary.physics.beam` (nodally exact for any
element length: the 8 cm bending layers at droppers and masts are resolved). Droppers are vertical bars of stiffness
``EA / L`` in tension and none in compression; ``L`` is the unstretched length. Gravity acts
on the wires, on the clamps and on the dropper wires (half of a dropper's weight at each end,
taut or slack). The CW is held at each steady arm at its support height and the MW at each
mast at that height plus the system height.

The dropper states are found by an active-set iteration: solve with the current set of taut
droppers, make slack every taut dropper in compression and taut every slack dropper that
would be stretched, repeat until no dropper changes state. A solve that does not settle
raises :class:`~catenary.plumbing.errors.ConvergenceError`.

Degrees of freedom are interleaved per node: ``[cw_w, cw_θ, mw_w, mw_θ]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from . import beam
from .config import Catenary, Wire
from catenary.plumbing.errors import ConvergenceError
from .section import Mesh, Section, build_mesh, inclined_dropper

DOFS_PER_NODE = 4
CW, MW = 0, 2  # offset of each wire's vertical DOF within a node


@dataclass(frozen=True)
class StaticSolution:
    """Static equilibrium of a section.

    Attributes
    ----------
    section : Section
    mesh : Mesh
    dofs : numpy.ndarray
        All nodal unknowns, interleaved ``[cw_w, cw_θ, mw_w, mw_θ]`` per node [m, rad].
    dropper_force_n : numpy.ndarray
        Tension in each dropper [N] (0 when slack).
    dropper_slack : numpy.ndarray of bool
        True for droppers that are slack.
    cw_reaction_n, mw_reaction_n : numpy.ndarray
        Upward vertical reaction of each support on the CW and on the MW [N].
    iterations : int
        Active-set iterations used.
    """

    section: Section
    mesh: Mesh
    dofs: np.ndarray
    dropper_force_n: np.ndarray
    dropper_slack: np.ndarray
    cw_reaction_n: np.ndarray
    mw_reaction_n: np.ndarray
    iterations: int

    @property
    def cw_height_m(self) -> np.ndarray:
        """CW height at the nodes [m]."""
        return self.dofs[CW::DOFS_PER_NODE]

    @property
    def mw_height_m(self) -> np.ndarray:
        """MW height at the nodes [m]."""
        return self.dofs[MW::DOFS_PER_NODE]

    @property
    def any_slack(self) -> bool:
        return bool(np.any(self.dropper_slack))

    def cw_height_at(self, chainage_m: np.ndarray) -> np.ndarray:
        """CW height at any chainage of the section, interpolated with the beam shape functions [m]."""
        return wire_height_at(self.mesh, self.dofs, chainage_m, CW)

    def mw_height_at(self, chainage_m: np.ndarray) -> np.ndarray:
        """MW height at any chainage of the section [m]."""
        return wire_height_at(self.mesh, self.dofs, chainage_m, MW)

    def cw_deflection_at(self, chainage_m: np.ndarray) -> np.ndarray:
        """CW height minus the chord between the steady arms of its span [m] (negative = below)."""
        s = np.asarray(chainage_m, dtype=float)
        return self.cw_height_at(s) - self.section.chord_height_m(s)

    def dropper_deflection_m(self) -> np.ndarray:
        """W: CW deflection from the chord at every dropper's design position [m], shape (n_droppers,)."""
        s = self.section.dropper_chainage_m
        return self.cw_height_m[self.mesh.dropper_nodes] - self.section.chord_height_m(s)


def wire_height_at(mesh: Mesh, dofs: np.ndarray, chainage_m: np.ndarray, wire_offset: int) -> np.ndarray:
    """Height of a wire at chainages from nodal DOFs, with the Hermite shape functions [m]."""
    e, xi = mesh.locate(chainage_m)
    h = mesh.element_length_m[e]
    n = beam.shape_functions(xi, h)
    i0 = DOFS_PER_NODE * e + wire_offset
    i1 = i0 + DOFS_PER_NODE
    return n[..., 0] * dofs[i0] + n[..., 1] * dofs[i0 + 1] + n[..., 2] * dofs[i1] + n[..., 3] * dofs[i1 + 1]


def element_dofs(mesh: Mesh, wire_offset: int) -> np.ndarray:
    """Global DOF numbers of each element of one wire, shape (n_elements, 4)."""
    first = DOFS_PER_NODE * np.arange(mesh.n_nodes - 1) + wire_offset
    return np.stack([first, first + 1, first + DOFS_PER_NODE, first + DOFS_PER_NODE + 1], axis=1)


def assemble_matrix(dofs: np.ndarray, blocks: np.ndarray, n_dofs: int) -> sp.csr_matrix:
    """Sparse global matrix from element blocks (n, 4, 4) scattered to ``dofs`` (n, 4)."""
    rows = np.repeat(dofs, 4, axis=1).ravel()
    cols = np.tile(dofs, (1, 4)).ravel()
    return sp.csr_matrix((blocks.ravel(), (rows, cols)), shape=(n_dofs, n_dofs))


def _unique_elements(mesh: Mesh, tension_by_span_n: np.ndarray):
    """Distinct (length, tension) pairs of the elements: (lengths, tensions, inverse index)."""
    pairs = np.column_stack([np.round(mesh.element_length_m, 12), tension_by_span_n[mesh.element_span]])
    unique, inverse = np.unique(pairs, axis=0, return_inverse=True)
    return unique[:, 0], unique[:, 1], inverse.ravel()


def wire_stiffness(mesh: Mesh, wire: Wire, tension_by_span_n: np.ndarray, wire_offset: int) -> sp.csr_matrix:
    """Bending plus tension stiffness of one wire, in the section's global numbering."""
    h, tension, inverse = _unique_elements(mesh, tension_by_span_n)
    k = beam.tensioned_stiffness(h, wire.bending_stiffness_n_m2, tension)[inverse]
    return assemble_matrix(element_dofs(mesh, wire_offset), k, DOFS_PER_NODE * mesh.n_nodes)


def wire_weight_loads(mesh: Mesh, wire: Wire, tension_by_span_n: np.ndarray, wire_offset: int, gravity_m_s2: float,
                      mass_factor_by_span: np.ndarray | None = None) -> np.ndarray:
    """Work-equivalent nodal loads of one wire's weight [N, N·m], exact shape functions.

    Parameters
    ----------
    mass_factor_by_span : numpy.ndarray, optional
        Mass per length of each span relative to ``wire``'s (a worn CW; 0 leaves a span's wire
        weightless, which the fast model uses to isolate one span's weight). Default 1.
    """
    h, tension, inverse = _unique_elements(mesh, tension_by_span_n)
    q = -wire.mass_per_length_kg_m * gravity_m_s2
    loads = beam.tensioned_uniform_load(h, q, wire.bending_stiffness_n_m2, tension)[inverse]
    if mass_factor_by_span is not None:      # the load is linear in q: scale it per element
        loads = loads * np.asarray(mass_factor_by_span, dtype=float)[mesh.element_span][:, None]
    f = np.zeros(DOFS_PER_NODE * mesh.n_nodes)
    np.add.at(f, element_dofs(mesh, wire_offset), loads)
    return f


def cw_point_load_vector(mesh: Mesh, chainage_m: np.ndarray, force_n: np.ndarray,
                         contact: Wire, contact_tension_by_span_n: np.ndarray) -> np.ndarray:
    """Work-equivalent nodal loads of vertical point forces on the CW (upward positive)
    [N, N·m], with the exact shape functions so that nodal results stay exact."""
    f = np.zeros(DOFS_PER_NODE * mesh.n_nodes)
    s = np.atleast_1d(np.asarray(chainage_m, dtype=float))
    force = np.broadcast_to(np.asarray(force_n, dtype=float), s.shape)
    e, xi = mesh.locate(s)
    n = beam.tensioned_shape_functions(xi, mesh.element_length_m[e], contact.bending_stiffness_n_m2,
                                       contact_tension_by_span_n[mesh.element_span[e]])
    np.add.at(f, element_dofs(mesh, CW)[e], force[:, None] * n)
    return f


class StaticModel:
    """Static FE model of one section, assembled once and solved for any extra CW loads.

    Parameters
    ----------
    section : Section
        Geometry, dropper lengths and tensions.
    catenary : Catenary
        Wires, droppers, gravity and mesh size.

    Examples
    --------
    >>> model = StaticModel(section, catenary)            # doctest: +SKIP
    >>> sol = model.solve()                               # doctest: +SKIP
    >>> sol.dropper_deflection_m()                        # W at the droppers [m] # doctest: +SKIP
    """

    def __init__(self, section: Section, catenary: Catenary):
        self.section = section
        self.catenary = catenary
        self.mesh = mesh = build_mesh(section, catenary.max_element_length_m)
        n = DOFS_PER_NODE * mesh.n_nodes
        self.n_dofs = n
        self.k_wires = (wire_stiffness(mesh, catenary.contact, section.contact_tension_by_span_n, CW)
                        + wire_stiffness(mesh, catenary.messenger, section.messenger_tension_by_span_n, MW))
        masts = mesh.mast_nodes
        self.fixed = np.concatenate([DOFS_PER_NODE * masts + CW, DOFS_PER_NODE * masts + MW])
        self.fixed_values = np.concatenate([section.cw_support_heights_m, section.mw_support_heights_m])
        free = np.ones(n, dtype=bool)
        free[self.fixed] = False
        self.free = np.flatnonzero(free)
        self.dropper_cw_dof = DOFS_PER_NODE * mesh.cw_clamp_nodes + CW
        self.dropper_mw_dof = DOFS_PER_NODE * mesh.dropper_nodes + MW
        # Vertical rest length and stiffness (= L and EA/L for vertical droppers).
        self.dropper_rest_length_m, self.dropper_stiffness_n_m = inclined_dropper(
            section.dropper_lengths_m, section.clamp_offset_m, catenary.droppers.axial_stiffness_n)
        self.f_gravity = self._gravity_loads()

    def _gravity_loads(self) -> np.ndarray:
        cat, mesh, sec = self.catenary, self.mesh, self.section
        g = cat.gravity_m_s2
        f = np.zeros(DOFS_PER_NODE * mesh.n_nodes)
        f += wire_weight_loads(mesh, cat.contact, sec.contact_tension_by_span_n, CW, g, sec.cw_mass_factor_by_span)
        f += wire_weight_loads(mesh, cat.messenger, sec.messenger_tension_by_span_n, MW, g)
        half_dropper = 0.5 * cat.droppers.mass_per_length_kg_m * sec.dropper_lengths_m
        np.add.at(f, self.dropper_cw_dof, -g * (cat.droppers.clamp_mass_contact_kg + half_dropper))
        np.add.at(f, self.dropper_mw_dof, -g * (cat.droppers.clamp_mass_messenger_kg + half_dropper))
        np.add.at(f, DOFS_PER_NODE * mesh.cw_point_mass_nodes + CW, -g * sec.cw_point_mass_kg)
        return f

    def total_weight_n(self) -> float:
        """Weight of everything the supports carry [N]."""
        return float(-self.f_gravity[0::2].sum())  # rotational DOFs carry moments, not forces

    def dropper_matrices(self, taut: np.ndarray) -> tuple[sp.csr_matrix, np.ndarray]:
        """Stiffness and preload of the taut droppers (energy ½ k (z_mw − z_cw − L_v)², with
        ``L_v`` the vertical rest length, see :func:`~catenary.physics.section.inclined_dropper`)."""
        k = np.where(taut, self.dropper_stiffness_n_m, 0.0)
        c, m = self.dropper_cw_dof, self.dropper_mw_dof
        rows = np.concatenate([c, m, c, m])
        cols = np.concatenate([c, m, m, c])
        vals = np.concatenate([k, k, -k, -k])
        kd = sp.csr_matrix((vals, (rows, cols)), shape=(self.n_dofs, self.n_dofs))
        f = np.zeros(self.n_dofs)
        kl = k * self.dropper_rest_length_m
        np.add.at(f, c, -kl)
        np.add.at(f, m, kl)
        return kd, f

    def solve(self, cw_point_loads: tuple[np.ndarray, np.ndarray] | None = None, *,
              max_iterations: int = 50, initial_taut: np.ndarray | None = None) -> StaticSolution:
        """Static equilibrium under gravity and optional point forces on the CW.

        Parameters
        ----------
        cw_point_loads : (chainage_m, force_n), optional
            Vertical point forces on the contact wire, upward positive [m], [N].
        max_iterations : int
            Bound on active-set iterations.
        initial_taut : array of bool, optional
            Starting dropper states (default: all taut).

        Raises
        ------
        ConvergenceError
            If the dropper states do not settle within ``max_iterations``.
        """
        f_ext = self.f_gravity.copy()
        if cw_point_loads is not None:
            f_ext += cw_point_load_vector(self.mesh, *cw_point_loads, self.catenary.contact,
                                          self.section.contact_tension_by_span_n)
        n_d = self.section.dropper_lengths_m.size
        taut = np.ones(n_d, dtype=bool) if initial_taut is None else np.asarray(initial_taut, dtype=bool).copy()
        seen = set()
        for iteration in range(1, max_iterations + 1):
            u, k_total, f_total = self.linear_solve(taut, f_ext)
            elongation = u[self.dropper_mw_dof] - u[self.dropper_cw_dof] - self.dropper_rest_length_m
            new_taut = elongation > 0.0
            if np.array_equal(new_taut, taut):
                break
            key = new_taut.tobytes()
            if key in seen:
                raise ConvergenceError(
                    f"dropper states cycle after {iteration} active-set iterations "
                    f"(droppers {np.flatnonzero(new_taut != taut).tolist()} keep switching)")
            seen.add(key)
            taut = new_taut
        else:
            raise ConvergenceError(f"dropper states did not settle in {max_iterations} active-set iterations")
        force = np.where(taut, self.dropper_stiffness_n_m * elongation, 0.0)
        residual = k_total @ u - f_total
        n_masts = self.section.n_spans + 1
        return StaticSolution(
            section=self.section, mesh=self.mesh, dofs=u, dropper_force_n=force, dropper_slack=~taut,
            cw_reaction_n=residual[self.fixed[:n_masts]], mw_reaction_n=residual[self.fixed[n_masts:]],
            iterations=iteration)

    def linear_solve(self, taut: np.ndarray, f_ext: np.ndarray,
                      extra_fixed: np.ndarray | None = None, extra_values: np.ndarray | None = None):
        """One linear solve with the droppers ``taut`` held in tension (no active set).

        Parameters
        ----------
        taut : numpy.ndarray of bool
            Droppers carrying their axial stiffness.
        f_ext : numpy.ndarray, shape (n_dofs,) or (n_dofs, m)
            External nodal loads [N] (e.g. ``f_gravity``); a column per load case, solved with
            one factorisation.
        extra_fixed, extra_values : numpy.ndarray, optional
            Further prescribed DOFs and their values [m], shape (k,) or, with load cases,
            (k, m) (the inverse static solver prescribes the CW at the droppers and reads the
            dropper tensions as reactions).

        Returns
        -------
        u, k, f
            The DOFs, the total stiffness and load (reactions are ``k @ u − f``), a column per
            load case.
        """
        kd, fd = self.dropper_matrices(taut)
        k = (self.k_wires + kd).tocsr()
        cases = np.ndim(f_ext) == 2
        f = f_ext + (fd[:, None] if cases else fd)
        fixed, free = self.fixed, self.free
        values = np.repeat(self.fixed_values[:, None], f.shape[1], axis=1) if cases else self.fixed_values
        if extra_fixed is not None:
            fixed = np.concatenate([fixed, extra_fixed])
            values = np.concatenate([values, extra_values])
            free = np.setdiff1d(free, extra_fixed)
        u = np.zeros(f.shape)
        u[fixed] = values
        rhs = f[free] - k[free][:, fixed] @ values
        kff = k[free][:, free].tocsc()
        try:
            u[free] = splu(kff).solve(rhs)
        except RuntimeError as exc:  # singular factor: a wire without support
            raise ConvergenceError(f"static stiffness matrix is singular ({exc})") from None
        if not np.all(np.isfinite(u)):
            raise ConvergenceError("static solve produced non-finite displacements")
        return u, k, f


def solve_static(section: Section, catenary: Catenary, **kwargs) -> StaticSolution:
    """Assemble and solve the static model of ``section`` (see :meth:`StaticModel.solve`)."""
    return StaticModel(section, catenary).solve(**kwargs)
