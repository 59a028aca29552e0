"""Hinge damping in the modal equations: the modal damping matrix and its complex modes.

The modal equations of a basis with unit-normalised coordinates q read
M q'' + (M diag(2 zeta w) + Phi_rel^T C_hinge Phi_rel) q' + M Omega^2 q = <f, V>, M the modal
masses: the structural damping of :mod:`ufmt.machining.recurrence` (a ratio per mode, default
0.03) plus the dampers of the hinges (``Hinge.damping6`` [N s/m, N m s/rad], along and about
global x, y, z) acting on the relative motion d = u_A(P) - u_B(P) of the hinge's two bodies at
its point P (the same rows as the springs of :mod:`ufmt.assembled`). Phi_rel^T C Phi_rel
(:func:`hinge_damping_matrix`) is stored on the basis (``ModalBasis.hinge_damping``); divided
by the modal masses, D = diag(2 zeta w) + M^-1 Phi_rel^T C Phi_rel [1/s]
(:func:`damping_matrix`) is not diagonal: the hinge dampers couple the modes.

The motion of a body at a hinge point: a rigid body's [r_C; theta] carried rigidly to P
(:func:`ufmt.kinematics.point_motion`), a virtual body's motion at its point (every hinge on it
shares that point), a beam's motion at the end the hinge sits on (the MSTMM field transferred
along the beam, :func:`ufmt.mstmm.modes.beam_shape`); ground does not move. Rigid directions
(stiffness inf) carry no relative motion and their damping is left out. The modes above the
basis (the static correction of :mod:`ufmt.machining.static`) stay undamped: they respond
quasi-statically.

Non-proportional damping: complex modes. The first-order form x' = A x + [0; f] of the modal
equations, x = [q; q'], A = [[0, I], [-Omega^2, -D]], is diagonalised once per basis and
damping, A = Psi Lambda Psi^-1 (:func:`damped_modes`). Each pole lambda_j of the upper half
plane and its conjugate give q = 2 Re(P z), q' = 2 Re(P Lambda z) with z_j' = lambda_j z_j +
(L f)_j (:class:`DampedModes`): the same scalar first-order equation as a classically damped
mode (:func:`ufmt.machining.recurrence.discretise_poles`), so both response paths keep their
exact first-order-hold recurrence, their periodic steady state per harmonic and their
periodic impulse response, with complex input and output weights in place of the real ones;
the FFT structure, the caching and the vectorisation over samples and harmonics stay. A direct
solve per harmonic would serve the periodic table but not the time path, the periodic path's
record window or its impulse-response columns, which need the discrete recurrence itself, and
it would cost an n x n solve per harmonic instead of n scalar transfers. A basis without hinge
damping (``hinge_damping`` None: no hinge of the model has any) and without frequency-dependent
hinges takes the diagonal path, unchanged.

Frequency-dependent hinges (a film k*(s) = k0 + k1 s tau / (1 + s tau) per direction,
:mod:`ufmt.kinds.aerostatic_hinge`, k1 = k_inf - k0): the basis is a basis of the static
model (every hinge at k0, :mod:`ufmt.machining.film_basis`) and each direction's Maxwell
branch adds one state, its spring's stretch s [m] (branch force k1 s): s' = d q' - s / tau, with
d (6, n) the hinge's relative motion in the modes (``ModalBasis.varying``), and the modal
equations gain - M^-1 d^T k1 s. In the frequency domain s = d q s tau / (1 + s tau): the
state-space form is exact for k*(W) at every W, within the basis. The first-order form grows
by one row per branch, A = [[0, I, 0], [-Omega^2, -D, -G], [0, d, -1/tau]], G = M^-1 d^T k1
(:func:`film_matrices`); its real film poles are kept with half weight like any real pole,
and q'' = f - D q' - Omega^2 q - G s (:meth:`DampedModes.state_weights`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache, lru_cache

import numpy as np
from threadpoolctl import ThreadpoolController

from ufmt.errors import UfmtError
from ufmt.kinds import hinge_kind_of, kind_of
from ufmt.machining.basis import ModalBasis
from ufmt.machining.recurrence import modal_damping
from ufmt.model.schema import GROUND, Model
from ufmt.mstmm.modes import ModeShapes, beam_shape
from ufmt.mstmm.overall import TransferSystem

#: Condition number of the complex-mode matrix above which the damped modal equations are
#: taken as defective (coalescing poles): their complex modes do not exist.
MAX_CONDITION = 1e10


def serial_blas():
    """A context in which BLAS runs on one thread: the complex modes' products are small
    (n x n times n x N), where BLAS threads only add synchronisation (tens of ms on a loaded
    machine against a fraction of one on one thread)."""
    return _blas_controller().limit(limits=1, user_api="blas")


@cache
def _blas_controller() -> ThreadpoolController:
    """The loaded BLAS libraries, found once (a new controller scans every shared library)."""
    return ThreadpoolController()


def hinge_damping_matrix(model: Model, shapes: ModeShapes) -> np.ndarray | None:
    """Phi_rel^T C_hinge Phi_rel (n, n) [kg/s] of the modes ``shapes`` (their normalisation),
    summed over the hinges and their non-rigid directions; None when no hinge damps."""
    damped = [h for h in model.hinges if np.any(h.damping6[~h.rigid] != 0.0)]
    if not damped:
        return None
    n = shapes.frequencies_hz.size
    out = np.zeros((n, n))
    for hinge, d in zip(damped, relative_motion(model, shapes, damped), strict=True):
        c = np.where(hinge.rigid, 0.0, hinge.damping6)
        out += (d.T * c) @ d
    return out


def relative_motion(model: Model, shapes: ModeShapes, hinges) -> list[np.ndarray]:
    """Per hinge of ``hinges``, the relative motion d = u_A(P) - u_B(P) (6, n) [r; theta] of
    its two sides at its point in the modes ``shapes`` (their normalisation)."""
    beams = {}  # body with a field -> its two ends' positions and motion (n, 2, 6)
    for hinge in hinges:
        for side in hinge.between:
            if side != GROUND and kind_of(model.body(side)).HINGES_AT_ENDS:
                beams[side] = None
    if beams:
        system = TransferSystem(model)
        beams = {name: beam_shape(system, shapes, name, [0.0, 1.0]) for name in beams}
    return [
        _side_motion(model, shapes, beams, h, 0) - _side_motion(model, shapes, beams, h, 1)
        for h in hinges
    ]


def _side_motion(model: Model, shapes: ModeShapes, beams, hinge, side: int) -> np.ndarray:
    """Motion [r; theta] (6, n) of side ``side`` of ``hinge`` at the hinge point per mode."""
    name = hinge.between[side]
    n = shapes.frequencies_hz.size
    if name == GROUND:
        return np.zeros((6, n))
    body = model.body(name)
    return kind_of(body).hinge_motion(body, shapes, beams.get(name), hinge.at)


def damping_matrix(basis: ModalBasis, zeta) -> np.ndarray:
    """D = diag(2 zeta w) + M^-1 Phi_rel^T C Phi_rel (n, n) [1/s] of the modal equations
    q'' + D q' + Omega^2 q = f (``zeta``: the structural ratios, scalar or (n,)). With the tool
    carrier in the basis (``basis.tool``) the structural part is the machine's diag(2 zeta w)
    carried to the basis' modes (the ratios of the tool's own mode left out) and the hinge
    part holds the shank's dashpot too (:mod:`ufmt.machining.tool`)."""
    zeta = modal_damping(zeta, basis.n_modes)
    tool = basis.tool
    if tool is None:
        out = np.diag(2 * zeta * basis.omega)
    else:  # the machine's structural damping in the tool's basis (ufmt.machining.tool)
        machine_zeta = np.delete(zeta, tool.mode)
        out = (tool.structure.T * (2 * machine_zeta * tool.structure_omega)) @ tool.structure
    if basis.hinge_damping is not None:
        out = out + basis.hinge_damping / basis.modal_mass[:, None]
    return out


