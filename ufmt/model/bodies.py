"""Reading the ``[[body]]`` tables of a model file: rigid bodies (mass, centre of mass, inertia
tensor), virtual bodies and beams (end points, material, section)."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from ufmt.errors import ModelError
from ufmt.limits import MAX_NAME_CHARS
from ufmt.model.rules import (
    BEAM_FIELDS,
    BODY_FIELDS,
    DEFINITE_RTOL,
    KIND_FIELDS,
    KIND_REQUIRED,
    KINDS,
    LIMITS,
    PARALLEL_RTOL,
    RIGID_FIELDS,
    SECTION_FIELDS,
    SYMMETRY_RTOL,
    TRIANGLE_RTOL,
    derived,
    label,
    real,
    vector,
)
from ufmt.model.schema import GROUND, Beam, Body, RigidBody, VirtualBody, frozen_array
from ufmt.tables import Where, short_number, short_vector


def parse_bodies(source: str, tables: list[Mapping]) -> dict[str, Body]:
    """The bodies of the ``[[body]]`` tables by name (unique, not "ground"), in file order."""
    bodies: dict[str, Body] = {}
    first_index: dict[str, int] = {}
    for index, table in enumerate(tables, start=1):
        where = Where(source, label("body", index, table), error=ModelError)
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


def _parse_body(where: Where, table: Mapping) -> Body:
    kind = table.get("kind")
    if kind in KINDS:
        valid, context = BODY_FIELDS + KIND_FIELDS[kind], f" for kind {kind!r}"
    else:
        valid, context = BODY_FIELDS + RIGID_FIELDS + BEAM_FIELDS, ""
    where.keys(table, valid, ("name",), context)
    name = where.string("name", table["name"], max_chars=MAX_NAME_CHARS)
    if "kind" not in table:
        where.missing("kind", f"valid kinds: {', '.join(KINDS)}")
    where.choice("kind", kind, KINDS, "kind")
    where.required(table, KIND_REQUIRED[kind], context)
    number = where.integer("number", table["number"]) if "number" in table else None
    return _PARSERS[kind](where, name, table, number)


def _virtual(where: Where, name: str, table: Mapping, number: int | None) -> VirtualBody:
    return VirtualBody(name=name, number=number)


def _rigid(where: Where, name: str, table: Mapping, number: int | None) -> RigidBody:
    return RigidBody(
        name=name,
        mass=real(where, "mass", table["mass"], "positive", "[kg]", "mass"),
        center_of_mass=vector(
            where, "center_of_mass", table["center_of_mass"], "finite", "[m]", "coordinate"
        ),
        inertia=_inertia(where, table["inertia"]),
        number=number,
    )


def _inertia(where: Where, value) -> np.ndarray:
    """Symmetric positive-definite 3x3 tensor whose principal moments obey the triangle rule."""
    rows = where.array("inertia", value, 3, "a 3x3 array [kg m^2]")
    matrix = np.array(
        [
            [
                real(where, f"inertia[{i}][{j}]", v, "finite", "[kg m^2]", "inertia_entry")
                for j, v in enumerate(where.array(f"inertia[{i}]", row, 3, "3 numbers [kg m^2]"))
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
            f"not symmetric: inertia[{i}][{j}] = {short_number(matrix[i, j])} but "
            f"inertia[{j}][{i}] = {short_number(matrix[j, i])} (allowed: symmetric within "
            f"{SYMMETRY_RTOL:g} relative)",
        )
    matrix = 0.5 * (matrix + matrix.T)
    moments = np.linalg.eigvalsh(matrix)
    if moments[0] <= DEFINITE_RTOL * moments[-1]:
        where.fail(
            "inertia",
            f"not positive definite: principal moments {derived(moments)} [kg m^2] "
            "(allowed: all > 0)",
        )
    low, high, unit = LIMITS["inertia"]
    if not (low <= moments[0] and moments[2] <= high):
        where.fail(
            "inertia",
            f"principal moments {derived(moments)} {unit} are outside the allowed range "
            f"[{low:g}, {high:g}] {unit}",
        )
    if moments[2] - (moments[0] + moments[1]) > TRIANGLE_RTOL * moments[2]:
        where.fail(
            "inertia",
            f"principal moments {derived(moments)} [kg m^2] are not physical: the largest exceeds "
            "the sum of the other two (a rigid body needs each <= the sum of the others)",
        )
    return frozen_array(matrix)


def _beam(where: Where, name: str, table: Mapping, number: int | None) -> Beam:
    start = vector(where, "start", table["start"], "finite", "[m]", "coordinate")
    end = vector(where, "end", table["end"], "finite", "[m]", "coordinate")
    axis = end - start
    length = float(np.linalg.norm(axis))
    if length <= 0:
        where.fail(
            "end", f"beam length is 0: start and end are both {short_vector(start)} (allowed: > 0)"
        )
    density = real(where, "density", table["density"], "positive", "[kg/m^3]", "density")
    youngs = real(where, "youngs_modulus", table["youngs_modulus"], "positive", "[Pa]", "modulus")
    shear = real(where, "shear_modulus", table["shear_modulus"], "positive", "[Pa]", "modulus")
    section = _section(where, table)
    orientation = None
    if "orientation" in table:
        orientation = vector(where, "orientation", table["orientation"], "finite")
        size = np.linalg.norm(orientation)
        sine = np.linalg.norm(np.cross(orientation, axis)) / (size * length) if size > 0 else 0.0
        if sine <= PARALLEL_RTOL:
            where.fail(
                "orientation",
                f"{short_vector(orientation)} is zero or parallel to the beam axis "
                f"{derived(axis / length)} "
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


def _section(where: Where, table: Mapping) -> dict[str, float]:
    """Section properties from ``diameter`` (solid/hollow circle) or the explicit fields."""
    explicit = [k for k in SECTION_FIELDS + ("torsion_constant",) if k in table]
    if "diameter" in table:
        if explicit:
            where.fail(
                explicit[0],
                "give either 'diameter' (circular section) or the explicit section "
                f"({', '.join(SECTION_FIELDS)}), not both",
            )
        return _circle(where, table)
    if "inner_diameter" in table:
        where.fail("inner_diameter", "needs 'diameter' (hollow circular section)")
    if not explicit:
        where.missing("diameter", f"a section: give 'diameter', or {', '.join(SECTION_FIELDS)}")
    for key in SECTION_FIELDS:
        if key not in table:
            where.missing(key, f"an explicit section needs {', '.join(SECTION_FIELDS)}")
    units = {"area": "[m^2]"}
    section = {
        k: real(where, k, table[k], "positive", units.get(k, "[m^4]"), _SECTION_LIMITS.get(k, ""))
        for k in SECTION_FIELDS
    }
    section["torsion_constant"] = (
        real(
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


def _circle(where: Where, table: Mapping) -> dict[str, float]:
    """Section of a solid or hollow circle (``diameter``, ``inner_diameter``)."""
    outer = real(where, "diameter", table["diameter"], "positive", "[m]", "diameter")
    inner = 0.0
    if "inner_diameter" in table:
        inner = real(
            where, "inner_diameter", table["inner_diameter"], "nonnegative", "[m]", "diameter"
        )
        if inner >= outer:
            where.fail(
                "inner_diameter",
                f"{short_number(inner)} is not less than diameter {short_number(outer)} "
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


#: kind -> the reader of its ``[[body]]`` table
_PARSERS = {"rigid": _rigid, "virtual": _virtual, "beam": _beam}
