"""One checker for the tables of every input file: each mistake is one line that names the
file, the table and the field, in one wording.

A :class:`Where` says where a value sits (the file and the table path, e.g. ``ufmt.toml:
machine`` or ``study.toml: axis[2]``) and which exception a problem raises (the caller
chooses: :class:`~ufmt.errors.ModelError` for model files, :class:`~ufmt.errors.StudyError`
for studies and calibration files). Its methods check a value and return it converted, or
raise::

    where = Where("ufmt.toml", "machine", error=ModelError)
    where.keys(table, valid=FIELDS, required=REQUIRED)   # unknown keys, then missing ones
    radius = where.number("tool_radius", table["tool_radius"], sign="positive", unit="[m]")
    where.within("force_scale", scale, 0.3, 3.0)
    size = where.numbers("workpiece_size", table["workpiece_size"], 2, sign="positive")
    sense = where.choice("rotation", table["rotation"], ("cw", "ccw"), "rotation")
    where.fail("tool_radius", "must exceed ...")         # a check of the caller's own
    n = where.integer("n", table.get("n", 9), 1, 100_000)  # an integer in [1, 100000]
    axis = Where("study.toml", error=StudyError).sub("axis[2]")   # study.toml: axis[2]: ...

Messages are ``<file>: <table>: field '<field>': <problem>`` (``<file>: field ...`` without a
table; ``<file>: <table>: <problem>`` for a problem of the table itself), on one line. The
problems, one wording each:

=================  ==========================================================================
unknown key        ``unknown field 'stifness' (did you mean 'stiffness'?)``, or without a
                   close name ``(valid fields: name, kind, number)``
missing key        ``missing (required)`` (or another reason in the parentheses)
wrong type         ``expected a number, got string 'heavy' (allowed: > 0 [kg])``
NaN                ``nan is not a number (allowed: finite [m])``
sign               ``-5 is not positive (allowed: > 0 [kg])``, ``-5 is negative (allowed: ...)``
infinite           ``inf is not finite (allowed: finite [m])``
range              ``0.5 is outside the allowed range [0.0001, 0.05] [m]``
minimum            ``0 is too small (allowed: >= 1)``, ``1 is too small (allowed: > 1)``
reversed bounds    ``reversed bounds [400, 200] (allowed: lower < upper)``
empty range        ``empty range [300, 300] (allowed: lower < upper)``
duplicate          ``'rpm' appears more than once``
choice             ``unknown kind 'rigd' (did you mean 'rigid'?)``, or ``(valid kinds: ...)``
length             ``expected 3 numbers [m], got an array of 2``
empty array        ``empty (at least one hinge name is required)``
empty string       ``empty (allowed: a non-empty string)``
=================  ==========================================================================

Every input file reads its tables with it: model files (:mod:`ufmt.model.load` and its
helpers, ``[machine]`` in :mod:`ufmt.model.machine`), study files (:mod:`ufmt.studies.fields`)
and calibration files (:mod:`ufmt.calibration.settings`, the reference tags in
:mod:`ufmt.calibration.frequencies`). A check of a caller's own goes through :meth:`Where.fail`
so that the prefix stays the same. A study kind reads its own fields with the file's
:class:`Where` and the readers of :mod:`ufmt.studies.fields`::

    def parse(where: Where, data: Mapping, parameters: Parameters) -> dict:
        bounds = read_bounds(where, data, parameters, required=True)   # [[bound]] tables
        samples = where.integer("samples", data.get("samples", 16), 2, MAX_POINTS)
        method = where.choice("method", data.get("method", "morris"), METHODS, "method")
        if method == "sobol" and samples & (samples - 1):
            where.fail("samples", f"{samples} is not a power of two (Sobol sampling)")
        return {"bounds": bounds, "options": {"samples": samples, "method": method}}

Base layer: imports only :mod:`ufmt.errors`.
"""

from __future__ import annotations

import datetime
import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import NoReturn

import numpy as np

from ufmt.errors import closest_name
from ufmt.limits import shown

#: What "allowed" says for each sign rule of :meth:`Where.number` (the unit is appended).
SIGN_ALLOWED = {None: "finite", "positive": "> 0", "nonnegative": ">= 0, finite"}


