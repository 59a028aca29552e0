"""The sensors of a modal test checked against the model they are compared with: every sensor
on a material body, near that body and inside the machine.

A rigid body carries no geometry but its mass, inertia and hinges: its radius is the larger of
the half-diagonal of the uniform box with its inertia, ``sqrt(1.5 tr(I) / m)`` (the box of
sides ``L_x² = 6 (I_y + I_z - I_x) / m`` ..., whose half-diagonal needs only the trace), and
the distance from its centre of mass to its farthest hinge point. A sensor may sit up to
RIGID_MARGIN radii from the centre of mass. A beam's section radius is ``sqrt(2 (I_y + I_z) /
A)`` (the radius of a solid round section); a sensor may sit up to BEAM_MARGIN section radii
from the axis and not past its ends. The machine's box holds every body (centre of mass ±
radius, beam ends ± section radius) and hinge point, grown by BOX_MARGIN of its diagonal on
each side; a test whose sensors fall outside it but would fall inside in another length unit
is told so (the unit slip the model loader also names).
"""

from __future__ import annotations

import numpy as np

from ufmt.errors import StudyError
from ufmt.model.schema import Beam, Model, RigidBody
from ufmt.tables import Where

RIGID_MARGIN = 1.5  # [-] body radii from a rigid body's centre of mass a sensor may sit
BEAM_MARGIN = 2.0  # [-] section radii from a beam's axis a sensor may sit
BEAM_END = 1e-6  # [m] how far past a beam's end a sensor may sit and still be on it
BOX_MARGIN = 0.25  # [-] the machine's box grows by this share of its diagonal on each side
UNIT_HINTS = (("mm", 1e-3), ("cm", 1e-2), ("in", 0.0254))  # units a slip is checked for


def body_radius(model: Model, body) -> float:
    """A rigid body's radius [m] or a beam's section radius [m] (module docstring)."""
    if isinstance(body, Beam):
        return float(np.sqrt(2.0 * (body.second_moment_y + body.second_moment_z) / body.area))
    box = np.sqrt(1.5 * np.trace(body.inertia) / body.mass)
    centre = np.asarray(body.center_of_mass, dtype=float)
    hinges = [np.linalg.norm(h.at - centre) for h in model.hinges if body.name in h.between]
    return float(max([box, *hinges]))


def machine_box(model: Model) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) corners [m] of the machine's box (module docstring)."""
    lows, highs = [], []
    for body in model.bodies:
        if isinstance(body, RigidBody):
            points = [np.asarray(body.center_of_mass, dtype=float)]
        elif isinstance(body, Beam):
            points = [np.asarray(body.start, float), np.asarray(body.end, float)]
        else:
            continue
        r = body_radius(model, body)
        lows += [p - r for p in points]
        highs += [p + r for p in points]
    lows += [np.asarray(h.at, float) for h in model.hinges]
    highs += [np.asarray(h.at, float) for h in model.hinges]
    low, high = np.min(lows, axis=0), np.max(highs, axis=0)
    grow = BOX_MARGIN * float(np.linalg.norm(high - low))
    return low - grow, high + grow


def check_sensors(model: Model, sensors, source: str = "") -> None:
    """Refuse (one line naming the test file and the sensor) a sensor on an unknown or
    virtual body, off its body or outside the machine (module docstring)."""
    where = Where(source or "modal test", error=StudyError)
    if not sensors:
        return
    positions = np.array([s.position for s in sensors], dtype=float)
    low, high = machine_box(model)
    inside = np.all((positions >= low) & (positions <= high), axis=1)
    if not inside.all():
        j = int(np.flatnonzero(~inside)[0])
        box = ", ".join(
            f"{a} {lo:.3g}..{hi:.3g}" for a, lo, hi in zip("xyz", low, high, strict=True)
        )
        where.fail(
            f"sensor {sensors[j].label}",
            f"outside the machine ({box} m){_unit_hint(positions, low, high)}",
        )
    names = [b.name for b in model.bodies]
    for sensor, point in zip(sensors, positions, strict=True):
        field = f"sensor {sensor.label}"
        body = model.body(where.choice(field, sensor.body, names, "body"))
        if isinstance(body, RigidBody):
            radius = body_radius(model, body)
            off = float(np.linalg.norm(point - body.center_of_mass))
            if off > RIGID_MARGIN * radius:
                where.fail(
                    field,
                    f"{off:.3g} m from the centre of mass of {body.name!r}, whose points lie "
                    f"within {radius:.3g} m of it (allowed: <= {RIGID_MARGIN:g} x that)",
                )
        elif isinstance(body, Beam):
            _check_on_beam(where, field, model, body, point)
        else:
            where.fail(field, f"body {body.name!r} is {body.kind}: it has no material point")


def _check_on_beam(where: Where, field: str, model: Model, beam: Beam, point) -> None:
    """A beam sensor between the beam's ends and within BEAM_MARGIN section radii of its
    axis."""
    start, end = np.asarray(beam.start, float), np.asarray(beam.end, float)
    length = float(np.linalg.norm(end - start))
    axis = (end - start) / length
    s = float((point - start) @ axis)
    if not -BEAM_END <= s <= length + BEAM_END:
        where.fail(
            field, f"the point is {s:.4g} m along beam {beam.name!r} of length {length:.4g} m"
        )
    off = float(np.linalg.norm(point - start - s * axis))
    radius = body_radius(model, beam)
    if off > BEAM_MARGIN * radius:
        where.fail(
            field,
            f"{off:.3g} m from the axis of beam {beam.name!r} of section radius {radius:.3g} m "
            f"(allowed: <= {BEAM_MARGIN:g} x that)",
        )


def _unit_hint(positions, low, high) -> str:
    """``: positions look like mm: did you mean --test-unit mm?`` when every sensor falls
    inside the box in that unit, else empty."""
    for unit, metres in UNIT_HINTS:
        scaled = positions * metres
        if np.all((scaled >= low) & (scaled <= high)):
            return (
                f"; the positions look like {unit}: did you mean --test-unit {unit} "
                f"(unit={unit!r})?"
            )
    return ""
