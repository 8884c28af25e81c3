"""Ingestion of a user's recording and masts files.

A **recording** is the contact-wire height measured along the line by a recording car:

========== ======== =====================================================================
column     required meaning
========== ======== =====================================================================
chainage_m yes      position along the line [m] as the car's odometer gives it, finite;
                    within a run strictly increasing or strictly decreasing (rows in time
                    order: the direction of travel)
height_m   yes      CW height above rail at the pantograph [m]; empty / NaN = drop-out
speed_kmh  no       train speed [km/h]
force_n    no       static force the measuring pantograph is set to push [N] (the declared
                    force the correction models)
stagger_m  no       lateral position of the contact point [m] (the stagger; it reverses at
                    every steady arm, which the registration uses to find the supports)
cw_residual_thickness_m
           no       residual thickness of the CW from the car's wear channel [m], within
                    (0, 0.03] m
contact_force_n
           no       contact force the head's load cells measure [N], within [−50, 500] N
                    (its mean over a run is the force the car really pushes)
run_id     no       text label of the measuring run; the rows of a run are consecutive.
                    Absent: the whole file is one run, named after the file
direction  no       +1 (travel towards increasing chainage) or -1, one value per run;
                    absent: read from the order of the rows
========== ======== =====================================================================

A recording may hold **several runs** (a ``run_id`` column, or several files read by
:func:`read_recordings`): the same line measured again, on the other track or in the other
direction. Each run is checked and registered on its own; run ids are unique across files.

A **masts** file lists the supports:

=========== ======== ====================================================================
column      required meaning
=========== ======== ====================================================================
mast_id     yes      unique text id
chainage_m  yes      position along the line [m]
section_id  yes      tensioning section (text); the masts of a section are on consecutive
                     rows with increasing chainage, sections in order along the line
span_type   no       type of the span that *starts* at this mast (N2, N3...); empty =
                     assign by length
cw_height_m no       design CW height at the steady arm [m]
=========== ======== ====================================================================

Both may be CSV (``.csv``) or Parquet (``.parquet``/``.pq``). Checks (each failure is an
:class:`~catenary.plumbing.errors.InputError` naming the file, the row and/or the column, and what was
expected): the file exists, is readable and non-empty; required columns are present; numeric
columns hold numbers; chainages are finite and, within a run, strictly monotonic (recording) or
increasing within each section (masts); heights are in metres (a median above 20 m is taken for
millimetres) and inside [0, 20] m; staggers within ±1 m; the median sampling step of each run
is at most 0.5 m; mast ids are unique; each section has at least two masts (one span).

Rows are numbered from 1 in the order of the file, the header not counted; for a CSV file the
line number (header = line 1) is given too. Columns the format does not know are ignored and
listed in ``DataFrame.attrs["ignored_columns"]``; they are not written to the ingest outputs.

Problems that concern one span only (a drop-out longer than a dropper spacing, a span without
samples, an unknown span type) are not errors here: :mod:`catenary.measurement.projection` rejects that span
and reports why.

One module, one concern: the input contract of the two files a user brings. Every check above
names the file, row and column in the same way (:func:`row_label`), and the formats, their
reading and their checks are kept together so that the documented format and the enforced one
are the same text.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa

from catenary.plumbing.errors import InputError
from catenary.plumbing.parquet import read_table, write_table

RECORDING_REQUIRED = ("chainage_m", "height_m")
RECORDING_OPTIONAL = ("speed_kmh", "force_n", "stagger_m", "cw_residual_thickness_m", "contact_force_n", "run_id",
                      "direction")
MASTS_REQUIRED = ("mast_id", "chainage_m", "section_id")
MASTS_OPTIONAL = ("span_type", "cw_height_m")

MAX_SAMPLING_STEP_M = 0.5
"""Largest median sampling step of a recording [m]."""
HEIGHT_RANGE_M = (0.0, 20.0)
"""Plausible CW heights above rail [m]; a median above the upper bound means millimetres."""
STAGGER_LIMIT_M = 1.0
"""Largest plausible |stagger| [m] (a real stagger is 0.2–0.4 m); beyond it: millimetres."""
THICKNESS_LIMIT_M = 0.03
"""Largest plausible residual thickness of a CW [m] (AC-150 is 14.8 mm new); beyond it: millimetres."""
CONTACT_FORCE_RANGE_N = (-50.0, 500.0)
"""Plausible measured contact forces [N] (dynamic, a measuring pantograph pushes 36–120 N static)."""

RECORDING_SCHEMA = pa.schema([
    pa.field("chainage_m", pa.float64(), nullable=False),
    pa.field("height_m", pa.float64()),
    pa.field("speed_kmh", pa.float64()),
    pa.field("force_n", pa.float64()),
    pa.field("stagger_m", pa.float64()),
    pa.field("cw_residual_thickness_m", pa.float64()),
    pa.field("contact_force_n", pa.float64()),
    pa.field("run_id", pa.string(), nullable=False),
    pa.field("direction", pa.int64(), nullable=False),
])
"""Arrow schema of ``results/ingest/recording.parquet``: rows in the file's order (time order
within a run), every row with its ``run_id`` and ``direction``; optional columns null when
absent; a null ``height_m`` is a drop-out."""

MASTS_SCHEMA = pa.schema([
    pa.field("mast_id", pa.string(), nullable=False),
    pa.field("chainage_m", pa.float64(), nullable=False),
    pa.field("section_id", pa.string(), nullable=False),
    pa.field("span_type", pa.string()),
    pa.field("cw_height_m", pa.float64()),
])
"""Arrow schema of ``results/ingest/masts.parquet`` (optional columns null when absent)."""

CSV_SUFFIXES = (".csv",)
PARQUET_SUFFIXES = (".parquet", ".pq")

_HINTS = {
    "height_m": {"height_mm": "heights look like millimetres; convert them to metres and name the column height_m",
                 "height": "units go in the column name: name it height_m (metres)"},
    "chainage_m": {"chainage_km": "convert the chainage to metres and name the column chainage_m",
                   "chainage": "units go in the column name: name it chainage_m (metres)"},
}


# --------------------------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------------------------

def _source(df: pd.DataFrame, source: str | None, default: str) -> str:
    if source is not None:
        return str(source)
    return str(df.attrs.get("source", default)) if isinstance(df, pd.DataFrame) else default


def row_label(position: int, source: str) -> str:
    """How a user finds the row at 0-based ``position``: ``row 5`` (``row 5 (line 6)`` in a CSV)."""
    if str(source).lower().endswith(CSV_SUFFIXES):
        return f"row {position + 1} (line {position + 2})"
    return f"row {position + 1}"


def rows_label(first: int, last: int, source: str) -> str:
    """A run of rows at 0-based positions ``first`` … ``last``, as :func:`row_label` words it."""
    if first == last:
        return row_label(first, source)
    text = f"rows {first + 1}–{last + 1}"
    if str(source).lower().endswith(CSV_SUFFIXES):
        text += f" (lines {first + 2}–{last + 2})"
    return text


def read_data_file(path: str | Path, text_columns: tuple[str, ...] = ()) -> pd.DataFrame:
    """Read a CSV or Parquet data file into a DataFrame, without checking its content.

    Parameters
    ----------
    path : str or pathlib.Path
        ``.csv``, ``.parquet`` or ``.pq`` file.
    text_columns : tuple of str
        Columns read as text from a CSV file (so that an id ``007`` stays ``007``).

    Returns
    -------
    pandas.DataFrame
        With ``attrs["source"]`` set to the path; column names stripped of surrounding blanks.

    Raises
    ------
    InputError
        Missing, empty or unreadable file, or an extension other than CSV / Parquet.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in CSV_SUFFIXES:
        if not path.is_file():
            raise InputError(f"{path}: file not found; expected a CSV file")
        try:
            df = pd.read_csv(path, dtype={c: str for c in text_columns}, **_csv_dialect(path))
        except pd.errors.EmptyDataError:
            raise InputError(f"{path}: empty file; expected a header row of column names and data rows") from None
        except (pd.errors.ParserError, UnicodeDecodeError, ValueError) as exc:
            raise InputError(f"{path}: not a readable CSV file ({exc}); expected comma-separated "
                             "values with a header row") from None
    elif suffix in PARQUET_SUFFIXES:
        df = read_table(path)
    else:
        raise InputError(f"{path}: unsupported file type {suffix or '(no extension)'!r}; "
                         "expected .csv or .parquet")
    df.columns = [str(c).strip() for c in df.columns]
    df.attrs["source"] = str(path)
    return df


