"""Confidence band of the CW deflection along the whole span under identified laws (paper Fig. 10).

CW profile between the droppers
-------------------------------
With the steady arms at zero height (so the chord is zero and the CW height *is* its
deflection from the chord) the contact wire is a tensioned beam loaded by its own weight, the
clamps, half of each dropper's weight and the dropper tensions ``F``; with neighbours (wires
continuous over the masts) it also feels the span's MW support heights through the
neighbours. Its height at any abscissa x is affine in the dropper forces, lengths and ΔH, with
coefficients that depend on the tensions: :meth:`catenary.physics.fast.FastSpanModel.profile_map`
condenses the same FE model as the fast model (pinned span or span in the line) onto the CW at
the band's abscissae and interpolates it in the tensions as the fast model does for W. The
dropper forces come from the fast model, so whole sample arrays are evaluated at once; the
result equals the FE solve of each sample to the fast model's accuracy (checked in the tests).

Band
----
The random inputs are sampled under the laws (a unit design mapped through the Gamma inverse
CDFs, as for J), samples with a slack dropper are dropped (the model law of W is that of a taut
span, as in J), and the band at each x is the pair of empirical quantiles
``(1 − level)/2`` and ``(1 + level)/2`` — 1 % and 99 % for the paper's 98 % band. It is a
pointwise band: at each x, a new span drawn from the same laws falls inside with probability
``level`` (not the whole profile at once).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from catenary.physics.config import SpanType
from catenary.physics.fast import FastSpanModel, ProfileMap
from .design import design_dimension, draw_unit_design, map_inputs

__all__ = ["DeflectionBand", "band_abscissae", "deflection_band", "sample_profiles"]


@dataclass(frozen=True)
class DeflectionBand:
    """Pointwise band of the CW deflection along a span.

    Attributes
    ----------
    x_m : numpy.ndarray
        Abscissae from the left mast [m].
    lower_m, upper_m : numpy.ndarray
        Quantiles ``(1 − level)/2`` and ``(1 + level)/2`` of the deflection at each x [m].
    median_m : numpy.ndarray
        Median deflection at each x [m].
    level : float
        Probability content at each x.
    n_samples : int
        Samples drawn.
    n_slack : int
        Samples dropped for a slack dropper (the band is that of taut spans).
    """

    x_m: np.ndarray
    lower_m: np.ndarray
    upper_m: np.ndarray
    median_m: np.ndarray
    level: float
    n_samples: int
    n_slack: int

    def rows(self) -> list[dict]:
        """One row per abscissa: ``x_m``, ``lower_m``, ``median_m``, ``upper_m``."""
        return [dict(x_m=float(x), lower_m=float(lo), median_m=float(me), upper_m=float(hi))
                for x, lo, me, hi in zip(self.x_m, self.lower_m, self.median_m, self.upper_m)]


def band_abscissae(span_type: SpanType, n_points: int) -> np.ndarray:
    """``n_points`` equally spaced abscissae over the span [m], with the dropper abscissae added."""
    x = np.linspace(0.0, span_type.length_m, int(n_points))
    return np.unique(np.concatenate([x, span_type.dropper_positions_m]))


def sample_profiles(model: FastSpanModel, operator: ProfileMap, dropper_lengths_m: np.ndarray,
                    messenger_tension_n: np.ndarray, system_height_left_m: np.ndarray,
                    system_height_right_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """CW deflection profiles of N spans (design T_CW) and their slack flags.

    Returns
    -------
    profiles : numpy.ndarray, shape (N, p)
        Deflection from the chord at ``operator.x_m`` [m] (not the static solution where slack).
    slack : numpy.ndarray of bool, shape (N,)
        True where a dropper would be in compression.
    """
    res = model.evaluate(dropper_lengths_m, messenger_tension_n, system_height_left_m, system_height_right_m)
    profiles = operator.deflection(res, dropper_lengths_m, messenger_tension_n, system_height_left_m,
                                   system_height_right_m, model.span_type.contact_tension_n)
    return profiles, res.slack


def deflection_band(model: FastSpanModel, means: np.ndarray, sigmas: np.ndarray, *, x_m: np.ndarray,
                    n_samples: int, level: float = 0.98, design_method: str = "sobol", seed: int = 0,
                    system_height_mode: str = "shared",
                    operator: ProfileMap | None = None) -> DeflectionBand:
    """Pointwise ``level`` band of the CW deflection along the span under the laws (means, sigmas).

    Parameters
    ----------
    model : FastSpanModel
        Fast model of the span type; its T_MW range must cover the samples.
    means, sigmas : array_like, shape (n + 2,)
        Gamma laws of droppers 1…n [m], T_MW [N], ΔH [m] (design order).
    x_m : array_like
        Abscissae from the left mast [m] (see :func:`band_abscissae`).
    n_samples : int
        Samples drawn (before removing slack ones).
    level : float
        Probability content at each x (0.98: quantiles 1 % and 99 %).
    design_method : {"sobol", "lhs"}
    seed : int
        Seed of the design.
    system_height_mode : {"shared", "independent"}
    operator : ProfileMap, optional
        Prebuilt ``model.profile_map(x_m)``.

    Raises
    ------
    ValueError
        If every sample has a slack dropper.
    """
    if not 0.0 < level < 1.0:
        raise ValueError(f"level: expected a probability in (0, 1), got {level!r}")
    means = np.asarray(means, dtype=float)
    n = means.size - 2
    design = draw_unit_design(int(n_samples), design_dimension(n, system_height_mode), method=design_method,
                              seed=seed)
    x = map_inputs(design.z, means, sigmas, system_height_mode)
    if operator is None:
        operator = model.profile_map(x_m)
    profiles, slack = sample_profiles(model, operator, x.dropper_lengths_m, x.messenger_tension_n,
                                      x.system_height_left_m, x.system_height_right_m)
    taut = profiles[~slack]
    if taut.shape[0] == 0:
        raise ValueError("every band sample has a slack dropper: the laws do not describe a taut span")
    lower, median, upper = np.quantile(taut, [0.5 * (1.0 - level), 0.5, 0.5 * (1.0 + level)], axis=0)
    return DeflectionBand(x_m=operator.x_m, lower_m=lower, upper_m=upper, median_m=median, level=float(level),
                          n_samples=int(n_samples), n_slack=int(slack.sum()))
