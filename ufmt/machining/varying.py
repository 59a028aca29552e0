"""Frequency-dependent hinges in the modal equations (e.g. :mod:`ufmt.kinds.aerostatic_hinge`).

The modal basis of a model with such hinges is the basis of its *static* model, every hinge
at its zero-frequency stiffness k0 (:func:`ufmt.mstmm.dependent.static_model`). At a frequency
W the hinges add what k*(W) has beyond k0 and the dashpots: on the relative motion d_h (6, n)
of hinge h in the basis' modes (:func:`ufmt.machining.damping.relative_motion`),

    dK(W) = sum_h d_h^T diag(k*_h(W) - k0_h - i W c_h) d_h       (n, n) complex,

and the modal equations at W are (Omega² + M^-1 dK(W) - W² + i W D) q = M^-1 <f, V> with D
the damping matrix of :func:`ufmt.machining.damping.damping_matrix`: a direct n x n solve per
frequency (:func:`varying_receptance`), exact within the basis; the static correction above
the basis stays at k0. With dK = 0 it is the modal superposition of :mod:`ufmt.machining.frf`.
"""

from __future__ import annotations

import numpy as np

from ufmt.kinds import hinge_kind_of
from ufmt.machining.basis import ModalBasis
from ufmt.machining.damping import damping_matrix, relative_motion
from ufmt.machining.recurrence import modal_damping
from ufmt.model.schema import Model
from ufmt.mstmm.modes import ModeShapes

CHUNK = 256  # frequencies per batched solve (memory ~ CHUNK n² complex)


def varying_motion(model: Model, shapes: ModeShapes) -> tuple:
    """((hinge, d (6, n)), ...) of the hinges of ``model`` whose stiffness depends on
    frequency, d their relative motion in the modes ``shapes``; () when none does."""
    hinges = [h for h in model.hinges if not hinge_kind_of(h).count_applies(h)]
    if not hinges:
        return ()
    return tuple(zip(hinges, relative_motion(model, shapes, hinges), strict=True))


def stiffness_change(basis: ModalBasis, w) -> np.ndarray:
    """dK(W) (F, n, n) [N/m per unit modal coordinate²] at W = ``w`` [rad/s] (F,)."""
    w = np.atleast_1d(np.asarray(w, dtype=float))
    n = basis.n_modes
    out = np.zeros((w.size, n, n), dtype=complex)
    for hinge, d in basis.varying:
        k0 = hinge.stiffness6
        elastic = np.isfinite(k0) & (k0 > 0)
        k = hinge_kind_of(hinge).complex_stiffness6(hinge, w)
        change = k - np.where(elastic, k0, 0.0) - 1j * w[:, None] * hinge.damping6[None, :]
        change = np.where(elastic[None, :], change, 0.0)  # rigid and released: no change
        out += np.einsum("in,fi,im->fnm", d, change, d)
    return out


def varying_receptance(basis: ModalBasis, c_out, c_in, freq_hz, zeta) -> np.ndarray:
    """The basis' part of H (F,) [m/N] between participations ``c_out`` and ``c_in`` with
    the frequency-dependent hinges at each frequency (module docstring)."""
    zeta = modal_damping(zeta, basis.n_modes)
    w = 2 * np.pi * np.atleast_1d(np.asarray(freq_hz, dtype=float))
    damping = damping_matrix(basis, zeta)
    rhs = np.asarray(c_in, dtype=float) / basis.modal_mass
    out = np.empty(w.size, dtype=complex)
    for s in range(0, w.size, CHUNK):
        ws = w[s : s + CHUNK]
        a = stiffness_change(basis, ws) / basis.modal_mass[None, :, None]
        a += np.diag(basis.omega**2)[None] + 1j * ws[:, None, None] * damping[None]
        a -= (ws**2)[:, None, None] * np.eye(basis.n_modes)[None]
        q = np.linalg.solve(a, np.broadcast_to(rhs, (ws.size, rhs.size))[..., None])[..., 0]
        out[s : s + CHUNK] = q @ np.asarray(c_out, dtype=float)
    return out
