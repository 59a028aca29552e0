"""A model moved rigidly: every point of the file in the one global frame shifted by a vector."""

from dataclasses import replace

import numpy as np

from ufmt.model.schema import Beam, RigidBody, frozen_array


def translated(model, shift):
    """``model`` with every body, hinge point and machine point moved by ``shift`` (3,) [m]."""
    shift = np.asarray(shift, dtype=float)

    def body(b):
        if isinstance(b, RigidBody):
            return replace(b, center_of_mass=frozen_array(b.center_of_mass + shift))
        if isinstance(b, Beam):
            return replace(b, start=frozen_array(b.start + shift), end=frozen_array(b.end + shift))
        return b

    machine = model.machine
    if machine is not None:
        machine = replace(
            machine,
            spindle_axis_xy=tuple(float(v) for v in np.add(machine.spindle_axis_xy, shift[:2])),
            workpiece_center_xy=tuple(
                float(v) for v in np.add(machine.workpiece_center_xy, shift[:2])
            ),
            cutting_plane_z=float(machine.cutting_plane_z + shift[2]),
        )
    return replace(
        model,
        bodies=tuple(body(b) for b in model.bodies),
        hinges=tuple(replace(h, at=frozen_array(h.at + shift)) for h in model.hinges),
        machine=machine,
    )
