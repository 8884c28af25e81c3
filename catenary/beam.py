"""Hermite (cubic) elements of a pre-tensioned Euler–Bernoulli beam, vectorised over elements.

Each node carries the vertical position ``w`` [m] and the slope ``θ`` [rad]. Small-slope
theory: ``EI w'''' − T w'' = q`` with a constant axial tension ``T``. The element matrices
are the classical ones (e.g. Przemieniecki, *Theory of Matrix Structural Analysis*, 1968):
bending stiffness, geometric stiffness of the axial tension, consistent mass and consistent
nodal loads. All functions take arrays of element lengths and return stacked matrices.
"""

from __future__ import annotations

import numpy as np


def bending_stiffness(h: np.ndarray, ei: float) -> np.ndarray:
    """Bending stiffness matrices, shape (n, 4, 4) [N/m, N, N·m].

    Parameters
    ----------
    h : array_like
        Element lengths [m].
    ei : float
        Bending stiffness EI [N·m²].
    """
    h = np.asarray(h, dtype=float)[:, None, None]
    k = np.array([[12.0, 6.0, -12.0, 6.0],
                  [6.0, 4.0, -6.0, 2.0],
                  [-12.0, -6.0, 12.0, -6.0],
                  [6.0, 2.0, -6.0, 4.0]])
    p = _powers(h)
    return ei * k * p / h**3


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
