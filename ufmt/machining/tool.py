"""The tool and holder as an oscillator on the fly-cutting head (paper eqs. 3.8-3.11).

The tool carrier (holder, shank and diamond) of mass m_t sits on the head through the shank's
z spring k_t = 1 / ``tool_compliance_m_per_N`` (a cantilever, 3 E I / L^3) and dashpot
c_t = 2 zeta_t sqrt(k_t m_t). The cutting force acts on the carrier, the spring's force on
the head at the tool point p. In the n modal coordinates q of the machine and the carrier's
absolute z coordinate u,

    M = diag(M_s, m_t),  K = [[M_s w_s^2 + k_t phi phi^T, -k_t phi], [-k_t phi^T, k_t]],
    C = [[M_s 2 zeta w_s + Phi_rel^T C_h Phi_rel + c_t phi phi^T, -c_t phi],
         [-c_t phi^T, c_t]],

phi (n,) the head's z translation at p per mode. The undamped pencil (K, M) gives n + 1 real
modes X (mass-normalised); the basis of :func:`with_tool` holds them: every body's shapes the
machine's combined by X, the tool body's shapes those of the carrier (the head's plus the
shank's stretch u - phi^T q along z), C carried to them as non-proportional damping
(:mod:`ufmt.machining.damping`), so the periodic path, the time path, the FRF and the static
correction carry the tool's mode with no special case and the entry step of the force rings.
The static correction stays on the head's side: with the carrier's shapes, the static
flexibility plus c_t = 1 / k_t on the tool body's z translation minus the basis' sum is the
head's residual exactly (:mod:`ufmt.machining.static`).

The tool turns with the head; its attachment is taken at the tool point half way through the
leading arc's cutting angles (:attr:`~ufmt.model.machine.Machine.cutting_angles`), where the
tool carries the force. Away from it the carrier's free motion has decayed (its decay time
1 / (zeta_t w_t) is a fraction of a millisecond against a spindle period of 0.1-0.3 s), and
the loads' arms still follow the tip (:mod:`ufmt.machining.cut_geometry`). As m_t -> 0 the
tool's mode leaves every band and the answer tends to the massless spring's quasi-static
one (``tool_mass_kg = 0``, the static correction's series compliance).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import scipy.linalg as sla

from ufmt.machining.basis import ModalBasis, ToolCoupling
from ufmt.machining.cutting import tool_tip
from ufmt.model.machine import Machine


def tool_point(machine: Machine) -> np.ndarray:
    """The tool point the shank is attached at [m]: the tip half way through the leading
    arc's cutting angles."""
    return tool_tip(np.array([0.5 * sum(machine.cutting_angles)]), machine)[0]


def with_tool(basis: ModalBasis, machine: Machine) -> ModalBasis:
    """``basis`` with the tool carrier as an oscillator on the head (module docstring); the
    basis itself when the tool is rigid or massless (``tool_compliance_m_per_N`` or
    ``tool_mass_kg`` 0) or when it carries the tool already."""
    c, m = machine.tool_compliance_m_per_N, machine.tool_mass_kg
    if basis.tool is not None or c == 0.0 or m == 0.0:
        return basis
    return _with_tool(
        basis,
        machine.tool_body,
        float(m),
        1.0 / c,
        float(machine.tool_damping_ratio),
        tuple(float(v) for v in tool_point(machine)),
    )


@lru_cache(maxsize=16)
def _with_tool(
    basis: ModalBasis, body: str, mass: float, stiffness: float, zeta: float, point: tuple
) -> ModalBasis:
    """:func:`with_tool` (cached per basis and tool, so the caches on the basis keep hitting)."""
    n = basis.n_modes
    phi = basis.point_shapes(body, np.array(point))[:, 2]
    mm = basis.modal_mass
    k = np.zeros((n + 1, n + 1))
    k[:n, :n] = np.diag(mm * basis.omega**2) + stiffness * np.outer(phi, phi)
    k[:n, n] = k[n, :n] = -stiffness * phi
    k[n, n] = stiffness
    w2, x = sla.eigh(k, np.diag(np.append(mm, mass)))
    xq = x[:n]
    stretch = x[n] - phi @ xq
    shapes = {name: xq.T @ v for name, v in basis.body_shapes.items()}
    shapes[body][:, 2] += stretch
    damping = 2 * zeta * np.sqrt(stiffness * mass)
    carried = damping * np.outer(stretch, stretch)
    if basis.hinge_damping is not None:
        carried = carried + xq.T @ basis.hinge_damping @ xq
    return ModalBasis(
        omega=np.sqrt(w2),
        modal_mass=np.ones(n + 1),
        body_shapes=shapes,
        body_centers=basis.body_centers,
        hinge_damping=carried,
        slide_y=basis.slide_y,
        varying=tuple((h, d @ xq) for h, d in basis.varying),
        resolved_hz=basis.resolved_hz,
        tool=ToolCoupling(
            body=body,
            stretch=stretch,
            structure=np.sqrt(mm)[:, None] * xq,
            structure_omega=basis.omega,
            mode=int(np.argmax(mass * x[n] ** 2)),
            mass=mass,
            stiffness=stiffness,
            damping=damping,
            point=np.array(point),
        ),
    )
