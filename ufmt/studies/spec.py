"""Study files (TOML): the immutable :class:`Study`, the :class:`StudyKind` record of each
kind, and the checkers of their fields (:mod:`ufmt.studies.load` reads a file with them).

A study file names its kind and what to vary. Common top-level fields::

    kind = "sweep"                       # a study kind of ufmt.studies.kinds: sweep, grid,
                                         #   optimise-process, ...
    name = "sweep-stiffness"             # optional; default: the file's stem; -> results/<name>/
    description = "..."                  # optional
    function = "ufmt.evaluate:evaluate"  # optional: "module:attribute" or "file.py:attribute"
                                         #   (relative to the study file); called as
                                         #   f(design, process, model) -> dict with "pv_nm"
    model = "../my-machine.toml"         # optional model file (relative to the study file);
                                         #   default: the packaged UFMT

    [base]                               # fixed values for every point (others: calibrated
    rpm = 300.0                          #   design, reference process)

    [design.head_z_N_m]                  # optional: design parameters of this study, added
    hinge = "h31"                        #   to the model's own [design] table (same schema,
    field = "stiffness"                  #   see ufmt.model.load.parse_design)
    components = [2]

Parameters are the model's (and the study's) declared design parameters
(``head_angular_stiffness_Nm_rad`` on the packaged UFMT), ``hinge.<name>.stiffness[i]`` /
``hinge.<name>.rotational_stiffness[i]``, and ``rpm``, ``feed_mm_min``, ``depth_um``. The model
is loaded while the study is parsed, and every value the study can set (base, axis values,
bound ends; ``scale`` resolved against the calibrated value) is checked with the model
loader's rules before any point runs: a negative or absurd stiffness, a ``scale`` of a released
(0) or rigid (inf) component, or a process value <= 0 is a :class:`~ufmt.errors.StudyError`.
Values along an axis or a bound are given by exactly one of::

    values = [1e6, 2e6, 5e6]             # explicit values
    range = [200.0, 400.0]               # absolute low, high (with n and spacing for an axis)
    scale = [0.1, 10.0]                  # low, high as multiples of the calibrated value
    n = 9                                # number of values (axes only; default 9)
    spacing = "log"                      # linear | log (default linear)

Each kind's own fields are documented in its module (:mod:`ufmt.studies.kinds` lists them).

Every problem raises :class:`~ufmt.errors.StudyError` with one line naming the file and field.
"""

from __future__ import annotations

import itertools
import math
import numbers
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from ufmt.design import (
    PROCESS_PARAMETERS,
    REFERENCE_PROCESS,
    apply_design,
    design_value,
    unknown_design_parameter,
)
from ufmt.errors import ModelError, StudyError, closest_name
from ufmt.evaluate import model_file, resolve_model
from ufmt.machining.process import TABLE1_RANGE
from ufmt.model.design import parse_design
from ufmt.model.schema import DesignParameter, Model

DEFAULT_FUNCTION = "ufmt.evaluate:evaluate"
DEFAULT_POINTS = 9
SPACINGS = ("linear", "log")

#: Top-level fields of every study file; each kind adds its own (StudyKind.fields).
COMMON_FIELDS = ("kind", "name", "description", "function", "model", "base", "design")
#: Most points of one axis or one grid: a study of more is a typo (a sweep of 1e5 points runs
#: for hours) and its value table alone could exhaust memory.
MAX_POINTS = 100_000
_AXIS_FIELDS = ("parameter", "values", "range", "scale", "n", "spacing")
_BOUND_FIELDS = ("parameter", "range", "scale", "spacing")
_GRID_FIELDS = ("name", "axis")
_SOURCES = ("values", "range", "scale")
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]*")


