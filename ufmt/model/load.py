"""Read, validate and write model files (TOML, schema in ../shared/DESIGN.md and the README).

Every path into a :class:`~ufmt.model.schema.Model` goes through :func:`model_from_dict`, which
checks each field and the connection graph and raises :class:`~ufmt.errors.ModelError` with one
line naming the file, the element and the field, e.g.
``model.toml: hinge 'h15': field 'stiffness[2]': -1e+09 is negative (allowed: >= 0, 0 =
released, inf = rigid)``. Vector components are indexed from 0 (``[2]`` is z).
:func:`model_to_toml` writes a model back so that loading the text gives the same model.
"""

from __future__ import annotations

import copy
import datetime
import functools
import math
import numbers
import re
import tomllib
from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from ufmt.errors import ModelError, closest_name
from ufmt.model.schema import (
    GROUND,
    Beam,
    Body,
    DesignParameter,
    Hinge,
    Model,
    RigidBody,
    VirtualBody,
    frozen_array,
)

KINDS = ("rigid", "virtual", "beam")
TOP_FIELDS = ("name", "description", "body", "hinge", "machine", "design")
BODY_FIELDS = ("name", "kind", "number")
RIGID_FIELDS = ("mass", "center_of_mass", "inertia")
CIRCLE_FIELDS = ("diameter", "inner_diameter")
SECTION_FIELDS = ("area", "second_moment_y", "second_moment_z", "polar_moment")
BEAM_REQUIRED = ("start", "end", "density", "youngs_modulus", "shear_modulus")
BEAM_FIELDS = BEAM_REQUIRED + CIRCLE_FIELDS + SECTION_FIELDS + ("torsion_constant", "orientation")
KIND_FIELDS = {"rigid": RIGID_FIELDS, "virtual": (), "beam": BEAM_FIELDS}
KIND_REQUIRED = {"rigid": RIGID_FIELDS, "virtual": (), "beam": BEAM_REQUIRED}
HINGE_REQUIRED = ("name", "between", "at", "stiffness", "rotational_stiffness")
HINGE_FIELDS = HINGE_REQUIRED + ("damping", "rotational_damping", "number")

SYMMETRY_RTOL = 1e-9  # inertia symmetry, relative to its largest entry
TRIANGLE_RTOL = 1e-9  # principal-moment triangle inequality, relative to the largest moment
DEFINITE_RTOL = 1e-12  # smallest principal moment must exceed this times the largest
BEAM_END_RTOL = 1e-9  # hinge point to beam end, relative to the beam length
POINT_RTOL = 1e-9  # virtual-body hinge points, relative to the model's coordinate extent
PARALLEL_RTOL = 1e-9  # beam orientation vs. axis: |sin angle| must exceed this

#: Physical magnitude bands [SI]: a finite, nonzero value outside (low, high) is rejected at load
#: (values far outside them are typing mistakes or overflow the eigen-solvers). Wide on purpose:
#: from a 1 mg part to a 1,000 t foundation, from foams to diamond.
LIMITS = {
    "mass": (1e-6, 1e9, "[kg]"),
    "inertia": (1e-12, 1e12, "[kg m^2]"),  # principal moments
    "inertia_entry": (0.0, 1e12, "[kg m^2]"),  # |I_ij|
    "density": (1.0, 1e5, "[kg/m^3]"),
    "modulus": (1e3, 1e13, "[Pa]"),
    "coordinate": (0.0, 1e4, "[m]"),  # |x|, |y|, |z| of points
    "diameter": (1e-6, 1e3, "[m]"),
    "area": (1e-12, 1e4, "[m^2]"),
    "second_moment": (1e-24, 1e4, "[m^4]"),
    "stiffness": (1e-6, 1e15, "[N/m]"),  # finite nonzero; 0 = released, inf = rigid
    "rotational_stiffness": (1e-6, 1e15, "[N m/rad]"),
    "damping": (0.0, 1e12, "[N s/m]"),
    "rotational_damping": (0.0, 1e12, "[N m s/rad]"),
}
#: Process parameters (names a design parameter may not take): see ufmt.evaluate.
PROCESS_NAMES = ("rpm", "feed_mm_min", "depth_um")
#: Hinge fields a [design] parameter may set.
DESIGN_FIELDS = ("stiffness", "rotational_stiffness")
DESIGN_ENTRY_FIELDS = ("hinge", "field", "components", "description")
_DESIGN_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")

