"""The report's tables as a person reads them: an engineer's units and names, the files kept SI.

Every table of the report is a copy of a machine-readable file of the pipeline (which keeps SI
and its ``_m`` / ``_n`` column names, for programs), written by :func:`engineer_table`:

* a column named with its unit is shown in the unit an engineer reads, the unit in its header:
  positions along the line (chainages, a span's position ``x``, a registration's offset, a span's
  length) in m; every other length — dropper lengths, deflections, heights, errors, their
  spreads — in mm; forces and tensions in N; speeds in km/h; ``dropper_1_length_m`` becomes
  "dropper 1 length [mm]";
* a table whose rows are quantities (``parameter``, ``input``, ``quantity`` or ``criterion``)
  names each row as an engineer does, with its unit ("dropper 1 length [mm]", "messenger tension
  T_MW [N]"), and shows the row's values (μ, σ, their standard errors and intervals, a nominal,
  mean and quantiles, a deviation) in that unit;
* everything else (probabilities, counts, flags, words) is left as it is.

Numbers are written to 6 significant digits: 0.001 mm on a 1 m dropper.
"""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd

from catenary.physics.names import CRITERION_LABELS, engineer_input
from catenary.plumbing.parquet import unit_suffix

__all__ = ["LINE_LENGTHS", "ROW_NAMES", "ROW_VALUES", "engineer_table", "header", "quantity", "write_engineer_table",
           "write_shown"]

#: Columns in metres that are positions or lengths along the line, shown in m (a span's
#: ``length_m`` is one, a dropper's is not: see :func:`_line_length`).
LINE_LENGTHS = re.compile(r"chainage|^x_m$|^offset_m$|^recorded_(low|high)_m$|^reference_m$")
#: Columns whose rows name the quantity of the row's values.
ROW_NAMES = ("parameter", "input", "quantity", "criterion")
#: Columns holding a value in the unit of the row's quantity.
ROW_VALUES = re.compile(
    r"^(mu|sigma)(_(se|profile_low|profile_high|total_low|total_high|systematic))?$"
    r"|^(estimate|standard_error|realized|profile_low|profile_high|total_low|total_high)$"
    r"|^(all_spans|explained_spans|difference)(_se)?$"
    r"|^(nominal|mean|std|q05|q50|q95|q95_low|q95_high|deviation)$"
    r"|^(median_width|rmse_posterior_mean|rmse_dropper_only|value|en50318_min|en50318_max)$"
    r"|^(planted_magnitude|realized_magnitude|identified)$")
#: Suffixes the CSV tables use beside those of the Parquet files (:func:`~catenary.plumbing.parquet.unit_suffix`).
_TABLE_SUFFIXES = (("_percent", "%"), ("_fraction", "fraction"), ("_cm", "cm"), ("_h", "h"))
#: How a unit is shown, where not as it is: the factor from it and the unit read.
_SHOWN = {"m": (1e3, "mm"), "cm": (10.0, "mm"), "fraction": (100.0, "%")}


def _unit(name: str) -> tuple[str, float, str] | None:
    """(bare name, factor, unit shown) of a name ending in a unit suffix; None without one."""
    suffix, unit = unit_suffix(name)
    if not suffix:
        suffix, unit = next(((s, u) for s, u in _TABLE_SUFFIXES if name.endswith(s) and len(name) > len(s)), ("", ""))
    if not suffix:
        return None
    factor, shown = _SHOWN.get(unit, (1.0, unit))
    return name[: -len(suffix)], factor, shown


def _line_length(column: str, columns) -> bool:
    """Whether a metre column is a position or length along the line (kept in m): a chainage,
    ``x``, an offset, or a ``length_m`` of a table that is not about droppers."""
    return bool(LINE_LENGTHS.search(column)) or (column == "length_m" and "dropper" not in columns)


def quantity(name: str) -> tuple[str, float, str]:
    """How a quantity named in SI is read: its label, the factor from SI and the unit
    (a contact-force criterion's :data:`~catenary.physics.names.CRITERION_LABELS`,
    :func:`~catenary.physics.names.engineer_input` for the identified inputs and
    dropper forces, else from the name's unit suffix; a name without one stays as it is)."""
    if name in CRITERION_LABELS:
        return CRITERION_LABELS[name]
    label, factor, unit = engineer_input(name)
    if unit != "SI":
        return label, factor, unit
    parsed = _unit(name)
    if parsed is None:
        return name.replace("_", " "), 1.0, ""
    bare, factor, unit = parsed
    return bare.replace("_", " "), factor, unit


def header(column: str, columns=()) -> tuple[str, float]:
    """A column's header as shown and the factor from its SI values: ``gap_norm_m`` → ("gap norm
    [mm]", 1000), ``start_chainage_m`` → ("start chainage [m]", 1); a column without a unit
    suffix keeps its name (underscores as spaces)."""
    parsed = _unit(column)
    if parsed is None:
        return column.replace("_", " "), 1.0
    bare, factor, unit = parsed
    if unit == "mm" and column.endswith("_m") and _line_length(column, columns):
        factor, unit = 1.0, "m"
    label, f, u = engineer_input(column)
    if u != "SI":
        return f"{label} [{u}]", f
    return f"{bare.replace('_', ' ')} [{unit}]", factor


def _numeric(values: pd.Series) -> bool:
    return pd.api.types.is_numeric_dtype(values) and not pd.api.types.is_bool_dtype(values)


def engineer_table(table: pd.DataFrame) -> pd.DataFrame:
    """``table`` as the report shows it (module docstring): the same rows, values in an
    engineer's units, headers with their unit."""
    out = table.copy()
    rows = next((c for c in ROW_NAMES if c in out.columns), None)
    if rows is not None:
        names = out[rows].fillna("").astype(str)
        factors = names.map(lambda n: quantity(n)[1])
        for column in out.columns:
            if ROW_VALUES.match(column) and _numeric(out[column]):
                out[column] = out[column] * factors.to_numpy()
        out[rows] = [f"{label} [{unit}]" if unit else label for label, _, unit in map(quantity, names)]
    renamed = {}
    for column in table.columns:
        if column == rows:
            renamed[column] = column
            continue
        shown, factor = header(column, table.columns)
        if factor != 1.0 and _numeric(out[column]):
            out[column] = out[column] * factor
        renamed[column] = shown
    return out.rename(columns=renamed)


def write_engineer_table(source: str | Path, path: str | Path) -> Path:
    """Read the machine table ``source`` (CSV), write :func:`engineer_table` of it to ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        table = pd.read_csv(source, keep_default_na=False, na_values=[""])
    except pd.errors.EmptyDataError:                 # a stage that had nothing to write (a budget not measured)
        path.write_text(Path(source).read_text(encoding="utf-8"), encoding="utf-8")
    else:
        engineer_table(table).to_csv(path, index=False, float_format="%.6g")
    return path


def write_shown(outputs) -> list[Path]:
    """Write the report's copy of every table among a rule's ``outputs``: for each output
    ``<name>_shown``, :func:`write_engineer_table` of output ``<name>`` (the workflow's
    ``table()`` declares the pair). Called by a rule script once its tables are written.

    Parameters
    ----------
    outputs : snakemake.io.Namedlist or mapping of str to path

    Returns
    -------
    list of pathlib.Path
        The copies written.
    """
    items = dict(outputs.items()) if hasattr(outputs, "items") else dict(outputs)
    return [write_engineer_table(items[name.removesuffix("_shown")], path)
            for name, path in items.items() if name.endswith("_shown")]
