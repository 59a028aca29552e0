"""The slide where it cuts: the model with its carriage moved to a slide position.

A model file places the workpiece centre under the spindle (slide position Y = 0,
``workpiece_center_xy``). A fly-cutter cuts with the plate under the tool's arc, not under the
spindle: the leading arc is over the plate while Y lies in ``Machine.cutting_span`` (the
packaged machine: -0.326 to -0.273 m, i.e. the slide about one tool radius from Y = 0). The
workpiece material point under the tool tip p sits at p + Y y_hat in the file's coordinates
(:mod:`ufmt.machining.cut_geometry`), so at slide position Y the carriage is displaced by
-Y y_hat from where the file draws it.

The carriage is the workpiece body and every body that reaches the ground only through it or
through a hinge that slides along y (y stiffness 0, e.g. the upper guideways' side air films
on the bed); every hinge on a carried body rides with it (its air pads, the linear motor's
forcer and the clamp plates travel with the slide, the guide surfaces under them are long).
:func:`model_at_slide` moves those bodies and hinge points; stiffness, masses and topology are
unchanged, so the MSTMM and the assembled model solve it as any other file.

Downstream code keeps the file's coordinates for the workpiece (the arm of the material point
is p - C + Y y_hat with C the centre the file gives): :func:`ufmt.machining.modal.modal_basis`
and :func:`ufmt.machining.static.residual_flexibility` solve the moved model and relabel the
carried bodies' centres back to the file's (a rigid translation changes no rigid-body motion).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ufmt.kinds import kind_of
from ufmt.model.machine import Machine
from ufmt.model.schema import GROUND, Model, frozen_array
from ufmt.recent import Recent

#: Moved bodies per (bodies of a loaded model, its hinges' places, the shift): the designs of
#: a stiffness study share their bodies, and so their assembled and static structure.
_MOVED = Recent(8)


def cut_slide_positions(machine: Machine) -> tuple[float, float, float]:
    """Slide positions Y [m] at the start, the middle and the end of the leading arc's cut
    (``Machine.cutting_span``)."""
    start, end = machine.cutting_span
    return start, 0.5 * (start + end), end


def cut_slide_position(machine: Machine) -> float:
    """Slide position Y [m] half way through the leading arc's cut: where the default modal
    basis is computed (see docs/ufmt-model.md, 'The slide where it cuts')."""
    return cut_slide_positions(machine)[1]


def carriage(model: Model, workpiece_body: str) -> frozenset[str]:
    """Names of the bodies the slide carries: the workpiece body and every body that reaches
    the ground only through it or through hinges that slide along y (y stiffness 0)."""
    links: dict[str, set[str]] = {}
    for hinge in model.hinges:
        if hinge.stiffness6[1] == 0.0 or workpiece_body in hinge.between:
            continue
        a, b = hinge.between
        links.setdefault(a, set()).add(b)
        links.setdefault(b, set()).add(a)
    grounded, todo = {GROUND}, [GROUND]
    while todo:
        for other in links.get(todo.pop(), ()):
            if other not in grounded:
                grounded.add(other)
                todo.append(other)
    return frozenset(b.name for b in model.bodies if b.name not in grounded)


def model_at_slide(model: Model, machine: Machine, slide_y: float) -> Model:
    """``model`` with its carriage at slide position ``slide_y`` [m] (displaced by -slide_y
    along y from the file's place); the model itself when ``slide_y`` is 0."""
    if slide_y == 0.0:
        return model
    moved = carriage(model, machine.workpiece_body)
    shift = np.array([0.0, -float(slide_y), 0.0])
    key = (model.bodies, tuple(h.at.tobytes() for h in model.hinges), shift.tobytes())
    bodies = _MOVED.get(
        key, lambda: tuple(_moved(b, shift) if b.name in moved else b for b in model.bodies)
    )
    hinges = tuple(
        replace(h, at=frozen_array(h.at + shift)) if _rides(model, h, moved) else h
        for h in model.hinges
    )
    return replace(model, bodies=bodies, hinges=hinges)


def _rides(model: Model, hinge, moved: frozenset[str]) -> bool:
    """True if ``hinge`` travels with the carriage: it is on a carried body and not on the end
    of a stationary beam (a hinge on a beam sits at the beam's end)."""
    if not moved.intersection(hinge.between):
        return False
    return not any(
        name != GROUND and name not in moved and kind_of(model.body(name)).HINGES_AT_ENDS
        for name in hinge.between
    )


def _moved(body, shift: np.ndarray):
    """``body`` translated by ``shift`` [m] (a virtual body: unchanged, its hinges carry it)."""
    return kind_of(body).moved(body, shift)