# rule -> (inf allowed, lower bound)
_RULES = {
    "finite": (False, None),
    "positive": (False, "positive"),
    "nonnegative": (False, "nonnegative"),
    "stiffness": (True, "nonnegative"),
}
_STIFFNESS_ALLOWED = ">= 0, 0 = released, inf = rigid"


# ---------------------------------------------------------------------------------------------
# public API


@functools.cache
def packaged_path(name: str = "ufmt.toml") -> Path:
    """A file packaged in ``ufmt/data`` (default: the calibrated UFMT model)."""
    return Path(str(resources.files("ufmt") / "data" / name))


def load_model(source: str | Path | None = None) -> Model:
    """Read and validate the model file at ``source`` (a path to a TOML file; default: the
    packaged, calibrated UFMT, :func:`packaged_path`).

    Raises
    ------
    ModelError
        One line naming the file (as given), the element and the field.
    """
    if source is None:
        source = packaged_path()
    where = str(source)
    try:
        text = Path(source).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ModelError(f"{where}: file not found") from None
    except IsADirectoryError:
        raise ModelError(f"{where}: is a directory, not a model file") from None
    except UnicodeDecodeError as exc:
        raise ModelError(f"{where}: not UTF-8 text (byte {exc.start})") from None
    except OSError as exc:
        raise ModelError(f"{where}: cannot read: {exc.strerror}") from None
    return load_model_text(text, source=where)


