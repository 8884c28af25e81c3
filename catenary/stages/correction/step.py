"""The correction's step after its first dynamic pass: the move of the static CW that the
measuring pass's response to it says closes the gap.

The correction iterates ``static ← static + step(gap)``. Moving the static CW by the gap (the
plain step) would close it in one pass if the measured height moved one for one with the
static CW. It does not: the pantograph's inertia answers each change of the profile, so that
raising the CW at a dropper raises the height the car reports there by 0.7–1.0 of the raise and
moves it at the span's other droppers by −0.20 to +0.32 of the raise (N2 at 40 km/h; N3 −0.14 to
+0.20; :func:`catenary.physics.measuring.support_response`).
After the first dynamic pass the plain step left ≈ 0.29 of the gap (median over the 500
sections of a 10 000-span line), so that 160 of them needed a third pass or more.

The pass is linear in the static CW while every dropper stays taut and the pantograph in
contact, and the response of a span depends only on its type and the measuring conditions: the
run's response ``A`` (heights at its droppers and masts per unit raise of each) is assembled
from the columns of one nominal span, shifted span by span, and the step solves
``A · move = gap`` on the measured support points. On 8 sections of a 10 000-span line
(2026-11-28, N2 and N3, 40 km/h; a scratch harness, the step taken after every pass) the gap
after the second dynamic pass fell from 0.79–1.31 mm to 0.30–0.86 mm and every one converged in
two dynamic passes (plain step: 4 of them in three).
Where the run departs from the nominal span — its first and last spans, a type change, a
dropper at the edge of slack, a run measured at another speed or force than the response's —
the step is less exact, never unchecked: each pass is still compared with the measurement and
the loop stops only on the tolerance.

The correction takes this step after its first dynamic pass only. That pass's gap (2–5 mm) is
the dynamic uplift's departure from the quasi-static one, linear in the profile; the gaps left
after it (≈ 1 mm and less) are what the nominal span does not describe, above all droppers at
the edge of slack, which a linear step overshoots: taken after every pass, it left 4 of a
1 000-span line's 50 sections with a span above the tolerance after all five passes (the plain
step 2, and 3 sections using all five).

The responses are computed once per line (rule ``measuring_response``) per span type and
direction of travel, at the median speed and force of the spans measured that way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from catenary.physics.config import Catenary
from catenary.physics.measuring import support_response
from catenary.physics.pantograph import Pantograph
from catenary.plumbing.errors import InputError

from .settings import CorrectionSettings

__all__ = ["RESPONSE_COLUMNS", "SupportResponse", "line_responses", "measuring_responses", "pick_response",
           "read_responses", "response_table", "run_response", "step_move"]

#: Columns of ``correction/measuring_response.parquet``: one row per entry of each response
#: matrix (``row``: the support point, ``column``: the raised support; :func:`support_response`).
RESPONSE_COLUMNS = ("span_type", "direction", "speed_m_s", "force_n", "neighbours", "row", "column", "response")

#: Neighbouring spans either side of the raised one in the nominal section: the response falls
#: from 0.82–0.98 at the raised dropper to ≤ 0.09 of the raise one span away and ≤ 0.03 two spans
#: away (N2, N3 at 40 km/h), so beyond is left out, and the section's own ends stay out of the
#: central span's response.
NEIGHBOURS = 2


@dataclass(frozen=True)
class SupportResponse:
    """The response of one span type's measuring pass (:func:`support_response`'s matrix) and
    the conditions it was computed at: direction of travel (±1), speed [m/s], static force [N]."""

    span_type: str
    direction: int
    speed_m_s: float
    force_n: float
    neighbours: int
    matrix: np.ndarray

    @property
    def own_response(self) -> np.ndarray:
        """At each of the central span's droppers, the measured height's move per unit raise of
        that dropper [m/m]."""
        n = self.matrix.shape[1] - 1
        return self.matrix[self.neighbours * n + np.arange(n), np.arange(n)]


def line_responses(spans: pd.DataFrame, catenary: Catenary, pantograph: Pantograph, settings: CorrectionSettings,
                   workers: int = 1) -> list[SupportResponse]:
    """The responses a line's correction takes its step from: per span type and direction
    (:func:`measuring_responses`, at the settings' speed, force and time step where the spans
    have none) for dynamic passes; none for quasi-static ones, which move one for one with the
    static CW (the plain step is theirs)."""
    if settings.mode != "dynamic":
        return []
    return measuring_responses(spans, catenary, pantograph, default_speed_m_s=settings.speed_kmh / 3.6,
                               default_force_n=settings.force_n, time_step_s=settings.time_step_s, workers=workers)


def measuring_responses(spans: pd.DataFrame, catenary: Catenary, pantograph: Pantograph, *, default_speed_m_s: float,
                        default_force_n: float, time_step_s: float, workers: int = 1) -> list[SupportResponse]:
    """One response per span type and direction of travel of ``spans`` (the projection's spans
    with ``span_type``, ``direction``, ``speed_kmh``, ``force_n``), at the median speed and force
    of its spans (the defaults where the recording has none)."""
    out = []
    spans = spans.assign(direction=spans["direction"] if "direction" in spans else 1)
    for (span_type, direction), part in spans.groupby(["span_type", "direction"], sort=True):
        speed = _median(part, "speed_kmh", default_speed_m_s * 3.6) / 3.6
        force = _median(part, "force_n", default_force_n)
        matrix = support_response(catenary.span_type(str(span_type)), catenary, pantograph.with_static_force(force),
                                  speed_m_s=speed, mode="dynamic", time_step_s=time_step_s, direction=int(direction),
                                  neighbours=NEIGHBOURS, workers=workers)
        out.append(SupportResponse(str(span_type), int(direction), speed, force, NEIGHBOURS, matrix))
    return out


def _median(part: pd.DataFrame, column: str, default: float) -> float:
    values = part[column].to_numpy(dtype=float) if column in part else np.full(len(part), np.nan)
    values = values[np.isfinite(values)]
    return float(np.median(values)) if values.size else float(default)


def response_table(responses: list[SupportResponse]) -> pd.DataFrame:
    """The responses in long form (:data:`RESPONSE_COLUMNS`), SI."""
    parts = []
    for r in responses:
        rows, cols = np.indices(r.matrix.shape)
        parts.append(pd.DataFrame({"span_type": r.span_type, "direction": r.direction, "speed_m_s": r.speed_m_s,
                                   "force_n": r.force_n, "neighbours": r.neighbours, "row": rows.ravel(),
                                   "column": cols.ravel(), "response": r.matrix.ravel()}))
    if not parts:
        return pd.DataFrame({c: pd.Series(dtype=str if c == "span_type" else float) for c in RESPONSE_COLUMNS})
    return pd.concat(parts, ignore_index=True)[list(RESPONSE_COLUMNS)]


def read_responses(table: pd.DataFrame, source: str = "measuring_response") -> list[SupportResponse]:
    """The responses of :func:`response_table`'s rows.

    Raises
    ------
    InputError
        A column is missing, or a matrix is not complete.
    """
    missing = [c for c in RESPONSE_COLUMNS if c not in table]
    if missing:
        raise InputError(f"{source}: missing column(s) {missing}; expected {list(RESPONSE_COLUMNS)}")
    out = []
    for (span_type, direction), part in table.groupby(["span_type", "direction"], sort=True):
        rows, cols = part["row"].to_numpy(dtype=int), part["column"].to_numpy(dtype=int)
        shape = (rows.max() + 1, cols.max() + 1)
        if len(part) != shape[0] * shape[1]:
            raise InputError(f"{source}: span type {span_type}, direction {direction}: {len(part)} entries, expected "
                             f"a full {shape[0]} × {shape[1]} matrix")
        matrix = np.empty(shape)
        matrix[rows, cols] = part["response"].to_numpy(dtype=float)
        first = part.iloc[0]
        out.append(SupportResponse(str(span_type), int(direction), float(first["speed_m_s"]), float(first["force_n"]),
                                   int(first["neighbours"]), matrix))
    return out


def pick_response(responses: list[SupportResponse], span_type: str, direction: int) -> SupportResponse | None:
    """The response of ``span_type`` in the direction of travel ``direction``, or None."""
    return next((r for r in responses if r.span_type == span_type and r.direction == direction), None)


def run_response(span_types: list[str], n_droppers: list[int], responses: list[SupportResponse],
                 direction: int) -> np.ndarray:
    """The response of a run of spans (module docstring): rows and columns its droppers span by
    span, then its masts, in chainage order. A span type without a response (or of another number
    of droppers than the table's) answers one for one at its own points (the plain step)."""
    n_sp = len(span_types)
    offsets = np.r_[0, np.cumsum(n_droppers)]
    nd = int(offsets[-1])
    a = np.eye(nd + n_sp + 1)
    picked = [pick_response(responses, t, direction) for t in span_types]
    picked = [r if r is not None and r.matrix.shape[1] == n + 1 else None for r, n in zip(picked, n_droppers)]

    def fill(column: int, owner: int, first_span: int, r: SupportResponse, source_column: int) -> None:
        """Column ``column`` of ``a`` from ``r``'s ``source_column``, the raised support's span being
        ``first_span`` (its left mast's span for a mast), ``owner`` the span whose type it takes."""
        nb, n = r.neighbours, n_droppers[owner]
        a[:, column] = 0.0
        for o in range(-nb, nb + 1):
            t = first_span + o
            if 0 <= t < n_sp and span_types[t] == span_types[owner] and n_droppers[t] == n:
                a[offsets[t]:offsets[t + 1], column] = r.matrix[(nb + o) * n:(nb + o + 1) * n, source_column]
        for o in range(-nb, nb + 2):
            m = first_span + o
            if 0 <= m <= n_sp:
                a[nd + m, column] = r.matrix[(2 * nb + 1) * n + nb + o, source_column]

    for s in range(n_sp):
        if picked[s] is not None:
            for k in range(n_droppers[s]):
                fill(offsets[s] + k, s, s, picked[s], k)
    for m in range(n_sp + 1):
        owner = min(m, n_sp - 1)
        if picked[owner] is not None:
            fill(nd + m, owner, m, picked[owner], n_droppers[owner])
    return a


def step_move(response: np.ndarray | None, gap_d: np.ndarray, gap_m: np.ndarray, on_d: np.ndarray,
              on_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The move of the static CW at the droppers and the masts [m] that closes the gaps
    ``gap_d``, ``gap_m`` [m] under ``response`` (:func:`run_response`), on the measured points
    ``on_d``, ``on_m`` only (the others stay); without a response, the gaps themselves."""
    if response is None:
        return gap_d, gap_m
    on = np.r_[on_d, on_m]
    move = np.zeros(on.size)
    move[on] = np.linalg.solve(response[np.ix_(on, on)], np.r_[gap_d, gap_m][on])
    return move[:gap_d.size], move[gap_d.size:]
