"""Elements of a pre-tensioned Euler–Bernoulli beam, vectorised over elements.

Each node carries the vertical position ``w`` [m] and the slope ``θ = dw/dx`` [rad].
Small-slope theory: ``EI w'''' − T w'' = q`` with a constant axial tension ``T``.

Two families:

* **Exact tensioned-beam** stiffness, loads and shape functions, built on the homogeneous
  solutions ``{1, x, e^{−λx}, e^{−λ(h−x)}}`` with ``λ = √(T/EI)``. Galerkin with exact shape
  functions is nodally exact for any element length. This matters for contact and messenger
  wires: their bending layer ``√(EI/T)`` ≈ 8 cm (at droppers, and at masts where the wire is
  continuous) is far shorter than a 0.5 m element; cubic elements there misplace a
  continuous wire's far field by a large fraction of (slope jump × 8 cm) ≈ 3 mm.
* **Hermite cubic** matrices (Przemieniecki, *Theory of Matrix Structural Analysis*, 1968):
  geometric stiffness (the string limit EI = 0), consistent mass and loads; used for the mass and for
  smooth interpolation between nodes.

All functions take arrays of element lengths and return stacked matrices.
"""

from __future__ import annotations

import numpy as np


def geometric_stiffness(h: np.ndarray, tension: float) -> np.ndarray:
    """Geometric stiffness of a constant axial tension, shape (n, 4, 4).

    Parameters
    ----------
    h : array_like
        Element lengths [m].
    tension : float
        Axial tension T [N].
    """
    h = np.asarray(h, dtype=float)[:, None, None]
    k = np.array([[36.0, 3.0, -36.0, 3.0],
                  [3.0, 4.0, -3.0, -1.0],
                  [-36.0, -3.0, 36.0, -3.0],
                  [3.0, -1.0, -3.0, 4.0]])
    return tension * k * _powers(h) / (30.0 * h)


def consistent_mass(h: np.ndarray, mass_per_length: float) -> np.ndarray:
    """Consistent mass matrices, shape (n, 4, 4) [kg, kg·m, kg·m²].

    Parameters
    ----------
    h : array_like
        Element lengths [m].
    mass_per_length : float
        Linear mass ρA [kg/m].
    """
    h = np.asarray(h, dtype=float)[:, None, None]
    m = np.array([[156.0, 22.0, 54.0, -13.0],
                  [22.0, 4.0, 13.0, -3.0],
                  [54.0, 13.0, 156.0, -22.0],
                  [-13.0, -3.0, -22.0, 4.0]])
    return mass_per_length * h * m * _powers(h) / 420.0


def uniform_load(h: np.ndarray, q: float) -> np.ndarray:
    """Consistent nodal loads of a uniform line load ``q`` [N/m], shape (n, 4) [N, N·m]."""
    h = np.asarray(h, dtype=float)[:, None]
    return q * h * np.array([0.5, 0.0, 0.5, 0.0]) + q * h**2 * np.array([0.0, 1.0, 0.0, -1.0]) / 12.0


