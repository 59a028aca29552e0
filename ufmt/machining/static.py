"""Static (residual-flexibility) correction for the modes above the modal basis.

A modal basis of n modes represents the flexibility of the structure only up to its highest
mode: the static deflection under a force is sum_s v_s v_s^T / (M_s w_s^2) over *all* modes,
and the modes above the basis carry a share of it (18 % of the tool-workpiece compliance in z
of the UFMT with 30 modes). Those modes respond quasi-statically to the cutting force (their
frequencies are far above its harmonics), so their contribution is the residual flexibility

    G_res = G_static - sum_{s <= n} v_s v_s^T / (M_s w_s^2)

times the instantaneous force (the classical static correction of mode superposition, e.g.
Craig & Kurdila, *Fundamentals of Structural Dynamics*, 2006, section 13.3). G_static is the
flexibility of the tool and workpiece bodies' 6 + 6 rigid-body coordinates from a static solve of
the assembled mass-stiffness model of the same file (:mod:`ufmt.assembled`): u = N (N^T K N)^-1
N^T f with N a basis of the motions the rigid hinges allow.

For a force F on the tool at point p and -F on the workpiece at its material point q = p + Y y
(:mod:`ufmt.machining.cut_geometry`), the relative displacement is P(p, q) G_res P(p, q)^T F with
P = [T_tool(p), -T_work(q)], T(x) = [I, -[(x - C)]x] the translation of point x of a rigid body.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg as sla

from ufmt.assembled import point_motion
from ufmt.errors import ModelError
from ufmt.machining.basis import ModalBasis
from ufmt.machining.slide import model_at_slide
from ufmt.model.machine import Machine
from ufmt.recent import Recent


@dataclass(frozen=True, eq=False)
class ResidualFlexibility:
    """Residual flexibility of the tool and workpiece bodies' rigid-body coordinates.

    Attributes
    ----------
    matrix : (12, 12) [m/N, m/(N m), rad/(N m)]: rows and columns [r_tool, theta_tool,
        r_work, theta_work] at the bodies' centres of mass (global frame).
    centers : (2, 3) centres of mass of the tool and the workpiece body [m].
    static : (12, 12) the full static flexibility it was made from (for reports and tests).
    """

    matrix: np.ndarray
    centers: np.ndarray
    static: np.ndarray

    def relative(self, tool_points, work_points, forces) -> tuple[np.ndarray, np.ndarray]:
        """Tool and workpiece point displacements [m] under the residual flexibility.

        ``forces`` (..., 3) [N] act on the tool at ``tool_points`` and, reversed, on the
        workpiece at ``work_points`` (both (..., 3) [m], broadcast). Returns the displacement
        of the tool point and of the workpiece point, each (..., 3).
        """
        t_tool = point_motion(np.asarray(tool_points, float) - self.centers[0])[..., :3, :]
        t_work = point_motion(np.asarray(work_points, float) - self.centers[1])[..., :3, :]
        forces = np.asarray(forces, dtype=float)
        wrench = np.concatenate(
            [
                np.einsum("...ji,...j->...i", t_tool, forces),
                -np.einsum("...ji,...j->...i", t_work, forces),
            ],
            axis=-1,
        )
        u = wrench @ self.matrix.T
        return (
            np.einsum("...ij,...j->...i", t_tool, u[..., :6]),
            np.einsum("...ij,...j->...i", t_work, u[..., 6:]),
        )


@dataclass(frozen=True, eq=False)
class _Structure:
    """What a static solve needs that the hinge stiffnesses do not change (see
    :func:`static_flexibility`): the reduced stiffness of the beams k_beams (r, r), the
    reduced finite spring directions d (s, r), their hinge and direction (s,) indices into the
    hinges' ``stiffness6``, and the map (r -> listed dofs) ``loads`` (r, 6B)."""

    k_beams: np.ndarray
    directions: np.ndarray
    spring_hinge: np.ndarray
    spring_direction: np.ndarray
    loads: np.ndarray


STRUCTURE_CACHE = 4
#: Structures of the last few models (key: bodies, hinge geometry and which directions are
#: rigid or released), so that a design change (hinge stiffnesses only) costs one small solve.
_STRUCTURES = Recent(STRUCTURE_CACHE)


def _structure(model, bodies: tuple[str, ...]) -> _Structure:
    """The :class:`_Structure` of ``model`` (assembled once per
    :meth:`~ufmt.model.schema.Model.structure_key` and bodies)."""
    key = (model.structure_key(), bodies)
    return _STRUCTURES.get(key, lambda: _build_structure(model, bodies))