@dataclass(frozen=True)
class Where:
    """The file and table a value sits in, and the exception its problems raise.

    source: the file as the user named it; table: the table path inside it ("" for the top
    of a file without table labels); error: the exception class every message raises.
    """

    source: str
    table: str = ""
    error: type[Exception] = field(kw_only=True)

    def sub(self, table: str) -> Where:
        """The table ``table`` inside this one (joined with ".")."""
        return Where(
            self.source, f"{self.table}.{table}" if self.table else table, error=self.error
        )

    def message(self, problem: str, field: str | None = None) -> str:
        """The one-line message of ``problem`` (about ``field``, or the table itself)."""
        parts = [self.source, *([self.table] if self.table else [])]
        parts += [f"field '{field}'"] if field is not None else []
        return one_line(": ".join([*parts, problem]))

    def fail(self, field: str, problem: str) -> NoReturn:
        """Raise the problem of ``field``."""
        raise self.error(self.message(problem, field))

    def fail_table(self, problem: str) -> NoReturn:
        """Raise a problem of the table itself (an unknown key, a missing link)."""
        raise self.error(self.message(problem))

    # -- keys ---------------------------------------------------------------------------------

    def keys(self, table: Mapping, valid, required=(), context: str = "") -> None:
        """Reject the first key not in ``valid`` (with the closest valid one), then the first
        ``required`` key that is missing; ``context`` qualifies the lists, e.g. `` for kind
        'rigid'``."""
        for key in table:
            if key not in valid:
                hint = did_you_mean(key, valid) or f"valid fields{context}: {', '.join(valid)}"
                self.fail_table(f"unknown field {str(key)!r} ({hint})")
        self.required(table, required, context)

    def required(self, table: Mapping, required, context: str = "") -> None:
        """Reject the first key of ``required`` that ``table`` lacks."""
        for key in required:
            if key not in table:
                self.missing(key, f"required{context}")

    def missing(self, field: str, why: str = "required") -> NoReturn:
        """Raise ``field: missing (why)``."""
        self.fail(field, f"missing ({why})")

    # -- scalars ------------------------------------------------------------------------------

    def string(
        self, field: str, value, allow_empty: bool = False, max_chars: int | None = None
    ) -> str:
        """A string (non-empty unless ``allow_empty``; at most ``max_chars`` characters)."""
        if not isinstance(value, str):
            self.fail(field, f"expected a string, got {type_name(value)}")
        if not allow_empty and not value.strip():
            self.fail(field, "empty (allowed: a non-empty string)")
        if max_chars is not None and len(value) > max_chars:
            self.fail(field, f"{len(value):,} characters (allowed: at most {max_chars:,})")
        return value

    def boolean(self, field: str, value) -> bool:
        """A boolean (true or false)."""
        if not isinstance(value, bool | np.bool_):
            self.fail(field, f"expected true or false, got {type_name(value)}")
        return bool(value)

    def integer(self, field: str, value, low: int | None = None, high: int | None = None) -> int:
        """An integer (not a boolean, not a float), from ``low`` to ``high`` where given."""
        if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Integral):
            allowed = (
                ""
                if low is None
                else f" (allowed: {f'[{low}, {high}]' if high is not None else f'>= {low}'})"
            )
            self.fail(field, f"expected an integer, got {type_name(value)}{allowed}")
        n = int(value)
        if low is not None and high is not None:
            self.within(field, n, low, high)
        elif low is not None:
            self.minimum(field, n, low)
        return n

    def number(
        self,
        field: str,
        value,
        *,
        sign: str | None = None,
        infinite: bool = False,
        unit: str = "",
        allowed: str | None = None,
    ) -> float:
        """A real number as float: not NaN, ``sign`` "positive" (> 0) or "nonnegative"
        (>= 0) if given, finite unless ``infinite``. ``unit`` (e.g. "[kg]") and ``allowed``
        (default from :data:`SIGN_ALLOWED`) say what is allowed in the messages."""
        if allowed is None:
            allowed = SIGN_ALLOWED[sign] + (f" {unit}" if unit else "")
        if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
            self.fail(field, f"expected a number, got {type_name(value)} (allowed: {allowed})")
        x = float(value)
        if math.isnan(x):
            self.fail(field, f"nan is not a number (allowed: {allowed})")
        if sign == "positive" and x <= 0:
            self.fail(field, f"{short_number(x)} is not positive (allowed: {allowed})")
        if sign == "nonnegative" and x < 0:
            self.fail(field, f"{short_number(x)} is negative (allowed: {allowed})")
        if math.isinf(x) and not infinite:
            self.fail(field, f"{short_number(x)} is not finite (allowed: {allowed})")
        return x

    def within(self, field: str, x: float, low: float, high: float, unit: str = "") -> float:
        """``x`` if ``low <= x <= high``, else :meth:`outside` (``unit`` e.g. "[m]")."""
        if not low <= x <= high:
            self.outside(field, x, low, high, unit)
        return x

    def outside(self, field: str, x: float, low: float, high: float, unit: str = "") -> NoReturn:
        """Raise ``x is outside the allowed range [low, high] unit``."""
        band = f"[{low:g}, {high:g}]" + (f" {unit}" if unit else "")
        self.fail(field, f"{short_number(x)} is outside the allowed range {band}")

    def minimum(
        self, field: str, x: float, low: float, *, strict: bool = False, unit: str = ""
    ) -> float:
        """``x`` if ``x >= low`` (``x > low`` if ``strict``), else ``x is too small``."""
        if x < low or (strict and x == low):
            allowed = f"{'>' if strict else '>='} {low:g}" + (f" {unit}" if unit else "")
            self.fail(field, f"{short_number(x)} is too small (allowed: {allowed})")
        return x

    def interval(self, field: str, value, *, allow_equal: bool = False, **rules):
        """``[lower, upper]``: two numbers (each checked by :meth:`number` with ``rules``) with
        lower < upper (lower <= upper if ``allow_equal``); returns (lower, upper)."""
        low, high = self.numbers(field, value, 2, **rules)
        if low > high:
            self.fail(
                field, f"reversed bounds {short_vector([low, high])} (allowed: lower < upper)"
            )
        if low == high and not allow_equal:
            self.fail(field, f"empty range {short_vector([low, high])} (allowed: lower < upper)")
        return low, high

    def unique(self, field: str, values) -> list:
        """``values`` as a list if none appears twice, else ``'x' appears more than once``."""
        seen = []
        for value in values:
            if value in seen:
                self.fail(field, f"{value!r} appears more than once")
            seen.append(value)
        return seen

    def choice(self, field: str, value, choices, noun: str, plural: str | None = None):
        """``value`` if it is one of ``choices``, else ``unknown <noun> 'x'`` with the closest
        choice or the list of ``plural`` (default noun + "s")."""
        if value not in choices:
            names = ", ".join(str(c) for c in choices)
            hint = did_you_mean(value, choices) or f"valid {plural or noun + 's'}: {names}"
            self.fail(field, f"unknown {noun} {shown(value)} ({hint})")
        return value

    # -- arrays and tables --------------------------------------------------------------------

    def array(self, field: str, value, n: int, what: str) -> list:
        """A list (or tuple, numpy array) of ``n`` items; ``what`` describes it in the
        message, e.g. "3 numbers [m]"."""
        if isinstance(value, np.ndarray):
            value = value.tolist()
        if not isinstance(value, list | tuple):
            self.fail(field, f"expected {what}, got {type_name(value)}")
        if len(value) != n:
            self.fail(field, f"expected {what}, got an array of {len(value)}")
        return list(value)

    def items(self, field: str, value, item: str, required: bool = False) -> list:
        """An array of any length (at least one element if ``required``); ``item`` names one
        element in the messages, e.g. "hinge name"."""
        if isinstance(value, np.ndarray):
            value = value.tolist()
        if not isinstance(value, list | tuple):
            self.fail(field, f"expected an array of {item}s, got {type_name(value)}")
        if required and not value:
            self.fail(field, f"empty (at least one {item} is required)")
        return list(value)

    def numbers(self, field: str, value, n: int, **rules) -> list[float]:
        """``n`` numbers (a pair, a vector), each checked by :meth:`number` with ``rules``
        as ``field[i]``."""
        what = f"{n} numbers {rules.get('unit', '')}".rstrip()
        items = self.array(field, value, n, what)
        return [self.number(f"{field}[{i}]", v, **rules) for i, v in enumerate(items)]

    def mapping(self, field: str, value, header: str) -> Mapping:
        """A table (``header`` e.g. "[machine]" names it in the message)."""
        if not isinstance(value, Mapping):
            self.fail(field, f"expected a table {header}, got {type_name(value)}")
        return value

    def tables(self, field: str, value, required: bool = False) -> list[Mapping]:
        """An array of tables ``[[field]]`` (at least one if ``required``)."""
        header = f"[[{field}]]"
        if isinstance(value, Mapping) or not isinstance(value, list | tuple):
            self.fail(field, f"expected an array of tables {header}, got {type_name(value)}")
        if required and not value:
            self.fail(field, f"empty (at least one {header} table is required)")
        for i, item in enumerate(value):
            if not isinstance(item, Mapping):
                self.fail(f"{field}[{i}]", f"expected a table {header}, got {type_name(item)}")
        return list(value)


