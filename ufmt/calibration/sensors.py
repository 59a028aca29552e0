"""The sensors of a modal test checked against the model they are compared with: every sensor
on a material body, near that body and inside the machine.

Each body kind says how far a sensor may sit from it (its ``radius`` and ``check_sensor``):
a rigid body's radius is the larger of the half-diagonal of the uniform box with its
inertia, ``sqrt(1.5 tr(I) / m)`` (the box of sides ``L_x² = 6 (I_y + I_z - I_x) / m`` ...,
whose half-diagonal needs only the trace), and the distance from its centre of mass to its
farthest hinge point, and a sensor may sit up to 1.5 radii from the centre of mass; a beam's
section radius is ``sqrt(2 (I_y + I_z) / A)`` (a solid round section's), and a sensor may
sit up to 2 section radii from the axis and not past its ends; a virtual body carries none.
The machine's box holds every body (centre of mass ± radius, beam ends ± section radius) and
hinge point, grown by BOX_MARGIN of its diagonal on each side; a test whose sensors fall
outside it but would fall inside in another length unit is told so (the unit slip the model
loader also names).
"""

from __future__ import annotations

import numpy as np

from ufmt.errors import StudyError
from ufmt.kinds import beam, kind_of
from ufmt.model.schema import Model
from ufmt.tables import Where

BOX_MARGIN = 0.25  # [-] the machine's box grows by this share of its diagonal on each side
UNIT_HINTS = (("mm", 1e-3), ("cm", 1e-2), ("in", 0.0254))  # units a slip is checked for
BEAM_END = beam.SENSOR_END  # [m] how far past a beam's end a sensor may sit


def machine_box(model: Model) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) corners [m] of the machine's box (module docstring)."""
    lows, highs = [], []
    for body in model.bodies:
        r = kind_of(body).radius(model, body)
        if r is None:
            continue
        points = [np.asarray(p, dtype=float) for p in kind_of(body).points(body).values()]
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
        kind_of(body).check_sensor(where, field, model, body, point)


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
