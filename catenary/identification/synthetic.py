"""Synthetic measured deflections: spans drawn from known Gamma laws through the fast model.

Used to check the identification on data whose truth is known (paper Table 2 laws). The draw is
plain Monte Carlo with NumPy's Gamma generator — independent of the design and of the inverse
CDFs used by J — and spans with a slack dropper are redrawn, matching the likelihood's model of
W given every dropper taut.
"""

from __future__ import annotations

import numpy as np

from ..errors import NoTautSolutionError
from ..fast import FastSpanModel

__all__ = ["MAX_DRAWS_PER_SPAN", "simulate_deflections"]

#: Draws allowed per requested span before giving up (a taut fraction below 1/1000).
MAX_DRAWS_PER_SPAN = 1000


def simulate_deflections(model: FastSpanModel, means: np.ndarray, sigmas: np.ndarray, n_spans: int, *,
                         seed: int, system_height_mode: str = "shared") -> np.ndarray:
    """Draw ``n_spans`` deflection vectors W [m] of spans with Gamma inputs (means, sigmas).

    Parameters
    ----------
    model : FastSpanModel
        Fast model; its tension range must cover the T_MW draws.
    means, sigmas : array_like, shape (n + 2,)
        Laws of droppers 1…n [m], T_MW [N] and ΔH [m].
    n_spans : int
        Number of spans K.
    seed : int
        Seed of ``numpy.random.default_rng``.
    system_height_mode : {"shared", "independent"}
        One ΔH per span at both masts, or independent draws at each mast.

    Returns
    -------
    numpy.ndarray, shape (K, n)
        W of taut spans only.

    Raises
    ------
    NoTautSolutionError
        If fewer than one draw in ``MAX_DRAWS_PER_SPAN`` is taut (the laws hardly describe a
        taut span): the redrawing stops there instead of looping on.
    """
    means = np.asarray(means, dtype=float)
    sigmas = np.asarray(sigmas, dtype=float)
    shape, scale = (means / sigmas) ** 2, sigmas**2 / means
    n = means.size - 2
    rng = np.random.default_rng(seed)
    out = []
    n_found = n_drawn = 0
    max_draws = MAX_DRAWS_PER_SPAN * n_spans + 16
    while n_found < n_spans:
        if n_drawn >= max_draws:
            raise NoTautSolutionError(
                f"{n_found} taut spans in {n_drawn} draws (slack fraction {1 - n_found / n_drawn:.4f}): these laws "
                f"hardly describe a taut span; {n_spans} taut spans would need more than {max_draws} draws")
        m = 2 * (n_spans - n_found) + 16
        n_drawn += m
        x = rng.gamma(shape, scale, size=(m, n + 2))
        right = rng.gamma(shape[-1], scale[-1], size=m) if system_height_mode == "independent" else x[:, -1]
        res = model.evaluate(x[:, :n], x[:, n], x[:, n + 1], right)
        taut = res.w_m[~res.slack]
        out.append(taut)
        n_found += taut.shape[0]
    return np.concatenate(out)[:n_spans]
