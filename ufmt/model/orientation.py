"""Spindle orientation: the ``[machine]`` table's directions, the machine frame, and the check
that they agree with the model's spindle.

The machining formulas (eq. 4.1, the cutting force, every error source, the surface) are
written in the *machine frame* (x_m, y_m, z_m): z_m along the spindle axis, from the cut
towards the spindle (opposite to the depth of cut), y_m opposite to the feed (the workpiece
moves along -y_m), x_m = y_m x z_m (right-handed). ``[machine]`` gives, in the model file's
global frame,

* ``spindle_direction``: z_m (default ``"z"``, a vertical spindle above the workpiece);
* ``feed_direction``: the direction the workpiece moves relative to the spindle (default
  ``"-y"``); normal to the spindle axis;
* ``gravity_direction``: where gravity pulls (default ``"-z"``; the carriage's weight,
  :mod:`ufmt.machining.carriage_load`).

Each is an axis name (``"x"``, ``"-z"``, ...) or a unit 3-vector. The ``[machine]`` lengths
(``spindle_axis_xy``, ``cutting_plane_z``, ``workpiece_center_xy``, the guideway profile's
positions) are machine-frame coordinates p_m = F^T p of the global point p, F the frame's
matrix (:func:`frame_matrix`); with the default directions F = I and they are global
coordinates.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ufmt.errors import ModelError
from ufmt.tables import Where, short_vector

#: Axis names a direction key accepts.
AXIS_NAMES = {
    f"{sign}{axis}": tuple(float(s * (i == k)) for k in range(3))
    for i, axis in enumerate("xyz")
    for sign, s in (("", 1), ("+", 1), ("-", -1))
}
#: Default directions (global frame): a vertical spindle, the workpiece fed along -y, gravity
#: along -z.
DIRECTION_FIELDS = {
    "spindle_direction": (0.0, 0.0, 1.0),
    "feed_direction": (0.0, -1.0, 0.0),
    "gravity_direction": (0.0, 0.0, -1.0),
}
#: A direction's | |v| - 1 | and the feed's |cos| against the spindle axis must not exceed it.
UNIT_TOL = 1e-6
#: |sin| of the angle between the spindle axis and a spindle beam (or a released hinge axis)
#: above which they are not parallel.
PARALLEL_TOL = 1e-6


def read_direction(where: Where, table: Mapping, field: str) -> tuple[float, float, float]:
    """The unit vector of direction ``field`` (its default when absent)."""
    if field not in table:
        return DIRECTION_FIELDS[field]
    value = table[field]
    allowed = 'an axis name ("x", "-z", ...) or a unit vector [x, y, z]'
    if isinstance(value, str):
        if value.strip().lower() not in AXIS_NAMES:
            where.fail(field, f"unknown direction {value!r} (allowed: {allowed})")
        return AXIS_NAMES[value.strip().lower()]
    v = np.array(where.numbers(field, value, 3, unit="[-]"))
    size = float(np.linalg.norm(v))
    if abs(size - 1.0) > UNIT_TOL:
        where.fail(field, f"{short_vector(v)} has length {size:.9g}, not 1 (allowed: {allowed})")
    return tuple(float(c) for c in v / size)


def read_directions(where: Where, table: Mapping) -> dict[str, tuple[float, float, float]]:
    """The three directions of a ``[machine]`` table; the feed must be normal to the spindle."""
    out = {field: read_direction(where, table, field) for field in DIRECTION_FIELDS}
    cosine = float(np.dot(out["spindle_direction"], out["feed_direction"]))
    if abs(cosine) > UNIT_TOL:
        where.fail(
            "feed_direction",
            f"{short_vector(out['feed_direction'])} is not normal to spindle_direction "
            f"{short_vector(out['spindle_direction'])} (cos = {cosine:.3g}; allowed: a feed in "
            "the cutting plane, normal to the spindle axis)",
        )
    return out


def frame_matrix(spindle, feed) -> np.ndarray:
    """(3, 3) columns x_m, y_m, z_m of the machine frame in global coordinates, from the
    spindle direction (z_m) and the feed direction (y_m = -feed); a rotation (det +1)."""
    z = np.asarray(spindle, dtype=float)
    y = -np.asarray(feed, dtype=float)
    y = y - (y @ z) * z
    y = y / np.linalg.norm(y)
    return np.column_stack([np.cross(y, z), y, z])


def check_spindle(machine, bodies: Mapping, hinges, source: str) -> None:
    """The spindle direction must be the model's spindle axis: every beam reached from the tool
    body through beams and virtual bodies (the spindle shaft) lies along it, and a hinge on
    the tool body or that shaft which releases exactly one rotation releases it about the
    spindle axis (the spindle turns about its own axis); the tool body is on the spindle's
    side of the workpiece body."""
    axis = np.asarray(machine.spindle_direction, dtype=float)
    where = Where(source, "machine", error=ModelError)
    shaft, todo, seen = {machine.tool_body}, [machine.tool_body], []
    while todo:
        name = todo.pop()
        for hinge in hinges:
            if name not in hinge.between or hinge in seen:
                continue
            seen.append(hinge)
            other = hinge.between[1] if hinge.between[0] == name else hinge.between[0]
            if bodies.get(other) is not None and bodies[other].kind in ("beam", "virtual"):
                if other not in shaft:
                    shaft.add(other)
                    todo.append(other)
    for name in sorted(shaft - {machine.tool_body}):
        body = bodies[name]
        if body.kind == "beam":
            line = (body.end - body.start) / np.linalg.norm(body.end - body.start)
            _parallel(where, axis, line, f"the spindle beam {name!r} (axis {short_vector(line)})")
    _side(where, axis, bodies[machine.tool_body], bodies[machine.workpiece_body])
    for hinge in seen:
        released = np.flatnonzero(np.asarray(hinge.rotational_stiffness) == 0.0)
        if released.size == 1:
            turn = np.eye(3)[released[0]]
            _parallel(
                where,
                axis,
                turn,
                f"the rotation hinge {hinge.name!r} releases (about {'xyz'[released[0]]})",
            )


def _side(where: Where, axis: np.ndarray, tool, work) -> None:
    """The tool body must lie on the spindle's side of the workpiece body (its centre, or its
    beam's middle, higher along the spindle axis)."""
    heights = [_middle(b) @ axis for b in (tool, work) if _middle(b) is not None]
    if len(heights) == 2 and heights[0] < heights[1]:
        where.fail(
            "spindle_direction",
            f"{short_vector(axis)} points from the tool body {tool.name!r} to the workpiece body "
            f"{work.name!r} (allowed: the direction from the cut towards the spindle, e.g. "
            f"{short_vector(-axis)})",
        )


def _middle(body) -> np.ndarray | None:
    """A rigid body's centre of mass, a beam's middle [m], None for a virtual body."""
    if body.kind == "rigid":
        return np.asarray(body.center_of_mass, dtype=float)
    if body.kind == "beam":
        return 0.5 * (np.asarray(body.start, dtype=float) + body.end)
    return None


def _parallel(where: Where, axis: np.ndarray, line: np.ndarray, what: str) -> None:
    if np.linalg.norm(np.cross(axis, line)) > PARALLEL_TOL:
        where.fail(
            "spindle_direction",
            f"{short_vector(axis)} is not along {what} (allowed: the spindle's axis, the "
            "direction from the cut towards the spindle)",
        )
