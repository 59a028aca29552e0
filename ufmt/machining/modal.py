"""Modal data for the cutting dynamics from the MSTMM eigen-solution (paper eqs. 3.8-3.13).

The first ``n_modes`` natural frequencies and mass-normalised augmented eigenvectors of the
model become a :class:`~ufmt.machining.basis.ModalBasis`: for every rigid body its
centre-of-mass translation and rotation per mode, unit modal masses (the shapes are
normalised so that ⟨V^s, M V^s⟩ = 1 kg; eq. 3.11 then reads q̈ + D q̇ + ω²q = ⟨f, V^s⟩) and
the model's hinge dampers projected on the modes (:mod:`ufmt.machining.damping`).
"""

from __future__ import annotations

import numpy as np

from ufmt.defaults import DEFAULT_BASIS_CUTOFF_HZ
from ufmt.errors import UfmtError
from ufmt.machining.basis import ModalBasis
from ufmt.machining.damping import hinge_damping_matrix
from ufmt.model.schema import Model
from ufmt.mstmm.modes import ModeShapes
from ufmt.mstmm.solve import solve_modes


def modal_basis(
    model: Model, n_modes: int | None = None, cutoff_hz: float = DEFAULT_BASIS_CUTOFF_HZ
) -> ModalBasis:
    """ModalBasis of ``model`` (MSTMM) [SI]: every mode below ``cutoff_hz`` [Hz] (the default
    basis, :mod:`ufmt.defaults`), or the first ``n_modes`` when given (the paper's choice);
    its hinge damping included."""
    solution = (
        solve_modes(model, count=n_modes)
        if n_modes is not None
        else solve_modes(model, fmax_hz=cutoff_hz)
    )
    shapes = solution.shapes
    if shapes is None or shapes.frequencies_hz.size == 0:
        raise UfmtError(f"{model.source}: the model has no elastic modes")
    return basis_from_shapes(shapes, model)


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
