"""Compiled time loop of :func:`catenary.physics.dynamics.run_pantograph` (Numba).

The algorithm is the module :mod:`catenary.physics.dynamics`'s, step for step: Newmark average
acceleration on the linear all-taut catenary, the pantograph's Newmark update, and at each step
the small active-set system of the slack droppers and the penalty contact
(:meth:`~catenary.physics.dynamics.PseudoForceSolver.equilibrium`), with the same Green's functions of
the factorised effective stiffness. Only the arithmetic moved, to compiled loops shaped for
a core: the effective stiffness's banded Cholesky factor is kept as ``Vᵀ D V`` (unit diagonal,
so the back-substitutions divide by nothing) and, at the usual half-bandwidth 5, each sweep
keeps the last five unknowns in registers; the right-hand side needs one product, with the
mass, not two: the damping is Rayleigh's, so its product is carried through ``K_eff`` exactly
(:func:`newmark_contact_loop`), and the mass's symmetric band is read once, its eleven products
per row summed as a tree (:func:`symmetric_band_product`); the slack droppers' Green's
functions are stored one dropper per row. Per step of a 20-span section (9 583 unknowns):
solve 189 → 59 µs and right-hand side 171 → 54 µs (2026-11-25), then the right-hand side
54 → 14 µs (2026-11-27, when the unchanged solve measured 35–40 µs): one-off measurements of
each kernel alone. The contact forces and heights are those of the Python loop
to rounding (fixture test), and ``docs/performance.md`` gives the profile.

Numba compiles the functions on first use and caches the machine code next to this file
(``__pycache__``), so a fresh process pays the compilation once per installation: 7.2 s, of
which ``np.linalg.solve``'s LAPACK binding had been 3.3 s before the active set's small system
was solved by :func:`_solve_small` (10.9 s; 2026-11-27).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["band_diagonals", "band_rows", "band_solve", "mass_band", "newmark_contact_loop", "symmetric_band_product"]

#: Status codes of :func:`newmark_contact_loop`.
OK, NOT_SETTLED, SINGULAR = 0, 1, 2


def band_rows(ab: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit-diagonal row storage of an upper banded Cholesky factor U (``K = Uᵀ U``).

    ``ab`` is LAPACK's storage ``ab[kd + i − j, j] = U[i, j]``. Returns ``rows`` with
    ``rows[i, k] = U[i, i + k] / U[i, i]`` (k = 0 … kd; zeros past the last row) and
    ``inv_diag_sq[i] = 1 / U[i, i]²``, so that ``K = Vᵀ D V`` with V unit upper banded and
    ``D = diag(U[i, i]²)``: :func:`band_solve` then needs no division.
    """
    kd = ab.shape[0] - 1
    n = ab.shape[1]
    rows = np.zeros((n, kd + 1))
    for k in range(kd + 1):
        rows[:n - k, k] = ab[kd - k, k:]
    diagonal = rows[:, 0].copy()
    return rows / diagonal[:, None], 1.0 / diagonal**2


def band_diagonals(matrix, kd: int) -> np.ndarray:
    """Diagonals of a sparse matrix of half-bandwidth ``kd``, shape (2 kd + 1, n):
    ``out[kd + d, i] = A[i, i + d]`` (zero where ``i + d`` is outside), for
    :func:`mass_band`."""
    a = matrix.tocsr()
    n = a.shape[0]
    out = np.zeros((2 * kd + 1, n))
    for d in range(-kd, kd + 1):
        diagonal = a.diagonal(d)
        if d >= 0:
            out[kd + d, :n - d] = diagonal
        else:
            out[kd + d, -d:] = diagonal
    if a.nnz and np.max(np.abs(a.indices - np.repeat(np.arange(n), np.diff(a.indptr)))) > kd:
        raise ValueError(f"matrix wider than the half-bandwidth {kd}")
    return out