def _csv_dialect(path: Path) -> dict:
    """Separator and decimal mark of a CSV file, from its first two lines.

    Comma-separated with decimal points is the format. A header with semicolons and no comma is
    the common European export (Excel with a comma decimal mark): it is read with ``sep=";"``
    and, when its first data line holds a digit-comma-digit, ``decimal=","``.
    """
    with open(path, encoding="utf-8", errors="replace") as handle:
        header, first = handle.readline(), handle.readline()
    if ";" not in header or "," in header:
        return {}
    return {"sep": ";", "decimal": "," if re.search(r"\d,\d", first) else "."}


def read_recording(path: str | Path) -> pd.DataFrame:
    """Read and check a recording file (CSV or Parquet); see the module docs for the format.

    Returns
    -------
    pandas.DataFrame
        Columns of :data:`RECORDING_SCHEMA` in that order: float64 ``chainage_m``, ``height_m``
        (NaN = drop-out), ``speed_kmh``, ``force_n`` (NaN when absent), text ``run_id``.

    Raises
    ------
    InputError
        Naming the file, the row and/or the column, and what was expected.
    """
    return validate_recording(read_data_file(path, text_columns=("run_id",)))


def read_masts(path: str | Path) -> pd.DataFrame:
    """Read and check a masts file (CSV or Parquet); see the module docs for the format.

    Returns
    -------
    pandas.DataFrame
        Columns of :data:`MASTS_SCHEMA` in that order, rows in file order: text ``mast_id``,
        float64 ``chainage_m``, text ``section_id``, text ``span_type`` (missing = assign by
        length), float64 ``cw_height_m`` (NaN when absent).

    Raises
    ------
    InputError
        Naming the file, the row and/or the column, and what was expected.
    """
    return validate_masts(read_data_file(path, text_columns=("mast_id", "section_id", "span_type")))


