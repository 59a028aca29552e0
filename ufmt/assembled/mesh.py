"""Beams of the assembled model: 3-D frame elements (stiffness and consistent mass;
Euler-Bernoulli, or a Timoshenko beam's bending from :mod:`ufmt.kinds.timoshenko`) and the
automatic mesh that keeps their frequency error below a target."""

from __future__ import annotations

import math

import numpy as np

from ufmt.kinds.timoshenko import planes
from ufmt.model.schema import Beam

DEFAULT_ELEMENTS_PER_BEAM = 8  # mesh when neither elements_per_beam nor a frequency is given
MIN_ELEMENTS_PER_BEAM = 2
MAX_ELEMENTS_PER_BEAM = 64  # cap of the automatic mesh (cost); see AssembledModel.mesh_error
DEFAULT_RTOL = 1e-8  # target relative frequency error of the automatic mesh below fmax
# Consistent-mass discretisation error of a mode at wavenumber k, element length h (checked in
# tests/test_assembled.py on a cantilever and a fixed-free rod):
#   bending, cubic Hermite:  df/f ~= (beta h)^4 / BENDING_ERROR_DIVISOR
#   axial and torsion, linear:  df/f ~= (k h)^2 / LINEAR_ERROR_DIVISOR
BENDING_ERROR_DIVISOR = 1440.0
LINEAR_ERROR_DIVISOR = 24.0
PARALLEL_SINE = 1e-9  # beam axis taken as parallel to global z below this |sin angle|


def beam_frame(beam: Beam) -> np.ndarray:
    """Rows e1, e2, e3 of the beam's local frame (``local = frame @ global``).

    e1 along start -> end; e2 the orientation vector (default global z, or global x when the
    axis is vertical) made orthogonal to e1; e3 = e1 x e2.
    """
    e1 = (beam.end - beam.start) / beam.length
    ref = beam.orientation
    if ref is None:
        vertical = math.hypot(e1[0], e1[1]) <= PARALLEL_SINE  # |e1 x z|
        ref = np.array([1.0, 0.0, 0.0]) if vertical else np.array([0.0, 0.0, 1.0])
    e2 = ref - (ref @ e1) * e1
    e2 = e2 / np.linalg.norm(e2)
    e3 = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ]
    return np.array([e1, e2, e3])


# frame-element dofs (node 1 then node 2, local axes) of each deformation
AXIAL, TORSION = np.ix_([0, 6], [0, 6]), np.ix_([3, 9], [3, 9])
BENDING_XY, BENDING_XZ = np.ix_([1, 5, 7, 11], [1, 5, 7, 11]), np.ix_([2, 4, 8, 10], [2, 4, 8, 10])


