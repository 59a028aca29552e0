"""Rigid-point kinematics shared by both solvers (the MSTMM and the assembled model): the
cross-product matrix, the motion of a point carried by a rigid body, the inertia tensor
about another point, and the loads carried from one point to another.

Small motions are ``[r; θ]`` (translation [m] of a reference point and rotation [rad]), all in
the global frame; a point P of a rigid body with reference point C moves by ``r + θ × (P - C)``
(paper eq. 2.5).
"""

from __future__ import annotations

import numpy as np

I3 = np.eye(3)
I3.flags.writeable = False


def skew(v) -> np.ndarray:
    """Cross-product matrices (..., 3, 3) of vectors (..., 3): ``skew(a) @ b == a x b``
    (paper eq. 2.10, the matrix written l̃ there)."""
    v = np.asarray(v, dtype=float)
    s = np.zeros(v.shape + (3,))
    s[..., 0, 1], s[..., 0, 2] = -v[..., 2], v[..., 1]
    s[..., 1, 0], s[..., 1, 2] = v[..., 2], -v[..., 0]
    s[..., 2, 0], s[..., 2, 1] = -v[..., 1], v[..., 0]
    return s


def point_motion(offset) -> np.ndarray:
    """(..., 6, 6) maps from ``[r_C; θ]`` to ``[r_C + θ × offset; θ]`` (paper eq. 2.5).

    offset (..., 3) [m]: vectors from the reference point C to the point P.
    """
    offset = np.asarray(offset, dtype=float)
    t = np.zeros(offset.shape[:-1] + (6, 6))
    t[..., range(6), range(6)] = 1.0
    t[..., :3, 3:] = -skew(offset)
    return t


def inertia_about(inertia_c: np.ndarray, mass: float, offset) -> np.ndarray:
    """Inertia tensor [kg m^2] about a point ``offset`` = (point → centre of mass) [m] away,
    from the tensor ``inertia_c`` about the centre of mass (parallel-axis theorem)."""
    d = np.asarray(offset, dtype=float)
    return inertia_c + mass * (d @ d * I3 - np.outer(d, d))


def carried_motion(motion: np.ndarray, point, new_point) -> np.ndarray:
    """``[r_Q; θ]`` (n, 6) of a rigid body's point Q = ``new_point`` from its motion at P =
    ``point``: ``r_Q = r_P + θ × (Q - P)`` (paper eq. 2.5); motion (n, >= 6) ``[r_P; θ; ...]``
    [m, rad]."""
    r = motion[:, :3] + np.cross(motion[:, 3:6], np.asarray(new_point) - point)
    return np.concatenate([r, motion[:, 3:6]], axis=1)


def load_transfer(p_in, p_out) -> np.ndarray:
    """U_{i,Ik}, k ≥ 2, of a rigid body or a massless point (paper eqs. 2.9, 2.11): the
    moment and force of input k carried to the output point, (12, 12) on the state
    ``[r; θ; m; q]``, the same at every ω."""
    u = np.zeros((12, 12))
    u[6:9, 6:9] = I3
    u[6:9, 9:12] = skew(np.asarray(p_out, dtype=float) - p_in)
    u[9:12, 9:12] = I3
    return u