# ---------------------------------------------------------------------------------------------
# message text


def one_line(text: str) -> str:
    """``text`` with every run of whitespace (newlines too) made one space."""
    return " ".join(text.split())


def did_you_mean(word, choices) -> str:
    """``did you mean 'x'?`` for the closest of ``choices`` (:func:`closest_name`), or ""."""
    close = closest_name(word, choices)
    return f"did you mean {close!r}?" if close else ""


def short_number(value: float) -> str:
    """Short text of a number that still reads back as the same value (an integer's digits)."""
    if isinstance(value, numbers.Integral) and not isinstance(value, bool | np.bool_):
        return str(int(value))
    value = float(value)
    short = f"{value:.6g}"
    return short if float(short) == value else repr(value)


def short_vector(values) -> str:
    """``[a, b, c]`` of :func:`short_number` of each value."""
    return "[" + ", ".join(short_number(v) for v in np.ravel(values)) + "]"


def type_name(value) -> str:
    """What a value is, for "expected ..., got <type_name>" (with the value when short)."""
    if value is None:
        return "an empty value"
    if isinstance(value, bool | np.bool_):
        return f"boolean {value!r}"
    if isinstance(value, str):
        return f"string {shown(value)}"
    if isinstance(value, numbers.Integral):
        return f"integer {value}"
    if isinstance(value, numbers.Real):
        return f"float {short_number(value)}"
    if isinstance(value, Mapping):
        return "a table"
    if isinstance(value, list | tuple | np.ndarray):
        return f"an array of {len(value)}"
    if isinstance(value, datetime.date | datetime.time):
        return f"datetime {value.isoformat()}"
    return type(value).__name__