@njit(cache=True)
def band_solve(rows, inv_diag_sq, rhs, out):
    """Solve ``Vᵀ D V x = rhs`` into ``out`` (:func:`band_rows`' storage of ``K = Uᵀ U``).

    Forward sweep Vᵀ y = rhs, scaling by D⁻¹, backward sweep V x = y. With the usual
    half-bandwidth 5 each unknown is a dot product with the five previous (next) ones kept in
    registers, so the recursion's critical path is one multiply-add per unknown; other widths
    (inclined droppers) take the general loop.
    """
    n, width = rows.shape
    if width == 6:
        # y_k = 0 before the first unknown, so the products with the rows before row 0
        # (read by wrap-around) vanish and the first five unknowns need no branch.
        y1 = y2 = y3 = y4 = y5 = 0.0
        for i in range(n):
            s = rhs[i] - (rows[i - 5, 5] * y5 + rows[i - 4, 4] * y4 + rows[i - 3, 3] * y3)
            s -= rows[i - 2, 2] * y2
            s -= rows[i - 1, 1] * y1
            y5, y4, y3, y2, y1 = y4, y3, y2, y1, s
            out[i] = s * inv_diag_sq[i]
        x1 = x2 = x3 = x4 = x5 = 0.0
        for i in range(n - 1, -1, -1):
            r = rows[i]
            s = out[i] - (r[5] * x5 + r[4] * x4 + r[3] * x3)
            s -= r[2] * x2
            s -= r[1] * x1
            x5, x4, x3, x2, x1 = x4, x3, x2, x1, s
            out[i] = s
        return out
    kd = width - 1
    for i in range(n):
        out[i] = rhs[i]
    for i in range(n):
        yi = out[i]
        for k in range(1, min(width, n - i)):
            out[i + k] -= rows[i, k] * yi
    for i in range(n):
        out[i] *= inv_diag_sq[i]
    for i in range(n - 1, -1, -1):
        s = out[i]
        for k in range(1, min(width, n - i)):
            s -= rows[i, k] * out[i + k]
        out[i] = s
    return out


def mass_band(matrix, kd: int) -> np.ndarray:
    """Upper diagonals of a symmetric sparse matrix of half-bandwidth ``kd``, padded for
    :func:`symmetric_band_product`: ``out[d, kd + i] = A[i, i + d]`` (d = 0 … kd), shape
    (kd + 1, n + 2 kd), zero where ``i + d`` is outside and in the padding."""
    diagonals = band_diagonals(matrix, kd)
    n = diagonals.shape[1]
    out = np.zeros((kd + 1, n + 2 * kd))
    out[:, kd:kd + n] = diagonals[kd:]
    return out


@njit(cache=True)
def symmetric_band_product(upper, x_padded, f, out):
    """``out = f + A x`` for a symmetric banded A given by :func:`mass_band` and x padded by kd
    zeros at each end (``x_padded[kd + i] = x[i]``): each stored diagonal serves both of its
    triangles, so A is read once, not twice."""
    kd = upper.shape[0] - 1
    n = f.size
    if kd == 5:
        # The usual half-bandwidth: the eleven products of a row summed as a tree, so no
        # chain of additions limits the loop.
        u0, u1, u2, u3, u4, u5 = upper[0], upper[1], upper[2], upper[3], upper[4], upper[5]
        x = x_padded
        for i in range(n):
            j = i + 5
            a = f[i] + u0[j] * x[j]
            b = u1[j] * x[j + 1] + u1[j - 1] * x[j - 1]
            c = u2[j] * x[j + 2] + u2[j - 2] * x[j - 2]
            d = u3[j] * x[j + 3] + u3[j - 3] * x[j - 3]
            e = u4[j] * x[j + 4] + u4[j - 4] * x[j - 4]
            g = u5[j] * x[j + 5] + u5[j - 5] * x[j - 5]
            out[i] = (a + b) + (c + d) + (e + g)
        return
    for i in range(n):
        s = f[i] + upper[0, kd + i] * x_padded[kd + i]
        for d in range(1, kd + 1):
            s += upper[d, kd + i] * x_padded[kd + i + d] + upper[d, kd + i - d] * x_padded[kd + i - d]
        out[i] = s