def load_model_text(text: str, source: str = "<string>") -> Model:
    """Parse and validate TOML ``text``; ``source`` names it in messages and in ``Model.source``."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ModelError(f"{source}: malformed TOML: {_one_line(str(exc))}") from None
    except RecursionError:
        raise ModelError(f"{source}: malformed TOML: values nested too deeply") from None
    return model_from_dict(data, source)


def model_from_dict(data: Mapping[str, Any], source: str = "<dict>") -> Model:
    """Validate a model given as nested dicts with the model-file keys (the single check path).

    Scalars may be Python or numpy numbers, vectors lists, tuples or numpy arrays;
    ``float("inf")`` means a rigid hinge direction.
    """
    source = str(source)
    top = _Where(source, "top level")
    if not isinstance(data, Mapping):
        top.fail_element(f"expected a table of model keys, got {_type_name(data)}")
    _check_fields(top, data, TOP_FIELDS, required=("name", "body"))
    name = _string(top, "name", data["name"])
    if "description" in data:
        _string(top, "description", data["description"], allow_empty=True)
    machine = data.get("machine", {})
    if not isinstance(machine, Mapping):
        top.fail("machine", f"expected a table [machine], got {_type_name(machine)}")
    _check_no_nan(top, "machine", machine)

    bodies = _parse_bodies(source, _tables(top, "body", data["body"], required=True))
    hinges = _parse_hinges(source, _tables(top, "hinge", data.get("hinge", [])), bodies)
    _check_numbers(source, bodies, hinges)
    _check_connected(source, bodies, hinges)
    return Model(
        name=name,
        bodies=tuple(bodies.values()),
        hinges=tuple(hinges),
        machine=copy.deepcopy(dict(machine)),
        design=parse_design(source, data.get("design", {}), {h.name: h for h in hinges}),
        source=source,
    )


def parse_design(source: str, table, hinges: Mapping[str, Hinge]) -> dict[str, DesignParameter]:
    """The named design parameters of a ``[design]`` table (model or study file).

    Each entry is a sub-table ``[design.<name>]`` with ``hinge`` (a hinge of the model),
    ``field`` (``stiffness`` or ``rotational_stiffness``), ``components`` (distinct indices
    0, 1, 2 = x, y, z) and an optional ``description``.

    Raises
    ------
    ModelError
        One line naming ``source``, the entry and the field (with a did-you-mean).
    """
    where = _Where(source, "design")
    if not isinstance(table, Mapping):
        where.fail_element(f"expected a table [design], got {_type_name(table)}")
    design = {}
    for name, entry in table.items():
        here = _Where(source, f"design.{name}")
        if not _DESIGN_NAME.fullmatch(str(name)) or name in PROCESS_NAMES:
            here.fail_element(
                "invalid parameter name (letters, digits and _, not starting with a digit; "
                f"not a process parameter {', '.join(PROCESS_NAMES)})"
            )
        if not isinstance(entry, Mapping):
            here.fail_element(
                f"expected a table [design.{name}] with hinge, field, components; got "
                f"{_type_name(entry)}"
            )
        _check_fields(here, entry, DESIGN_ENTRY_FIELDS, DESIGN_ENTRY_FIELDS[:3])
        hinge = _string(here, "hinge", entry["hinge"])
        if hinge not in hinges:
            hint = _suggest(hinge, hinges) or f"hinges are {', '.join(hinges)}"
            here.fail("hinge", f"unknown hinge {hinge!r} ({hint})")
        field = _string(here, "field", entry["field"])
        if field not in DESIGN_FIELDS:
            hint = _suggest(field, DESIGN_FIELDS) or f"allowed: {', '.join(DESIGN_FIELDS)}"
            here.fail("field", f"unknown field {field!r} ({hint})")
        components = entry["components"]
        if not isinstance(components, list | tuple) or not components:
            here.fail("components", "expected a non-empty array of indices 0, 1, 2 (x, y, z)")
        for i, c in enumerate(components):
            if isinstance(c, bool) or c not in (0, 1, 2):
                here.fail(f"components[{i}]", f"{c!r} is not 0, 1 or 2 (x, y, z)")
        if len(set(components)) != len(components):
            here.fail("components", f"{list(components)} repeats an index")
        description = _string(here, "description", entry.get("description", ""), True)
        design[str(name)] = DesignParameter(
            str(name), hinge, field, tuple(int(c) for c in components), description
        )
    return design


def model_to_toml(model: Model) -> str:
    """TOML text of ``model`` in the model-file schema; ``load_model_text`` of it gives it back.

    Numbers are written at full precision (``repr``), infinite stiffness as ``inf``; beams are
    written with their explicit section (area, second moments, polar moment, torsion constant).
    A file's ``description`` is not kept (``Model`` has no field for it); the ``[design]``
    declarations are (the calibration writes the identified model through this function).
    """
    lines = [f"name = {_toml_value(model.name)}"]
    for body in model.bodies:
        lines += ["", "[[body]]", *_body_lines(body)]
    for hinge in model.hinges:
        lines += ["", "[[hinge]]", *_hinge_lines(hinge)]
    if model.machine:
        lines += _table_lines(("machine",), model.machine)
    for parameter in model.design.values():
        lines += design_lines(parameter)
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


# ---------------------------------------------------------------------------------------------
# messages


class _Where:
    """The file and element an error is about."""

    def __init__(self, source: str, element: str):
        self.source = source
        self.element = element

    def fail(self, field: str, problem: str) -> NoReturn:
        raise ModelError(_one_line(f"{self.source}: {self.element}: field '{field}': {problem}"))

    def fail_element(self, problem: str) -> NoReturn:
        raise ModelError(_one_line(f"{self.source}: {self.element}: {problem}"))


def _one_line(text: str) -> str:
    return " ".join(text.split())


def _num(value: float) -> str:
    """Short text of a number that still reads back as the same value."""
    value = float(value)
    short = f"{value:.6g}"
    return short if float(short) == value else repr(value)


def _vec(values) -> str:
    return "[" + ", ".join(_num(v) for v in np.ravel(values)) + "]"


def _derived(values) -> str:
    """Computed quantities (distances, principal moments) to 4 significant digits."""
    text = ", ".join(f"{v:.4g}" for v in np.ravel(values))
    return f"[{text}]" if np.ndim(values) else text


def _type_name(value) -> str:
    if isinstance(value, bool | np.bool_):
        return f"boolean {value!r}"
    if isinstance(value, str):
        return f"string {value!r}"
    if isinstance(value, numbers.Integral):
        return f"integer {value}"
    if isinstance(value, numbers.Real):
        return f"float {_num(value)}"
    if isinstance(value, Mapping):
        return "a table"
    if isinstance(value, list | tuple | np.ndarray):
        return f"an array of {len(value)}"
    if isinstance(value, datetime.date | datetime.time):
        return f"datetime {value.isoformat()}"
    return type(value).__name__


def _suggest(word: str, choices) -> str:
    close = closest_name(word, choices)
    return f"did you mean {close!r}?" if close else ""


# ---------------------------------------------------------------------------------------------
# field checks


def _check_fields(where: _Where, table: Mapping, valid, required=(), what="") -> None:
    """Reject unknown keys (suggesting the closest valid one), then report missing ones."""
    for key in table:
        if key not in valid:
            hint = _suggest(str(key), valid) or f"valid fields{what}: {', '.join(valid)}"
            where.fail_element(f"unknown field {str(key)!r} ({hint})")
    _check_required(where, table, required, what)


def _check_required(where: _Where, table: Mapping, required, what="") -> None:
    for key in required:
        if key not in table:
            where.fail(key, f"missing (required{what})")


def _string(where: _Where, field: str, value, allow_empty=False) -> str:
    if not isinstance(value, str):
        where.fail(field, f"expected a string, got {_type_name(value)}")
    if not allow_empty and not value.strip():
        where.fail(field, "empty (allowed: a non-empty string)")
    return value


def _integer(where: _Where, field: str, value) -> int:
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Integral):
        where.fail(field, f"expected an integer, got {_type_name(value)}")
    return int(value)


def _real(where: _Where, field: str, value, rule: str, unit: str = "", limit: str = "") -> float:
    """A float checked against ``rule`` (finite | positive | nonnegative | stiffness) and, if
    ``limit`` names one, the physical band ``LIMITS[limit]`` (finite nonzero values only)."""
    allows_inf, bound = _RULES[rule]
    if rule == "stiffness":
        allowed = _STIFFNESS_ALLOWED
    else:
        allowed = {None: "finite", "positive": "> 0", "nonnegative": ">= 0, finite"}[bound]
        allowed += f" {unit}" if unit else ""
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        where.fail(field, f"expected a number, got {_type_name(value)} (allowed: {allowed})")
    x = float(value)
    if math.isnan(x):
        where.fail(field, f"nan is not a number (allowed: {allowed})")
    if bound == "positive" and x <= 0:
        where.fail(field, f"{_num(x)} is not positive (allowed: {allowed})")
    if bound == "nonnegative" and x < 0:
        where.fail(field, f"{_num(x)} is negative (allowed: {allowed})")
    if math.isinf(x) and not allows_inf:
        where.fail(field, f"{_num(x)} is not finite (allowed: {allowed})")
    if limit and math.isfinite(x) and x != 0.0:
        low, high, unit_ = LIMITS[limit]
        if not low <= abs(x) <= high:
            band = f"|x| <= {high:g}" if low == 0 else f"{low:g} to {high:g}"
            where.fail(
                field, f"{_num(x)} is outside the physical range {band} {unit_} (ufmt LIMITS)"
            )
    return x


def _array(where: _Where, field: str, value, n: int, what: str) -> list:
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, list | tuple):
        where.fail(field, f"expected {what}, got {_type_name(value)}")
    if len(value) != n:
        where.fail(field, f"expected {what}, got an array of {len(value)}")
    return list(value)


def _vector(
    where: _Where, field: str, value, rule: str, unit: str = "", limit: str = ""
) -> np.ndarray:
    items = _array(where, field, value, 3, f"3 numbers {unit}".rstrip())
    return frozen_array(
        [_real(where, f"{field}[{i}]", v, rule, unit, limit) for i, v in enumerate(items)]
    )


def _tables(where: _Where, field: str, value, required=False) -> list[Mapping]:
    header = f"[[{field}]]"
    if isinstance(value, Mapping) or not isinstance(value, list | tuple):
        where.fail(field, f"expected an array of tables {header}, got {_type_name(value)}")
    if required and not value:
        where.fail(field, f"empty (at least one {header} table is required)")
    for i, item in enumerate(value):
        if not isinstance(item, Mapping):
            where.fail(f"{field}[{i}]", f"expected a table {header}, got {_type_name(item)}")
    return list(value)


def _check_no_nan(where: _Where, field: str, value) -> None:
    """Reject NaN anywhere inside a free-form value (the [machine] table)."""
    if isinstance(value, Mapping):
        for key, item in value.items():
            _check_no_nan(where, f"{field}.{key}", item)
    elif isinstance(value, list | tuple | np.ndarray):
        for i, item in enumerate(value):
            _check_no_nan(where, f"{field}[{i}]", item)
    elif isinstance(value, numbers.Real) and math.isnan(float(value)):
        where.fail(field, "nan is not a number")


# ---------------------------------------------------------------------------------------------
# bodies


def _label(kind: str, index: int, table: Mapping) -> str:
    """``body 'x'`` when the table has a usable name, else ``body #3`` (1-based, file order)."""
    name = table.get("name")
    return f"{kind} {name!r}" if isinstance(name, str) and name.strip() else f"{kind} #{index}"


