"""Members of the assembled model: 3-D frame elements (stiffness and consistent mass), each
member's parts' finite elements (:func:`ufmt.kinds.beam.parts`: rods, bending planes of its
theory) put in place, and the automatic mesh that keeps their frequency error below a target
(each part's element length rule)."""

from __future__ import annotations

import math

import numpy as np

from ufmt.kinds import kind_of
from ufmt.model.schema import Body

DEFAULT_ELEMENTS_PER_BEAM = 8  # mesh when neither elements_per_beam nor a frequency is given
MIN_ELEMENTS_PER_BEAM = 2
MAX_ELEMENTS_PER_BEAM = 64  # cap of the automatic mesh (cost); see AssembledModel.mesh_error
DEFAULT_RTOL = 1e-8  # target relative frequency error of the automatic mesh below fmax


def beam_frame(beam: Body) -> np.ndarray:
    """Rows e1, e2, e3 of the member's local frame (``local = frame @ global``): its kind's
    ``local_frame`` from start to end (e1 along the axis, e2 the section's local y axis)."""
    return kind_of(beam).local_frame(beam, beam.start, beam.end).T


def frame_element(beam: Body, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Local 12x12 stiffness and consistent mass of a frame element of length h [m]: each
    part's element (``formulation.element(h)``) at its end dofs with its signs.

    Dofs ``[u v w theta_x theta_y theta_z]`` of node 1 then node 2 in the beam's local axes,
    with ``theta_z = dv/dx`` and ``theta_y = -dw/dx``; second_moment_z acts in the x-y plane.
    Returns (k [N/m, N, N m], m [kg, kg m, kg m^2]).
    """
    k = np.zeros((12, 12))
    m = np.zeros((12, 12))
    for part in kind_of(beam).parts(beam):
        k_part, m_part = part.formulation.element(h)
        at = np.ix_(part.ends, part.ends)
        if np.any(part.end_signs < 0):
            flip = part.end_signs[:, None] * part.end_signs
            k_part, m_part = k_part * flip, m_part * flip
        k[at] += k_part
        m[at] += m_part
    return k, m


def mesh_error(beam: Body, elements: int, fmax_hz: float) -> float:
    """Estimated worst relative frequency error of modes below fmax_hz [Hz] for this mesh: the
    largest of its parts' ``mesh_error`` at fmax_hz (for cubic bending elements
    ``(beta h)^4 / 1440``, for linear rods ``(k h)^2 / 24``, beta and k the wavenumbers); it
    bounds a mode whose energy is all in this beam (others are proportionally better). Errors
    are positive: consistent mass makes every frequency an upper bound (Rayleigh-Ritz).
    """
    h = beam.length / elements
    omega = 2.0 * math.pi * fmax_hz
    return max(float(p.formulation.mesh_error(omega, h)) for p in kind_of(beam).parts(beam))


def elements_for(beam: Body, fmax_hz: float, rtol: float = DEFAULT_RTOL) -> int:
    """Fewest frame elements with :func:`mesh_error` <= rtol at fmax_hz (uncapped, >= 2): the
    element no longer than any part's ``element_length``."""
    omega = 2.0 * math.pi * fmax_hz
    h = min(p.formulation.element_length(omega, rtol) for p in kind_of(beam).parts(beam))
    return max(MIN_ELEMENTS_PER_BEAM, math.ceil(beam.length / h) if h < math.inf else 0)
