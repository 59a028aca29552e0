"""A model seen in its machine frame: every machining formula works there.

The machining code (eq. 4.1, the cutting force, the slide, the error sources, the static
correction, the FRF's tool-workpiece end) is written with z along the spindle axis and the
workpiece fed along -y (:mod:`ufmt.model.orientation`). :func:`in_machine_frame` rotates a
model whose ``[machine]`` names another spindle or feed direction into that frame, p_m = F^T p
(F: :attr:`~ufmt.model.machine.Machine.frame`): centres of mass, inertia tensors F^T J F,
beam ends and section orientations, hinge points, hinge springs and dampers, gravity. A
rotation changes no natural frequency, and the machining then sees the machine it was written
for. A model with the default directions is returned as it is (the same object).

A hinge's springs act along the global axes; a machine axis that mixes global axes needs the
same value on each of them (a spindle off the global axes on an isotropic hinge), else the
hinge cannot be written in the machine frame and the model is refused.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ufmt.errors import ModelError
from ufmt.kinds import hinge_kind_of, kind_of
from ufmt.model.orientation import DIRECTION_FIELDS
from ufmt.model.schema import Model, frozen_array
from ufmt.recent import Recent
from ufmt.tables import short_vector

#: |F_ij| below this: machine axis j has no share of global axis i.
MIX_TOL = 1e-12
#: Rotated bodies per (bodies of a loaded model, frame): the designs of a study share them, so
#: the static structure cached by body identity (:mod:`ufmt.machining.static`) is reused.
_ROTATED = Recent(8)
#: Models in their machine frame per loaded model (models are immutable, hashed by identity):
#: the caches keyed by model (the carriage's load, the residual) see one object per model.
_FRAMED = Recent(8)


def in_machine_frame(model: Model) -> Model:
    """``model`` in the machine frame of its ``[machine]`` table (itself when that frame is the
    global one or the model has no ``[machine]``); ModelError names a hinge whose springs
    cannot be written along the machine's axes."""
    machine = model.machine
    if machine is None or machine.upright:
        return model
    return _FRAMED.get(model, lambda: _rotated(model))


def _rotated(model: Model) -> Model:
    """``model`` rotated into its machine frame (see :func:`in_machine_frame`)."""
    machine = model.machine
    frame = machine.frame
    bodies = _ROTATED.get(
        (model.bodies, frame.tobytes()), lambda: tuple(_body(b, frame) for b in model.bodies)
    )
    hinges = tuple(_hinge(h, frame, model.source) for h in model.hinges)
    gravity = tuple(float(g) for g in frame.T @ machine.gravity_direction)
    table = {k: v for k, v in machine.table.items() if k not in DIRECTION_FIELDS}
    table["gravity_direction"] = list(gravity)  # the table reads back as this machine
    machine = replace(
        machine,
        spindle_direction=DIRECTION_FIELDS["spindle_direction"],
        feed_direction=DIRECTION_FIELDS["feed_direction"],
        gravity_direction=gravity,
        table=table,
    )
    return replace(model, bodies=bodies, hinges=hinges, machine=machine)


def to_machine(points, frame: np.ndarray) -> np.ndarray:
    """Machine-frame coordinates (..., 3) of global points or vectors (..., 3)."""
    return np.asarray(points, dtype=float) @ frame


def _body(body, frame: np.ndarray):
    """``body`` rotated into the machine frame (its kind's own rotation)."""
    return kind_of(body).rotated(body, frame)


def _hinge(hinge, frame: np.ndarray, source: str):
    """``hinge`` in the machine frame: its point rotated, its diagonal springs and dampers
    along the machine's axes."""
    fields = ("stiffness", "rotational_stiffness", "damping", "rotational_damping")
    changes = {
        f: frozen_array(_along(getattr(hinge, f), frame, hinge.name, f, source)) for f in fields
    }
    moved = replace(hinge, at=frozen_array(to_machine(hinge.at, frame)), **changes)
    return hinge_kind_of(hinge).rotated(moved, lambda v, f: _along(v, frame, hinge.name, f, source))


def _along(values, frame: np.ndarray, name: str, field: str, source: str) -> np.ndarray:
    """Diagonal ``values`` along global x, y, z as a diagonal along the machine's axes: F^T
    diag(values) F is diagonal when every machine axis mixes only equal values."""
    values = np.asarray(values, dtype=float)
    out = np.empty(3)
    for j in range(3):
        mixed = values[np.abs(frame[:, j]) > MIX_TOL]
        if np.any(mixed != mixed[0]):
            raise ModelError(
                f"{source}: hinge {name!r}: field {field!r}: {short_vector(values)} along global "
                f"x, y, z cannot act along the machine's axis {'xyz'[j]} "
                f"{short_vector(frame[:, j])} (allowed: equal values on the global axes it "
                "mixes; [machine] spindle_direction and feed_direction along global axes)"
            )
        out[j] = mixed[0]
    return out
