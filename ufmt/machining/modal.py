"""Modal data for the cutting dynamics from the MSTMM eigen-solution (paper eqs. 3.8-3.13).

The first ``n_modes`` natural frequencies and mass-normalised augmented eigenvectors of the
model become a :class:`~ufmt.machining.basis.ModalBasis`: for every rigid body its
centre-of-mass translation and rotation per mode, unit modal masses (the shapes are
normalised so that ⟨V^s, M V^s⟩ = 1 kg; eq. 3.11 then reads q̈ + D q̇ + ω²q = ⟨f, V^s⟩) and
the model's hinge dampers projected on the modes (:mod:`ufmt.machining.damping`). The modes are
those of the slide where it cuts (:mod:`ufmt.machining.slide`): half way through the leading
arc's cut unless a slide position is given.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ufmt.defaults import DEFAULT_BASIS_CUTOFF_HZ
from ufmt.errors import UfmtError
from ufmt.kinds import frequency_dependent
from ufmt.machining.basis import ModalBasis
from ufmt.machining.damping import hinge_damping_matrix
from ufmt.machining.film_basis import film_basis
from ufmt.machining.machine_frame import in_machine_frame
from ufmt.machining.slide import carriage, cut_slide_position, model_at_slide
from ufmt.model.schema import Model
from ufmt.mstmm.dependent import bounding
from ufmt.mstmm.modes import ModeShapes
from ufmt.mstmm.solve import solve_modes


def modal_basis(
    model: Model,
    n_modes: int | None = None,
    cutoff_hz: float = DEFAULT_BASIS_CUTOFF_HZ,
    slide_y: float | None = None,
) -> ModalBasis:
    """ModalBasis of ``model`` (MSTMM) [SI]: every mode below ``cutoff_hz`` [Hz] (the default
    basis, :mod:`ufmt.defaults`), or the first ``n_modes`` when given (the paper's choice);
    its hinge damping included; with frequency-dependent hinges the Ritz basis of
    :mod:`ufmt.machining.film_basis` (its static and high-frequency models' modes, both by
    ``cutoff_hz`` or ``n_modes``). ``slide_y`` [m]: the slide position the modes are solved at
    (default: half way through the cut, :func:`~ufmt.machining.slide.cut_slide_position`;
    0 for a model without a ``[machine]`` table); body centres stay in the file's coordinates."""
    slide_y, moved = model_where_it_cuts(model, slide_y)

    def solved(m):
        return (
            solve_modes(m, count=n_modes)
            if n_modes is not None
            else solve_modes(m, fmax_hz=cutoff_hz)
        )

    if not frequency_dependent(moved):
        return basis_at_slide(model, moved, slide_y, solved(moved))
    static, high = (solved(bounding(moved, upper=u)).shapes for u in (False, True))
    return _placed(model, film_basis(moved, static, high), slide_y)


def model_where_it_cuts(model: Model, slide_y: float | None = None) -> tuple[float, Model]:
    """The slide position the modes are solved at [m] (``slide_y``, or by default half way
    through the cut; 0 without a ``[machine]`` table) and ``model`` moved there, in its machine
    frame (:mod:`ufmt.machining.machine_frame`)."""
    model = in_machine_frame(model)
    machine = model.machine
    if slide_y is None:
        slide_y = 0.0 if machine is None else cut_slide_position(machine)
    return slide_y, model if slide_y == 0.0 else model_at_slide(model, machine, slide_y)


def basis_at_slide(model: Model, moved: Model, slide_y: float, solution) -> ModalBasis:
    """ModalBasis of ``model`` from the MSTMM ``solution`` (with shapes) of ``moved``, the
    model at slide position ``slide_y`` [m] (:func:`model_where_it_cuts`); body centres back
    in the file's coordinates."""
    model = in_machine_frame(model)
    shapes = solution.shapes
    if shapes is None or shapes.frequencies_hz.size == 0:
        raise UfmtError(f"{model.source}: the model has no elastic modes")
    return _placed(model, basis_from_shapes(shapes, moved), slide_y)


def _placed(model: Model, basis: ModalBasis, slide_y: float) -> ModalBasis:
    """``basis`` solved at slide position ``slide_y`` [m] with the carried body centres back in
    the file's coordinates."""
    if slide_y == 0.0:
        return basis
    model = in_machine_frame(model)
    carried = carriage(model, model.machine.workpiece_body)
    back = np.array([0.0, slide_y, 0.0])  # the carried centres, back to the file's place
    centers = {k: c + back if k in carried else c for k, c in basis.body_centers.items()}
    return replace(basis, body_centers=centers, slide_y=float(slide_y))


def basis_from_shapes(shapes: ModeShapes, model: Model | None = None) -> ModalBasis:
    """ModalBasis of MSTMM mode shapes (unit modal mass, rigid-body motions), with the hinge
    damping of ``model`` (the model the shapes belong to; None: no hinge damping)."""
    n = shapes.frequencies_hz.size
    return ModalBasis(
        omega=shapes.omega,
        modal_mass=np.ones(n),
        body_shapes=dict(shapes.rigid),
        body_centers=dict(shapes.centers),
        hinge_damping=None if model is None else hinge_damping_matrix(model, shapes),
    )
