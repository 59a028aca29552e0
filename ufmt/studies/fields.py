"""Reading a study file's fields with the one table checker, :class:`ufmt.tables.Where`.

A study kind's ``parse(where, data, parameters)`` (:class:`~ufmt.studies.spec.StudyKind`)
reads its own fields with this API and nothing else::

    where.number("target_pv_nm", data.get("target_pv_nm", 100.0), sign="positive")
    where.integer("samples", data.get("samples", 16), 2, MAX_POINTS)
    where.choice("method", data.get("method", "morris"), ("morris", "sobol"), "method")
    bounds = read_bounds(where, data, parameters, required=True)     # [[bound]] tables
    axes = read_axes(where, data, parameters, required=False)        # [[axis]] tables
    grids = read_grids(where, data, parameters)                      # [[grid]] tables
    name = parameters.check(where.sub("draw[0]"), "parameter", t["parameter"])  # own tables
    if "rpm" in parameters.base: where.sub("base").fail("rpm", "is searched; remove it")
    k = parameters.baseline("head_axial_stiffness_N_m")  # base, else reference/calibrated

``where`` is the file's :class:`~ufmt.tables.Where` at its top level (``where.sub("optimiser")``
for a table, ``where.fail(field, problem)`` for a check of the kind's own); ``data`` the parsed
TOML, whose top-level keys are already checked against ``COMMON_FIELDS`` and the kind's
``fields``; ``parameters`` the :class:`Parameters` the study can set. Every reader raises
:class:`~ufmt.errors.StudyError` with one line, ``<file>: <table>: field '<field>': <problem>``,
in the wording of :mod:`ufmt.tables`. An ``[[axis]]`` or ``[[bound]]`` table is named by its
index until its parameter is read (``axis[0]``), then by the parameter (``bound 'rpm'``).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ufmt.design import (
    PROCESS_PARAMETERS,
    REFERENCE_PROCESS,
    apply_design,
    design_value,
    unknown_design_parameter,
)
from ufmt.errors import ModelError, StudyError
from ufmt.evaluate import model_file, resolve_model
from ufmt.machining.process import TABLE1_RANGE
from ufmt.model.design import parse_design
from ufmt.model.schema import DesignParameter, Model
from ufmt.studies.spec import Axis, Bound, Group, Study
from ufmt.tables import Where

DEFAULT_FUNCTION = "ufmt.evaluate:evaluate"
DEFAULT_POINTS = 9
SPACINGS = ("linear", "log")

#: Top-level fields of every study file; each kind adds its own (StudyKind.fields).
COMMON_FIELDS = ("kind", "name", "description", "function", "model", "base", "design")
#: Most points of one axis or one grid: a study of more is a typo (a sweep of 1e5 points runs
#: for hours) and its value table alone could exhaust memory.
MAX_POINTS = 100_000
AXIS_FIELDS = ("parameter", "values", "range", "scale", "n", "spacing")
BOUND_FIELDS = ("parameter", "range", "scale", "spacing")
GRID_FIELDS = ("name", "axis")
VALUE_SOURCES = ("values", "range", "scale")
NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]*")
NAME_ALLOWED = "allowed: letters, digits, _ . -"


@dataclass(frozen=True)
class Parameters:
    """The parameters a study can set and their values when not varied.

    model: the study's model; declared: its design parameters with the study's ``[design]``;
    base: the study's fixed values (``[base]``).
    """

    model: Model
    declared: dict[str, DesignParameter] = field(default_factory=dict)
    base: dict[str, float] = field(default_factory=dict)

    def check(self, where: Where, field: str, name) -> str:
        """``name`` if it is a process parameter or a design parameter of the model, else
        the problem (with a did-you-mean) as ``field``'s."""
        name = where.string(field, name)
        if name not in PROCESS_PARAMETERS:
            problem = unknown_design_parameter(name, self.model, self.declared)
            if problem:
                where.fail(field, problem)
        return name

    def baseline(self, name: str) -> float:
        """The value of ``name`` when the study does not vary it: its base value, else the
        reference process, else the model's calibrated design [SI, process units]."""
        if name in self.base:
            return self.base[name]
        if name in PROCESS_PARAMETERS:
            return REFERENCE_PROCESS[name]
        return design_value(self.model, name, self.declared)


