"""Element transfer matrices of the MSTMM, batched over an array of angular frequencies.

State vector at a point (paper eq. 2.1): ``[x y z θx θy θz mx my mz qx qy qz]``; transfer runs
from the tip (input end) to the root (output end). ``q`` is the force that the tip-side element
exerts on the root-side one; the torque ``m`` has the opposite sense (paper eq. 3.1). The
transfer matrices are ``(n_omega, 12, 12)``, except the other-input matrix of a body, which is
the same at every ω, ``(12, 12)``.
"""

from __future__ import annotations

import math

import numpy as np

from ufmt.kinds.beam import section_axis
from ufmt.kinds.timoshenko import bending_transfer
from ufmt.kinematics import I3, inertia_about, skew
from ufmt.model.schema import Beam


def rigid_body_first_input(
    omega: np.ndarray, mass: float, inertia_c, com, p_in, p_out
) -> np.ndarray:
    """U_{i,I1} of a rigid body (paper eq. 2.8) [SI].

    mass [kg], inertia_c [kg m^2] about the centre of mass ``com`` [m], first input point
    ``p_in`` and output point ``p_out`` [m]. Affine in ω²: the constant part is the kinematic
    transfer, the ω² part the inertia forces.
    """
    l_io = skew(np.asarray(p_out) - p_in)
    l_ic = skew(np.asarray(com) - p_in)
    l_co = skew(np.asarray(p_out) - com)
    j_i = inertia_about(np.asarray(inertia_c), mass, np.asarray(com) - p_in)
    base = np.eye(12)
    base[0:3, 3:6] = -l_io
    base[6:9, 9:12] = l_io
    inertial = np.zeros((12, 12))
    inertial[6:9, 0:3] = mass * l_co
    inertial[6:9, 3:6] = -(mass * l_io @ l_ic + j_i)
    inertial[9:12, 0:3] = mass * I3
    inertial[9:12, 3:6] = -mass * l_ic
    w2 = np.asarray(omega, dtype=float)[:, None, None] ** 2
    return base[None] + w2 * inertial[None]


def rigid_body_other_input(p_in, p_out) -> np.ndarray:
    """U_{i,Ik}, k ≥ 2, of a rigid or virtual body (paper eqs. 2.9, 2.11): forces only;
    (12, 12), the same at every ω."""
    u = np.zeros((12, 12))
    u[6:9, 6:9] = I3
    u[6:9, 9:12] = skew(np.asarray(p_out, dtype=float) - p_in)
    u[9:12, 9:12] = I3
    return u


def hinge(
    omega: np.ndarray, stiffness6: np.ndarray, damping6: np.ndarray | None = None
) -> np.ndarray:
    """Spatial spring-damper hinge (paper eqs. 2.13, 2.14) with complex stiffness k + iωc.

    stiffness6 [N/m, N m/rad] along/about global x, y, z, (6,) or per ω (n, 6) (a
    frequency-dependent hinge's k'(ω)); ``inf`` is rigid (zero compliance).
    Released directions (stiffness 0) are not representable as a transfer matrix; the caller
    handles them exactly with an extra unknown, and this function gives them zero compliance.
    """
    omega = np.asarray(omega, dtype=float)
    k = np.asarray(stiffness6, dtype=float)
    kc = np.broadcast_to(k, (omega.size, 6))
    if damping6 is not None and np.any(damping6):
        kc = kc + 1j * omega[:, None] * np.asarray(damping6)[None, :]
    elastic = np.broadcast_to((k > 0) & np.isfinite(k), kc.shape)  # rigid, released: zero
    compliance = np.zeros(kc.shape, dtype=kc.dtype)
    compliance[elastic] = 1.0 / kc[elastic]
    u = np.zeros((omega.size, 12, 12), dtype=compliance.dtype)
    idx = np.arange(12)
    u[:, idx, idx] = 1.0
    u[:, [0, 1, 2], [9, 10, 11]] = -compliance[:, :3]  # K = -1/k (translation)
    u[:, [3, 4, 5], [6, 7, 8]] = compliance[:, 3:]  # K' = +1/k' (rotation)
    return u