def _parse_bodies(source: str, tables: list[Mapping]) -> dict[str, Body]:
    bodies: dict[str, Body] = {}
    first_index: dict[str, int] = {}
    for index, table in enumerate(tables, start=1):
        where = _Where(source, _label("body", index, table))
        body = _parse_body(where, table)
        if body.name == GROUND:
            where.fail("name", f"{GROUND!r} is reserved for the fixed frame (choose another name)")
        if body.name in bodies:
            where.fail(
                "name",
                f"duplicate body name (body #{first_index[body.name]} and body #{index} "
                "have the same name)",
            )
        bodies[body.name] = body
        first_index[body.name] = index
    return bodies


def _parse_body(where: _Where, table: Mapping) -> Body:
    kind = table.get("kind")
    if kind in KINDS:
        valid, what = BODY_FIELDS + KIND_FIELDS[kind], f" for kind {kind!r}"
    else:
        valid, what = BODY_FIELDS + RIGID_FIELDS + BEAM_FIELDS, ""
    _check_fields(where, table, valid, ("name",), what)
    name = _string(where, "name", table["name"])
    if "kind" not in table:
        where.fail("kind", f"missing (valid kinds: {', '.join(KINDS)})")
    if kind not in KINDS:
        hint = _suggest(str(kind), KINDS)
        where.fail(
            "kind",
            f"unknown kind {kind!r} (valid kinds: {', '.join(KINDS)}"
            + (f"; {hint})" if hint else ")"),
        )
    _check_required(where, table, KIND_REQUIRED[kind], what)
    number = _integer(where, "number", table["number"]) if "number" in table else None
    if kind == "virtual":
        return VirtualBody(name=name, number=number)
    if kind == "rigid":
        return RigidBody(
            name=name,
            mass=_real(where, "mass", table["mass"], "positive", "[kg]", "mass"),
            center_of_mass=_vector(
                where, "center_of_mass", table["center_of_mass"], "finite", "[m]", "coordinate"
            ),
            inertia=_inertia(where, table["inertia"]),
            number=number,
        )
    return _beam(where, name, table, number)