# ---------------------------------------------------------------------------------------------
# the fields every study has


def read_common(where: Where, data: Mapping, path: Path) -> tuple[dict[str, Any], Parameters]:
    """The fields every study has (name, description, function, model, base, design), read
    from the parsed TOML ``data`` of the file at ``path``, and the :class:`Parameters` of its
    (loaded) model."""
    name = where.string("name", data.get("name", path.stem))
    if not NAME.fullmatch(name):
        where.fail("name", f"{name!r} is not a valid study name ({NAME_ALLOWED})")
    model = data.get("model")
    model = None if model is None else (path.parent / where.string("model", model)).resolve()
    parameters = _parameters(where, model, data.get("design", {}))
    parameters = replace(parameters, base=_base(where, data.get("base", {}), parameters))
    common = dict(
        name=name,
        description=where.string("description", data.get("description", ""), allow_empty=True),
        function=_function(where, data.get("function", DEFAULT_FUNCTION)),
        model=model,
        base=parameters.base,
        design=parameters.declared,
    )
    return common, parameters


def _parameters(where: Where, path: Path | None, design) -> Parameters:
    """The study's model (packaged if None) with its and the study's ``[design]``."""
    try:
        model, _ = resolve_model(model_file(path))
    except ModelError as exc:
        where.fail("model", str(exc))
    try:
        declared = parse_design(where.source, design, {h.name: h for h in model.hinges})
    except ModelError as exc:
        raise StudyError(str(exc)) from None
    return Parameters(model, declared)


def _function(where: Where, ref) -> str:
    ref = where.string("function", ref)
    module, _, attribute = ref.partition(":")
    if not module or not attribute.isidentifier():
        where.fail("function", f"{ref!r} is not 'module:function' or 'file.py:function'")
    if module.endswith(".py") and not Path(module).is_absolute():
        ref = f"{(Path(where.source).parent / module).resolve()}:{attribute}"
    return ref


def _base(where: Where, table, parameters: Parameters) -> dict[str, float]:
    where.mapping("base", table, "[base]")
    at = where.sub("base")
    return {parameters.check(at, key, key): at.number(key, value) for key, value in table.items()}


# ---------------------------------------------------------------------------------------------
# axes, grids and bounds


def read_axes(where: Where, table: Mapping, parameters: Parameters, required: bool) -> list[Axis]:
    """The ``[[axis]]`` tables of ``table`` (at ``where``), each over a different parameter."""
    tables = where.tables("axis", table.get("axis", []), required)
    axes = [_axis(where, i, t, parameters) for i, t in enumerate(tables)]
    where.unique("axis", [a.parameter for a in axes])
    return axes


def _axis(where: Where, index: int, table: Mapping, parameters: Parameters) -> Axis:
    """The ``index``-th ``[[axis]]`` table of the table at ``where``."""
    at = where.sub(f"axis[{index}]")
    at.keys(table, AXIS_FIELDS, required=("parameter",))
    parameter = parameters.check(at, "parameter", table["parameter"])
    at = where.sub(f"axis {parameter!r}")
    source, values, log = _values(at, table, parameters, parameter)
    if source == "values":
        if "n" in table:
            at.fail("n", "n goes with range or scale, not with values")
        return Axis(parameter, tuple(values), log)
    n = at.integer("n", table.get("n", DEFAULT_POINTS), 1, MAX_POINTS)
    low, high = values
    grid = np.geomspace(low, high, n) if log else np.linspace(low, high, n)
    return Axis(parameter, tuple(float(v) for v in grid), log, relative=source == "scale")