# --------------------------------------------------------------------------------------------
# column checks
# --------------------------------------------------------------------------------------------

def _check_table(df: Any, src: str, required: tuple[str, ...], optional: tuple[str, ...], what: str) -> None:
    if not isinstance(df, pd.DataFrame):
        raise InputError(f"{src}: expected a table ({what}), got {type(df).__name__}")
    if df.shape[1] == 0 and len(df) == 0:
        raise InputError(f"{src}: empty table (no columns, no rows); expected {what} with columns "
                         f"{', '.join(required)}")
    names = [str(c) for c in df.columns]
    duplicated = sorted({n for n in names if names.count(n) > 1})
    if duplicated:
        raise InputError(f"{src}: column(s) {', '.join(map(repr, duplicated))} appear more than once; "
                         "expected each column once")
    missing = [c for c in required if c not in names]
    if missing:
        hints = [hint for c in missing for alt, hint in _HINTS.get(c, {}).items() if alt in names]
        if len(names) == 1 and any(sep in names[0] for sep in (";", "\t", "|")):
            hints.append("the header is one column holding separators other than commas; expected "
                         "comma-separated values with decimal points (or semicolons throughout with "
                         "decimal commas)")
        raise InputError(
            f"{src}: missing required column(s) {', '.join(map(repr, missing))}; expected columns "
            f"{', '.join(required)} (optional: {', '.join(optional)}); found: "
            f"{', '.join(names) if names else '(none)'}" + (f". Hint: {'; '.join(hints)}" if hints else ""))
    if len(df) == 0:
        raise InputError(f"{src}: no data rows (only a header); expected {what}")


