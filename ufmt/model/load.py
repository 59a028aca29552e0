"""Read and validate model files (TOML, schema in ../shared/DESIGN.md and the README).

Every path into a :class:`~ufmt.model.schema.Model` goes through :func:`model_from_dict`, which
checks each field and the connection graph and raises :class:`~ufmt.errors.ModelError` with one
line naming the file, the element and the field, e.g.
``model.toml: hinge 'h15': field 'stiffness[2]': -1e+09 is negative (allowed: >= 0, 0 =
released, inf = rigid)``. Vector components are indexed from 0 (``[2]`` is z). The bodies are
read by :mod:`ufmt.model.bodies`, the hinges and the connection graph by
:mod:`ufmt.model.hinges`, the ``[machine]`` table by :mod:`ufmt.model.machine`, the
``[design]`` table by :mod:`ufmt.model.design`, the ``[[uncertain]]`` tables by
:mod:`ufmt.model.uncertain`; :func:`ufmt.model.write.model_to_toml` writes a
model back so that loading the text gives the same model.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import replace
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ufmt import limits
from ufmt.errors import ModelError
from ufmt.kinds import kind_of
from ufmt.model.bodies import parse_bodies
from ufmt.model.design import parse_design
from ufmt.model.hinges import check_connected, check_numbers, parse_hinges
from ufmt.model.machine import (
    MAX_LENGTH_M,
    check_machine_bodies,
    check_machine_geometry,
    read_machine,
    unit_hint,
)
from ufmt.model.orientation import check_spindle
from ufmt.model.rules import TOP_FIELDS
from ufmt.model.schema import Model
from ufmt.model.uncertain import parse_uncertain
from ufmt.tables import Where, type_name
from ufmt.tomlfile import parse_toml, read_text


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
    return load_model_text(read_text(source, ModelError), source=str(source))


def load_model_text(text: str, source: str = "<string>") -> Model:
    """Parse and validate TOML ``text``; ``source`` names it in messages and in ``Model.source``."""
    return model_from_dict(parse_toml(text, source, ModelError), source)


def model_from_dict(data: Mapping[str, Any], source: str = "<dict>") -> Model:
    """Validate a model given as nested dicts with the model-file keys (the single check path).

    Scalars may be Python or numpy numbers, vectors lists, tuples or numpy arrays;
    ``float("inf")`` means a rigid hinge direction. The ``[machine]`` table, if any, is read
    into a :class:`~ufmt.model.machine.Machine` whose tool and workpiece are bodies of the model.
    """
    source = str(source)
    top = Where(source, "top level", error=ModelError)
    if not isinstance(data, Mapping):
        top.fail_table(f"expected a table of model keys, got {type_name(data)}")
    top.keys(data, TOP_FIELDS, required=("name", "body"))
    name = top.string("name", data["name"])
    if "description" in data:
        top.string("description", data["description"], allow_empty=True)
    machine = None
    if "machine" in data:
        machine = read_machine(top.mapping("machine", data["machine"], "[machine]"), source)

    for key, most in (("body", limits.MAX_BODIES), ("hinge", limits.MAX_HINGES)):
        size = len(data.get(key, ())) if isinstance(data.get(key), list) else 0
        if size > most:  # before anything is built from them
            top.fail(key, f"{size:,} [[{key}]] tables; a model holds at most {most:,}")
    bodies = parse_bodies(source, top.tables("body", data["body"], required=True))
    hinges = parse_hinges(source, top.tables("hinge", data.get("hinge", [])), bodies)
    check_extent(source, bodies.values(), hinges)
    check_numbers(source, bodies, hinges)
    check_connected(source, bodies, hinges)
    if machine is not None:
        check_machine_bodies(machine, bodies, source)
        check_spindle(machine, bodies, hinges, source)
        check_machine_geometry(machine, bodies.values(), source)
    model = Model(
        name=name,
        bodies=tuple(bodies.values()),
        hinges=tuple(hinges),
        machine=machine,
        design=parse_design(source, data.get("design", {}), {h.name: h for h in hinges}),
        source=source,
    )
    if "uncertain" not in data:
        return model
    return replace(model, uncertain=parse_uncertain(source, data["uncertain"], model))


def check_extent(source: str, bodies, hinges) -> None:
    """Lengths a machine can have: the model's points (centres of mass, beam ends, hinge
    points) span at most ``MAX_LENGTH_M`` along each axis and a beam's section is no wider
    (equivalent diameter sqrt(4 A / pi)); a model typed in mm or cm fails here, with a hint.
    Only spans are checked: the model may sit anywhere in its frame."""
    named = [
        (f"body {b.name!r}", field, point)
        for b in bodies
        for field, point in kind_of(b).points(b).items()
    ]
    named += [(f"hinge {h.name!r}", "at", h.at) for h in hinges]
    fits = lambda v: v <= MAX_LENGTH_M  # noqa: E731
    for body in bodies:
        width = kind_of(body).section_width(body)
        if width is not None and not fits(width):
            Where(source, f"body {body.name!r}", error=ModelError).fail(
                "diameter",
                f"a section {width:g} m wide (diameter, or sqrt(4 area / pi); at most"
                f" {MAX_LENGTH_M:g} m): {unit_hint(width, fits)}",
            )
    if len(named) < 2:
        return
    points = np.array([p for _, _, p in named], dtype=float)
    spans = points.max(axis=0) - points.min(axis=0)
    axis = int(np.argmax(spans))
    if not fits(spans[axis]):
        far, field, _ = named[int(np.argmax(points[:, axis]))]
        near, near_field, _ = named[int(np.argmin(points[:, axis]))]
        Where(source, far, error=ModelError).fail(
            field,
            f"the model spans {spans[axis]:g} m along {'xyz'[axis]} (from {near} {near_field});"
            f" a machine spans at most {MAX_LENGTH_M:g} m: {unit_hint(spans[axis], fits)}",
        )


def as_model(model: Model | str | Path | None) -> Model:
    """``model`` itself if it is a loaded :class:`Model`, else :func:`load_model` of it (a path;
    None: the packaged UFMT): what every public entry point calls first."""
    return model if isinstance(model, Model) else load_model(model)
