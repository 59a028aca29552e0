"""The virtual body kind (paper eq. 2.11): a massless point where hinges meet.

One node at the point of its hinges (all at one point), six small motions; no mass, no
member stiffness, no mesh, no material point for a sensor.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ufmt.errors import ModelError
from ufmt.model.schema import VirtualBody
from ufmt.tables import Where

NAME = "virtual"
CLASS = VirtualBody
FIELDS: tuple[str, ...] = ()
REQUIRED: tuple[str, ...] = ()
WRITTEN: tuple[str, ...] = ()
FORM = "point"  # one massless node at its hinges' point
ONE_FRAME = False  # a point: its motion is kept apart from the rigid bodies'
MASSLESS = True  # every hinge on it must be at one point; its dofs carry no mass
MEMBER = False
MESHED = False
HINGES_AT_ENDS = False  # it has no place of its own: its hinges carry it


def parse(where: Where, name: str, table: Mapping, number: int | None) -> VirtualBody:
    """The body of a ``kind = "virtual"`` table (no fields of its own)."""
    return VirtualBody(name=name, number=number)


def written(body: VirtualBody) -> list[tuple[str, object]]:
    """(field, value) written back after name, kind and number."""
    return [(k, getattr(body, k)) for k in WRITTEN]


def points(body: VirtualBody) -> dict[str, np.ndarray]:
    """No points of its own (its hinges place it)."""
    return {}


def section_width(body: VirtualBody) -> None:
    """No section."""
    return None


def check_hinge_point(where: Where, at: np.ndarray, body: VirtualBody) -> None:
    """Checked over all its hinges together (one point), not one by one."""


def node_points(model, body: VirtualBody) -> np.ndarray:
    """Its one node (1, 3) [m]: the point of the first hinge that names it."""
    for hinge in model.hinges:
        if body.name in hinge.between:
            return np.asarray(hinge.at, dtype=float)[None]
    raise ModelError(f"{model.source}: body {body.name!r}: no hinge names it")


def point_map(body: VirtualBody, nodes: np.ndarray, point, source: str) -> tuple[int, np.ndarray]:
    """(node index, T): the hinges act on the point itself."""
    return 0, np.eye(6)


def node_mass(body: VirtualBody) -> None:
    """No mass."""
    return None


def rigidity(body: VirtualBody) -> None:
    """No deformation."""
    return None


def moved(body: VirtualBody, shift: np.ndarray) -> VirtualBody:
    """Unchanged: its hinges carry it."""
    return body


def rotated(body: VirtualBody, frame: np.ndarray) -> VirtualBody:
    """Unchanged: it has no place of its own."""
    return body


def radius(model, body: VirtualBody) -> None:
    """None: it has no extent."""
    return None


def check_sensor(where: Where, field: str, model, body: VirtualBody, point) -> None:
    """Refused: a virtual body has no material point to carry a sensor."""
    where.fail(field, f"body {body.name!r} is {body.kind}: it has no material point")


def hinge_motion(body: VirtualBody, shapes, ends, point) -> np.ndarray:
    """Motion ``[r; θ]`` (6, n) of the point in each mode."""
    return shapes.virtual[body.name].T


def sensor_motion(body: VirtualBody, shapes, point, field_point) -> None:
    """No material point: a sensor cannot sit on it (None)."""
    return None
