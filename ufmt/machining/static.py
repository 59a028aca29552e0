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
from ufmt.machining.machine_frame import in_machine_frame
from ufmt.machining.slide import model_at_slide
from ufmt.model.machine import Machine
from ufmt.model.orientation import DIRECTION_FIELDS
from ufmt.recent import Recent


@dataclass(frozen=True, eq=False)
class ResidualFlexibility:
    """Residual flexibility of the tool and workpiece bodies' rigid-body coordinates.

    Attributes
    ----------
    matrix : (12, 12) [m/N, m/(N m), rad/(N m)]: rows and columns [r_tool, theta_tool,
        r_work, theta_work] at the bodies' centres of mass (machine frame: the model's,
        :func:`residual_flexibility` rotates it in).
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
    hinges' ``stiffness6``, the map (r -> listed dofs) ``loads`` (r, 6B); the zero-frequency
    modes, mass-normalised, ``rigid`` (r, m), their inertia loads ``relief`` = M rigid (r, m)
    and the trace of the reduced mass ``mass_trace`` [kg...] (m = 0: none); ``weight`` (r,)
    [N, N m] the reduced load of gravity on every mass (:data:`GRAVITY`)."""

    k_beams: np.ndarray
    directions: np.ndarray
    spring_hinge: np.ndarray
    spring_direction: np.ndarray
    loads: np.ndarray
    rigid: np.ndarray
    relief: np.ndarray
    mass_trace: float
    weight: np.ndarray


#: Standard acceleration of gravity [m/s^2], along ``[machine] gravity_direction`` (-z).
GRAVITY = 9.81

STRUCTURE_CACHE = 16  # the residual's slide position and the carriage-load profile's knots
#: Structures of the last few models (key: bodies, hinge geometry and which directions are
#: rigid or released), so that a design change (hinge stiffnesses only) costs one small solve.
_STRUCTURES = Recent(STRUCTURE_CACHE)


def _structure(model, bodies: tuple[str, ...]) -> _Structure:
    """The :class:`_Structure` of ``model`` (assembled once per
    :meth:`~ufmt.model.schema.Model.structure_key` and bodies)."""
    key = (model.structure_key(), bodies, _gravity(model))
    return _STRUCTURES.get(key, lambda: _build_structure(model, bodies))


def _gravity(model) -> tuple[float, float, float]:
    """Unit direction of gravity in the model's frame (``[machine] gravity_direction``;
    -z without a ``[machine]`` table)."""
    if model.machine is None:
        return DIRECTION_FIELDS["gravity_direction"]
    return model.machine.gravity_direction


#: Frame elements per beam of a model with zero-frequency modes: the inertia relief loads
#: each beam by its consistent mass and the response's rigid part is weighted by it, an
#: O(h^2) error in a beam's own deformation (a spindle's twist under the relief torque: 25 %
#: with 1 element, 2e-4 with 32, against 64). Without zero modes 1 element is exact.
RELIEF_ELEMENTS_PER_BEAM = 32


def _build_structure(model, bodies: tuple[str, ...]) -> _Structure:
    """:class:`_Structure` of ``model`` (see :func:`_structure`)."""
    from ufmt.assembled import assemble
    from ufmt.assembled.constraints import zero_modes

    # one cubic frame element per beam is exact in statics (no load between the nodes; with
    # zero modes see RELIEF_ELEMENTS_PER_BEAM); springs at zero give the beams alone, at one
    # their unit direction rows d_j
    def with_springs(value):
        hinges = []
        for h in model.hinges:
            finite = ~(h.rigid | h.released)
            k = np.where(finite, value, h.stiffness6)
            hinges.append(replace(h, stiffness=k[:3], rotational_stiffness=k[3:]))
        return replace(model, hinges=tuple(hinges))

    elements = 1
    springs = assemble(with_springs(1.0), elements_per_beam=elements)
    zero = zero_modes(springs)
    if zero.shape[1]:  # the inertia relief spreads along the beams' mass
        elements = RELIEF_ELEMENTS_PER_BEAM
        springs = assemble(with_springs(1.0), elements_per_beam=elements)
        zero = zero_modes(springs)
    beams = assemble(with_springs(0.0), elements_per_beam=elements)
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
    mass = basis.T @ springs.M @ basis
    zero = basis.T @ zero  # the zero modes lie in the range of the basis: C z = 0
    if zero.shape[1]:
        zero = zero @ np.linalg.inv(np.linalg.cholesky(zero.T @ mass @ zero)).T
    index = np.array(finite, dtype=int).reshape(-1, 2)
    return _Structure(
        k_beams=basis.T @ beams.K @ basis,
        directions=d @ basis,
        spring_hinge=index[:, 0],
        spring_direction=index[:, 1],
        loads=basis[dofs].T,
        rigid=zero,
        relief=mass @ zero,
        mass_trace=float(np.trace(mass)),
        weight=basis.T @ (springs.M @ _fall(springs, _gravity(model))),
    )