def _is_missing(value: Any) -> bool:
    if value is None or value is pd.NA or value is pd.NaT:
        return True
    if isinstance(value, (float, np.floating)):
        return bool(np.isnan(value))
    if isinstance(value, str):
        return value.strip() == ""
    return False


def _to_float(value: Any) -> float:
    try:
        return float(value)
    except (TypeError, ValueError, OverflowError):
        return float("nan")


def _numeric(df: pd.DataFrame, column: str, src: str, expected: str, *, allow_missing: bool) -> np.ndarray:
    """Column as float64; junk, ±inf and (unless allowed) missing values are InputErrors."""
    series = df[column]
    values: np.ndarray | None = None
    if pd.api.types.is_numeric_dtype(series.dtype) and not pd.api.types.is_bool_dtype(series.dtype):
        try:
            values = series.to_numpy(dtype=float, na_value=np.nan)
        except (TypeError, ValueError):
            values = None
        missing = np.isnan(values) if values is not None else None
    if values is None:
        obj = series.astype(object)
        values = np.array([np.nan if _is_missing(v) or isinstance(v, (bool, np.bool_)) else _to_float(v)
                           for v in obj], dtype=float)
        missing = np.array([_is_missing(v) for v in obj], dtype=bool)
        junk = np.isnan(values) & ~missing
        if junk.any():
            i = int(np.flatnonzero(junk)[0])
            raise InputError(f"{src}: {row_label(i, src)}, column {column!r}: expected a number "
                             f"({expected}), got {obj.iloc[i]!r}")
    infinite = np.isinf(values)
    if infinite.any():
        i = int(np.flatnonzero(infinite)[0])
        raise InputError(f"{src}: {row_label(i, src)}, column {column!r}: expected a finite number "
                         f"({expected}), got {values[i]}")
    if not allow_missing and missing.any():
        i = int(np.flatnonzero(missing)[0])
        raise InputError(f"{src}: {row_label(i, src)}, column {column!r}: missing value; expected {expected}")
    return values


def _text(df: pd.DataFrame, column: str, src: str, expected: str, *, required: bool) -> pd.Series:
    """Column as text (pandas ``str`` dtype, NaN = missing); integral floats lose their ``.0``."""
    out: list[str | None] = []
    for v in df[column].astype(object):
        if _is_missing(v):
            out.append(None)
        elif isinstance(v, (float, np.floating)) and float(v).is_integer():
            out.append(str(int(v)))
        else:
            out.append(str(v).strip())
    if required:
        gaps = [i for i, v in enumerate(out) if v is None]
        if gaps:
            raise InputError(f"{src}: {row_label(gaps[0], src)}, column {column!r}: missing value; "
                             f"expected {expected}")
    return pd.Series(out, dtype="str", index=pd.RangeIndex(len(out)))


def _check_heights(values: np.ndarray, column: str, src: str) -> None:
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        return
    low, high = HEIGHT_RANGE_M
    median = float(np.median(finite))
    if median > high:
        raise InputError(f"{src}: column {column!r}: median {median:g} — heights look like millimetres; "
                         "expected metres (3–8 m above rail)")
    bad = np.flatnonzero(np.isfinite(values) & ((values < low) | (values > high)))
    if bad.size:
        i = int(bad[0])
        raise InputError(f"{src}: {row_label(i, src)}, column {column!r}: height {values[i]:g} m is outside "
                         f"[{low:g}, {high:g}] m; expected the CW height above rail in metres (3–8 m)")


def _ignored(df: pd.DataFrame, known: tuple[str, ...]) -> list[str]:
    return [str(c) for c in df.columns if c not in known]


# --------------------------------------------------------------------------------------------
# validation
# --------------------------------------------------------------------------------------------