@dataclass(frozen=True)
class Axis:
    """Values of one parameter: absolute, or multiples of its calibrated value (``relative``)."""

    parameter: str
    values: tuple[float, ...]
    log: bool = False
    relative: bool = False

    def resolved(self, baseline: Mapping[str, float]) -> tuple[float, ...]:
        """Absolute values, scaling relative ones by ``baseline[parameter]``."""
        if not self.relative:
            return self.values
        return tuple(v * baseline[self.parameter] for v in self.values)


@dataclass(frozen=True)
class Bound:
    """Search or sampling interval of one parameter; ``log`` searches in log10 of it."""

    parameter: str
    low: float
    high: float
    log: bool = False
    relative: bool = False

    def resolved(self, baseline: Mapping[str, float]) -> tuple[float, float]:
        """Absolute (low, high), scaling relative ones by ``baseline[parameter]``."""
        factor = baseline[self.parameter] if self.relative else 1.0
        return self.low * factor, self.high * factor


@dataclass(frozen=True)
class Group:
    """Points varied together: one axis (a one-at-a-time sweep) or several (a grid)."""

    name: str
    axes: tuple[Axis, ...]

    def points(self, baseline: Mapping[str, float]) -> list[dict[str, float]]:
        """Full-factorial points over the axes (first axis slowest)."""
        names = [a.parameter for a in self.axes]
        values = [a.resolved(baseline) for a in self.axes]
        return [dict(zip(names, combo, strict=True)) for combo in itertools.product(*values)]


@dataclass(frozen=True)
class Study:
    """A validated study file; ``options`` holds the kind's own fields with defaults filled."""

    path: Path
    name: str
    kind: str
    description: str
    function: str
    model: Path | None
    base: dict[str, float]
    groups: tuple[Group, ...] = ()
    bounds: tuple[Bound, ...] = ()
    options: dict[str, Any] = field(default_factory=dict)
    text: str = ""
    design: dict[str, DesignParameter] = field(default_factory=dict)
    baseline: dict[str, float] = field(default_factory=dict)
    content_sha256: str = ""

    @property
    def parameters(self) -> tuple[str, ...]:
        """Every parameter the study sets: base keys, then axes and bounds, in file order."""
        names = list(self.base)
        names += [a.parameter for g in self.groups for a in g.axes]
        names += [b.parameter for b in self.bounds]
        return tuple(dict.fromkeys(names))

    @property
    def relative_parameters(self) -> tuple[str, ...]:
        """Parameters given as multiples of their calibrated value (need a baseline)."""
        items = [a for g in self.groups for a in g.axes] + list(self.bounds)
        return tuple(dict.fromkeys(i.parameter for i in items if i.relative))


@dataclass(frozen=True)
class StudyKind:
    """A study kind: its own top-level fields and what a run of it does.

    Each kind's module defines one; :mod:`ufmt.studies.kinds` names them all.

    * ``parse(where, data, base)``: check the kind's fields of the parsed TOML ``data``
      (``base``: the study's fixed values) and return the kind's parts of the :class:`Study`
      (``groups``, ``bounds``, ``options``);
    * ``planned_points(study)``: the number of points a run requests (exact, or an
      optimiser's budget: an upper bound);
    * ``analyse(study, evaluator, baseline, out_dir)``: request the points from the run's
      :class:`ufmt.studies.journal.Evaluator`, write the kind's ``tables`` (file names in
      ``out_dir``, besides points.csv) and return the headline finding;
    * ``figures(out_dir)``: the figures of a finished run drawn from its tables, by PNG file
      name.
    """

    name: str
    fields: tuple[str, ...]
    tables: tuple[str, ...]
    parse: Callable[..., dict[str, Any]]
    planned_points: Callable[..., int]
    analyse: Callable[..., str]
    figures: Callable[..., dict]