@dataclass(frozen=True, eq=False)
class DampedModes:
    """Complex modes of q'' + D q' + Omega^2 q = f (see the module docstring).

    poles (m,) lambda_j [1/s], the upper half plane (a real pole stands for itself, its output
    weight halved); inputs (m, n) L: z' = lambda z + L f; outputs (n, m) P: q = 2 Re(P z);
    damping (n, n) D [1/s]; omega (n,) [rad/s]; with film branches (:func:`film_matrices`)
    film_outputs (b, m): s = 2 Re(P_s z) and film_forces (n, b) G. Arrays read-only.
    """

    poles: np.ndarray
    inputs: np.ndarray
    outputs: np.ndarray
    damping: np.ndarray
    omega: np.ndarray
    film_outputs: np.ndarray | None = None
    film_forces: np.ndarray | None = None

    def projected(self, z, force, on_q, on_qd, on_qdd):
        """q^T on_q, q'^T on_qd and q''^T on_qdd ((T, k) each) of complex coordinates z (m, T)
        under the modal force (n, T), for shapes on_q, on_qd, on_qdd (n, k) [per mode].

        q = 2 Re(P z), q' = 2 Re(P Lambda z) and q'' = f - D q' - Omega^2 q; the shapes are
        carried to the complex modes, so q, q', q'' (n, T) are never formed: one real product
        of (2 k, m) by (m, 2 T) in place of complex ones of (n, m) by (m, T)."""
        weights = self.state_weights(on_q, on_qd, on_qdd)
        k = weights.shape[1]
        # one product with z's real and imaginary parts as they lie in memory (interleaved)
        both = np.concatenate([weights.real.T, weights.imag.T]) @ z.view(float)  # (2 k, 2 T)
        out = 2 * (both[:k, 0::2] - both[k:, 1::2]).T
        cuts = np.cumsum([on_q.shape[1], on_qd.shape[1]])
        q, qd, qdd = np.split(out, cuts, axis=1)
        return q, qd, qdd + force.T @ on_qdd

    def state_weights(self, on_q, on_qd, on_qdd) -> np.ndarray:
        """W (m, k) with [q^T on_q, q'^T on_qd, (q'' - f)^T on_qdd] = 2 Re(z^T W) for complex
        coordinates z (m, T), shapes (n, k_q), (n, k_qd), (n, k_qdd), k their total (see
        :meth:`projected`)."""
        rate = self.outputs * self.poles  # P Lambda
        accel = -(self.outputs.T @ ((self.omega**2)[:, None] * on_qdd)) - rate.T @ (
            self.damping.T @ on_qdd
        )
        if self.film_forces is not None:  # the film branches' forces on the modes
            accel = accel - self.film_outputs.T @ (self.film_forces.T @ on_qdd)
        return np.concatenate([self.outputs.T @ on_q, rate.T @ on_qd, accel], axis=1)


