"""Lumped-mass pantograph models, read from config.

A pantograph is a chain of masses, head first: link ``i`` (stiffness ``k_i``, damping ``c_i``)
joins mass ``i`` to mass ``i + 1``, and the last link joins the lowest mass to the car body.
The static force acts on the lowest mass and the aerodynamic force ``a·v²`` on the head; in
static equilibrium the chain transmits both to the contact. The springs are at rest (carrying
exactly that force) when the head is at a reference working height, which the dynamic model
sets to the mean static CW height of the run, so the mean contact force is
``static_force_n + aero_coefficient_n_s2_m2 · v²`` (v in m/s). A grounded link of zero
stiffness models a force-regulated (air-spring) pantograph: its uplift force is constant.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import yaml

from catenary.plumbing.errors import ConfigError


@dataclass(frozen=True)
class Pantograph:
    """A lumped pantograph.

    Attributes
    ----------
    name : str
    masses_kg : numpy.ndarray
        Masses from the head down [kg].
    stiffnesses_n_m, dampings_n_s_m : numpy.ndarray
        Link ``i`` joins mass ``i`` to mass ``i + 1``; the last to the car body [N/m], [N·s/m].
    static_force_n : float
        Static uplift force on the lowest mass [N].
    aero_coefficient_n_s2_m2 : float
        Aerodynamic uplift ``a`` of ``a·v²`` on the head [N·s²/m²].
    """

    name: str
    masses_kg: np.ndarray
    stiffnesses_n_m: np.ndarray
    dampings_n_s_m: np.ndarray
    static_force_n: float
    aero_coefficient_n_s2_m2: float = 0.0

    @property
    def n_masses(self) -> int:
        return int(self.masses_kg.size)

    def mean_force_n(self, speed_m_s: float) -> float:
        """Static plus aerodynamic uplift transmitted to the contact [N]."""
        return self.static_force_n + self.aero_coefficient_n_s2_m2 * speed_m_s**2

    def with_static_force(self, static_force_n: float) -> "Pantograph":
        """A copy with another static force [N] (e.g. the measuring force)."""
        return Pantograph(self.name, self.masses_kg, self.stiffnesses_n_m, self.dampings_n_s_m,
                          float(static_force_n), self.aero_coefficient_n_s2_m2)

    @property
    def head_flexibility_m_n(self) -> float:
        """Static head displacement per unit head force [m/N]: Σ 1/k over the chain (∞ when
        the grounded link has no stiffness: a constant-force pantograph)."""
        k = self.stiffnesses_n_m
        return float(np.inf) if k[-1] == 0 else float(np.sum(1.0 / k))

    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Mass, damping and stiffness matrices of the chain (head first)."""
        return np.diag(self.masses_kg), _chain(self.dampings_n_s_m), _chain(self.stiffnesses_n_m)


def _chain(links: np.ndarray) -> np.ndarray:
    """Matrix of springs (or dampers) in series, the last one grounded."""
    n = links.size
    k = np.zeros((n, n))
    for i, value in enumerate(links):
        k[i, i] += value
        if i + 1 < n:
            k[i + 1, i + 1] += value
            k[i, i + 1] -= value
            k[i + 1, i] -= value
    return k


def pantograph_from_dict(name: str, raw: Mapping[str, Any], where: str) -> Pantograph:
    """Build and check a :class:`Pantograph`; errors name the key under ``where``."""
    arrays = {}
    for key in ("masses_kg", "stiffnesses_n_m", "dampings_n_s_m"):
        value = raw.get(key) if isinstance(raw, Mapping) else None
        if not isinstance(value, (list, tuple)) or not value:
            raise ConfigError(f"{where}.{key}: expected a non-empty list of numbers")
        arr = np.asarray(value, dtype=float)
        if np.any(~np.isfinite(arr)) or np.any(arr < 0):
            raise ConfigError(f"{where}.{key}: expected values ≥ 0, got {value}")
        # Every mass and every internal link must be positive; the grounded link of the
        # stiffnesses may be 0 (a force-regulated pantograph), dampings may be 0.
        must_be_positive = {"masses_kg": arr, "stiffnesses_n_m": arr[:-1]}.get(key)
        if must_be_positive is not None and np.any(must_be_positive <= 0):
            raise ConfigError(f"{where}.{key}: expected positive values (only the grounded, last "
                              f"stiffness may be 0), got {value}")
        arrays[key] = arr
    n = arrays["masses_kg"].size
    for key in ("stiffnesses_n_m", "dampings_n_s_m"):
        if arrays[key].size != n:
            raise ConfigError(f"{where}.{key}: expected {n} values (one link per mass), got {arrays[key].size}")
    force = raw.get("static_force_n")
    if isinstance(force, bool) or not isinstance(force, (int, float)) or force <= 0:
        raise ConfigError(f"{where}.static_force_n: expected a positive force [N], got {force!r}")
    aero = raw.get("aero_coefficient_n_s2_m2", 0.0)
    if isinstance(aero, bool) or not isinstance(aero, (int, float)):
        raise ConfigError(f"{where}.aero_coefficient_n_s2_m2: expected a number, got {aero!r}")
    return Pantograph(name, arrays["masses_kg"], arrays["stiffnesses_n_m"], arrays["dampings_n_s_m"],
                      float(force), float(aero))


def load_pantographs(path: str | Path) -> dict[str, Pantograph]:
    """Read every pantograph of ``path`` (YAML mapping name → model)."""
    path = Path(path)
    try:
        raw = yaml.safe_load(path.read_text())
    except FileNotFoundError:
        raise ConfigError(f"{path}: pantograph file not found") from None
    if not isinstance(raw, Mapping) or not raw:
        raise ConfigError(f"{path}: expected a mapping of pantograph models")
    return {str(k): pantograph_from_dict(str(k), v, f"{path}:{k}") for k, v in raw.items()}
