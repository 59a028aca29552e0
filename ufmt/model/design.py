"""Reading a ``[design]`` table (model or study file): the named design parameters, each a
set of components of one hinge's stiffness; and the grammar of the parameter names a model
takes (``machine.<key>``, ``hinge.<name>.<field>[i]``, a declared name) with their values."""

from __future__ import annotations

import re
from collections.abc import Mapping

import numpy as np

from ufmt.errors import ModelError
from ufmt.model.machine import OPTIONAL_FIELDS
from ufmt.model.schema import DesignParameter, Hinge, Model
from ufmt.tables import Where, type_name

#: Process parameters (names a design parameter may not take): see ufmt.evaluate.
PROCESS_NAMES = ("rpm", "feed_mm_min", "depth_um")
#: Hinge fields a [design] parameter may set.
DESIGN_FIELDS = ("stiffness", "rotational_stiffness")
DESIGN_ENTRY_FIELDS = ("hinge", "field", "components", "description")
_DESIGN_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


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
    where = Where(source, "design", error=ModelError)
    if not isinstance(table, Mapping):
        where.fail_table(f"expected a table [design], got {type_name(table)}")
    return {
        str(name): _parameter(where.sub(str(name)), name, entry, hinges)
        for name, entry in table.items()
    }


def _parameter(here: Where, name, entry, hinges: Mapping[str, Hinge]) -> DesignParameter:
    """One ``[design.<name>]`` entry."""
    if not _DESIGN_NAME.fullmatch(str(name)) or name in PROCESS_NAMES:
        here.fail_table(
            "invalid parameter name (letters, digits and _, not starting with a digit; "
            f"not a process parameter {', '.join(PROCESS_NAMES)})"
        )
    if not isinstance(entry, Mapping):
        here.fail_table(
            f"expected a table [design.{name}] with hinge, field, components; got "
            f"{type_name(entry)}"
        )
    here.keys(entry, DESIGN_ENTRY_FIELDS, DESIGN_ENTRY_FIELDS[:3])
    hinge = here.string("hinge", entry["hinge"])
    here.choice("hinge", hinge, hinges, "hinge")
    field = here.string("field", entry["field"])
    here.choice("field", field, DESIGN_FIELDS, "field")
    components = entry["components"]
    if not isinstance(components, list | tuple) or not components:
        here.fail("components", "expected a non-empty array of indices 0, 1, 2 (x, y, z)")
    for i, c in enumerate(components):
        if isinstance(c, bool) or c not in (0, 1, 2):
            here.fail(f"components[{i}]", f"{c!r} is not 0, 1 or 2 (x, y, z)")
    if len(set(components)) != len(components):
        here.fail("components", f"{list(components)} repeats an index")
    description = here.string("description", entry.get("description", ""), True)
    return DesignParameter(str(name), hinge, field, tuple(int(c) for c in components), description)


# ---------------------------------------------------------------------------------------------
# the parameter names a model takes (the design vocabulary's grammar, ufmt.design)

_HINGE_PARAMETER = re.compile(
    r"hinge\.(?P<hinge>[^.\[\]]+)\.(?P<field>stiffness|rotational_stiffness)\[(?P<index>[012])\]"
)
MACHINE_PREFIX = "machine."
#: ``[machine]`` pairs whose components are parameters ``machine.<key>[i]``.
MACHINE_PAIRS = ("workpiece_size",)
_MACHINE_PARAMETER = re.compile(r"machine\.(?P<key>[A-Za-z_]+)(\[(?P<index>[01])\])?")


def machine_target(name: str) -> tuple[str, int | None] | None:
    """([machine] key, pair index or None) that parameter ``name`` sets, or None if ``name``
    is not a ``machine.`` parameter."""
    match = _MACHINE_PARAMETER.fullmatch(name)
    if match is None:
        return None
    key, index = match["key"], match["index"]
    if index is None and key in OPTIONAL_FIELDS:
        return key, None
    if index is not None and key in MACHINE_PAIRS:
        return key, int(index)
    return None


def design_target(
    name: str, parameters: Mapping[str, DesignParameter]
) -> tuple[str, str, tuple[int, ...]]:
    """(hinge, field, components) that design parameter ``name`` sets.

    Raises
    ------
    KeyError
        ``name`` is neither a declared design parameter nor ``hinge.<name>.<field>[i]``.
    """
    if name in parameters:
        p = parameters[name]
        return p.hinge, p.field, p.components
    match = _HINGE_PARAMETER.fullmatch(name)
    if match is None:
        raise KeyError(name)
    return match["hinge"], match["field"], (int(match["index"]),)


def parameter_value(model: Model, name: str, parameters: Mapping[str, DesignParameter]) -> float:
    """The value of parameter ``name`` in ``model`` (``parameters``: the declared design
    parameters): the mean of its components [SI], or the ``[machine]`` value."""
    target = machine_target(name) if name not in parameters else None
    if target is not None:
        key, index = target
        value = getattr(model.machine, key)
        return float(value if index is None else value[index])
    hinge, field, components = design_target(name, parameters)
    return float(np.mean(getattr(model.hinge(hinge), field)[list(components)]))