def _fall(am, direction) -> np.ndarray:
    """Every node of ``am`` translated by GRAVITY [m/s^2] along the unit vector ``direction``:
    M times it is the weight of every mass (for a beam the consistent load of its distributed
    weight)."""
    fall = np.zeros(len(am.dof_labels))
    for axis, share in zip("xyz", direction, strict=True):
        fall[[label[2] == axis for label in am.dof_labels]] = GRAVITY * share
    return fall


def static_flexibility(model, bodies: tuple[str, ...]) -> np.ndarray:
    """Static flexibility of the listed bodies' 6 coordinates each, (6B, 6B) (assembled model).

    u = N (N^T K N)^-1 N^T f, N a basis of the motions the rigid hinges allow. The hinges'
    finite springs enter K as sum_j k_j d_j d_j^T: the beams' part and the spring directions
    are assembled once per structure (bodies, hinge geometry, rigid and released directions),
    so another design (hinge stiffnesses) costs the reduced sum and a Cholesky solve.

    The bodies must be rigid or virtual (one node of 6 dofs). A model with zero-frequency
    modes (a released spindle rotation; found from geometry,
    :func:`ufmt.assembled.constraints.zero_modes`) gets the flexibility of its elastic modes
    only, sum_{elastic} v v^T / (M w^2) (inertia relief: the drive holds the spindle, and the
    modal basis leaves those modes out too): with Phi the mass-normalised zero modes and any
    sigma > 0, (K + sigma M Phi Phi^T M)^-1 = sum_elastic + Phi Phi^T / sigma, so
    G = (K + sigma M Phi Phi^T M)^-1 - Phi Phi^T / sigma, sigma = tr K / tr M.
    """
    st = _structure(model, tuple(bodies))
    return st.loads.T @ _elastic_solve(model, st, st.loads)


def gravity_deflection(model, bodies: tuple[str, ...]) -> np.ndarray:
    """Static deflection (6B,) [m, rad] of the listed bodies' coordinates (translation of the
    centre of mass, rotation) under the weight of every mass of ``model`` (GRAVITY along the
    machine's ``gravity_direction``, -z by default),
    solved as :func:`static_flexibility` (elastic modes only where zero modes exist)."""
    st = _structure(model, tuple(bodies))
    return st.loads.T @ _elastic_solve(model, st, st.weight)


def _elastic_solve(model, st: _Structure, rhs: np.ndarray) -> np.ndarray:
    """sum_elastic v v^T rhs / (M w^2) on the reduced coordinates of ``st`` for ``model``'s
    stiffnesses (see :func:`static_flexibility`)."""
    k = np.array([h.stiffness6 for h in model.hinges]).reshape(-1, 6)
    k = k[st.spring_hinge, st.spring_direction]
    k_red = st.k_beams + (st.directions.T * k) @ st.directions
    if not st.rigid.shape[1]:
        return _cholesky_solve(k_red, rhs, model.source)
    sigma = np.trace(k_red) / st.mass_trace
    shifted = k_red + sigma * (st.relief @ st.relief.T)
    return _cholesky_solve(shifted, rhs, model.source) - st.rigid @ (st.rigid.T @ rhs) / sigma


def _cholesky_solve(k: np.ndarray, loads: np.ndarray, source: str) -> np.ndarray:
    """k^-1 loads for a positive definite k; ModelError if it is not (a mechanism the
    geometry did not show)."""
    try:
        return sla.cho_solve(sla.cho_factor(k), loads)
    except np.linalg.LinAlgError:
        raise ModelError(
            f"{source}: the static solve is singular: a motion strains no hinge that the "
            "model's geometry does not show as free"
        ) from None


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
    model = in_machine_frame(model)
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
