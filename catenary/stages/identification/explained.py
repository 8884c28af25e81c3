"""The laws of the spans the final model explains: one span type's identification again without the
spans the diagnosis flags (its ``diagnosis/spans.csv``), which the later stages read by default
(``diagnosis.later_stages_laws``) so that no law is drawn from what the model cannot vouch for.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import pandas as pd

from catenary.physics.config import Catenary, SpanType
from catenary.plumbing.errors import InputError
from .data import CorrectedData
from .propagation import span_shifts
from .runner import identify_laws
from .settings import IdentificationSettings
from .tables import s_opt_table

__all__ = ["ExplainedLaws", "identify_explained", "unexplained_spans"]

_LOG = logging.getLogger(__name__)


def unexplained_spans(spans: pd.DataFrame) -> set[str]:
    """Ids of the spans the final model does not explain, or explains only by an effect of the
    user's own (``diagnosis/spans.csv``: ``unexplained``, ``explained_by``)."""
    flagged = spans["unexplained"].astype(str) == "True"
    own = spans["explained_by"].fillna("").astype(str) != "" if "explained_by" in spans else False
    return set(spans.loc[flagged | own, "span_id"].astype(str))


@dataclass(frozen=True)
class ExplainedLaws:
    """The laws without the unexplained spans.

    Attributes
    ----------
    table : DataFrame or None
        Their ``s_opt`` table; None where there is none to draw (every span explained, or too
        few explained spans): the later stages then use the laws of every span.
    why : str
        Why there is no table ("" where there is one).
    left_out : set of str
        The spans left out.
    n_identified : int
        The spans the laws were identified on.
    """

    table: pd.DataFrame | None
    why: str
    left_out: set[str]
    n_identified: int


def identify_explained(span_type: SpanType, catenary: Catenary, data: CorrectedData, spans: pd.DataFrame,
                       settings: IdentificationSettings, repeatability_m2: np.ndarray | None, *,
                       model_error: pd.DataFrame | None = None, corrected: pd.DataFrame | None = None,
                       log: logging.Logger | None = None) -> ExplainedLaws:
    """The identification of :func:`~.runner.identify_laws` on the spans of ``data`` that
    ``spans`` (the diagnosis' per-span check) does not flag.

    Parameters
    ----------
    span_type, catenary, settings
        As the identification of every span took them.
    data : CorrectedData
        Every span's corrected W (with its measurements besides W, if any).
    spans : DataFrame
        ``diagnosis/spans.csv``.
    repeatability_m2 : numpy.ndarray or None
        The measurement's repeatability per dropper [m²] (:func:`catenary.measurement.repeatability.read_noise`).
    model_error, corrected : DataFrame, optional
        The correction's model-error shifts and corrected table, when the budget was measured.
    log : logging.Logger, optional

    Returns
    -------
    ExplainedLaws
    """
    log = log or _LOG
    departing = unexplained_spans(spans)
    leave = pd.Series(data.span_id).isin(departing).to_numpy()
    bulk = data.without(leave, "unexplained by the final model (diagnosis/spans.csv)")
    if not leave.any():
        return ExplainedLaws(None, "every span is explained by the final model", set(), bulk.w_m.shape[0])
    left_out = set(np.asarray(data.span_id)[leave].astype(str))
    log.info("%s: %d spans left out as unexplained (%s); %d identified", span_type.name, int(leave.sum()),
             ", ".join(sorted(left_out)), bulk.w_m.shape[0])
    w_shifts = (span_shifts(model_error, span_type.name, bulk.span_id, span_type.n_droppers, corrected)
                if model_error is not None else None)
    try:
        laws = identify_laws(span_type, catenary, bulk.w_m, settings, left_out=bulk.left_out,
                             mast_pairs=bulk.mast_pairs, log=log, n_runs=bulk.n_runs,
                             noise_covariance_m2=settings.noise_covariance_m2(span_type.n_droppers, repeatability_m2),
                             w_shifts=w_shifts, observations=bulk.observations)
    except InputError as exc:        # too few explained spans for the identified parameters
        return ExplainedLaws(None, f"the {bulk.w_m.shape[0]} explained spans cannot identify the laws alone ({exc})",
                             left_out, bulk.w_m.shape[0])
    return ExplainedLaws(s_opt_table(laws.result, (), laws.model_error), "", left_out, bulk.w_m.shape[0])
