"""Assembled mass-stiffness model: the "ordinary method" cross-check of the MSTMM.

An independent finite-element model of the same :class:`~ufmt.model.schema.Model`; it imports
nothing from :mod:`ufmt.mstmm`: both take the body kinds of :mod:`ufmt.kinds`, the MSTMM their
exact formulations, this model their finite elements, and the rigid-point kinematics
(:mod:`ufmt.kinematics`). Modules: :mod:`~ufmt.assembled.mesh` (frame elements from a member's
parts, automatic mesh), :mod:`~ufmt.assembled.bodies` (how each body form enters),
:mod:`~ufmt.assembled.matrices` (dofs, K, M, hinge relative motion: :func:`assemble`),
:mod:`~ufmt.assembled.constraints` (rigid directions, massless split, zero-mode count),
:mod:`~ufmt.assembled.solve` (condensation and singular values: :func:`assembled_modes`).

* 6 dofs per rigid body (translation of its centre of mass and small rotation, global frame),
  6 per virtual body (at its point), 6 per node of each beam's mesh.
* Beams: 3-D frame elements, 12x12 stiffness and consistent mass (axial and torsion linear,
  torsional rotary inertia rho*J_p; bending in the local x-y and x-z planes by the element of
  the beam's theory: cubic Hermite for the beam of paper eq. 3.3, Przemieniecki's shear
  element for a Timoshenko beam).
* Hinges (paper eqs. 2.13, 2.14): springs on the relative motion ``d = u_A(P) - u_B(P)`` of the
  two bodies at the hinge point P, where ``u(P) = [r_C + theta x (P - C); theta]`` for a rigid
  body and a virtual body or beam end moves with its own 6 dofs; ground does not move.
  Stiffness 0 adds nothing (released), ``inf`` imposes ``d_j = 0`` exactly (dependent dofs
  eliminated), a finite k adds ``k d_j^2 / 2`` to the strain energy.
* Massless dofs (virtual bodies) are condensed exactly; zero-frequency (rigid-body and
  mechanism) modes are counted and left out of the frequency list.

Numerics. The stiffness is kept factored, ``K = F^T F`` (F: square-root-weighted deformation
of every spring direction and every beam element), and the natural frequencies are the singular
values of ``F_red L^-T`` (``L L^T`` the reduced mass matrix) instead of eigenvalues of
``(K_red, M_red)``: with a fine beam mesh ``lambda_max / lambda_1`` reaches 1e12 and ``eigh``
loses ``eps * lambda_max`` in every eigenvalue (relative errors 1e-8 to 1e-6 on a 64- to
256-element cantilever), the singular values only ``eps * sqrt(lambda_max)``. The number of
zero-frequency modes comes from geometry alone (which motions strain nothing), never from a
threshold on small frequencies.
"""

from ufmt.assembled.matrices import AssembledModel, assemble
from ufmt.assembled.solve import (
    AssembledModes,
    Structure,
    assembled_modes,
    reduced_matrices,
    structure,
    svd,
)
from ufmt.kinematics import point_motion  # the point map this model is built on (machining uses it)

__all__ = [
    "AssembledModel",
    "AssembledModes",
    "Structure",
    "assemble",
    "assembled_modes",
    "point_motion",
    "reduced_matrices",
    "structure",
    "svd",
]