def _inertia(where: _Where, value) -> np.ndarray:
    """Symmetric positive-definite 3x3 tensor whose principal moments obey the triangle rule."""
    what = "a 3x3 array [kg m^2]"
    rows = _array(where, "inertia", value, 3, what)
    matrix = np.array(
        [
            [
                _real(where, f"inertia[{i}][{j}]", v, "finite", "[kg m^2]", "inertia_entry")
                for j, v in enumerate(_array(where, f"inertia[{i}]", row, 3, "3 numbers [kg m^2]"))
            ]
            for i, row in enumerate(rows)
        ]
    )
    scale = np.max(np.abs(matrix))
    asym = np.abs(matrix - matrix.T)
    if np.any(asym > SYMMETRY_RTOL * scale):
        i, j = np.unravel_index(np.argmax(asym), asym.shape)
        where.fail(
            "inertia",
            f"not symmetric: inertia[{i}][{j}] = {_num(matrix[i, j])} but inertia[{j}][{i}] = "
            f"{_num(matrix[j, i])} (allowed: symmetric within {SYMMETRY_RTOL:g} relative)",
        )
    matrix = 0.5 * (matrix + matrix.T)
    moments = np.linalg.eigvalsh(matrix)
    if moments[0] <= DEFINITE_RTOL * moments[-1]:
        where.fail(
            "inertia",
            f"not positive definite: principal moments {_derived(moments)} [kg m^2] "
            "(allowed: all > 0)",
        )
    low, high, unit = LIMITS["inertia"]
    if not (low <= moments[0] and moments[2] <= high):
        where.fail(
            "inertia",
            f"principal moments {_derived(moments)} {unit} are outside the physical range "
            f"{low:g} to {high:g} {unit} (ufmt LIMITS)",
        )
    if moments[2] - (moments[0] + moments[1]) > TRIANGLE_RTOL * moments[2]:
        where.fail(
            "inertia",
            f"principal moments {_derived(moments)} [kg m^2] are not physical: the largest exceeds "
            "the sum of the other two (a rigid body needs each <= the sum of the others)",
        )
    return frozen_array(matrix)