def default_run_id(source: str) -> str:
    """The run id of a file without a ``run_id`` column: the file's name without its suffix."""
    name = Path(str(source)).name
    return Path(name).stem or "run"


def _consecutive_blocks(values: pd.Series, src: str, column: str, what: str, expected: str
                        ) -> list[tuple[str, int, int]]:
    """(value, first row, end row) of each block of equal ``values``; a value appearing again after
    another is refused, naming the row, ``column``, ``what`` it is and what was ``expected``."""
    ids = values.to_numpy(dtype=object)
    starts = np.flatnonzero(np.r_[True, ids[1:] != ids[:-1]])
    ends = np.r_[starts[1:], ids.size]
    seen: dict[str, int] = {}
    blocks = []
    for a, b in zip(starts, ends):
        name = str(ids[a])
        if name in seen:
            raise InputError(f"{src}: {row_label(int(a), src)}, column '{column}': {what} {name!r} appears again "
                             f"after other {what}s (it started at {row_label(seen[name], src)}); {expected}")
        seen[name] = int(a)
        blocks.append((name, int(a), int(b)))
    return blocks


def _run_blocks(run_id: pd.Series, src: str) -> list[tuple[str, int, int]]:
    """(run id, first row, end row) of each run; a run's rows must be consecutive."""
    return _consecutive_blocks(run_id, src, "run_id", "run", "expected the rows of a run consecutive, in time order")


def _run_direction(chainage: np.ndarray, given: np.ndarray | None, name: str, first: int, src: str,
                   several: bool) -> int:
    """Direction of travel of one run (rows ``first`` … of ``src``) from its chainage order and
    the optional ``direction`` column; InputError where the chainage is not strictly monotonic."""
    step = np.diff(chainage)
    if step.size == 0:
        order = 1
    else:
        order = 1 if step[0] > 0 else -1
        bad = np.flatnonzero(step * order <= 0)
        if bad.size or step[0] == 0:
            i = first + (int(bad[0]) + 1 if bad.size else 1)
            k = i - first
            word = "increasing" if order > 0 else "decreasing"
            comparison = "not greater than" if order > 0 else "not less than"
            hint = ("; a file holding several runs needs a run_id column (or one file per run)"
                    if not several else "")
            raise InputError(
                f"{src}: {row_label(i, src)}, column 'chainage_m': {chainage[k]:.6g} m is {comparison} the previous "
                f"row's {chainage[k - 1]:.6g} m in run {name!r}, whose chainage is {word} from "
                f"{row_label(first, src)}; expected strictly {word} chainage within a run (rows in time order, "
                f"without duplicates){hint}")
    if given is None:
        return order
    values = np.unique(given)
    if values.size != 1 or values[0] not in (-1.0, 1.0):
        raise InputError(f"{src}: column 'direction' holds {', '.join(f'{v:g}' for v in values[:5])} in run "
                         f"{name!r} (from {row_label(first, src)}); expected +1 (towards increasing chainage) or "
                         "-1, one value per run")
    direction = int(values[0])
    if step.size and order < 0 < direction:
        raise InputError(f"{src}: column 'direction': run {name!r} (from {row_label(first, src)}) is declared +1 "
                         "(towards increasing chainage) but its rows run towards decreasing chainage; expected "
                         "the rows in time order, or sorted by increasing chainage with the direction given")
    return direction


