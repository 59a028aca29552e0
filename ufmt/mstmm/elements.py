"""Element transfer matrices of the MSTMM, batched over an array of angular frequencies.

State vector at a point (paper eq. 2.1): ``[x y z θx θy θz mx my mz qx qy qz]``; transfer runs
from the tip (input end) to the root (output end). ``q`` is the force that the tip-side element
exerts on the root-side one; the torque ``m`` has the opposite sense (paper eq. 3.1). The
transfer matrices are ``(n_omega, 12, 12)``. A body's own formulations are its kind's
(:mod:`ufmt.kinds`): a rigid body's U_{i,I1}, U_{i,Ik} in :mod:`ufmt.kinds.rigid`, a member's
deformations (:func:`ufmt.kinds.beam.parts`) each with its transfer matrix; this module puts
a member's parts in place and rotates them to the global frame.
"""

from __future__ import annotations

import numpy as np

from ufmt.kinds import kind_of
from ufmt.model.schema import Body


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


def beam_frame(beam: Body, p_in, p_out) -> np.ndarray:
    """Columns e1, e2, e3 of a member's local frame for transfer from p_in to p_out (its
    kind's ``local_frame``: e1 along the transfer direction, e2 the section's local y axis)."""
    return kind_of(beam).local_frame(beam, p_in, p_out)


def beam_local(omega: np.ndarray, beam: Body, length=None) -> np.ndarray:
    """Transfer matrix of a member in its own axes (paper eqs. 2.12, 3.3): each of its parts'
    (:func:`ufmt.kinds.beam.parts`) transfer matrix at its place in the 12-state.

    Local axes: x1 along the beam from input to output (the state conventions of the kinds'
    formulations: axial q = -N, torsion m = +GJ θ', bending in the x1-y plane with I_z, in the
    x1-z plane with I_y and θy = -w'). ``length`` [m] gives the transfer over a part of the
    beam (default: the whole beam); an array of the shape of ``omega`` gives one length per
    frequency.
    """
    w2 = np.asarray(omega, dtype=float) ** 2
    u = np.zeros((w2.size, 12, 12))
    for part, block in _blocks(w2, beam, length, motion_only=False):
        u[:, np.array(part.state)[:, None], part.state] = block
    return u


def beam_local_displacement(omega: np.ndarray, beam: Body, length, state: np.ndarray):
    """Displacement and rotation (n, 6) [m, rad] in the beam's axes at ``length`` [m] (one
    per ω) from the input end, of the local input states ``state`` (n, 12): the first six
    rows of :func:`beam_local` applied to them, without the 12 x 12 matrices (mode shapes
    along a beam need only these)."""
    w2 = np.asarray(omega, dtype=float) ** 2
    y = state.T
    out = np.empty((6, w2.size))
    for part, block in _blocks(w2, beam, length, motion_only=True):
        rows = part.state[: len(part.state) // 2]  # its displacement entries
        out[list(rows)] = (block.transpose(1, 2, 0) * y[list(part.state)][None]).sum(axis=1)
    return out.T


def _blocks(w2: np.ndarray, beam: Body, length, motion_only: bool):
    """(part, its transfer matrix (n, r, k) with its state signs) of each part of the member
    at ω² ``w2`` over ``length`` [m] (None: the whole member); equal formulations (a circle's
    two bending planes) computed once."""
    span = beam.length if length is None else np.asarray(length, dtype=float)
    done = {}
    for part in kind_of(beam).parts(beam):
        f = part.formulation
        key = (type(f), f.key)
        if key not in done:
            done[key] = f.transfer(w2, span, motion_only)
        block = done[key]
        signs = part.state_signs
        if np.any(signs < 0):
            rows = signs[: block.shape[1]]
            block = block * rows[:, None] * signs[None, :]
        yield part, block


def beam_rotation(beam: Body, p_in, p_out) -> np.ndarray:
    """(12, 12) block-diagonal rotation from the beam's local frame (transfer from ``p_in``
    to ``p_out``) to the global frame, acting on the four 3-vectors of a state."""
    return np.kron(np.eye(4), beam_frame(beam, p_in, p_out))


def beam(
    omega: np.ndarray,
    beam: Body,
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