@njit(cache=True)
def _shape(x_nodes, lam, basis_inverse, exact, e, x):
    h = x_nodes[e + 1] - x_nodes[e]
    xl = min(max(x - x_nodes[e], 0.0), h)
    n = np.empty(4)
    if exact:
        a = np.array([1.0, xl, np.exp(-lam[e] * xl), np.exp(-lam[e] * (h - xl))])
        for j in range(4):
            s = 0.0
            for i in range(4):
                s += a[i] * basis_inverse[e, i, j]
            n[j] = s
    else:
        xi = xl / h
        n[0] = 1.0 - 3.0 * xi**2 + 2.0 * xi**3
        n[1] = h * (xi - 2.0 * xi**2 + xi**3)
        n[2] = 3.0 * xi**2 - 2.0 * xi**3
        n[3] = h * (-xi**2 + xi**3)
    return n


@njit(cache=True)
def _solve_small(a, b, x):
    """``a x = b`` for the small dense system of the active set, into ``x`` (Gaussian
    elimination with partial pivoting; ``a`` and ``b`` are overwritten). Returns False if a
    pivot vanishes (a singular system). Written out rather than ``np.linalg.solve``, whose
    LAPACK binding took 3.3 s of the loop's 11 s compilation in every fresh process."""
    n = b.size
    for k in range(n):
        p = k
        for r in range(k + 1, n):
            if abs(a[r, k]) > abs(a[p, k]):
                p = r
        if a[p, k] == 0.0:
            return False
        if p != k:
            for c in range(n):
                a[k, c], a[p, c] = a[p, c], a[k, c]
            b[k], b[p] = b[p], b[k]
        for r in range(k + 1, n):
            f = a[r, k] / a[k, k]
            for c in range(k, n):
                a[r, c] -= f * a[k, c]
            b[r] -= f * b[k]
    for k in range(n - 1, -1, -1):
        s = b[k]
        for c in range(k + 1, n):
            s -= a[k, c] * x[c]
        x[k] = s / a[k, k]
    return True


