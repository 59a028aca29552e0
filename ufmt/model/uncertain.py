"""Reading a model file's ``[[uncertain]]`` tables: the inputs of that machine which nothing
measures, each with its band and the band's source (what ``ufmt simulate --uncertainty``, the
uncertainty and the tolerance studies sample on this model).

One table per input::

    [[uncertain]]
    name = "machine.force_scale"     # a parameter of this model (ufmt.design): machine.<key>,
                                     #   hinge.<name>.stiffness[i], a [design] name, or
                                     #   damping.hinge_factor (a factor on every hinge damper)
    band = [0.8, 1.25]               # [low, high] [SI], or
    # scale = [0.5, 2.0]             #   times the model's own value
    distribution = "loguniform"      # uniform (default) | loguniform: how it is sampled
    source = "..."                   # where the band comes from (required)

Every end of a band must be a value the model file could hold (the ``[machine]`` key's range,
the hinge limits of :data:`ufmt.model.rules.LIMITS`), so that every sample is a valid model.
A band is kept absolute: ``scale`` is resolved against the file's own value when it is read.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import NoReturn

import numpy as np

from ufmt.defaults import REFERENCE_PROCESS
from ufmt.errors import ModelError
from ufmt.model.design import MACHINE_PREFIX, design_target, machine_target, parameter_value
from ufmt.model.machine import OPTIONAL_FIELDS, read_machine
from ufmt.model.rules import LIMITS
from ufmt.model.schema import Model, UncertainInput
from ufmt.tables import Where, did_you_mean

UNCERTAIN_FIELDS = ("name", "band", "scale", "distribution", "source")
DISTRIBUTIONS = ("uniform", "loguniform")
#: the factor on every hinge damper (``damping`` and ``rotational_damping``) of the model
HINGE_DAMPING_FACTOR = "damping.hinge_factor"


def parse_uncertain(source: str, tables, model: Model) -> tuple[UncertainInput, ...]:
    """The ``[[uncertain]]`` tables of the file ``source`` for the loaded ``model``.

    Raises
    ------
    ModelError
        One line naming the file, the entry and the field: an unknown name, NaN, low >= high,
        an end outside what the model allows, a missing source, a name given twice.
    """
    top = Where(source, "", error=ModelError)
    entries = top.tables("uncertain", tables)
    out: list[UncertainInput] = []
    for i, table in enumerate(entries):
        where = Where(source, f"uncertain[{i}]", error=ModelError)
        where.keys(table, UNCERTAIN_FIELDS, required=("name", "source"))
        name = where.string("name", table["name"])
        where = Where(source, f"uncertain {name!r}", error=ModelError)
        if name in [u.name for u in out]:
            top.fail("uncertain", f"{name!r} appears more than once")
        value = _value(where, name, model)
        low, high = _band(where, table, value)
        log = where.choice(
            "distribution", table.get("distribution", "uniform"), DISTRIBUTIONS, "distribution"
        )
        given = "scale" if "scale" in table else "band"  # the field a message names
        if log == "loguniform" and low <= 0:
            where.fail(given, f"[{low:g}, {high:g}]: a log-uniform band needs low > 0")
        for end in (low, high):
            _check_end(where, given, name, end, model)
        text = where.string("source", table["source"])
        out.append(UncertainInput(name, low, high, log == "loguniform", text))
    return tuple(out)


def _value(where: Where, name: str, model: Model) -> float:
    """The model's own value of parameter ``name`` (1 for the hinge damping factor)."""
    if name == HINGE_DAMPING_FACTOR:
        return 1.0
    if name in REFERENCE_PROCESS:
        where.fail("name", f"{name!r} is a process parameter, not an input of the machine")
    if name.startswith(MACHINE_PREFIX) and name not in model.design:
        if model.machine is None:
            where.fail("name", f"{name!r}: the model has no [machine] table")
        if machine_target(name) is None:
            _unknown(where, name, [f"{MACHINE_PREFIX}{key}" for key in OPTIONAL_FIELDS])
        return parameter_value(model, name, model.design)
    try:
        hinge, _, _ = design_target(name, model.design)
    except KeyError:
        _unknown(where, name, [*model.design, HINGE_DAMPING_FACTOR])
    hinges = [h.name for h in model.hinges]
    if hinge not in hinges:
        hint = did_you_mean(hinge, hinges) or f"hinges: {', '.join(hinges)}"
        where.fail("name", f"{name!r}: the model has no hinge {hinge!r} ({hint})")
    return parameter_value(model, name, model.design)


def _unknown(where: Where, name: str, names) -> NoReturn:
    """Raise: ``name`` is no parameter of the model (with the closest of ``names``)."""
    hint = did_you_mean(name, names) or f"declared: {', '.join(names)}"
    where.fail(
        "name",
        f"unknown parameter {name!r} ({hint}) (allowed: machine.<key>,"
        f" hinge.<name>.stiffness[i] or .rotational_stiffness[i], a [design] name,"
        f" {HINGE_DAMPING_FACTOR})",
    )


def _band(where: Where, table: Mapping, value: float) -> tuple[float, float]:
    """[low, high] of the entry: its ``band``, or its ``scale`` times the model's ``value``."""
    given = [key for key in ("band", "scale") if key in table]
    if len(given) != 1:
        where.fail_table("give exactly one of band = [low, high] or scale = [low, high]")
    if given == ["band"]:
        return where.interval("band", table["band"])
    low, high = where.interval("scale", table["scale"], sign="positive")
    if not (math.isfinite(value) and value > 0):
        where.fail(
            "scale",
            f"the model's value is {value!r} (released, rigid or not positive): a scale of it"
            " is meaningless; give band",
        )
    return low * value, high * value


def _check_end(where: Where, given: str, name: str, end: float, model: Model) -> None:
    """``end`` is a value the model file could hold for ``name`` (every component it sets);
    ``given``: the field that gave it (band or scale)."""
    if name == HINGE_DAMPING_FACTOR:
        largest = max((float(max(h.damping6)) for h in model.hinges), default=0.0)
        most = LIMITS["damping"][1] / largest if largest > 0 else math.inf
        if not 0.0 <= end <= most:
            where.outside(given, end, 0.0, most, "(times every hinge damper)")
        return
    target = machine_target(name) if name not in model.design else None
    if target is None:
        hinge, field, components = design_target(name, model.design)
        low, high, unit = LIMITS[field]  # field: the hinge's stiffness or rotational_stiffness
        where.within(given, end, low, high, unit)
        old = np.asarray(getattr(model.hinge(hinge), field))[list(components)]
        mean = old.mean()  # a mean over components scales them in proportion (ufmt.design)
        for value in old * (end / mean) if np.isfinite(mean) and mean > 0 else [end]:
            if not low <= value <= high:
                where.fail(
                    given,
                    f"{end:g} sets a component to {value:g}, outside [{low:g}, {high:g}] {unit}",
                )
        return
    key, index = target
    if index is None:
        _, low, high, unit = OPTIONAL_FIELDS[key]
        where.within(given, end, low, high, "" if unit == "-" else f"[{unit}]")
        return
    table = dict(model.machine.table)
    pair = list(table.get(key, getattr(model.machine, key)))
    pair[index] = end
    try:  # the [machine] reader's own rules (the plate inside the tool circle)
        read_machine({**table, key: pair}, model.source)
    except ModelError as exc:
        where.fail(given, f"{end:g} is not a value the model can take ({exc})")