def read_common(where: StudyContext, data: Mapping, path: Path) -> dict[str, Any]:
    """The fields every study has (name, description, function, model, base, design), read
    from the parsed TOML ``data`` of the file at ``path``; loads the study's model."""
    name = _string(where, "name", data.get("name", path.stem))
    if not _NAME.fullmatch(name):
        where.fail("name", f"{name!r} is not a valid study name (letters, digits, _ . -)")
    model = data.get("model")
    model = None if model is None else (path.parent / _string(where, "model", model)).resolve()
    where.use_model(model, data.get("design", {}))
    base = _base(where, data.get("base", {}))
    return dict(
        name=name,
        description=_string(where, "description", data.get("description", ""), empty=True),
        function=_function(where, data.get("function", DEFAULT_FUNCTION)),
        model=model,
        base=base,
        design=where.declared,
    )


# ---------------------------------------------------------------------------------------------
# values checked against the model before any point runs


def study_baseline(where: StudyContext, study: Study) -> dict[str, float]:
    """Value of every study parameter when it is not varied: base, else reference process,
    else the model's calibrated design."""
    baseline = {}
    for name in study.parameters:
        if name in study.base:
            baseline[name] = study.base[name]
        elif name in PROCESS_PARAMETERS:
            baseline[name] = REFERENCE_PROCESS[name]
        else:
            baseline[name] = design_value(where.model, name, where.declared)
    for name in study.relative_parameters:
        value = baseline[name]
        if not (math.isfinite(value) and value > 0):
            state = "released (0)" if value == 0 else f"{value!r}"
            if math.isinf(value):
                state = "rigid (inf)"
            where.fail(
                f"{name}.scale",
                f"the calibrated value of {name} is {state}: a scale of it is meaningless;"
                " give absolute values (range or values)",
            )
    return baseline


def check_values(where: StudyContext, study: Study, baseline: Mapping[str, float]) -> None:
    """Every value the study can set passes the model loader's rules (design) or is a finite
    number > 0 (process), so no point runs with an input the model could not hold."""
    values: dict[str, set[float]] = {name: {v} for name, v in study.base.items()}
    for group in study.groups:
        for axis in group.axes:
            values.setdefault(axis.parameter, set()).update(axis.resolved(baseline))
    for bound in study.bounds:
        values.setdefault(bound.parameter, set()).update(bound.resolved(baseline))
    for name, given in values.items():
        for value in sorted(given):
            if name in PROCESS_PARAMETERS:
                if not (math.isfinite(value) and value > 0):
                    unit = TABLE1_RANGE[name][2]
                    where.fail(name, f"{value!r} must be a finite number > 0 [{unit}]")
                continue
            try:
                apply_design(where.model, {name: value}, where.declared)
            except ModelError as exc:
                where.fail(name, f"value {value!r} is not allowed: {exc}")


# ---------------------------------------------------------------------------------------------
# fields


class StudyContext:
    """The study file being parsed (for messages) and the model its parameters refer to."""

    def __init__(self, source: str):
        self.source = source
        self.model: Model | None = None
        self.declared: dict[str, DesignParameter] = {}

    def use_model(self, path: Path | None, design) -> None:
        """Load the study's model (packaged if None) and its ``[design]`` declarations."""
        try:
            self.model, _ = resolve_model(model_file(path))
        except ModelError as exc:
            self.fail("model", str(exc))
        try:
            self.declared = parse_design(
                self.source, design, {h.name: h for h in self.model.hinges}
            )
        except ModelError as exc:
            raise StudyError(str(exc)) from None

    def fail(self, field: str, problem: str) -> NoReturn:
        """Raise the one-line StudyError naming the file and ``field``."""
        prefix = f"{self.source}: field '{field}': " if field else f"{self.source}: "
        raise StudyError(" ".join(f"{prefix}{problem}".split()))


def name_hint(word: str, choices, what: str) -> str:
    """ "did you mean ...?" for the closest of ``choices``, else the list of ``what``."""
    close = closest_name(word, choices, cutoff=0.5)
    return f"did you mean {close!r}?" if close else f"{what}: {', '.join(choices)}"