@njit(cache=True)
def newmark_contact_loop(n_steps, dt, x_steps, force_steps, coefficients, rayleigh, f_const, m_upper,
                         rows, inv_diag_sq, z_t, dd, dropper_mw, dropper_cw, dropper_k, dropper_l,
                         x_nodes, lam, basis_inverse, exact, element_dofs, m_p, c_p, k_eff_p_inv, p_flex,
                         reference, k_c, mast_dofs, static_mast, u, v, acc, y, yv, ya, slack, touching, f_c,
                         max_iterations, out_f, out_w, out_head, out_slack, out_uplift):
    """The time loop of ``run_pantograph`` from its initial state; fills the ``out_*`` arrays.

    ``coefficients`` holds Newmark's (a0, a1, a2, a3, a4, a5, γ) and ``rayleigh`` the damping's
    (α, β) with ``C = α M + β K₀``; the effective stiffness ``K_eff = K₀ + a0 M + a1 C`` is
    factorised in ``rows``, ``inv_diag_sq`` (:func:`band_rows`), M is given by its upper
    diagonals (:func:`mass_band`) and ``z_t[j]`` is K_eff⁻¹ g_j.

    The right-hand side ``f + M p + C q`` (p, q Newmark's combinations of u, v, a) needs no
    product with C: since ``K_eff = (1 + a1 β) K₀ + (a0 + a1 α) M``,
    ``K_eff⁻¹ (f + M p + C q) = K_eff⁻¹ (f + M (p + κ q)) + σ q`` with
    ``σ = β / (1 + a1 β)`` and ``κ = α − σ (a0 + a1 α)``, exactly. Returns (status, step):
    status 1 when the dropper/contact states of ``step`` did not settle in ``max_iterations``.
    ``x_steps[k]`` is the contact point's chainage [m] and ``force_steps[k]`` the uplift force
    applied to the pantograph's head [N] at step ``k``. Status 2: the active-set system of
    ``step`` was singular.
    """
    a0, a1, a2, a3, a4, a5, gamma = (coefficients[0], coefficients[1], coefficients[2], coefficients[3],
                                     coefficients[4], coefficients[5], coefficients[6])
    n = u.size
    n_d = dropper_k.size
    n_p = y.size
    n_el = x_nodes.size - 1
    # K⁻¹ e_d of the DOFs under the contact, kept in a few slots: consecutive elements share a
    # node, so moving to the next element needs two new solves, not four.
    n_slots = 8
    slot_dof = np.full(n_slots, -1, dtype=np.int64)
    slot_used = np.zeros(n_slots, dtype=np.int64)
    unit = np.zeros((n_slots, n))
    unit_rhs = np.zeros(n)
    slots = np.zeros(4, dtype=np.int64)
    alpha, beta = rayleigh[0], rayleigh[1]
    sigma = beta / (1.0 + a1 * beta)
    kappa = alpha - sigma * (a0 + a1 * alpha)
    # p + κ q and σ q as combinations of u, v, a.
    pu, pv, pa = a0 + kappa * a1, a2 + kappa * a4, a3 + kappa * a5
    su, sv, sa = sigma * a1, sigma * a4, sigma * a5
    kd = m_upper.shape[0] - 1
    pk = np.zeros(n + 2 * kd)                # p + κ q, padded by kd zeros at each end
    shift = np.empty(n)                      # σ q
    rhs = np.empty(n)
    u_star = np.empty(n)
    for i in range(n):                       # the right-hand side's vectors of the first step
        pk[kd + i] = pu * u[i] + pv * v[i] + pa * acc[i]
        shift[i] = su * u[i] + sv * v[i] + sa * acc[i]
    keep = np.zeros(4, dtype=np.int64)
    shape = np.zeros(4)
    zp_g = np.empty(n_d)
    e_star = np.empty(n_d)
    elongation = np.empty(n_d)
    e = 0
    x = x_steps[0]
    while e < n_el - 1 and x_nodes[e + 1] <= x:
        e += 1
    for step in range(n_steps):
        x = x_steps[step]
        while e < n_el - 1 and x_nodes[e + 1] <= x:
            e += 1
        full = _shape(x_nodes, lam, basis_inverse, exact, e, x)
        m = 0
        for j in range(4):
            if element_dofs[e, j] >= 0:
                keep[m] = element_dofs[e, j]
                shape[m] = full[j]
                m += 1
        if step > 0:
            # Right-hand side of the catenary's effective system (from the last update).
            symmetric_band_product(m_upper, pk, f_const, rhs)
            # Pantograph predictor.
            rhs_p = np.zeros(n_p)
            rhs_p[0] = force_steps[step]
            pp = a0 * y + a2 * yv + a3 * ya
            qp = a1 * y + a4 * yv + a5 * ya
            y_star = np.zeros(n_p)
            for r in range(n_p):
                for c in range(n_p):
                    rhs_p[r] += m_p[r, c] * pp[c] + c_p[r, c] * qp[c]
            for r in range(n_p):
                for c in range(n_p):
                    y_star[r] += k_eff_p_inv[r, c] * rhs_p[c]
            head_free = reference + y_star[0]
            head_flex = p_flex[0]
            for j in range(m):
                found = -1
                for k in range(n_slots):
                    if slot_dof[k] == keep[j]:
                        found = k
                if found < 0:
                    found = 0
                    for k in range(n_slots):          # the least recently used slot
                        if slot_used[k] < slot_used[found]:
                            found = k
                    unit_rhs[:] = 0.0
                    unit_rhs[keep[j]] = 1.0
                    band_solve(rows, inv_diag_sq, unit_rhs, unit[found])
                    slot_dof[found] = keep[j]
                slot_used[found] = step
                slots[j] = found
            # u* = K_eff⁻¹ rhs + σ q: the σ q term is added where u* is read (the droppers, the
            # contact, the update pass), not in a pass of its own.
            band_solve(rows, inv_diag_sq, rhs, u_star)
            # zp = K⁻¹ N_p (the response to a unit contact force) is needed at the droppers and
            # under the contact only: read there from the unit responses.
            for i in range(n_d):
                s = 0.0
                for j in range(m):
                    s += (unit[slots[j], dropper_mw[i]] - unit[slots[j], dropper_cw[i]]) * shape[j]
                zp_g[i] = s
                mw, cw = dropper_mw[i], dropper_cw[i]
                e_star[i] = (u_star[mw] + shift[mw]) - (u_star[cw] + shift[cw]) - dropper_l[i]
            w_star = 0.0
            cz = 0.0
            for j in range(m):
                w_star += shape[j] * (u_star[keep[j]] + shift[keep[j]])
                for k in range(m):
                    cz += shape[j] * unit[slots[k], keep[j]] * shape[k]
            # Active set of slack droppers and contact.
            settled = False
            lam_s = np.zeros(0)
            s_idx = np.zeros(0, dtype=np.int64)
            fc = 0.0
            for _ in range(max_iterations):
                s_idx = np.flatnonzero(slack)
                ns = s_idx.size
                a = np.zeros((ns + 1, ns + 1))
                b = np.zeros(ns + 1)
                for r in range(ns):
                    for c in range(ns):
                        a[r, c] = (1.0 if r == c else 0.0) - dropper_k[s_idx[r]] * dd[s_idx[r], s_idx[c]]
                    b[r] = dropper_k[s_idx[r]] * e_star[s_idx[r]]
                if touching:
                    for r in range(ns):
                        a[r, ns] = -dropper_k[s_idx[r]] * zp_g[s_idx[r]]
                        a[ns, r] = k_c * zp_g[s_idx[r]]
                    a[ns, ns] = 1.0 - k_c * head_flex + k_c * cz
                    b[ns] = k_c * (head_free - w_star)
                    sol = np.zeros(ns + 1)
                    solved = _solve_small(a, b, sol)
                else:
                    sol = np.zeros(ns + 1)
                    solved = _solve_small(a[:ns, :ns].copy(), b[:ns].copy(), sol[:ns])
                if not solved:
                    return SINGULAR, step
                lam_s = sol[:ns]
                fc = sol[ns]
                same = True
                for i in range(n_d):
                    s = e_star[i] + zp_g[i] * fc
                    for r in range(ns):
                        s += dd[i, s_idx[r]] * lam_s[r]
                    elongation[i] = s
                    if (dropper_k[i] * s < 0.0) != slack[i]:
                        same = False
                w_c = w_star + cz * fc
                for r in range(ns):
                    w_c += zp_g[s_idx[r]] * lam_s[r]
                gap = head_free + head_flex * fc - w_c
                new_touching = (fc > 0.0) if touching else (gap > 0.0)
                if new_touching != touching:
                    same = False
                if same:
                    settled = True
                    break
                for i in range(n_d):
                    slack[i] = dropper_k[i] * elongation[i] < 0.0
                touching = new_touching
            if not settled:
                return NOT_SETTLED, step
            for r in range(s_idx.size):          # the slack droppers' pseudo-forces
                column = z_t[s_idx[r]]
                for i in range(n):
                    u_star[i] += column[i] * lam_s[r]
            # One pass: the new state (u* + fc K⁻¹ N_p), Newmark's update, and p + κ q, σ q of
            # the next step's right-hand side.
            c0 = shape[0] * fc if m > 0 else 0.0
            c1 = shape[1] * fc if m > 1 else 0.0
            c2 = shape[2] * fc if m > 2 else 0.0
            c3 = shape[3] * fc if m > 3 else 0.0
            r0, r1 = unit[slots[0]], unit[slots[1] if m > 1 else slots[0]]
            r2, r3 = unit[slots[2] if m > 2 else slots[0]], unit[slots[3] if m > 3 else slots[0]]
            for i in range(n):
                u_new = (u_star[i] + shift[i]) + c0 * r0[i] + c1 * r1[i] + c2 * r2[i] + c3 * r3[i]
                acc_new = a0 * (u_new - u[i]) - a2 * v[i] - a3 * acc[i]
                v_new = v[i] + dt * ((1 - gamma) * acc[i] + gamma * acc_new)
                u[i] = u_new
                v[i] = v_new
                acc[i] = acc_new
                pk[kd + i] = pu * u_new + pv * v_new + pa * acc_new
                shift[i] = su * u_new + sv * v_new + sa * acc_new
            y_new = y_star + p_flex * fc
            ya_new = a0 * (y_new - y) - a2 * yv - a3 * ya
            yv = yv + dt * ((1 - gamma) * ya + gamma * ya_new)
            y = y_new
            ya = ya_new
            f_c = fc if touching else 0.0
        out_f[step] = f_c
        w = 0.0
        for j in range(m):
            w += shape[j] * u[keep[j]]
        out_w[step] = w
        out_head[step] = reference + y[0]
        out_slack[step] = np.sum(slack)
        for k in range(mast_dofs.size):
            if mast_dofs[k] >= 0:
                out_uplift[step, k] = u[mast_dofs[k]] - static_mast[k]
    return OK, n_steps
