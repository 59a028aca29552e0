"""Reading the ``[[body]]`` tables of a model file: the common fields (name, kind, number),
then the reader of the body's kind (:mod:`ufmt.kinds`)."""

from __future__ import annotations

from collections.abc import Mapping

from ufmt.errors import ModelError
from ufmt.kinds import BODY_KINDS, KINDS
from ufmt.limits import MAX_NAME_CHARS
from ufmt.model.rules import BODY_FIELDS, label
from ufmt.model.schema import GROUND, Body
from ufmt.tables import Where


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
        valid, context = BODY_FIELDS + BODY_KINDS[kind].FIELDS, f" for kind {kind!r}"
    else:
        valid = BODY_FIELDS + tuple(dict.fromkeys(f for k in BODY_KINDS.values() for f in k.FIELDS))
        context = ""
    where.keys(table, valid, ("name",), context)
    name = where.string("name", table["name"], max_chars=MAX_NAME_CHARS)
    if "kind" not in table:
        where.missing("kind", f"valid kinds: {', '.join(KINDS)}")
    where.choice("kind", kind, KINDS, "kind")
    where.required(table, BODY_KINDS[kind].REQUIRED, context)
    number = where.integer("number", table["number"]) if "number" in table else None
    return BODY_KINDS[kind].parse(where, name, table, number)
