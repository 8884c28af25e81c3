"""The configuration contract: the JSON schemas shipped with the package.

The files under ``catenary/schemas/`` (``config``, ``catenary``, ``campaign``) are the one
statement of what a valid setting is: the workflow validates its config files with them
(``workflow/schemas/`` links to them) and the package validates every settings block it reads
with the same files, through :func:`check`. Python keeps only the checks a schema cannot
express (a list that must increase, a dropper inside its span, a name known to the physics).

Errors are :class:`~catenary.plumbing.errors.ConfigError` in one or two lines naming the key (dotted
path) and what was expected, never a dump of the schema.
"""

from __future__ import annotations

import numbers
from collections.abc import Mapping
from functools import lru_cache
from importlib.resources import files
from typing import Any

import numpy as np
import yaml
from jsonschema import Draft202012Validator, validators
from jsonschema.exceptions import ValidationError

from .errors import ConfigError

__all__ = ["SCHEMAS", "check", "load_schema", "merged_mapping", "schema_path"]

#: Names of the shipped schemas (``catenary/schemas/<name>.schema.yaml``).
SCHEMAS = ("config", "catenary", "campaign")


def _is_array(checker, instance) -> bool:
    return isinstance(instance, (list, tuple))


def _is_integer(checker, instance) -> bool:
    if isinstance(instance, (bool, np.bool_)):
        return False
    if isinstance(instance, (numbers.Integral, np.integer)):
        return True
    return isinstance(instance, (float, np.floating)) and float(instance).is_integer()


def _is_number(checker, instance) -> bool:
    return isinstance(instance, (numbers.Real, np.floating, np.integer)) and not isinstance(instance, (bool, np.bool_))


# Settings objects hold tuples and NumPy scalars; YAML gives lists and Python numbers. Both are valid.
_Validator = validators.extend(
    Draft202012Validator,
    type_checker=Draft202012Validator.TYPE_CHECKER.redefine_many(
        {"array": _is_array, "integer": _is_integer, "number": _is_number}),
)


def schema_path(name: str):
    """Path (a :mod:`importlib.resources` traversable) of the shipped schema ``name``."""
    if name not in SCHEMAS:
        raise ValueError(f"schema: expected one of {SCHEMAS}, got {name!r}")
    return files("catenary") / "schemas" / f"{name}.schema.yaml"


@lru_cache(maxsize=None)
def _validator(name: str):
    schema = yaml.safe_load(schema_path(name).read_text(encoding="utf-8"))
    return _Validator(schema)


def load_schema(name: str) -> dict:
    """The shipped schema ``name`` as a mapping (do not modify it)."""
    return _validator(name).schema


def _short(value: Any, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 1] + "…"


def _expected(error: ValidationError) -> str:
    """What the schema expected, in words, for one validation error."""
    kind, arg, schema = error.validator, error.validator_value, error.schema
    if kind == "required":
        return "missing key"
    if kind == "additionalProperties":
        known = sorted(schema.get("properties", {}))
        extra = sorted(set(error.instance) - set(known)) if isinstance(error.instance, dict) else []
        return f"unknown key(s) {', '.join(map(str, extra))}" + (f"; known: {', '.join(known)}" if known else "")
    bounds = {"minimum": "≥", "exclusiveMinimum": ">", "maximum": "≤", "exclusiveMaximum": "<"}
    if kind in bounds:
        return f"expected a value {bounds[kind]} {arg}, got {_short(error.instance)}"
    if kind == "type":
        names = {"integer": "an integer", "number": "a number", "string": "a string", "array": "a list",
                 "object": "a mapping", "boolean": "true or false", "null": "null"}
        kinds = [arg] if isinstance(arg, str) else arg
        return f"expected {' or '.join(names.get(k, k) for k in kinds)}, got {_short(error.instance)}"
    if kind == "enum":
        return f"expected one of {', '.join(map(str, arg))}, got {_short(error.instance)}"
    if kind == "const":
        return f"expected {arg!r}, got {_short(error.instance)}"
    if kind in ("oneOf", "anyOf"):
        options = []
        for option in arg:
            if "const" in option:
                options.append(repr(option["const"]))
            elif "enum" in option:
                options.append(" or ".join(map(repr, option["enum"])))
            elif "type" in option:
                article = {"null": "null", "array": "a list", "integer": "an integer", "object": "a mapping"}
                options.append(article.get(option["type"], f"a {option['type']}")
                               + "".join(f" {bounds[b]} {option[b]}" for b in bounds if b in option))
            else:
                options.append("a value of another form")
        return f"expected {' or '.join(options)}, got {_short(error.instance)}"
    if kind in ("minItems", "maxItems"):
        return f"expected {'at least' if kind == 'minItems' else 'at most'} {arg} item(s), got {_short(error.instance)}"
    if kind == "pattern":
        what = schema.get("description") or f"a name matching {arg}"
        return f"expected {what}, got {_short(error.instance)}"
    return f"{error.message if len(error.message) <= 120 else error.message[:119] + '…'}"


def check(instance: Any, name: str, *path: str, where: str | None = None) -> None:
    """Validate ``instance`` against the shipped schema ``name``, or its property ``path``.

    Parameters
    ----------
    instance : Any
        A config mapping (tuples and NumPy scalars are accepted as arrays and numbers).
    name : {"config", "catenary", "campaign"}
    *path : str
        Property names from the schema's root to the block that ``instance`` is, e.g.
        ``("identification",)`` for the identification block of the workflow config.
    where : str, optional
        Dotted name of ``instance`` in messages (default: ``path`` joined, or ``name``).

    Raises
    ------
    ConfigError
        On the first error (deepest first), naming the key and what was expected.
    """
    validator = _validator(name)
    schema = validator.schema
    for key in path:
        schema = schema["properties"][key]
    errors = list(validator.evolve(schema=schema).iter_errors(instance))
    if not errors:
        return
    # The deepest error names the most precise key; among equals, the first in document order.
    error = max(errors, key=lambda e: len(e.absolute_path))
    if error.validator in ("oneOf", "anyOf") and error.context:
        deeper = [c for c in error.context if len(c.absolute_path) > len(error.absolute_path)]
        if deeper:
            error = max(deeper, key=lambda e: len(e.absolute_path))
    prefix = where or ".".join(path) or name
    parts = [prefix]
    for part in error.absolute_path:
        if isinstance(part, int):
            parts[-1] += f"[{part}]"
        else:
            parts.append(str(part))
    if error.validator == "required":      # name the first missing key itself
        parts.append(next(k for k in error.validator_value if k not in error.instance))
    key = ".".join(parts)
    raise ConfigError(f"{key}: {_expected(error)}")


def merged_mapping(base: Mapping, over: Mapping | None) -> dict:
    """``base`` with ``over`` laid on it, nested mappings merged key by key (unknown keys kept,
    so that the schema reports them): a settings block under its per-span-type overrides, or a
    block's defaults under what the config gives. It lives here, beside :func:`check`, so that
    the workflow merges and checks its blocks without importing the stages' packages."""
    out = dict(base)
    if not isinstance(over, Mapping):
        return over if over is not None else out
    for key, value in over.items():
        nested = isinstance(base.get(key), Mapping) and isinstance(value, Mapping)
        out[key] = merged_mapping(base[key], value) if nested else value
    return out