def validate_recording(df: pd.DataFrame, source: str | None = None) -> pd.DataFrame:
    """Check a recording table (one run or several) and return it with canonical columns.

    Idempotent: a validated recording passes again unchanged.

    Parameters
    ----------
    df : pandas.DataFrame
        Raw table (e.g. from :func:`read_data_file`).
    source : str, optional
        Name used in messages; default ``df.attrs["source"]`` or ``"recording"``.

    Returns
    -------
    pandas.DataFrame
        Columns of :data:`RECORDING_SCHEMA`, rows in the original order, RangeIndex; every row
        carries its ``run_id`` (the file's name when the file has none) and the run's
        ``direction`` (+1 towards increasing chainage, -1 towards decreasing).

    Raises
    ------
    InputError
        Naming the source, the row and/or the column, and what was expected.
    """
    src = _source(df, source, "recording")
    _check_table(df, src, RECORDING_REQUIRED, RECORDING_OPTIONAL, "a recording, one row per sample")
    n = len(df)
    chainage = _numeric(df, "chainage_m", src, "chainage along the line [m]", allow_missing=False)
    if "run_id" in df.columns:
        run_id = _text(df, "run_id", src, "a run label", required=False)
        if run_id.isna().all():
            run_id = pd.Series([default_run_id(src)] * n, dtype="str")
        elif run_id.isna().any():
            i = int(np.flatnonzero(run_id.isna().to_numpy())[0])
            raise InputError(f"{src}: {row_label(i, src)}, column 'run_id': missing value; expected a run label on "
                             "every row (or no run_id column: the file is then one run)")
    else:
        run_id = pd.Series([default_run_id(src)] * n, dtype="str")
    given = (_numeric(df, "direction", src, "+1 or -1", allow_missing=False) if "direction" in df.columns
             else None)
    blocks = _run_blocks(run_id, src)
    direction = np.empty(n, dtype=np.int64)
    for name, a, b in blocks:
        direction[a:b] = _run_direction(chainage[a:b], None if given is None else given[a:b], name, a, src,
                                        len(blocks) > 1)
        if b - a >= 2:
            median_step = float(np.median(np.abs(np.diff(chainage[a:b]))))
            if median_step > MAX_SAMPLING_STEP_M:
                raise InputError(f"{src}: column 'chainage_m': median sampling step {median_step:.3g} m in run "
                                 f"{name!r}; expected at most {MAX_SAMPLING_STEP_M:g} m between samples")
    height = _numeric(df, "height_m", src, "CW height above rail [m], empty for a drop-out", allow_missing=True)
    if not np.isfinite(height).any():
        raise InputError(f"{src}: column 'height_m' holds no value (all drop-outs); expected CW heights "
                         "above rail [m]")
    _check_heights(height, "height_m", src)
    out = pd.DataFrame({"chainage_m": chainage, "height_m": height})
    for column, expected in (("speed_kmh", "train speed [km/h]"), ("force_n", "static force of the pantograph [N]"),
                             ("stagger_m", "lateral position of the contact point [m]"),
                             ("cw_residual_thickness_m", "residual thickness of the contact wire [m]"),
                             ("contact_force_n", "measured contact force [N]")):
        out[column] = (_numeric(df, column, src, expected, allow_missing=True) if column in df.columns
                       else np.full(n, np.nan))
    for column, low, high, unit, what in (
            ("stagger_m", -STAGGER_LIMIT_M, STAGGER_LIMIT_M, "m",
             f"the lateral position of the contact point in metres, within ±{STAGGER_LIMIT_M:g} m (millimetres?)"),
            ("cw_residual_thickness_m", 0.0, THICKNESS_LIMIT_M, "m",
             f"the wire's residual thickness in metres, in (0, {THICKNESS_LIMIT_M:g}] m (millimetres?)"),
            ("contact_force_n", *CONTACT_FORCE_RANGE_N, "N",
             f"a contact force in newtons within [{CONTACT_FORCE_RANGE_N[0]:g}, {CONTACT_FORCE_RANGE_N[1]:g}] N")):
        values = out[column].to_numpy()
        bad = np.flatnonzero(np.isfinite(values) & ((values < low) | (values > high)
                                                    | ((values <= low) & (column == "cw_residual_thickness_m"))))
        if bad.size:
            i = int(bad[0])
            raise InputError(f"{src}: {row_label(i, src)}, column '{column}': {values[i]:g} {unit}; expected {what}")
    out["run_id"] = run_id.to_numpy(dtype=object)
    out["run_id"] = out["run_id"].astype("str")
    out["direction"] = direction
    out.attrs["source"] = src
    out.attrs["ignored_columns"] = _ignored(df, RECORDING_REQUIRED + RECORDING_OPTIONAL)
    return out