def _beam(where: _Where, name: str, table: Mapping, number: int | None) -> Beam:
    start = _vector(where, "start", table["start"], "finite", "[m]", "coordinate")
    end = _vector(where, "end", table["end"], "finite", "[m]", "coordinate")
    axis = end - start
    length = float(np.linalg.norm(axis))
    if length <= 0:
        where.fail("end", f"beam length is 0: start and end are both {_vec(start)} (allowed: > 0)")
    density = _real(where, "density", table["density"], "positive", "[kg/m^3]", "density")
    youngs = _real(where, "youngs_modulus", table["youngs_modulus"], "positive", "[Pa]", "modulus")
    shear = _real(where, "shear_modulus", table["shear_modulus"], "positive", "[Pa]", "modulus")
    section = _section(where, table)
    orientation = None
    if "orientation" in table:
        orientation = _vector(where, "orientation", table["orientation"], "finite")
        size = np.linalg.norm(orientation)
        sine = np.linalg.norm(np.cross(orientation, axis)) / (size * length) if size > 0 else 0.0
        if sine <= PARALLEL_RTOL:
            where.fail(
                "orientation",
                f"{_vec(orientation)} is zero or parallel to the beam axis "
                f"{_derived(axis / length)} "
                "(allowed: any vector not parallel to the axis; it fixes local y)",
            )
    return Beam(
        name=name,
        start=start,
        end=end,
        density=density,
        youngs_modulus=youngs,
        shear_modulus=shear,
        orientation=orientation,
        number=number,
        **section,
    )


_SECTION_LIMITS = {
    "area": "area",
    "second_moment_y": "second_moment",
    "second_moment_z": "second_moment",
    "polar_moment": "second_moment",
}


def _section(where: _Where, table: Mapping) -> dict[str, float]:
    """Section properties from ``diameter`` (solid/hollow circle) or the explicit fields."""
    explicit = [k for k in SECTION_FIELDS + ("torsion_constant",) if k in table]
    if "diameter" in table:
        if explicit:
            where.fail(
                explicit[0],
                "give either 'diameter' (circular section) or the explicit section "
                f"({', '.join(SECTION_FIELDS)}), not both",
            )
        outer = _real(where, "diameter", table["diameter"], "positive", "[m]", "diameter")
        inner = 0.0
        if "inner_diameter" in table:
            inner = _real(
                where, "inner_diameter", table["inner_diameter"], "nonnegative", "[m]", "diameter"
            )
            if inner >= outer:
                where.fail(
                    "inner_diameter",
                    f"{_num(inner)} is not less than diameter {_num(outer)} "
                    "(allowed: 0 <= inner_diameter < diameter)",
                )
        second = math.pi * (outer**4 - inner**4) / 64.0
        return {
            "area": math.pi * (outer**2 - inner**2) / 4.0,
            "second_moment_y": second,
            "second_moment_z": second,
            "polar_moment": 2.0 * second,
            "torsion_constant": 2.0 * second,
        }
    if "inner_diameter" in table:
        where.fail("inner_diameter", "needs 'diameter' (hollow circular section)")
    if not explicit:
        where.fail(
            "diameter",
            f"missing section (give 'diameter', or {', '.join(SECTION_FIELDS)})",
        )
    for key in SECTION_FIELDS:
        if key not in table:
            where.fail(key, f"missing (an explicit section needs {', '.join(SECTION_FIELDS)})")
    units = {"area": "[m^2]"}
    section = {
        k: _real(where, k, table[k], "positive", units.get(k, "[m^4]"), _SECTION_LIMITS.get(k, ""))
        for k in SECTION_FIELDS
    }
    section["torsion_constant"] = (
        _real(
            where,
            "torsion_constant",
            table["torsion_constant"],
            "positive",
            "[m^4]",
            "second_moment",
        )
        if "torsion_constant" in table
        else section["polar_moment"]
    )
    return section


# ---------------------------------------------------------------------------------------------
# hinges and the connection graph


