"""Assembled mass-stiffness model: the "ordinary method" cross-check of the MSTMM.

An independent finite-element model of the same :class:`~ufmt.model.schema.Model` (it shares
no code with :mod:`ufmt.mstmm`):

* 6 dofs per rigid body (translation of its centre of mass and small rotation, global frame),
  6 per virtual body (at its point), 6 per node of each beam's mesh;
* beams meshed with 3-D Euler-Bernoulli frame elements: 12x12 stiffness and consistent mass
  (axial and torsion linear, bending cubic Hermite in the local x-y and x-z planes, torsional
  rotary inertia rho*J_p; no shear deformation, no bending rotary inertia: the beam of paper
  eq. 3.3);
* hinges as springs on the relative motion ``d = u_A(P) - u_B(P)`` of the two bodies at the
  hinge point P (paper eqs. 2.13, 2.14), with ``u(P) = [r_C + theta x (P - C); theta]`` for a
  rigid body: stiffness 0 adds nothing (released), ``inf`` imposes ``d_j = 0`` exactly by
  eliminating dependent dofs, a finite value adds ``k_j d_j^2 / 2`` to the strain energy;
* massless dofs (virtual bodies) condensed exactly; rigid-body and mechanism modes counted.

Numerics. The stiffness is kept in the factored form ``K = F^T F`` (``F``: square-root-weighted
deformations of every spring direction and every element) and the frequencies are the singular
values of ``F_red L^-T`` (``M_red = L L^T``), not eigenvalues of ``(K, M)``: with a fine beam
mesh ``K`` has ``lambda_max / lambda_1 ~ 1e12`` and ``eigh`` loses ``eps * lambda_max`` in every
eigenvalue, while the singular values lose ``eps * sqrt(lambda_max)``. Zero-frequency modes
are counted from the rank of the unweighted deformations (geometry only, no stiffness scale).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from ufmt.errors import ModelError
from ufmt.model.schema import GROUND, Beam, Model, RigidBody, VirtualBody

COMPONENTS = ("x", "y", "z", "rx", "ry", "rz")

DEFAULT_ELEMENTS_PER_BEAM = 8  # mesh when neither elements_per_beam nor a frequency is given
MIN_ELEMENTS_PER_BEAM = 2
DEFAULT_RTOL = 1e-8  # target relative frequency error of the automatic mesh below fmax
# Consistent-mass discretisation error per element of length h at wavenumber k (measured on a
# free-free beam and a fixed-free rod, see tests/test_assembled.py):
#   bending (cubic Hermite): df/f ~= (beta h)^4 / BENDING_ERROR_DIVISOR
#   axial, torsion (linear): df/f ~= (k h)^2 / 24
BENDING_ERROR_DIVISOR = 2880.0
LINEAR_ERROR_DIVISOR = 24.0
PARALLEL_SINE = 1e-9  # beam axis treated as parallel to global z below this |sin angle|
RANK_RTOL = 1e-9  # rank of geometric (unweighted) matrices, relative to the largest value
PIVOT_PREFERENCE = 1e3  # column weight that makes massless dofs the dependent ones


# ---------------------------------------------------------------------------------------------
# geometry and elements


def _skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrix: ``_skew(a) @ b == a x b`` (paper eq. 2.10)."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def point_motion(offset: np.ndarray) -> np.ndarray:
    """6x6 map from ``[r_C; theta]`` to ``[r_C + theta x offset; theta]`` (paper eq. 2.5).

    offset [m]: vector from the reference point C to the point P.
    """
    t = np.eye(6)
    t[:3, 3:] = -_skew(offset)
    return t


def beam_frame(beam: Beam) -> np.ndarray:
    """Rows e1, e2, e3 of the beam's local frame (local = frame @ global).

    e1 along start -> end; e2 the orientation vector (default global z, global x when the axis
    is vertical) projected off e1; e3 = e1 x e2.
    """
    e1 = (beam.end - beam.start) / beam.length
    ref = beam.orientation
    if ref is None:
        z = np.array([0.0, 0.0, 1.0])
        ref = z if np.linalg.norm(np.cross(e1, z)) > PARALLEL_SINE else np.array([1.0, 0, 0])
    e2 = ref - (ref @ e1) * e1
    e2 = e2 / np.linalg.norm(e2)
    return np.array([e1, e2, np.cross(e1, e2)])


def frame_element(beam: Beam, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Local 12x12 stiffness and consistent mass of a frame element of length h [m].

    Dofs ``[u v w theta_x theta_y theta_z]`` at node 1 then node 2, local axes; theta_z = dv/dx,
    theta_y = -dw/dx. Returns (k [N/m, N, N m], m [kg, kg m, kg m^2]).
    """
    e, g, rho, a = beam.youngs_modulus, beam.shear_modulus, beam.density, beam.area
    k = np.zeros((12, 12))
    m = np.zeros((12, 12))
    rod_k = np.array([[1.0, -1.0], [-1.0, 1.0]])
    rod_m = np.array([[2.0, 1.0], [1.0, 2.0]]) * h / 6.0
    for idx, stiff, inertia in (
        ([0, 6], e * a / h, rho * a),  # axial
        ([3, 9], g * beam.torsion_constant / h, rho * beam.polar_moment),  # torsion
    ):
        k[np.ix_(idx, idx)] += stiff * rod_k
        m[np.ix_(idx, idx)] += inertia * rod_m
    hb_k = np.array(
        [
            [12.0, 6 * h, -12.0, 6 * h],
            [6 * h, 4 * h * h, -6 * h, 2 * h * h],
            [-12.0, -6 * h, 12.0, -6 * h],
            [6 * h, 2 * h * h, -6 * h, 4 * h * h],
        ]
    )
    hb_m = np.array(
        [
            [156.0, 22 * h, 54.0, -13 * h],
            [22 * h, 4 * h * h, 13 * h, -3 * h * h],
            [54.0, 13 * h, 156.0, -22 * h],
            [-13 * h, -3 * h * h, -22 * h, 4 * h * h],
        ]
    ) * (rho * a * h / 420.0)
    flip = np.diag([1.0, -1.0, 1.0, -1.0])  # theta_y = -dw/dx
    for idx, second, sign in (
        ([1, 5, 7, 11], beam.second_moment_z, np.eye(4)),  # x-y plane: v, theta_z
        ([2, 4, 8, 10], beam.second_moment_y, flip),  # x-z plane: w, theta_y
    ):
        k[np.ix_(idx, idx)] += (e * second / h**3) * (sign @ hb_k @ sign)
        m[np.ix_(idx, idx)] += sign @ hb_m @ sign
    return k, m