def check_keys(where: StudyContext, prefix: str, table: Mapping, valid) -> None:
    """Every key of ``table`` is one of ``valid`` (``prefix`` names the table)."""
    for key in table:
        if key not in valid:
            where.fail(
                f"{prefix}{key}", f"unknown field ({name_hint(str(key), valid, 'valid fields')})"
            )


def _string(where: StudyContext, field: str, value, empty: bool = False) -> str:
    if not isinstance(value, str) or (not empty and not value.strip()):
        where.fail(field, f"expected a non-empty string, got {value!r}")
    return value


def read_real(where: StudyContext, field: str, value, minimum: float | None = None) -> float:
    """A finite number (not a bool), at least ``minimum`` if given."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
        where.fail(field, f"expected a finite number, got {value!r}")
    if minimum is not None and value < minimum:
        where.fail(field, f"{value!r} is below {minimum!r}")
    return float(value)


def read_positive(where: StudyContext, field: str, value) -> float | None:
    """A finite number > 0, or None if not given."""
    if value is None:
        return None
    value = read_real(where, field, value)
    if value <= 0:
        where.fail(field, f"{value!r} must be > 0")
    return value


def read_count(
    where: StudyContext, field: str, value, minimum: int, maximum: int | None = None
) -> int:
    """An integer (not a bool) from ``minimum`` to ``maximum`` (a number of points)."""
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        where.fail(field, f"expected an integer >= {minimum}, got {value!r}")
    if maximum is not None and value > maximum:
        where.fail(field, f"{value!r} is more than the allowed {maximum:,} points")
    return value


def _parameter(where: StudyContext, field: str, name) -> str:
    name = _string(where, field, name)
    if name not in PROCESS_PARAMETERS:
        problem = unknown_design_parameter(name, where.model, where.declared)
        if problem:
            where.fail(field, problem)
    return name


def _function(where: StudyContext, ref) -> str:
    ref = _string(where, "function", ref)
    module, _, attribute = ref.partition(":")
    if not module or not attribute.isidentifier():
        where.fail("function", f"{ref!r} is not 'module:function' or 'file.py:function'")
    if module.endswith(".py") and not Path(module).is_absolute():
        ref = f"{(Path(where.source).parent / module).resolve()}:{attribute}"
    return ref


def _base(where: StudyContext, table) -> dict[str, float]:
    if not isinstance(table, Mapping):
        where.fail("base", "expected a table of parameter = value")
    base = {}
    for key, value in table.items():
        base[_parameter(where, f"base.{key}", key)] = read_real(where, f"base.{key}", value)
    return base


def _tables(where: StudyContext, field: str, value, required: bool) -> list[Mapping]:
    if not isinstance(value, list) or not all(isinstance(t, Mapping) for t in value):
        where.fail(field, f"expected an array of tables [[{field}]]")
    if required and not value:
        where.fail(field, f"at least one [[{field}]] is required")
    return value


def _interval(where: StudyContext, label: str, table: Mapping) -> tuple[str, list[float], bool]:
    """Which of values/range/scale the table gives, its numbers, and its spacing."""
    sources = [s for s in _SOURCES if s in table]
    if len(sources) != 1:
        where.fail(label, "give exactly one of values, range, scale")
    source = sources[0]
    raw = table[source]
    if not isinstance(raw, list):
        where.fail(f"{label}.{source}", f"expected an array, got {raw!r}")
    numbers_ = [read_real(where, f"{label}.{source}", v) for v in raw]
    spacing = table.get("spacing", "linear")
    if spacing not in SPACINGS:
        where.fail(f"{label}.spacing", f"unknown spacing {spacing!r} (linear or log)")
    log = spacing == "log"
    if source != "values":
        if len(numbers_) != 2:
            where.fail(f"{label}.{source}", f"expected [low, high], got {raw!r}")
        low, high = numbers_
        if low > high:
            where.fail(
                f"{label}.{source}", f"reversed bounds [{low!r}, {high!r}] (need low < high)"
            )
        if low == high:
            where.fail(f"{label}.{source}", f"empty range [{low!r}, {high!r}] (need low < high)")
    if not numbers_:
        where.fail(f"{label}.values", "empty range: no values")
    if (log or source == "scale") and min(numbers_) <= 0:
        where.fail(f"{label}.{source}", f"{raw!r} must be > 0 for log spacing or a scale")
    return source, numbers_, log


def _axis(where: StudyContext, label: str, table: Mapping) -> Axis:
    check_keys(where, f"{label}.", table, _AXIS_FIELDS)
    if "parameter" not in table:
        where.fail(f"{label}.parameter", "missing")
    parameter = _parameter(where, f"{label}.parameter", table["parameter"])
    label = f"{label}[{parameter}]"
    source, values, log = _interval(where, label, table)
    if source == "values":
        if "n" in table:
            where.fail(f"{label}.n", "n goes with range or scale, not with values")
        return Axis(parameter, tuple(values), log)
    n = read_count(where, f"{label}.n", table.get("n", DEFAULT_POINTS), 1, MAX_POINTS)
    low, high = values
    grid = np.geomspace(low, high, n) if log else np.linspace(low, high, n)
    return Axis(parameter, tuple(float(v) for v in grid), log, relative=source == "scale")


def read_axes(where: StudyContext, label: str, value, required: bool) -> list[Axis]:
    """The ``[[axis]]`` tables at ``label``, each over a different parameter."""
    tables = _tables(where, label, value, required)
    axes = [_axis(where, f"{label}[{i}]", t) for i, t in enumerate(tables)]
    check_unique(where, label, [a.parameter for a in axes])
    return axes


def read_grids(where: StudyContext, value) -> list[Group]:
    """The named ``[[grid]]`` tables of a sweep: two or more axes each, crossed."""
    groups = []
    for i, table in enumerate(_tables(where, "grid", value, required=False)):
        check_keys(where, f"grid[{i}].", table, _GRID_FIELDS)
        name = _string(where, f"grid[{i}].name", table.get("name", ""))
        if not _NAME.fullmatch(name):
            where.fail(f"grid[{i}].name", f"{name!r} is not a valid name (letters, digits, _ . -)")
        axes = read_axes(where, f"grid[{i}].axis", table.get("axis", []), required=True)
        if len(axes) < 2:
            where.fail(f"grid[{i}].axis", "a grid needs at least two axes")
        size = math.prod(len(a.values) for a in axes)
        if size > MAX_POINTS:
            where.fail(
                f"grid[{i}].axis", f"{size:,} points is more than the allowed {MAX_POINTS:,}"
            )
        groups.append(Group(name, tuple(axes)))
    return groups


def read_bounds(where: StudyContext, value, required: bool) -> tuple[Bound, ...]:
    """The ``[[bound]]`` tables (range or scale), each over a different parameter."""
    bounds = []
    for i, table in enumerate(_tables(where, "bound", value, required)):
        check_keys(where, f"bound[{i}].", table, _BOUND_FIELDS)
        if "parameter" not in table:
            where.fail(f"bound[{i}].parameter", "missing")
        parameter = _parameter(where, f"bound[{i}].parameter", table["parameter"])
        label = f"bound[{parameter}]"
        if "values" in table:
            where.fail(f"{label}.values", "a bound takes range or scale, not values")
        source, (low, high), log = _interval(where, label, table)
        bounds.append(Bound(parameter, low, high, log, relative=source == "scale"))
    check_unique(where, "bound", [b.parameter for b in bounds])
    return tuple(bounds)


def check_unique(where: StudyContext, field: str, names: list[str]) -> None:
    """No name appears twice in ``names`` (the entries of ``field``)."""
    for name in names:
        if names.count(name) > 1:
            where.fail(field, f"{name!r} appears more than once")
