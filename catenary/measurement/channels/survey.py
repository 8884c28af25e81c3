"""The survey file: what crews measured on the line besides the car's recording.

One row per measured value:

============ ======== ======================================================================
column       required meaning
============ ======== ======================================================================
quantity     yes      what was measured: ``messenger_tension_n`` (in a span),
                      ``cw_residual_thickness_m`` (in a span), ``contact_tension_n`` (at a
                      section's tensioning device), ``system_height_m`` (at a mast) or
                      ``measuring_force_n`` (the car's static force, calibrated at standstill)
span_id      per      the span, ``{left_mast_id}-{right_mast_id}`` (span quantities)
section_id   per      the tensioning section (section quantities)
mast_id      per      the mast (mast quantities)
value        yes      the measured value [SI: m, N]
std          no       its standard uncertainty [same unit]; empty: the config's
                      ``measurements.accuracy``
============ ======== ======================================================================

"per": the id column the quantity's place needs must be filled on its rows; a line quantity
needs none. CSV or Parquet. Every failure is an :class:`~catenary.plumbing.errors.InputError` naming the
file, the row and the column, and what was expected.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from catenary.measurement.recording import read_data_file, row_label
from catenary.plumbing.errors import InputError
from .quantities import QUANTITIES

__all__ = ["ID_COLUMN", "SURVEY_COLUMNS", "read_survey"]

SURVEY_COLUMNS = ("quantity", "span_id", "section_id", "mast_id", "value", "std")

#: The id column each place of a quantity needs.
ID_COLUMN = {"span": "span_id", "section": "section_id", "mast": "mast_id", "line": None}

#: Plausible ranges of each quantity's value [SI] (a value outside is a unit or a column mistake).
_RANGE = {"cw_residual_thickness_m": (0.0, 0.03), "messenger_tension_n": (1.0e3, 1.0e5),
          "contact_tension_n": (1.0e3, 1.0e5), "system_height_m": (0.3, 5.0), "measuring_force_n": (1.0, 500.0)}


def read_survey(path: str | Path) -> pd.DataFrame:
    """Read and check a survey file (module docstring).

    Returns
    -------
    pandas.DataFrame
        Columns :data:`SURVEY_COLUMNS`: ``quantity`` and the ids as text (empty where not needed),
        ``value`` and ``std`` float64 [SI] (``std`` NaN where the file gives none). A file with a
        header only gives no rows.
    """
    df = read_data_file(path, text_columns=("quantity", "span_id", "section_id", "mast_id"))
    src = str(path)
    missing = [c for c in ("quantity", "value") if c not in df.columns]
    if missing:
        raise InputError(f"{src}: missing column(s) {missing}; expected {', '.join(SURVEY_COLUMNS)} "
                         "(quantity, value required)")
    out = pd.DataFrame({"quantity": df["quantity"].fillna("").astype(str).str.strip()})
    for column in ("span_id", "section_id", "mast_id"):
        out[column] = (df[column].fillna("").astype(str).str.strip() if column in df.columns else "")
    for column in ("value", "std"):
        if column not in df.columns:
            out[column] = np.nan
            continue
        values = pd.to_numeric(df[column], errors="coerce")
        bad = np.flatnonzero(values.isna() & df[column].notna() & (df[column].astype(str).str.strip() != ""))
        if bad.size:
            i = int(bad[0])
            raise InputError(f"{src}: {row_label(i, src)}, column {column!r}: {df[column].iloc[i]!r} is not a number")
        out[column] = values.astype(float)
    for i, row in enumerate(out.itertuples(index=False)):
        where = f"{src}: {row_label(i, src)}"
        if row.quantity not in QUANTITIES:
            raise InputError(f"{where}, column 'quantity': {row.quantity!r}; expected one of {', '.join(QUANTITIES)}")
        id_column = ID_COLUMN[QUANTITIES[row.quantity].place]
        if id_column is not None and not getattr(row, id_column):
            raise InputError(f"{where}, column {id_column!r}: empty; a {row.quantity} row names its "
                             f"{id_column.removesuffix('_id')}")
        low, high = _RANGE[row.quantity]
        if not (np.isfinite(row.value) and low <= row.value <= high) or (row.quantity == "cw_residual_thickness_m"
                                                                         and row.value <= 0):
            unit = QUANTITIES[row.quantity].unit
            raise InputError(f"{where}, column 'value': {row.value:g}; expected a {row.quantity} in SI units within "
                             f"[{low:g}, {high:g}] {unit}")
        if not np.isnan(row.std) and not (np.isfinite(row.std) and row.std > 0):
            raise InputError(f"{where}, column 'std': {row.std:g}; expected a standard uncertainty > 0 or empty "
                             "(the config's accuracy)")
    return out.reset_index(drop=True)