def read_recordings(paths) -> pd.DataFrame:
    """Read and check one or several recording files into one table of runs.

    Parameters
    ----------
    paths : str, pathlib.Path or list of them
        Each file holds one run or several (``run_id``); see the module docs.

    Returns
    -------
    pandas.DataFrame
        The files' validated rows one after the other (:data:`RECORDING_SCHEMA`), with
        ``attrs["runs"]`` = {run id: source file}.

    Raises
    ------
    InputError
        A file's own problem (see :func:`read_recording`), or the same run id in two files.
    """
    paths = [paths] if isinstance(paths, (str, Path)) else list(paths)
    if not paths:
        raise InputError("recording: no file given; expected one recording file or a list of them")
    parts, owner, ignored = [], {}, []
    for path in paths:
        part = read_recording(path)
        for run in part["run_id"].unique():
            if run in owner:
                raise InputError(f"{path}: run {run!r} is also in {owner[run]}; expected each run id once across "
                                 "the recording files (name the runs in a run_id column, or give the files "
                                 "different names)")
            owner[str(run)] = str(path)
        ignored += [c for c in part.attrs.get("ignored_columns", []) if c not in ignored]
        parts.append(part)
    out = pd.concat(parts, ignore_index=True) if len(parts) > 1 else parts[0]
    out.attrs["source"] = ", ".join(str(p) for p in paths)
    out.attrs["runs"] = owner
    out.attrs["ignored_columns"] = ignored
    return out


def runs_table(recording: pd.DataFrame) -> pd.DataFrame:
    """One row per run of a validated recording: ``run_id``, ``direction``, ``n_samples``,
    ``start_chainage_m`` and ``end_chainage_m`` (lowest and highest), ``median_speed_kmh`` (NaN
    without speeds), ``has_stagger``; runs in order of appearance."""
    rows = []
    for run, part in recording.groupby("run_id", sort=False):
        x = part["chainage_m"].to_numpy(dtype=float)
        rows.append({"run_id": str(run), "direction": int(part["direction"].iloc[0]), "n_samples": len(part),
                     "start_chainage_m": float(x.min()), "end_chainage_m": float(x.max()),
                     "median_speed_kmh": float(part["speed_kmh"].median()) if part["speed_kmh"].notna().any()
                     else float("nan"),
                     "has_stagger": bool(part["stagger_m"].notna().any())})
    return pd.DataFrame(rows, columns=["run_id", "direction", "n_samples", "start_chainage_m", "end_chainage_m",
                                       "median_speed_kmh", "has_stagger"])


def run_samples(recording: pd.DataFrame, run_id: str) -> pd.DataFrame:
    """The samples of one run sorted by increasing chainage (whatever its direction), RangeIndex."""
    part = recording[recording["run_id"] == run_id]
    if part.empty:
        raise KeyError(f"run {run_id!r} not in the recording")
    return part.sort_values("chainage_m", kind="stable").reset_index(drop=True)