def elements_for(beam: Beam, fmax_hz: float, rtol: float = DEFAULT_RTOL) -> int:
    """Number of frame elements that keeps modes below fmax within ~rtol relative error.

    With omega = 2 pi fmax, the bending wavenumber beta = (omega^2 rho A / (E I_min))^(1/4) and
    the axial and torsional wavenumbers k = omega sqrt(rho/E), omega sqrt(rho J_p/(G J_t)),
    the element length h satisfies (beta h)^4 / BENDING_ERROR_DIVISOR <= rtol and
    (k h)^2 / LINEAR_ERROR_DIVISOR <= rtol; at least MIN_ELEMENTS_PER_BEAM elements.
    Consistent mass makes every frequency converge from above (Rayleigh-Ritz).
    """
    omega = 2.0 * math.pi * fmax_hz
    rho, e = beam.density, beam.youngs_modulus
    beta = (omega**2 * rho * beam.area / (e * min(beam.second_moment_y, beam.second_moment_z))) ** 0.25
    k_axial = omega * math.sqrt(rho / e)
    k_torsion = omega * math.sqrt(rho * beam.polar_moment / (beam.shear_modulus * beam.torsion_constant))
    h_bending = (BENDING_ERROR_DIVISOR * rtol) ** 0.25 / beta if beta > 0 else math.inf
    h_linear = math.sqrt(LINEAR_ERROR_DIVISOR * rtol) / max(k_axial, k_torsion, 1e-300)
    return max(MIN_ELEMENTS_PER_BEAM, math.ceil(beam.length / min(h_bending, h_linear)))


