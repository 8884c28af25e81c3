"""Synthetic measured deflections with a known truth, for checks of the identification.

* :func:`simulate_deflections` — independent spans drawn from known Gamma laws through the fast
  model (the identification's own model: no model-form error). The draw is plain Monte Carlo
  with NumPy's Gamma generator — independent of the design and of the inverse CDFs used by J —
  and spans with a slack dropper are redrawn, matching the likelihood's model of W given every
  dropper taut.
* :func:`line_deflections` — a whole line drawn from a campaign truth specification and solved
  statically section by section, as the campaign does it (wires continuous over the masts, a
  mast's ΔH shared by its two spans, random neighbours): W as a perfect correction would hand
  it over, with the pairs of spans that share a mast.
"""

from __future__ import annotations

import numpy as np

import dataclasses

import pandas as pd

from catenary.measurement.campaign import static_truth
from catenary.measurement.truth import TruthSpec, draw_line
from catenary.physics.config import Catenary
from catenary.physics.fast import FastSpanModel
from catenary.plumbing.errors import NoTautSolutionError
from .dependence import adjacent_span_pairs

__all__ = ["MAX_DRAWS_PER_SPAN", "LineDeflections", "line_deflections", "simulate_deflections"]

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


@dataclasses.dataclass(frozen=True)
class LineDeflections:
    """Static W of one span type's spans in a drawn line.

    Attributes
    ----------
    w_m : numpy.ndarray, shape (K, n)
        Static CW deflection from the chord at the droppers [m].
    mast_pairs : numpy.ndarray of int, shape (P, 2)
        Rows of ``w_m`` that share a mast.
    truth : pandas.DataFrame
        The truth rows of those spans (:func:`catenary.measurement.campaign.static_truth`), for
        :func:`catenary.measurement.campaign.realized_truth`.
    """

    w_m: np.ndarray
    mast_pairs: np.ndarray
    truth: pd.DataFrame


def line_deflections(spec: TruthSpec, catenary: Catenary, span_type: str, *, seed: int) -> LineDeflections:
    """Draw the line of ``spec`` with ``seed`` and solve it statically (module docstring).

    Parameters
    ----------
    spec : TruthSpec
        Campaign truth specification (laws, sections, hidden effects); its own seed is replaced.
    catenary : Catenary
    span_type : str
        The span type whose spans are returned.
    seed : int
        Seed of the line's draw.
    """
    line = draw_line(dataclasses.replace(spec, seed=int(seed)), catenary)
    truth = static_truth(line, catenary)
    truth = truth[truth["span_type"] == span_type].reset_index(drop=True)
    if truth.empty:
        raise ValueError(f"span type {span_type!r}: no span of that type in the truth specification")
    n = catenary.span_type(span_type).n_droppers
    w = truth[[f"static_w{i + 1}_m" for i in range(n)]].to_numpy(dtype=float)
    pairs = adjacent_span_pairs(truth["section_id"], truth["start_chainage_m"], truth["end_chainage_m"])
    return LineDeflections(w_m=w, mast_pairs=pairs, truth=truth)
