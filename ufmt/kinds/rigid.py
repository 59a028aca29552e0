"""The rigid body kind (paper eqs. 2.5, 2.8, 2.9, 3.1): mass, centre of mass, inertia tensor.

One node at the centre of mass carrying six small motions ``[r_C; θ]``; a point P of the
body moves by ``r_C + θ × (P - C)`` (eq. 2.5). It has no member stiffness (no clamped
count) and no mesh: both solvers take its 6x6 mass block, the MSTMM through its transfer
matrix (:func:`first_input_transfer`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from ufmt.kinematics import I3, carried_motion, inertia_about, point_motion, skew
from ufmt.model.rules import (
    DEFINITE_RTOL,
    LIMITS,
    SYMMETRY_RTOL,
    TRIANGLE_RTOL,
    derived,
    real,
    vector,
)
from ufmt.model.schema import RigidBody, frozen_array
from ufmt.tables import Where, short_number

NAME = "rigid"
CLASS = RigidBody
FIELDS = ("mass", "center_of_mass", "inertia")
REQUIRED = FIELDS
WRITTEN = FIELDS  # the fields written back after name, kind and number
FORM = "mass"  # one node that carries its mass block (mass, center_of_mass, inertia)
ONE_FRAME = True  # its motion is one 6-vector about its centre of mass
MASSLESS = False  # its node carries mass
MEMBER = False  # no exact member stiffness: no clamped-clamped count applies
MESHED = False  # the assembled model takes it as one node, whatever the mesh
HINGES_AT_ENDS = False  # a hinge on it may sit anywhere (and ride with it)


def parse(where: Where, name: str, table: Mapping, number: int | None) -> RigidBody:
    """The body of a ``kind = "rigid"`` table (fields checked, one-line errors)."""
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


def written(body: RigidBody) -> list[tuple[str, object]]:
    """(field, value) written back after name, kind and number."""
    return [(k, getattr(body, k)) for k in WRITTEN]


def points(body: RigidBody) -> dict[str, np.ndarray]:
    """The points [m] the body's fields place (field -> point)."""
    return {"center_of_mass": body.center_of_mass}


def section_width(body: RigidBody) -> None:
    """No section."""
    return None


def check_hinge_point(where: Where, at: np.ndarray, body: RigidBody) -> None:
    """A hinge may sit anywhere on a rigid body."""


def node_points(model, body: RigidBody) -> np.ndarray:
    """Its one node (1, 3) [m]: the centre of mass."""
    return np.asarray(body.center_of_mass, dtype=float)[None]


def point_map(body: RigidBody, nodes: np.ndarray, point, source: str) -> tuple[int, np.ndarray]:
    """(node index, T (6, 6)): the motion at ``point`` [m] is T times the node's (eq. 2.5)."""
    return 0, point_motion(np.asarray(point, dtype=float) - body.center_of_mass)


def node_mass(body: RigidBody) -> np.ndarray:
    """Mass block (6, 6) [kg, kg m^2] of its node: mass and inertia at the centre of mass."""
    block = np.zeros((6, 6))
    block[range(3), range(3)] = body.mass
    block[3:, 3:] = body.inertia
    return block


def rigidity(body: RigidBody) -> None:
    """No deformation: nothing to add to the rows whose null space is a rigid motion."""
    return None


def moved(body: RigidBody, shift: np.ndarray) -> RigidBody:
    """The body translated by ``shift`` [m]."""
    return replace(body, center_of_mass=frozen_array(body.center_of_mass + shift))


def rotated(body: RigidBody, frame: np.ndarray) -> RigidBody:
    """The body in the frame whose axes are the columns of ``frame`` (global coordinates)."""
    return replace(
        body,
        center_of_mass=frozen_array(body.center_of_mass @ frame),
        inertia=frozen_array(frame.T @ body.inertia @ frame),
    )


SENSOR_MARGIN = 1.5  # [-] body radii from the centre of mass a modal-test sensor may sit


def radius(model, body: RigidBody) -> float:
    """The body's radius [m]: the larger of the half-diagonal of the uniform box with its
    inertia, sqrt(1.5 tr(I) / m), and the distance from its centre of mass to its farthest
    hinge point (a rigid body carries no other geometry)."""
    box = np.sqrt(1.5 * np.trace(body.inertia) / body.mass)
    centre = np.asarray(body.center_of_mass, dtype=float)
    hinges = [np.linalg.norm(h.at - centre) for h in model.hinges if body.name in h.between]
    return float(max([box, *hinges]))


def check_sensor(where: Where, field: str, model, body: RigidBody, point) -> None:
    """A sensor within SENSOR_MARGIN radii of the centre of mass."""
    size = radius(model, body)
    off = float(np.linalg.norm(point - body.center_of_mass))
    if off > SENSOR_MARGIN * size:
        where.fail(
            field,
            f"{off:.3g} m from the centre of mass of {body.name!r}, whose points lie "
            f"within {size:.3g} m of it (allowed: <= {SENSOR_MARGIN:g} x that)",
        )


def hinge_motion(body: RigidBody, shapes, ends, point) -> np.ndarray:
    """Motion ``[r; θ]`` (6, n) at ``point`` [m] in each mode of ``shapes`` (``ends``: unused,
    the motion of a field's ends)."""
    return point_motion(np.asarray(point) - body.center_of_mass) @ shapes.rigid[body.name].T


def sensor_motion(body: RigidBody, shapes, point, field_point) -> np.ndarray:
    """Motion ``[r; θ]`` (n, 6) at a sensor's ``point`` [m] (``field_point``: unused)."""
    return carried_motion(shapes.rigid[body.name], body.center_of_mass, point)


def first_input_transfer(omega: np.ndarray, mass: float, inertia_c, com, p_in, p_out) -> np.ndarray:
    """U_{i,I1} (n, 12, 12) of a rigid body (paper eq. 2.8) [SI] at ω (n,) [rad/s].

    mass [kg], inertia_c [kg m^2] about the centre of mass ``com`` [m], first input point
    ``p_in`` and output point ``p_out`` [m]. Affine in ω²: the constant part is the kinematic
    transfer, the ω² part the inertia forces.
    """
    l_io = skew(np.asarray(p_out) - p_in)
    l_ic = skew(np.asarray(com) - p_in)
    l_co = skew(np.asarray(p_out) - com)
    j_i = inertia_about(np.asarray(inertia_c), mass, np.asarray(com) - p_in)
    base = np.eye(12)
    base[0:3, 3:6] = -l_io
    base[6:9, 9:12] = l_io
    inertial = np.zeros((12, 12))
    inertial[6:9, 0:3] = mass * l_co
    inertial[6:9, 3:6] = -(mass * l_io @ l_ic + j_i)
    inertial[9:12, 0:3] = mass * I3
    inertial[9:12, 3:6] = -mass * l_ic
    w2 = np.asarray(omega, dtype=float)[:, None, None] ** 2
    return base[None] + w2 * inertial[None]


def mass_products(body: RigidBody, va: np.ndarray, vb: np.ndarray) -> np.ndarray:
    """⟨V_a, M V_b⟩ (n, 6) [kg] per direction of two motions ``[r_C; θ]`` (n, 6): m r_a·r_b per
    axis and θ_a,i (J θ_b)_i per axis (eq. 3.1)."""
    out = np.empty((va.shape[0], 6))
    out[:, :3] = body.mass * va[:, :3] * vb[:, :3]
    out[:, 3:] = va[:, 3:] * (vb[:, 3:] @ body.inertia)
    return out