def beam_frame(beam: Beam, p_in, p_out) -> np.ndarray:
    """Columns e1, e2, e3 of the beam's local frame for transfer from p_in to p_out.

    e1 runs along the transfer direction; e2 is the section's local y axis
    (:func:`ufmt.kinds.beam.section_axis`: ``orientation``, default global z or global x for a
    vertical beam, projected off the axis); e3 = e1 x e2. Flipping e1 flips e3 only, which
    leaves the second moments about e2 and e3 unchanged.
    """
    e1 = np.asarray(p_out, dtype=float) - p_in
    e1 /= np.linalg.norm(e1)
    e2 = section_axis(beam)
    return np.column_stack([e1, e2, np.cross(e1, e2)])


# S, T/x, U/x², V/x³ = Σ_k x⁴ᵏ / (4k + j)!, j = 0..3; 12 terms: 16¹²/48! is below eps
_KRYLOV_SERIES = 1.0 / np.array(
    [[math.factorial(4 * k + j) for j in range(4)] for k in range(12)], dtype=float
)


def _krylov_scaled(x4: np.ndarray):
    """Entire Krylov-Duncan functions in terms of x⁴ = (λL)⁴, stable for all x ≥ 0.

    Returns s, t, u, v with S(x) = s, T(x)/x = t, U(x)/x² = u, V(x)/x³ = v, where
    S = (cosh+cos)/2, T = (sinh+sin)/2, U = (cosh-cos)/2, V = (sinh-sin)/2.
    A power series in x⁴ is used below x = 2 (no cancellation), closed forms above.
    """
    x4 = np.asarray(x4, dtype=float)
    big = ~(x4 < 16.0)
    series = np.empty((4, *x4.shape))
    if not big.all():  # Horner in x⁴, all four at once (the function first: long loops)
        terms = _KRYLOV_SERIES.reshape(*_KRYLOV_SERIES.shape, *(1,) * x4.ndim)
        xs = np.where(big, 0.0, x4)
        series[:] = terms[-1]
        for coefficients in terms[-2::-1]:
            series *= xs
            series += coefficients
    s, t, u, v = series
    if big.any():
        x = np.sqrt(np.sqrt(x4[big]))
        ch, c, sh, sn = np.cosh(x), np.cos(x), np.sinh(x), np.sin(x)
        s[big] = (ch + c) / 2
        t[big] = (sh + sn) / 2 / x
        u[big] = (ch - c) / 2 / x**2
        v[big] = (sh - sn) / 2 / x**3
    return s, t, u, v


def _axial(omega2, stiffness, inertia_per_length, length):
    """cos(βL), sin(βL)/β, β sin(βL) for u'' + β²u = 0, β² = ρA ω²/EA, stable at β → 0."""
    b2 = omega2 * inertia_per_length / stiffness
    bl = np.sqrt(b2) * length
    sinc = np.sinc(bl / np.pi)  # sin(βL)/(βL)
    return np.cos(bl), length * sinc, b2 * length * sinc


# where beam_local's entries go: axial (x, qx), torsion (θx, mx), then the 16 entries of
# bending in the x1-y plane (y, θz, mz, qy) and in the x1-z plane (z, θy, my, qz)
_TWIST = ((0, 0), (0, 9), (9, 0), (9, 9), (3, 3), (3, 6), (6, 3), (6, 6))
_PLANES = ((1, 5, 8, 10), (2, 4, 7, 11))
_ROWS, _COLS = np.array(_TWIST + tuple((a, b) for p in _PLANES for a in p for b in p)).T


def beam_local(omega: np.ndarray, beam: Beam, length: float | None = None) -> np.ndarray:
    """Transfer matrix of a beam in its own axes (paper eqs. 2.12, 3.3); a Timoshenko beam's
    bending from :mod:`ufmt.kinds.timoshenko`.

    Derived from eq. 3.3 in the state conventions of this module (the printed eq. 2.12 mixes
    λy and λz and has sign slips). Local axes: x1 along the beam from input to output; axial
    q = -N, N = EA u'; torsion m = +GJ θ'; bending in the x1-y plane uses I_z (θz = v',
    mz = EI v'', qy = EI v'''), in the x1-z plane I_y (θy = -w', my = -EI w'', qz = EI w''').
    ``length`` [m] gives the transfer over a part of the beam (default: the whole beam); an
    array of the shape of ``omega`` gives one length per frequency. Axial and torsion, and
    the two bending planes, are computed together (rows of 2) and scattered at once.
    """
    w2 = np.asarray(omega, dtype=float) ** 2
    twist, bend = _beam_blocks(w2, beam, length, rows=4)
    u = np.zeros((w2.size, 12, 12))
    u[:, _ROWS, _COLS] = np.concatenate([twist.reshape(8, -1), bend.reshape(32, -1)]).T
    return u