def _parse_hinges(source: str, tables: list[Mapping], bodies: dict[str, Body]) -> list[Hinge]:
    hinges: list[Hinge] = []
    first_index: dict[str, int] = {}
    for index, table in enumerate(tables, start=1):
        where = _Where(source, _label("hinge", index, table))
        hinge = _parse_hinge(where, table, bodies)
        if hinge.name in first_index:
            where.fail(
                "name",
                f"duplicate hinge name (hinge #{first_index[hinge.name]} and hinge #{index} "
                "have the same name)",
            )
        first_index[hinge.name] = index
        hinges.append(hinge)
    _check_virtual_points(source, hinges, bodies)
    return hinges


def _parse_hinge(where: _Where, table: Mapping, bodies: dict[str, Body]) -> Hinge:
    _check_fields(where, table, HINGE_FIELDS, HINGE_REQUIRED)
    name = _string(where, "name", table["name"])
    between = _between(where, table["between"], bodies)
    at = _vector(where, "at", table["at"], "finite", "[m]", "coordinate")
    for side in between:
        body = bodies.get(side)
        if isinstance(body, Beam):
            _check_at_beam_end(where, at, body)
    zeros = np.zeros(3)
    return Hinge(
        name=name,
        between=between,
        at=at,
        stiffness=_hinge_vector(where, "stiffness", table["stiffness"]),
        rotational_stiffness=_hinge_vector(
            where, "rotational_stiffness", table["rotational_stiffness"]
        ),
        damping=_hinge_vector(where, "damping", table.get("damping", zeros)),
        rotational_damping=_hinge_vector(
            where, "rotational_damping", table.get("rotational_damping", zeros)
        ),
        number=_integer(where, "number", table["number"]) if "number" in table else None,
    )


_HINGE_RULES = {
    "stiffness": ("stiffness", "[N/m]"),
    "rotational_stiffness": ("stiffness", "[N m/rad]"),
    "damping": ("nonnegative", "[N s/m]"),
    "rotational_damping": ("nonnegative", "[N m s/rad]"),
}


def _hinge_vector(where: _Where, field: str, value) -> np.ndarray:
    """A hinge's 3-vector ``field`` checked by its rule and physical band."""
    rule, unit = _HINGE_RULES[field]
    return _vector(where, field, value, rule, unit, field)


def check_hinge_values(model: Model, hinge: str, field: str, values, context: str = "") -> None:
    """Check new ``values`` of a hinge's ``field`` with the loader's rules (same one-line
    messages as a model file, ``context`` appended, e.g. the design parameter that set them).

    Raises
    ------
    ModelError
        A value the model file could not hold (negative or NaN stiffness, outside LIMITS).
    """
    where = _Where(model.source, f"hinge {hinge!r}")
    try:
        _hinge_vector(where, field, list(values))
    except ModelError as exc:
        raise ModelError(f"{exc}{f' ({context})' if context else ''}") from None


def _between(where: _Where, value, bodies: dict[str, Body]) -> tuple[str, str]:
    items = _array(where, "between", value, 2, f'two body names (or "{GROUND}")')
    for i, item in enumerate(items):
        _string(where, f"between[{i}]", item)
        if item != GROUND and item not in bodies:
            hint = _suggest(item, [*bodies, GROUND])
            where.fail(
                f"between[{i}]",
                f"unknown body {item!r} ("
                + (hint or f"bodies are {', '.join(map(repr, bodies))} and {GROUND!r}")
                + ")",
            )
    a, b = items
    if a == b:
        where.fail("between", f"connects {a!r} to itself (allowed: two different bodies)")
    return (a, b)


def _check_at_beam_end(where: _Where, at: np.ndarray, beam: Beam) -> None:
    length = beam.length
    distance = min(np.linalg.norm(at - beam.start), np.linalg.norm(at - beam.end))
    if distance > BEAM_END_RTOL * length:
        where.fail(
            "at",
            f"{_vec(at)} is not at an end of beam {beam.name!r} (start {_vec(beam.start)}, "
            f"end {_vec(beam.end)}; {_derived(distance)} m away; allowed: within "
            f"{BEAM_END_RTOL:g} x length {_num(length)} m of an end)",
        )


