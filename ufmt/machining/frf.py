"""Tool-workpiece receptance in z: the frequency response behind z_re (paper eqs. 3.9-3.11)."""

from __future__ import annotations

import numpy as np

from ufmt.machining.basis import ModalBasis
from ufmt.machining.cutting import tool_tip
from ufmt.machining.damping import damped_modes
from ufmt.machining.recurrence import DEFAULT_ZETA, modal_damping
from ufmt.machining.static import ResidualFlexibility
from ufmt.model.machine import Machine


def tool_workpiece_receptance(
    basis: ModalBasis,
    machine: Machine,
    freq_hz,
    zeta=DEFAULT_ZETA,
    tool_angle: float = 0.0,
    residual: ResidualFlexibility | None = None,
) -> np.ndarray:
    """Relative z displacement per unit force pair in z at the tool tip [m/N].

    A force +F z on the tool tip and -F z on the workpiece at the same point (the material
    point under the tip with the slide where the basis was solved, ``basis.slide_y``) give
    z_re(W) = H(W) F with H(W) = sum_s c_s^2 / (M_s (w_s^2 - W^2 + 2 i zeta_s w_s W)),
    c_s = (V_tool,s - V_work,s)_z at the tip (modal superposition, eqs. 3.9-3.11), plus the
    residual flexibility of the modes above the basis (``residual``, frequency-independent;
    :mod:`ufmt.machining.static`), so that H(0) is the full static compliance. With hinge
    damping on the basis (:mod:`ufmt.machining.damping`) the modes couple:
    H(W) = sum_j [a_j / (i W - lambda_j) + conj(a_j) / (i W - conj(lambda_j))],
    a_j = (c^T P)_j (L c / M)_j, over the complex modes (exactly c^T (Omega^2 - W^2 + i W D)^-1
    (c / M)).

    Parameters
    ----------
    freq_hz : (F,) frequencies [Hz].
    zeta : structural modal damping, scalar or (n,); the basis' hinge damping adds to it.
    tool_angle : spindle angle phi of the tool tip [rad] (0: tip along +y, over the middle of
        the workpiece).
    residual : static correction (:func:`ufmt.machining.static.residual_flexibility`); none:
        modal superposition alone.

    Returns
    -------
    (F,) complex receptance [m/N].
    """
    tip = tool_tip(np.array([tool_angle]), machine)
    work = tip + np.array([0.0, basis.slide_y, 0.0])  # the material point cut, file coordinates
    c = (
        basis.point_shapes(machine.tool_body, tip)
        - basis.point_shapes(machine.workpiece_body, work)
    )[:, 0, 2]
    zeta = modal_damping(zeta, basis.n_modes)
    w = 2 * np.pi * np.asarray(freq_hz, dtype=float)[None, :]
    modes = damped_modes(basis, zeta)
    if modes is None:
        om = basis.omega[:, None]
        den = basis.modal_mass[:, None] * (om**2 - w**2 + 2j * zeta[:, None] * om * w)
        h = np.sum(c[:, None] ** 2 / den, axis=0)
    else:
        a = ((c @ modes.outputs) * (modes.inputs @ (c / basis.modal_mass)))[:, None]
        lam = modes.poles[:, None]
        h = np.sum(a / (1j * w - lam) + np.conj(a) / (1j * w - np.conj(lam)), axis=0)
    if residual is not None:
        tool, work = residual.relative(tip[0], work[0], [0.0, 0.0, 1.0])
        h = h + (tool[2] - work[2])
    return h