def validate_masts(df: pd.DataFrame, source: str | None = None) -> pd.DataFrame:
    """Check a masts table and return it with canonical columns and dtypes.

    Idempotent: validated masts pass again unchanged. Rows are kept in file order, so that the
    position of a mast (+1) is its row number in the user's file.

    Parameters
    ----------
    df : pandas.DataFrame
        Raw table (e.g. from :func:`read_data_file`).
    source : str, optional
        Name used in messages; default ``df.attrs["source"]`` or ``"masts"``.

    Returns
    -------
    pandas.DataFrame
        Columns of :data:`MASTS_SCHEMA`, RangeIndex.

    Raises
    ------
    InputError
        Naming the source, the row and/or the column, and what was expected.
    """
    src = _source(df, source, "masts")
    _check_table(df, src, MASTS_REQUIRED, MASTS_OPTIONAL, "masts, one row per mast")
    mast_id = _text(df, "mast_id", src, "a unique mast id", required=True)
    dup = mast_id.duplicated(keep=False).to_numpy()
    if dup.any():
        first = mast_id.iloc[int(np.flatnonzero(dup)[0])]
        rows = np.flatnonzero((mast_id == first).to_numpy())
        raise InputError(f"{src}: column 'mast_id': id {first!r} appears {rows.size} times, at "
                         f"{', '.join(row_label(int(r), src) for r in rows)}; expected unique mast ids")
    section = _text(df, "section_id", src, "the id of the mast's tensioning section", required=True)
    chainage = _numeric(df, "chainage_m", src, "chainage of the mast [m]", allow_missing=False)

    # Sections: contiguous rows, increasing chainage within, in order along the line, >= 2 masts.
    blocks = _consecutive_blocks(section, src, "section_id", "section",
                                 "expected the masts of a section on consecutive rows")
    previous: tuple[str, int] | None = None
    for name, a, b in blocks:
        if b - a < 2:
            raise InputError(f"{src}: {row_label(int(a), src)}, column 'section_id': section {name!r} has only "
                             "1 mast; expected at least 2 masts per section (one span)")
        step = np.diff(chainage[a:b])
        bad = np.flatnonzero(step <= 0)
        if bad.size:
            i = int(a + bad[0] + 1)
            raise InputError(
                f"{src}: {row_label(i, src)}, column 'chainage_m': mast {mast_id.iloc[i]!r} at "
                f"{chainage[i]:.6g} m is not after the previous mast {mast_id.iloc[i - 1]!r} at "
                f"{chainage[i - 1]:.6g} m of section {name!r}; expected increasing chainage within a section")
        if previous is not None and chainage[a] < chainage[previous[1]]:
            raise InputError(
                f"{src}: {row_label(int(a), src)}, column 'chainage_m': section {name!r} starts at "
                f"{chainage[a]:.6g} m, before section {previous[0]!r} ({chainage[previous[1]]:.6g} m); "
                "expected sections in order along the line")
        previous = (name, int(a))

    n = len(df)
    out = pd.DataFrame({"mast_id": mast_id, "chainage_m": chainage, "section_id": section})
    out["span_type"] = (_text(df, "span_type", src, "a span type name", required=False)
                        if "span_type" in df.columns else pd.Series([None] * n, dtype="str"))
    if "cw_height_m" in df.columns:
        cw = _numeric(df, "cw_height_m", src, "design CW height at the steady arm [m]", allow_missing=True)
        _check_heights(cw, "cw_height_m", src)
        out["cw_height_m"] = cw
    else:
        out["cw_height_m"] = np.full(n, np.nan)
    out.attrs["source"] = src
    out.attrs["ignored_columns"] = _ignored(df, MASTS_REQUIRED + MASTS_OPTIONAL)
    return out


# --------------------------------------------------------------------------------------------
# ingest outputs
# --------------------------------------------------------------------------------------------

def write_recording(df: pd.DataFrame, path: str | Path, *, config_hash: str) -> None:
    """Write a validated recording to ``path`` (``results/ingest/recording.parquet``)."""
    write_table(validate_recording(df), path, RECORDING_SCHEMA, config_hash=config_hash, kind="recording")


def write_masts(df: pd.DataFrame | None, path: str | Path, *, config_hash: str) -> None:
    """Write validated masts to ``path`` (``results/ingest/masts.parquet``); ``None``: no mast
    table was given (an empty table: the registration finds the masts from the trace)."""
    if df is None:
        df = pd.DataFrame({f.name: pd.Series(dtype="str" if f.type == pa.string() else "float64")
                           for f in MASTS_SCHEMA})
    else:
        df = validate_masts(df)
    write_table(df, path, MASTS_SCHEMA, config_hash=config_hash, kind="masts")