def read_grids(where: Where, table: Mapping, parameters: Parameters) -> list[Group]:
    """The named ``[[grid]]`` tables of a sweep: two or more axes each, crossed."""
    groups = []
    for i, t in enumerate(where.tables("grid", table.get("grid", []))):
        at = where.sub(f"grid[{i}]")
        at.keys(t, GRID_FIELDS, required=("name",))
        name = at.string("name", t["name"])
        if not NAME.fullmatch(name):
            at.fail("name", f"{name!r} is not a valid name ({NAME_ALLOWED})")
        grid = where.sub(f"grid {name!r}")
        axes = read_axes(grid, t, parameters, required=True)
        if len(axes) < 2:
            grid.fail("axis", "a grid needs at least two axes")
        size = math.prod(len(a.values) for a in axes)
        if size > MAX_POINTS:
            grid.fail("axis", f"{size:,} points is more than the allowed {MAX_POINTS:,}")
        groups.append(Group(name, tuple(axes)))
    return groups


def read_bounds(
    where: Where, table: Mapping, parameters: Parameters, required: bool
) -> tuple[Bound, ...]:
    """The ``[[bound]]`` tables of ``table`` (range or scale), each over a different
    parameter."""
    bounds = []
    for i, t in enumerate(where.tables("bound", table.get("bound", []), required)):
        at = where.sub(f"bound[{i}]")
        at.keys(t, BOUND_FIELDS, required=("parameter",))
        parameter = parameters.check(at, "parameter", t["parameter"])
        at = where.sub(f"bound {parameter!r}")
        if "values" in t:
            at.fail("values", "a bound takes range or scale, not values")
        source, (low, high), log = _values(at, t, parameters, parameter)
        bounds.append(Bound(parameter, low, high, log, relative=source == "scale"))
    where.unique("bound", [b.parameter for b in bounds])
    return tuple(bounds)


def _values(
    where: Where, table: Mapping, parameters: Parameters, parameter: str
) -> tuple[str, list[float], bool]:
    """Which of values/range/scale the table gives, its numbers, and whether it is log-spaced;
    a scale needs a finite calibrated value > 0 to multiply."""
    sources = [s for s in VALUE_SOURCES if s in table]
    if len(sources) != 1:
        where.fail_table("give exactly one of values, range, scale")
    source = sources[0]
    log = where.choice("spacing", table.get("spacing", "linear"), SPACINGS, "spacing") == "log"
    rules = {}
    if log or source == "scale":
        rules = {"sign": "positive", "allowed": "> 0 for log spacing or a scale"}
    if source == "values":
        items = where.items("values", table["values"], "value", required=True)
        return source, [where.number(f"values[{i}]", v, **rules) for i, v in enumerate(items)], log
    low_high = list(where.interval(source, table[source], **rules))
    if source == "scale":
        _check_scalable(where, parameters, parameter)
    return source, low_high, log


def _check_scalable(where: Where, parameters: Parameters, name: str) -> None:
    """A scale of ``name`` multiplies its baseline: refuse a released, rigid or absurd one."""
    value = parameters.baseline(name)
    if not (math.isfinite(value) and value > 0):
        state = "released (0)" if value == 0 else f"{value!r}"
        if math.isinf(value):
            state = "rigid (inf)"
        where.fail(
            "scale",
            f"the calibrated value of {name} is {state}: a scale of it is meaningless;"
            " give absolute values (range or values)",
        )


# ---------------------------------------------------------------------------------------------
# values checked against the model before any point runs


def study_baseline(study: Study, parameters: Parameters) -> dict[str, float]:
    """Value of every study parameter when it is not varied (:meth:`Parameters.baseline`)."""
    return {name: parameters.baseline(name) for name in study.parameters}


def check_values(
    where: Where, study: Study, parameters: Parameters, baseline: Mapping[str, float]
) -> None:
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
                where.number(name, value, sign="positive", unit=f"[{TABLE1_RANGE[name][2]}]")
                continue
            try:
                apply_design(parameters.model, {name: value}, parameters.declared)
            except ModelError as exc:
                where.fail(name, f"value {value!r} is not allowed: {exc}")