def damped_modes(basis: ModalBasis, zeta) -> DampedModes | None:
    """:class:`DampedModes` of ``basis`` with structural ratios ``zeta``, or None when the basis
    carries no hinge damping and no frequency-dependent hinge (the diagonal, classically
    damped modal equations)."""
    if basis.hinge_damping is None and not basis.varying:
        return None
    return _damped_modes(basis, tuple(modal_damping(zeta, basis.n_modes).tolist()))


@lru_cache(maxsize=8)
def _damped_modes(basis: ModalBasis, zeta: tuple) -> DampedModes:
    """:func:`damped_modes` (cached per basis and damping)."""
    n = basis.n_modes
    d = damping_matrix(basis, np.array(zeta))
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-np.diag(basis.omega**2), -d]])
    film = film_matrices(basis)
    if film is not None:  # one state per film branch (module docstring)
        forces, rows, rates = film
        b = rates.size
        a = np.block(
            [
                [a, np.vstack([np.zeros((n, b)), -forces])],
                [np.hstack([np.zeros((b, n)), rows]), -np.diag(rates)],
            ]
        )
    lam, vectors = np.linalg.eig(a)
    try:
        inverse = np.linalg.inv(vectors)
    except np.linalg.LinAlgError:
        inverse = np.full_like(vectors, np.inf)
    # the product of the Frobenius norms bounds the condition number from above: the SVD of
    # the exact one only where the bound does not settle it
    bound = np.linalg.norm(vectors) * np.linalg.norm(inverse)
    if not bound <= MAX_CONDITION and not np.linalg.cond(vectors) <= MAX_CONDITION:
        raise UfmtError("the hinge-damped modal equations are defective (coalescing poles)")
    keep = np.flatnonzero(lam.imag >= 0.0)
    keep = keep[np.argsort(np.abs(lam[keep]), kind="stable")]
    weight = np.where(lam[keep].imag > 0.0, 1.0, 0.5)
    out = [lam[keep], inverse[keep, n : 2 * n], vectors[:n, keep] * weight, d, basis.omega]
    if film is not None:
        out += [vectors[2 * n :, keep] * weight, film[0]]
    for x in out:
        x.setflags(write=False)
    return DampedModes(*out)


def film_matrices(basis: ModalBasis) -> tuple | None:
    """(G (n, b) = M^-1 d^T k1, d rows (b, n), 1/tau (b,) [1/s]) of the film branches of the
    basis' frequency-dependent hinges (module docstring), one per direction whose k'(ω)
    varies; None when there are none."""
    forces, rows, rates = [], [], []
    for hinge, d in basis.varying:
        rate, k1 = hinge_kind_of(hinge).branches6(hinge)
        for i in np.flatnonzero(k1 > 0.0):
            forces.append(d[i] * k1[i] / basis.modal_mass)
            rows.append(d[i])
            rates.append(rate[i])
    if not rates:
        return None
    return np.array(forces).T, np.array(rows), np.array(rates)
