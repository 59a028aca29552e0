"""Writing a model as TOML text in the model-file schema (the inverse of
:func:`ufmt.model.load.load_model_text`)."""

from __future__ import annotations

import datetime
import numbers
import re
from collections.abc import Mapping
from typing import Any

import numpy as np

from ufmt.kinds import hinge_kind_of, kind_of
from ufmt.model.rules import HINGE_FIELDS
from ufmt.model.schema import Body, DesignParameter, Hinge, Model, UncertainInput


def model_to_toml(model: Model) -> str:
    """TOML text of ``model`` in the model-file schema; ``load_model_text`` of it gives it back.

    Numbers are written at full precision (``repr``), infinite stiffness as ``inf``; beams are
    written with their explicit section (area, second moments, polar moment, torsion constant);
    the ``[machine]`` table as it was read (its keys in their order, their TOML types).
    A file's ``description`` is not kept (``Model`` has no field for it); the ``[design]``
    declarations are (the calibration writes the identified model through this function), and
    the ``[[uncertain]]`` inputs with their bands absolute.
    """
    lines = [f"name = {toml_value(model.name)}"]
    for body in model.bodies:
        lines += ["", "[[body]]", *_body_lines(body)]
    for hinge in model.hinges:
        lines += ["", "[[hinge]]", *_hinge_lines(hinge)]
    if model.machine is not None:
        lines += _table_lines(("machine",), model.machine.table)
    for parameter in model.design.values():
        lines += design_lines(parameter)
    for entry in model.uncertain:
        lines += ["", "[[uncertain]]", *_uncertain_lines(entry)]
    return "\n".join(lines) + "\n"


def design_lines(parameter: DesignParameter) -> list[str]:
    """The ``[design.<name>]`` table of one design parameter (TOML lines, blank line first)."""
    pairs = [
        ("hinge", parameter.hinge),
        ("field", parameter.field),
        ("components", list(parameter.components)),
        ("description", parameter.description or None),
    ]
    return ["", f"[design.{_toml_key(parameter.name)}]", *_pairs(pairs)]


def _uncertain_lines(entry: UncertainInput) -> list[str]:
    """One ``[[uncertain]]`` table (its band absolute, as the loader keeps it)."""
    pairs = [
        ("name", entry.name),
        ("band", [entry.low, entry.high]),
        ("distribution", "loguniform" if entry.log else "uniform"),
        ("source", entry.source),
    ]
    return _pairs(pairs)


_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")
_ESCAPES = {
    '"': '\\"',
    "\\": "\\\\",
    "\b": "\\b",
    "\t": "\\t",
    "\n": "\\n",
    "\f": "\\f",
    "\r": "\\r",
}


def _toml_string(text: str) -> str:
    out = []
    for ch in text:
        if ch in _ESCAPES:
            out.append(_ESCAPES[ch])
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04x}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def _toml_key(key) -> str:
    key = str(key)
    return key if _BARE_KEY.match(key) else _toml_string(key)


def toml_value(value) -> str:
    """TOML text of one value (string, number, boolean, date, array, inline table)."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    elif isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        return repr(float(value))  # full precision; 'inf', '-inf', 'nan' are TOML floats
    if isinstance(value, datetime.date | datetime.time):
        return value.isoformat()
    if isinstance(value, Mapping):
        return "{" + ", ".join(f"{_toml_key(k)} = {toml_value(v)}" for k, v in value.items()) + "}"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


def _table_lines(path: tuple[str, ...], table: Mapping) -> list[str]:
    """A [table] with its plain keys first and its sub-tables after (TOML requires this order)."""
    lines = ["", "[" + ".".join(_toml_key(p) for p in path) + "]"]
    subtables = {k: v for k, v in table.items() if isinstance(v, Mapping)}
    lines += [f"{_toml_key(k)} = {toml_value(v)}" for k, v in table.items() if k not in subtables]
    for key, sub in subtables.items():
        lines += _table_lines((*path, key), sub)
    return lines


def _pairs(pairs: list[tuple[str, Any]]) -> list[str]:
    return [f"{k} = {toml_value(v)}" for k, v in pairs if v is not None]


def _body_lines(body: Body) -> list[str]:
    pairs: list[tuple[str, Any]] = [("name", body.name), ("kind", body.kind)]
    pairs.append(("number", body.number))
    pairs += kind_of(body).written(body)
    return _pairs(pairs)


def _hinge_lines(hinge: Hinge) -> list[str]:
    kind = [] if hinge.kind == "spring" else [("kind", hinge.kind)]  # the default stays implicit
    pairs = [(k, getattr(hinge, k)) for k in HINGE_FIELDS]
    return _pairs(pairs[:1] + kind + pairs[1:] + hinge_kind_of(hinge).written(hinge))