def _build_structure(model, bodies: tuple[str, ...]) -> _Structure:
    """:class:`_Structure` of ``model`` (see :func:`_structure`)."""
    from ufmt.assembled import assemble

    # one cubic frame element per beam is exact in statics (no load between the nodes);
    # springs at zero give the beams alone, at one their unit direction rows d_j
    def with_springs(value):
        hinges = []
        for h in model.hinges:
            finite = ~(h.rigid | h.released)
            k = np.where(finite, value, h.stiffness6)
            hinges.append(replace(h, stiffness=k[:3], rotational_stiffness=k[3:]))
        return replace(model, hinges=tuple(hinges))

    beams = assemble(with_springs(0.0), elements_per_beam=1)
    springs = assemble(with_springs(1.0), elements_per_beam=1)
    finite = [
        (i, j) for i, h in enumerate(model.hinges) for j in np.flatnonzero(~(h.rigid | h.released))
    ]
    d = springs.deformation[springs.deformation.shape[0] - len(finite) :]
    dofs = []
    for name in bodies:
        body_dofs = beams.body_dofs[name]
        if body_dofs.shape[0] != 1:
            raise ModelError(
                f"{model.source}: machine: body {name!r} is a beam; the static correction "
                "needs rigid tool and workpiece bodies"
            )
        dofs.append(body_dofs[0])
    dofs = np.concatenate(dofs)
    if len(beams.constraints):
        rows = beams.constraints / np.linalg.norm(beams.constraints, axis=1, keepdims=True)
        basis = sla.null_space(rows, rcond=1e-9)
    else:
        basis = np.eye(beams.K.shape[0])
    index = np.array(finite, dtype=int).reshape(-1, 2)
    return _Structure(
        k_beams=basis.T @ beams.K @ basis,
        directions=d @ basis,
        spring_hinge=index[:, 0],
        spring_direction=index[:, 1],
        loads=basis[dofs].T,
    )


#: Eigenvalues of the reduced stiffness below this fraction of the largest are mechanisms
#: (zero-frequency motions; rounding leaves them at ~1e-16 of the largest).
MECHANISM_RTOL = 1e-12


def static_flexibility(model, bodies: tuple[str, ...]) -> np.ndarray:
    """Static flexibility of the listed bodies' 6 coordinates each, (6B, 6B) (assembled model).

    u = N (N^T K N)^-1 N^T f, N a basis of the motions the rigid hinges allow. The hinges'
    finite springs enter K as sum_j k_j d_j d_j^T: the beams' part and the spring directions
    are assembled once per structure (bodies, hinge geometry, rigid and released directions),
    so another design (hinge stiffnesses) costs the reduced sum and a Cholesky solve.

    The bodies must be rigid or virtual (one node of 6 dofs). Zero-stiffness motions (a
    released spindle rotation: the model's zero-frequency modes) carry no static correction
    (pseudo-inverse on the elastic motions); ModelError if nothing is restrained.
    """
    st = _structure(model, tuple(bodies))
    k = np.array([h.stiffness6 for h in model.hinges]).reshape(-1, 6)
    k = k[st.spring_hinge, st.spring_direction]
    k_red = st.k_beams + (st.directions.T * k) @ st.directions
    try:
        chol = sla.cho_factor(k_red)
    except np.linalg.LinAlgError:
        return st.loads.T @ _mechanism_free_solve(k_red, st.loads, model.source)
    return st.loads.T @ sla.cho_solve(chol, st.loads)


def _mechanism_free_solve(k_red: np.ndarray, loads: np.ndarray, source: str) -> np.ndarray:
    """K^+ loads for a stiffness matrix with zero-stiffness motions (a mechanism such as a
    released spindle rotation): the static correction is the elastic part only, so the
    load components on the mechanism's motions are dropped (they are the zero-frequency
    modes, which the modal basis leaves out too). Raises ModelError when every motion is a
    mechanism."""
    w, v = np.linalg.eigh(k_red)
    elastic = w > MECHANISM_RTOL * np.abs(w).max(initial=0.0)
    if not elastic.any():
        raise ModelError(f"{source}: the structure is not restrained (no static solution)")
    coords = v[:, elastic]
    return coords @ ((coords.T @ loads) / w[elastic, None])


def residual_flexibility(model, basis: ModalBasis, machine: Machine) -> ResidualFlexibility:
    """The static correction of ``basis`` for the tool and workpiece bodies of ``machine``.

    G_res = G_static - sum_s v_s v_s^T / (M_s w_s^2), v_s the bodies' rigid motions in mode s;
    G_static is solved with the slide where the basis was solved (``basis.slide_y``,
    :mod:`ufmt.machining.slide`). The tool's own z compliance (``tool_compliance_m_per_N``)
    is added to the tool body's z translation. With a massless tool it moves the tip by
    c F_z, quasi-statically like the modes above the basis; with the tool carrier in the basis
    (:mod:`ufmt.machining.tool`, the tool body's shapes the carrier's) the basis' sum holds c
    exactly, and the residual is the head's alone.
    """
    bodies = (machine.tool_body, machine.workpiece_body)
    static = static_flexibility(model_at_slide(model, machine, basis.slide_y), bodies)
    v = np.concatenate([basis.body_shapes[b] for b in bodies], axis=1)  # (n, 12)
    modal = (v.T / (basis.modal_mass * basis.omega**2)) @ v
    centers = np.stack([basis.body_centers[b] for b in bodies])
    res = static - modal
    res = 0.5 * (res + res.T)
    # the tool and holder: a z spring between the tool body and the tip. A z force F_z at
    # any tip point loads the tool body's centre with F_z in z, so the compliance c on that
    # translation moves every tip point by c F_z in z and nothing else.
    res[2, 2] += machine.tool_compliance_m_per_N
    for a in (res, centers, static):
        a.setflags(write=False)
    return ResidualFlexibility(matrix=res, centers=centers, static=static)
