"""Parquet intermediates with an explicit Arrow schema and provenance metadata.

Every intermediate table of the pipeline is written by :func:`write_table`:

* the Arrow schema is given by the caller, never inferred from the DataFrame, so that a column
  keeps its type (and nullability) whatever the data happen to contain;
* each field carries a ``unit`` metadata entry derived from its name (units live in the column
  names, SI: ``_m`` → ``m``, ``_n`` → ``N``, ``_kmh`` → ``km/h``... see :func:`unit_of`);
* the file carries the keys ``catenary.schema_version``, ``catenary.package_version``,
  ``catenary.config_hash`` and ``catenary.kind``;
* the bytes are a pure function of the data, the schema and the metadata (no timestamp, pinned
  compression, statistics and page settings), so that an unchanged input gives an unchanged
  file and Snakemake or a checksum sees no spurious change.

:func:`read_table` reads any Parquet file back and turns a missing, empty, truncated or
non-Parquet file into an :class:`~catenary.plumbing.errors.InputError` naming the file.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from catenary import __version__
from .errors import InputError

SCHEMA_VERSION = "1"
"""Version of the layout of the intermediates; bump it when a schema changes."""

METADATA_PREFIX = "catenary."

# Longest suffix first: "_n_m" (N/m) must win over "_m".
_UNIT_SUFFIXES: tuple[tuple[str, str], ...] = (
    ("_n_s_m", "N·s/m"),
    ("_n_m2", "N·m²"),
    ("_kg_m", "kg/m"),
    ("_m_s2", "m/s²"),
    ("_n_m", "N/m"),
    ("_m_s", "m/s"),
    ("_kmh", "km/h"),
    ("_hz", "Hz"),
    ("_mm", "mm"),
    ("_kg", "kg"),
    ("_m", "m"),
    ("_n", "N"),
    ("_s", "s"),
)

_COMPRESSION = "zstd"
_COMPRESSION_LEVEL = 3


def unit_of(column: str) -> str:
    """Unit of a column from the suffix of its name, ``""`` for a dimensionless or text column.

    Examples
    --------
    >>> unit_of("chainage_m"), unit_of("force_n"), unit_of("speed_kmh"), unit_of("span_id")
    ('m', 'N', 'km/h', '')
    """
    return unit_suffix(column)[1]


def unit_suffix(column: str) -> tuple[str, str]:
    """The unit suffix of a column's name and its unit (:func:`unit_of`); ``("", "")`` without one.

    Examples
    --------
    >>> unit_suffix("stiffness_n_m"), unit_suffix("span_id")
    (('_n_m', 'N/m'), ('', ''))
    """
    name = column.lower()
    for suffix, unit in _UNIT_SUFFIXES:
        if name.endswith(suffix) and len(name) > len(suffix):
            return suffix, unit
    return "", ""


def with_units(schema: pa.Schema) -> pa.Schema:
    """``schema`` with a ``unit`` metadata entry on every field (kept if already present)."""
    fields = []
    for field in schema:
        meta = dict(field.metadata or {})
        meta.setdefault(b"unit", unit_of(field.name).encode())
        fields.append(field.with_metadata(meta))
    return pa.schema(fields, metadata=schema.metadata)


def _canonical(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {str(k): _canonical(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_canonical(v) for v in value]
    if isinstance(value, np.ndarray):
        return [_canonical(v) for v in value.tolist()]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    return value


def config_hash(mapping: Mapping[str, Any]) -> str:
    """SHA-256 (hex) of the canonical JSON of ``mapping``.

    Keys are sorted, separators compact, NumPy scalars and arrays turned into plain numbers and
    lists, paths into strings: two mappings with the same content give the same hash whatever
    their key order.
    """
    text = json.dumps(_canonical(mapping), sort_keys=True, separators=(",", ":"), ensure_ascii=False,
                      default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


#: Workflow keys that say where the outputs go or how the jobs are cut, not how the outputs are made.
NOT_HASHED = ("results", "sections_per_correction_job")


def settings_hash(workflow_config: Mapping[str, Any]) -> str:
    """:func:`config_hash` of a workflow configuration without the keys of :data:`NOT_HASHED`.

    The folder says where the outputs go and the sections per correction job how the work is
    cut, not how the outputs were made: the same settings run into two folders (a local run and
    a cluster run, say), in jobs cut either way, write byte-identical tables.
    """
    return config_hash({key: value for key, value in workflow_config.items() if key not in NOT_HASHED})


def file_metadata(*, config_hash: str, kind: str, extra: Mapping[str, str] | None = None) -> dict[str, str]:
    """The file-level metadata written by :func:`write_table` (``extra`` keys get the same prefix)."""
    return {
        f"{METADATA_PREFIX}schema_version": SCHEMA_VERSION,
        f"{METADATA_PREFIX}package_version": __version__,
        f"{METADATA_PREFIX}config_hash": str(config_hash),
        f"{METADATA_PREFIX}kind": str(kind),
        **{f"{METADATA_PREFIX}{k}": str(v) for k, v in (extra or {}).items()},
    }


def to_arrow(df: pd.DataFrame, schema: pa.Schema) -> pa.Table:
    """Convert ``df`` to an Arrow table of exactly ``schema`` (columns in schema order).

    Raises
    ------
    ValueError
        If a schema column is missing from ``df``, ``df`` has a column the schema does not
        know, a non-nullable column holds a missing value, or a value does not fit its type.
    """
    missing = [name for name in schema.names if name not in df.columns]
    extra = [str(c) for c in df.columns if c not in schema.names]
    if missing or extra:
        raise ValueError(f"DataFrame does not match the schema: missing columns {missing}, "
                         f"columns not in the schema {extra}")
    arrays = []
    for field in schema:
        column = df[field.name]
        if not field.nullable and column.isna().any():
            row = int(np.flatnonzero(column.isna().to_numpy())[0]) + 1
            raise ValueError(f"column {field.name!r}: missing value at row {row}, the schema forbids it")
        try:
            if pa.types.is_floating(field.type):
                values = pd.to_numeric(column, errors="raise").to_numpy(dtype=float, na_value=np.nan)
            else:
                values = column.to_numpy(dtype=object)
            arrays.append(pa.array(values, type=field.type, from_pandas=True))
        except (pa.ArrowException, TypeError, ValueError) as exc:
            raise ValueError(f"column {field.name!r}: cannot store as {field.type} ({exc})") from None
    return pa.Table.from_arrays(arrays, schema=schema)


def write_table(df: pd.DataFrame, path: str | Path, schema: pa.Schema, *, config_hash: str, kind: str,
                extra_metadata: Mapping[str, str] | None = None, row_group_rows: int = 1 << 20) -> None:
    """Write ``df`` to the Parquet file ``path`` with the explicit Arrow ``schema``.

    Parameters
    ----------
    df : pandas.DataFrame
        Exactly the columns of ``schema`` (any order); the index is not written.
    path : str or pathlib.Path
        Output file; parent folders are created. Written through a temporary file then renamed,
        so a reader never sees a half-written file.
    schema : pyarrow.Schema
        Column names, types and nullability. A ``unit`` field metadata entry is added from each
        column name (:func:`unit_of`) unless the field already has one.
    config_hash : str
        Hash of the configuration that produced the table (:func:`config_hash`).
    kind : str
        What the table is (``"recording"``, ``"masts"``, ``"spans"``...).
    extra_metadata : mapping of str to str, optional
        Further file-level keys (e.g. the identification's ``status``).
    row_group_rows : int
        Rows per row group: smaller groups let a reader that filters (:func:`read_table`'s
        ``filters``) skip what it does not need, by the groups' statistics.

    Notes
    -----
    The bytes depend only on the inputs: no timestamp is written, the compression (zstd level
    3), statistics, dictionary encoding and page format are pinned, and the pandas metadata
    (which records library versions) is not written — the Arrow schema is authoritative.
    """
    path = Path(path)
    schema = with_units(schema).with_metadata(file_metadata(config_hash=config_hash, kind=kind,
                                                            extra=extra_metadata))
    table = to_arrow(df, schema)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    try:
        pq.write_table(
            table, tmp,
            compression=_COMPRESSION, compression_level=_COMPRESSION_LEVEL,
            write_statistics=True, use_dictionary=False, version="2.6", data_page_version="1.0",
            store_schema=True, row_group_size=row_group_rows,
        )
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def _open(path: str | Path, categorical: list[str] | None = None) -> pq.ParquetFile:
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: file not found; expected a Parquet file")
    if path.stat().st_size == 0:
        raise InputError(f"{path}: empty file; expected a Parquet file with a header row of columns")
    try:
        return pq.ParquetFile(path, read_dictionary=categorical)
    except (pa.ArrowException, OSError, ValueError) as exc:
        raise InputError(f"{path}: not a readable Parquet file ({exc}); expected a Parquet file "
                         "(corrupt, truncated, or another format with a .parquet name?)") from None


def read_table(path: str | Path, columns: list[str] | None = None, filters: list[tuple] | None = None,
               categorical: list[str] | None = None) -> pd.DataFrame:
    """Read the Parquet file ``path`` into a DataFrame (default Arrow → pandas conversion).

    Parameters
    ----------
    columns : list of str, optional
        Only these columns (default all).
    filters : list of tuple, optional
        Only the rows that pass them, in pyarrow's form (``[("run_id", "=", "r1")]``,
        ``[("span_id", "in", ids)]``): the row groups whose statistics exclude them are not read,
        so a job that needs a part of a long file holds that part, not the file.
    categorical : list of str, optional
        Text columns read as pandas categoricals (each distinct value once, the rows as codes):
        a column of a few thousand span ids over millions of samples is read ≈ 4× faster and
        factorised at no cost.

    Raises
    ------
    InputError
        If the file is missing, empty, truncated or not Parquet; the message names the file.
    """
    pf = _open(path, categorical)
    try:
        if filters is None:
            return pf.read(columns=columns).to_pandas()
        return pq.read_table(path, columns=columns, filters=filters, schema=pf.schema_arrow,
                             read_dictionary=categorical).to_pandas()
    except (pa.ArrowException, OSError, ValueError) as exc:
        raise InputError(f"{path}: corrupt Parquet data ({exc}); expected a readable Parquet file") from None


def distinct_values(path: str | Path, column: str) -> list:
    """The values of ``column`` in the Parquet file ``path``, in order of first appearance (that
    column alone read)."""
    pf = _open(path)
    try:
        values = pf.read(columns=[column]).column(column)
        first = {v: pc.index(values, v).as_py() for v in pc.unique(values).to_pylist()}
    except (pa.ArrowException, OSError, ValueError) as exc:
        raise InputError(f"{path}: corrupt Parquet data ({exc}); expected a readable Parquet file") from None
    return sorted(first, key=first.get)


def read_metadata(path: str | Path) -> dict[str, str]:
    """File-level key/value metadata of the Parquet file ``path`` (decoded to text).

    Raises
    ------
    InputError
        As :func:`read_table`.
    """
    meta = _open(path).schema_arrow.metadata or {}
    return {k.decode(errors="replace"): v.decode(errors="replace") for k, v in meta.items()}