def frame_element(beam: Beam, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Local 12x12 stiffness and consistent mass of a frame element of length h [m].

    Dofs ``[u v w theta_x theta_y theta_z]`` of node 1 then node 2 in the beam's local axes,
    with ``theta_z = dv/dx`` and ``theta_y = -dw/dx``; second_moment_z acts in the x-y plane.
    Returns (k [N/m, N, N m], m [kg, kg m, kg m^2]).
    """
    e, g, rho, a = beam.youngs_modulus, beam.shear_modulus, beam.density, beam.area
    k = np.zeros((12, 12))
    m = np.zeros((12, 12))
    rod_k = np.array([[1.0, -1.0], [-1.0, 1.0]])
    rod_m = np.array([[2.0, 1.0], [1.0, 2.0]]) * h / 6.0
    for idx, stiffness, inertia in (
        (AXIAL, e * a / h, rho * a),
        (TORSION, g * beam.torsion_constant / h, rho * beam.polar_moment),
    ):
        k[idx] += stiffness * rod_k
        m[idx] += inertia * rod_m
    bend_k = (
        np.array(
            [
                [12.0, 6 * h, -12.0, 6 * h],
                [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                [-12.0, -6 * h, 12.0, -6 * h],
                [6 * h, 2 * h * h, -6 * h, 4 * h * h],
            ]
        )
        / h**3
    )
    bend_m = np.array(
        [
            [156.0, 22 * h, 54.0, -13 * h],
            [22 * h, 4 * h * h, 13 * h, -3 * h * h],
            [54.0, 13 * h, 156.0, -22 * h],
            [-13 * h, -3 * h * h, -22 * h, 4 * h * h],
        ]
    ) * (rho * a * h / 420.0)
    flip = np.array([1.0, -1.0, 1.0, -1.0])  # theta_y = -dw/dx
    flip = flip[:, None] * flip
    if beam.timoshenko:  # shear deformation and rotary inertia (Przemieniecki's element)
        (k_xy, m_xy), (k_xz, m_xz) = (plane.element(h) for plane in planes(beam))
        k[BENDING_XY], m[BENDING_XY] = k_xy, m_xy
        k[BENDING_XZ], m[BENDING_XZ] = k_xz * flip, m_xz * flip
        return k, m
    k[BENDING_XY] += e * beam.second_moment_z * bend_k  # x-y plane: v, theta_z
    m[BENDING_XY] += bend_m
    k[BENDING_XZ] += e * beam.second_moment_y * (bend_k * flip)  # x-z plane: w, theta_y
    m[BENDING_XZ] += bend_m * flip
    return k, m


def _wavenumbers(beam: Beam, fmax_hz: float) -> tuple[float, float]:
    """Bending and largest of axial/torsional wavenumber [1/m] at fmax_hz."""
    omega = 2.0 * math.pi * fmax_hz
    rho, e = beam.density, beam.youngs_modulus
    weakest = min(beam.second_moment_y, beam.second_moment_z)
    bending = (omega**2 * rho * beam.area / (e * weakest)) ** 0.25
    if beam.timoshenko:  # shear makes the bending waves shorter
        bending = max(bending, *(plane.wavenumber(omega) for plane in planes(beam)))
    axial = omega * math.sqrt(rho / e)
    torsion = omega * math.sqrt(
        rho * beam.polar_moment / (beam.shear_modulus * beam.torsion_constant)
    )
    return bending, max(axial, torsion)


def mesh_error(beam: Beam, elements: int, fmax_hz: float) -> float:
    """Estimated worst relative frequency error of modes below fmax_hz [Hz] for this mesh.

    ``max((beta h)^4 / BENDING_ERROR_DIVISOR, (k h)^2 / LINEAR_ERROR_DIVISOR)`` with beta the
    bending and k the larger of the axial and torsional wavenumbers at fmax_hz; it bounds a mode
    whose energy is all in this beam (others are proportionally better). Errors are positive:
    consistent mass makes every frequency an upper bound (Rayleigh-Ritz).
    """
    h = beam.length / elements
    bending, linear = _wavenumbers(beam, fmax_hz)
    return max((bending * h) ** 4 / BENDING_ERROR_DIVISOR, (linear * h) ** 2 / LINEAR_ERROR_DIVISOR)


def elements_for(beam: Beam, fmax_hz: float, rtol: float = DEFAULT_RTOL) -> int:
    """Fewest frame elements with :func:`mesh_error` <= rtol at fmax_hz (uncapped, >= 2).

    The element length h satisfies ``beta h <= (BENDING_ERROR_DIVISOR rtol)^(1/4)`` and
    ``k h <= (LINEAR_ERROR_DIVISOR rtol)^(1/2)``.
    """
    bending, linear = _wavenumbers(beam, fmax_hz)
    h = min(
        (BENDING_ERROR_DIVISOR * rtol) ** 0.25 / bending if bending > 0 else math.inf,
        math.sqrt(LINEAR_ERROR_DIVISOR * rtol) / linear if linear > 0 else math.inf,
    )
    return max(MIN_ELEMENTS_PER_BEAM, math.ceil(beam.length / h) if h < math.inf else 0)