def beam_local_displacement(omega: np.ndarray, beam: Beam, length, state: np.ndarray):
    """Displacement and rotation (n, 6) [m, rad] in the beam's axes at ``length`` [m] (one
    per ω) from the input end, of the local input states ``state`` (n, 12): the first six
    rows of :func:`beam_local` applied to them, without the 12 x 12 matrices (mode shapes
    along a beam need only these)."""
    w2 = np.asarray(omega, dtype=float) ** 2
    twist, bend = _beam_blocks(w2, beam, length, rows=2)
    y = state.T
    out = np.empty((6, w2.size))
    # axial x and torsion θx: two entries each
    out[[0, 3]] = twist[:, 0] * y[[0, 3]] + twist[:, 1] * y[[9, 6]]
    # per bending plane its displacement and rotation rows, four entries each
    plane = (bend.reshape(2, 2, 4, -1) * y[np.array(_PLANES)][:, None]).sum(axis=2)
    out[[1, 5]], out[[2, 4]] = plane
    return out.T


def _beam_blocks(w2: np.ndarray, beam: Beam, length, rows: int):
    """The nonzero entries of :func:`beam_local` at ω² ``w2`` over ``length`` [m] (None: the
    whole beam): axial and torsion (2, rows, n) and the two bending planes (2, 4 rows, n),
    in the order of ``_TWIST`` and ``_PLANES``; ``rows``: of each block the first 4 (all
    of them) or 2 (the displacement rows)."""
    L = beam.length if length is None else np.asarray(length, dtype=float)
    rho, E, A = beam.density, beam.youngs_modulus, beam.area
    # axial (EA, ρA) and torsion (GJ, ρI_p)
    k = np.array([[E * A], [beam.shear_modulus * beam.torsion_constant]])
    c, sl, bs = _axial(w2, k, np.array([[rho * A], [rho * beam.polar_moment]]), L)
    sgn = np.array([[-1.0], [1.0]])
    twist = [c, sgn * sl / k, -sgn * k * bs, c][:rows]
    if beam.timoshenko:
        return np.stack(twist, axis=1), bending_transfer(w2, beam, L, rows)
    # bending with EI_z (x1-y plane, sign +1) and EI_y (x1-z plane, sign -1)
    ei = np.array([[E * beam.second_moment_z], [E * beam.second_moment_y]])
    sgn = np.array([[1.0], [-1.0]])
    lam4 = rho * A * w2 / ei
    s, t, uu, v = _krylov_scaled(lam4 * L**4)
    T_l, U_l2, V_l3 = L * t, L**2 * uu, L**3 * v  # T/λ, U/λ², V/λ³
    lV = lam4 * V_l3  # λV
    bend = [
        *(s, sgn * T_l, sgn * U_l2 / ei, V_l3 / ei),
        *(sgn * lV, s, T_l / ei, sgn * U_l2 / ei),
    ]
    if rows == 4:
        l2U, l3T = lam4 * U_l2, lam4 * T_l  # λ²U, λ³T
        bend += [
            *(sgn * ei * l2U, ei * lV, s, sgn * T_l),
            *(ei * l3T, sgn * ei * l2U, sgn * lV, s),
        ]
    return np.stack(twist, axis=1), np.stack(bend, axis=1)


def beam_rotation(beam: Beam, p_in, p_out) -> np.ndarray:
    """(12, 12) block-diagonal rotation from the beam's local frame (transfer from ``p_in``
    to ``p_out``) to the global frame, acting on the four 3-vectors of a state."""
    return np.kron(np.eye(4), beam_frame(beam, p_in, p_out))


def beam(
    omega: np.ndarray,
    beam: Beam,
    p_in=None,
    p_out=None,
    length: float | None = None,
    rotation: np.ndarray | None = None,
) -> np.ndarray:
    """Beam transfer matrix from end ``p_in`` towards end ``p_out`` in the global frame [SI].

    ``length`` [m] (scalar, or one per ω) stops the transfer part-way along the beam (for
    mode shapes). ``rotation``: :func:`beam_rotation` of (p_in, p_out), if already known.
    """
    t = beam_rotation(beam, p_in, p_out) if rotation is None else rotation
    return t[None] @ beam_local(omega, beam, length) @ t.T[None]