def _check_virtual_points(source: str, hinges: list[Hinge], bodies: dict[str, Body]) -> None:
    """Every hinge on a virtual body must be at one point (the body has no size)."""
    points = [h.at for h in hinges]
    for b in bodies.values():
        if isinstance(b, RigidBody):
            points.append(b.center_of_mass)
        elif isinstance(b, Beam):
            points += [b.start, b.end]
    scale = float(np.max(np.abs(points))) if points else 0.0
    first: dict[str, Hinge] = {}
    for hinge in hinges:
        for side in hinge.between:
            if not isinstance(bodies.get(side), VirtualBody):
                continue
            ref = first.setdefault(side, hinge)
            distance = float(np.linalg.norm(hinge.at - ref.at))
            if distance > POINT_RTOL * scale:
                _Where(source, f"hinge {hinge.name!r}").fail(
                    "at",
                    f"impossible geometry: virtual body {side!r} is a point, but hinge "
                    f"{ref.name!r} puts it at {_vec(ref.at)} and this hinge at {_vec(hinge.at)} "
                    f"({_derived(distance)} m apart; allowed: all hinges on a virtual body "
                    "at one point)",
                )


def _check_numbers(source: str, bodies: dict[str, Body], hinges: list[Hinge]) -> None:
    """Element numbers (the paper's, shared by bodies and hinges) must be unique."""
    seen: dict[int, str] = {}
    elements = [("body", b) for b in bodies.values()] + [("hinge", h) for h in hinges]
    for kind, element in elements:
        if element.number is None:
            continue
        label = f"{kind} {element.name!r}"
        if element.number in seen:
            _Where(source, label).fail(
                "number", f"{element.number} is already the number of {seen[element.number]}"
            )
        seen[element.number] = label


def _check_connected(source: str, bodies: dict[str, Body], hinges: list[Hinge]) -> None:
    """Every body has a hinge and a chain of hinges to ground."""
    neighbours: dict[str, set[str]] = {name: set() for name in [*bodies, GROUND]}
    for h in hinges:
        a, b = h.between
        neighbours[a].add(b)
        neighbours[b].add(a)
    for name in bodies:
        if not neighbours[name]:
            _Where(source, f"body {name!r}").fail_element(
                "has no hinge (no [[hinge]] names it in 'between'; every body needs one)"
            )
    reached = {GROUND}
    frontier = [GROUND]
    while frontier:
        for other in neighbours[frontier.pop()] - reached:
            reached.add(other)
            frontier.append(other)
    for name in bodies:
        if name not in reached:
            linked = ", ".join(map(repr, sorted(neighbours[name])))
            _Where(source, f"body {name!r}").fail_element(
                f"not connected to {GROUND!r}: no chain of hinges ('between') leads from it to "
                f"{GROUND!r} (it is linked only to {linked})"
            )


# ---------------------------------------------------------------------------------------------
# writer

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


def _toml_value(value) -> str:
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
        return "{" + ", ".join(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in value.items()) + "}"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


def _table_lines(path: tuple[str, ...], table: Mapping) -> list[str]:
    """A [table] with its plain keys first and its sub-tables after (TOML requires this order)."""
    lines = ["", "[" + ".".join(_toml_key(p) for p in path) + "]"]
    subtables = {k: v for k, v in table.items() if isinstance(v, Mapping)}
    lines += [f"{_toml_key(k)} = {_toml_value(v)}" for k, v in table.items() if k not in subtables]
    for key, sub in subtables.items():
        lines += _table_lines((*path, key), sub)
    return lines


def _pairs(pairs: list[tuple[str, Any]]) -> list[str]:
    return [f"{k} = {_toml_value(v)}" for k, v in pairs if v is not None]


def _body_lines(body: Body) -> list[str]:
    pairs: list[tuple[str, Any]] = [("name", body.name), ("kind", body.kind)]
    pairs.append(("number", body.number))
    if isinstance(body, RigidBody):
        pairs += [
            ("mass", body.mass),
            ("center_of_mass", body.center_of_mass),
            ("inertia", body.inertia),
        ]
    elif isinstance(body, Beam):
        pairs += [
            (k, getattr(body, k))
            for k in (
                "start",
                "end",
                "density",
                "youngs_modulus",
                "shear_modulus",
                *SECTION_FIELDS,
                "torsion_constant",
                "orientation",
            )
        ]
    return _pairs(pairs)


def _hinge_lines(hinge: Hinge) -> list[str]:
    return _pairs([(k, getattr(hinge, k)) for k in HINGE_FIELDS])
