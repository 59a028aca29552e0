"""Reading the ``[[hinge]]`` tables of a model file and checking the connection graph: what
each hinge joins and where, element numbers, every body linked to ground."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ufmt.errors import ModelError
from ufmt.kinds import HINGE_KINDS, kind_of
from ufmt.limits import MAX_NAME_CHARS
from ufmt.model.rules import HINGE_FIELDS, HINGE_REQUIRED, POINT_RTOL, derived, label, vector
from ufmt.model.schema import GROUND, Body, Hinge, Model
from ufmt.tables import Where, short_vector


def parse_hinges(source: str, tables: list[Mapping], bodies: dict[str, Body]) -> list[Hinge]:
    """The hinges of the ``[[hinge]]`` tables (unique names), in file order."""
    hinges: list[Hinge] = []
    first_index: dict[str, int] = {}
    for index, table in enumerate(tables, start=1):
        where = Where(source, label("hinge", index, table), error=ModelError)
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


def _parse_hinge(where: Where, table: Mapping, bodies: dict[str, Body]) -> Hinge:
    kind = where.string("kind", table.get("kind", "spring"))
    where.choice("kind", kind, list(HINGE_KINDS), "hinge kind")
    module = HINGE_KINDS[kind]
    where.keys(table, (*HINGE_FIELDS, "kind", *module.FIELDS), HINGE_REQUIRED + module.REQUIRED)
    name = where.string("name", table["name"], max_chars=MAX_NAME_CHARS)
    between = _between(where, table["between"], bodies)
    at = vector(where, "at", table["at"], "finite", "[m]", "coordinate")
    for side in between:
        if side != GROUND:
            kind_of(bodies[side]).check_hinge_point(where, at, bodies[side])
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
        number=where.integer("number", table["number"]) if "number" in table else None,
        kind=kind,
        extra=module.parse(where, table),
    )


_HINGE_RULES = {
    "stiffness": ("stiffness", "[N/m]"),
    "rotational_stiffness": ("stiffness", "[N m/rad]"),
    "damping": ("nonnegative", "[N s/m]"),
    "rotational_damping": ("nonnegative", "[N m s/rad]"),
}


def _hinge_vector(where: Where, field: str, value) -> np.ndarray:
    """A hinge's 3-vector ``field`` checked by its rule and physical band."""
    rule, unit = _HINGE_RULES[field]
    return vector(where, field, value, rule, unit, field)


def check_hinge_values(model: Model, hinge: str, field: str, values, context: str = "") -> None:
    """Check new ``values`` of a hinge's ``field`` with the loader's rules (same one-line
    messages as a model file, ``context`` appended, e.g. the design parameter that set them).

    Raises
    ------
    ModelError
        A value the model file could not hold (negative or NaN stiffness, outside LIMITS).
    """
    where = Where(model.source, f"hinge {hinge!r}", error=ModelError)
    try:
        _hinge_vector(where, field, list(values))
    except ModelError as exc:
        raise ModelError(f"{exc}{f' ({context})' if context else ''}") from None


def _between(where: Where, value, bodies: dict[str, Body]) -> tuple[str, str]:
    items = where.array("between", value, 2, f'two body names (or "{GROUND}")')
    for i, item in enumerate(items):
        where.string(f"between[{i}]", item)
        if item != GROUND:
            where.choice(f"between[{i}]", item, [*bodies, GROUND], "body", "bodies")
    a, b = items
    if a == b:
        where.fail("between", f"connects {a!r} to itself (allowed: two different bodies)")
    return (a, b)


def _check_virtual_points(source: str, hinges: list[Hinge], bodies: dict[str, Body]) -> None:
    """Every hinge on a massless point body (a virtual body) must be at one point."""
    points = [h.at for h in hinges]
    for b in bodies.values():
        points += list(kind_of(b).points(b).values())
    scale = float(np.max(np.abs(points))) if points else 0.0
    first: dict[str, Hinge] = {}
    for hinge in hinges:
        for side in hinge.between:
            if side == GROUND or not kind_of(bodies[side]).MASSLESS:
                continue
            ref = first.setdefault(side, hinge)
            distance = float(np.linalg.norm(hinge.at - ref.at))
            if distance > POINT_RTOL * scale:
                Where(source, f"hinge {hinge.name!r}", error=ModelError).fail(
                    "at",
                    f"impossible geometry: {bodies[side].kind} body {side!r} is a point, but hinge "
                    f"{ref.name!r} puts it at {short_vector(ref.at)} and this hinge at "
                    f"{short_vector(hinge.at)} ({derived(distance)} m apart; allowed: all "
                    "hinges on a virtual body at one point)",
                )


def check_numbers(source: str, bodies: dict[str, Body], hinges: list[Hinge]) -> None:
    """Element numbers (the paper's, shared by bodies and hinges) must be unique."""
    seen: dict[int, str] = {}
    elements = [("body", b) for b in bodies.values()] + [("hinge", h) for h in hinges]
    for kind, element in elements:
        if element.number is None:
            continue
        name = f"{kind} {element.name!r}"
        if element.number in seen:
            Where(source, name, error=ModelError).fail(
                "number", f"{element.number} is already the number of {seen[element.number]}"
            )
        seen[element.number] = name


def check_connected(source: str, bodies: dict[str, Body], hinges: list[Hinge]) -> None:
    """Every body has a hinge and a chain of hinges to ground."""
    neighbours: dict[str, set[str]] = {name: set() for name in [*bodies, GROUND]}
    for h in hinges:
        a, b = h.between
        neighbours[a].add(b)
        neighbours[b].add(a)
    for name in bodies:
        if not neighbours[name]:
            Where(source, f"body {name!r}", error=ModelError).fail_table(
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
            Where(source, f"body {name!r}", error=ModelError).fail_table(
                f"not connected to {GROUND!r}: no chain of hinges ('between') leads from it to "
                f"{GROUND!r} (it is linked only to {linked})"
            )