def shape_functions(xi: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Hermite shape functions at local coordinates ``xi`` ∈ [0, 1], shape (..., 4).

    ``w(xi) = N @ [w1, θ1, w2, θ2]`` for an element of length ``h`` [m].
    """
    xi = np.asarray(xi, dtype=float)
    h = np.asarray(h, dtype=float)
    return np.stack([
        1.0 - 3.0 * xi**2 + 2.0 * xi**3,
        h * (xi - 2.0 * xi**2 + xi**3),
        3.0 * xi**2 - 2.0 * xi**3,
        h * (-xi**2 + xi**3),
    ], axis=-1)


def _powers(h: np.ndarray) -> np.ndarray:
    """Matrix of length powers that makes a 4×4 pattern dimensionally right: h^(i_rot + j_rot)."""
    rot = np.array([0, 1, 0, 1])
    return h ** (rot[:, None] + rot[None, :])


def exact_basis_matrix(h: np.ndarray, lam: float) -> tuple[np.ndarray, np.ndarray]:
    """Nodal values of the basis {1, x, e^{−λx}, e^{−λ(h−x)}}: C (n, 4, 4) and a = e^{−λh}.

    ``C⁻¹`` maps an element's nodal DOFs to the coefficients of its exact tensioned-beam
    solution (used by the dynamic model for the contact point's shape functions).
    """
    a = np.exp(-lam * h)
    one, zero = np.ones_like(h), np.zeros_like(h)
    c = np.stack([
        np.stack([one, zero, one, a], axis=-1),               # w(0)
        np.stack([zero, one, -lam * one, lam * a], axis=-1),  # w'(0)
        np.stack([one, h, a, one], axis=-1),                  # w(h)
        np.stack([zero, one, -lam * a, lam * one], axis=-1),  # w'(h)
    ], axis=-2)
    return c, a


def tensioned_stiffness(h: np.ndarray, ei: float, tension: float) -> np.ndarray:
    """Exact stiffness of a tensioned beam element, shape (n, 4, 4).

    ``K = C⁻ᵀ G C⁻¹`` with ``G = ∫ (EI φ''ᵀφ'' + T φ'ᵀφ') dx`` over the homogeneous basis φ,
    integrated in closed form. Falls back to the string (geometric Hermite) matrix for EI = 0.
    """
    h = np.asarray(h, dtype=float)
    if ei == 0.0:
        return geometric_stiffness(h, tension)
    lam = np.sqrt(tension / ei)
    c, a = exact_basis_matrix(h, lam)
    g = np.zeros(h.shape + (4, 4))
    g[:, 1, 1] = tension * h
    g[:, 1, 2] = g[:, 2, 1] = -tension * (1.0 - a)
    g[:, 1, 3] = g[:, 3, 1] = tension * (1.0 - a)
    # EI λ⁴ = T λ²: the bending and tension parts of the e^{−λx}·e^{−λ(h−x)} term cancel.
    g[:, 2, 2] = g[:, 3, 3] = tension * lam * (1.0 - a * a)
    c_inv = np.linalg.inv(c)
    return np.swapaxes(c_inv, -1, -2) @ g @ c_inv


def tensioned_uniform_load(h: np.ndarray, q: float, ei: float, tension: float) -> np.ndarray:
    """Work-equivalent nodal loads of a uniform load ``q`` [N/m] with the exact shape
    functions, shape (n, 4); with them the static nodal solution is exact."""
    h = np.asarray(h, dtype=float)
    if ei == 0.0:
        return uniform_load(h, q)
    lam = np.sqrt(tension / ei)
    c, a = exact_basis_matrix(h, lam)
    integral = np.stack([h, 0.5 * h * h, (1.0 - a) / lam, (1.0 - a) / lam], axis=-1)
    return q * (np.swapaxes(np.linalg.inv(c), -1, -2) @ integral[..., None])[..., 0]


def tensioned_shape_functions(xi: np.ndarray, h: np.ndarray, ei: float, tension: float) -> np.ndarray:
    """Exact shape functions at ``xi`` ∈ [0, 1] of elements of length ``h``, shape (..., 4).

    Used for point loads between nodes: the nodal solution then stays exact.
    """
    xi = np.asarray(xi, dtype=float)
    h = np.broadcast_to(np.asarray(h, dtype=float), xi.shape)
    if ei == 0.0:
        return shape_functions(xi, h)
    lam = np.sqrt(tension / ei)
    c, _ = exact_basis_matrix(h.ravel(), lam)
    x = (xi * h).ravel()
    hr = h.ravel()
    phi = np.stack([np.ones_like(x), x, np.exp(-lam * x), np.exp(-lam * (hr - x))], axis=-1)
    n = (phi[:, None, :] @ np.linalg.inv(c))[:, 0, :]
    return n.reshape(xi.shape + (4,))
