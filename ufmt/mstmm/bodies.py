"""How each body kind enters the MSTMM: its nodes and edges in the transfer graph, the node a
hinge on it meets, the state its motion is read from, its motion in a mode and its mass
products.

:data:`BODY_RULES` maps each body form of :mod:`ufmt.kinds` (``FORM`` of a kind's module:
"mass", "point", "member") to its :class:`BodyRules`: a new body kind of an existing form
needs nothing here; its own formulations (a mass node's U_{i,I1}, a member's parts, their
mass products) come from its kind's module. Every node of the transfer graph carries one of
two transfer rules: a mass node's (:data:`RIGID_NODE`, eqs. 2.8, 2.9, 2.5) or a massless
point's (:data:`POINT_NODE`: a virtual body or a beam end, eq. 2.11).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.special import gammaln

from ufmt.kinds import BODY_KINDS, kind_of
from ufmt.kinematics import skew
from ufmt.model.schema import Beam, Body, Model, RigidBody, VirtualBody
from ufmt.mstmm import elements
from ufmt.mstmm.graph import Edge, Node, NodeTransfer, Topology

# ---------------------------------------------------------------------------------------------
# node transfer rules


@functools.lru_cache(maxsize=4096)
def _mass_parts(kind: str, mass, inertia: tuple, com: tuple, p_in: tuple, p_out: tuple):
    """Constant and ω² parts (12, 12) of a rigid body's U_{i,I1} (eq. 2.8, its kind's
    ``first_input_transfer``), shared by every design with the same body (a stiffness sweep
    builds them once)."""
    both = BODY_KINDS[kind].first_input_transfer(
        np.array([0.0, 1.0]), mass, np.reshape(inertia, (3, 3)), com, np.array(p_in), p_out
    )
    parts = both[0], both[1] - both[0]
    for a in parts:
        a.flags.writeable = False  # cached: shared by every walk
    return parts


def _mass_first_input(node: Node, first_point) -> tuple[np.ndarray, np.ndarray]:
    """U_{i,I1} of the node's body (eq. 2.8, a mass node's): constant and ω² parts."""
    b = node.body
    points = (b.center_of_mass, first_point, node.output_point)
    inertia = tuple(np.ravel(b.inertia))
    return _mass_parts(b.kind, b.mass, inertia, *(tuple(p) for p in points))


@functools.lru_cache(maxsize=4096)
def _rigid_geometric_map(lever: tuple) -> np.ndarray:
    """H_k (6, 12) on a rigid body (eqs. 2.5-2.7): the displacement of input k carried to the
    first input point (``lever`` = p_k - p_1 [m]), and the rotation."""
    h_k = np.zeros((6, 12))
    h_k[0:3, 0:3] = np.eye(3)
    h_k[0:3, 3:6] = skew(lever)
    h_k[3:6, 3:6] = np.eye(3)
    h_k.flags.writeable = False  # cached: shared by every walk
    return h_k


def _point_geometric_map() -> np.ndarray:
    """H_k (6, 12) at a massless point: every input end has the same displacement."""
    h_k = np.zeros((6, 12))
    h_k[0:3, 0:3] = np.eye(3)
    h_k[3:6, 3:6] = np.eye(3)
    h_k.flags.writeable = False
    return h_k


_POINT_GEOMETRIC_MAP = _point_geometric_map()

#: a rigid body's node: mass in U_{i,I1}, levers across the body
RIGID_NODE = NodeTransfer(
    first_input=_mass_first_input,
    other_lever=lambda p_k, p_out: p_k,
    geometric_map=lambda p_1, p_k: _rigid_geometric_map(tuple(np.subtract(p_k, p_1))),
)
#: a massless point (virtual body, beam end): U_{i,I1} = I, no lever
POINT_NODE = NodeTransfer(
    first_input=lambda node, first_point: None,
    other_lever=lambda p_k, p_out: p_out,
    geometric_map=lambda p_1, p_k: _POINT_GEOMETRIC_MAP,
)


# ---------------------------------------------------------------------------------------------
# the table


@dataclass
class ShapeParts:
    """Body motions of a set of modes, by where :class:`ufmt.mstmm.modes.ModeShapes` keeps
    them: rigid (n, 6) at the centre of mass (and the centres), virtual (n, 6) at the point,
    beams (positions, weights, motion (n, g, 6)) along the beam."""

    rigid: dict = field(default_factory=dict)
    virtual: dict = field(default_factory=dict)
    beams: dict = field(default_factory=dict)
    centers: dict = field(default_factory=dict)


@dataclass(frozen=True)
class BodyRules:
    """The MSTMM's handlers for one body form.

    graph(model, body) -> (nodes, edges) it adds to the transfer graph;
    hinge_end(body, point) -> the name of its node at a hinge point;
    reference(body, point) -> the reference point [m] of that node's six small-motion dofs;
    state_key(topology, body) -> the state map (:meth:`TransferSystem.states` key) its motion
        is read from;
    shape(system, body, states, z, omega, parts) -> None: its motion in each mode into the
        :class:`ShapeParts`;
    kinetic(body, rigid_a, beams_a, rigid_b, beams_b, out) -> None: its mass products
        ⟨V_a, M V_b⟩ (n, 6) [kg] per direction into ``out``;
    edge_matrix(omega, body, rotation), edge_rotation(body, p_in, p_out): the transfer matrix
        of its own edge and that edge's rotation to the global frame (None without an edge).
    """

    graph: Callable
    hinge_end: Callable
    reference: Callable
    state_key: Callable
    shape: Callable
    kinetic: Callable
    edge_matrix: Callable | None = None
    edge_rotation: Callable | None = None


def rules_of(body: Body) -> BodyRules:
    """The handlers of ``body``'s form (its kind's ``FORM``)."""
    return BODY_RULES[kind_of(body).FORM]


def apply_state(state, z: np.ndarray) -> np.ndarray:
    """States (n, 12) of a State map at each mode's frequency and unknowns z (n, order)."""
    return np.einsum("nik,nk->ni", state.arr, z[:, state.cols])


def _own_node(body: Body, point) -> str:
    """A body that is one node: its name."""
    return body.name


def _at_point(body: Body, point) -> np.ndarray:
    """A node whose dofs are taken at the hinge point itself."""
    return point


def _no_mass(body, rigid_a, beams_a, rigid_b, beams_b, out) -> None:
    """A massless body adds nothing."""


# -- mass nodes (rigid bodies) ------------------------------------------------------------------


def _mass_graph(model: Model, body: RigidBody) -> tuple[list[Node], list[Edge]]:
    """One node that carries the body's mass and extent."""
    return [Node(body.name, RIGID_NODE, body=body)], []


def _mass_state_key(topology: Topology, body: RigidBody) -> tuple:
    """A rigid body's motion is read from its first input."""
    return ("node_in", body.name, 0)


def _mass_shape(system, body: RigidBody, states, z, omega, parts: ShapeParts) -> None:
    """[r_C; θ] at the centre of mass from the state at the first input end."""
    point = system.topology.first_input_point(body.name)
    state = states[_mass_state_key(system.topology, body)]
    s = np.einsum("nik,nk->ni", state.arr[:, :6], z[:, state.cols])  # [r_P; θ] only
    # r_C = r_P + θ × (C - P) (eq. 2.5), as rows: θ @ skew(C - P)
    r = s[:, :3] + s[:, 3:] @ skew(body.center_of_mass - point)
    parts.rigid[body.name] = np.concatenate([r, s[:, 3:]], axis=1)
    parts.centers[body.name] = body.center_of_mass


def _mass_kinetic(body: RigidBody, rigid_a, beams_a, rigid_b, beams_b, out) -> None:
    """Its kind's mass products of the two motions at the centre of mass (eq. 3.1)."""
    out[:] = kind_of(body).mass_products(body, rigid_a[body.name], rigid_b[body.name])


# -- massless points (virtual bodies) -----------------------------------------------------------


def _point_graph(model: Model, body: VirtualBody) -> tuple[list[Node], list[Edge]]:
    """One massless node at its kind's node point (its hinges' point)."""
    return [Node(body.name, POINT_NODE, point=kind_of(body).node_points(model, body)[0])], []


def _point_state_key(topology: Topology, body: VirtualBody) -> tuple:
    """A virtual body's motion is read from its output."""
    return ("node_out", body.name)


def _point_shape(system, body: VirtualBody, states, z, omega, parts: ShapeParts) -> None:
    """[r; θ] at the body's point: the displacement half of its output state."""
    state = states[_point_state_key(system.topology, body)]
    parts.virtual[body.name] = apply_state(state, z)[:, :6]


# -- members (beams) ----------------------------------------------------------------------------


def _member_graph(model: Model, body: Beam) -> tuple[list[Node], list[Edge]]:
    """Two massless end nodes ``<beam>@start``, ``<beam>@end`` and the beam edge between."""
    nodes = [
        Node(f"{body.name}@{end}", POINT_NODE, point=p)
        for end, p in (("start", body.start), ("end", body.end))
    ]
    edge = Edge(
        body.name, "body", body, f"{body.name}@start", f"{body.name}@end", body.start, body.end
    )
    return nodes, [edge]


def beam_end_node(beam: Beam, point) -> str:
    """Name of the node at the beam end nearest ``point``."""
    d0 = np.linalg.norm(np.asarray(point) - beam.start)
    d1 = np.linalg.norm(np.asarray(point) - beam.end)
    return f"{beam.name}@start" if d0 <= d1 else f"{beam.name}@end"


def _member_state_key(topology: Topology, body: Beam) -> tuple:
    """A beam's motion is read from its input end."""
    return ("edge_in", topology.body_edge(body.name))


def _member_shape(system, body: Beam, states, z, omega, parts: ShapeParts) -> None:
    """The beam's displacement field at its Gauss points (:func:`beam_field`)."""
    parts.beams[body.name] = beam_field(system, body, states, z, omega)


def _member_kinetic(body: Beam, rigid_a, beams_a, rigid_b, beams_b, out) -> None:
    """Its kind's mass products of the two fields at its Gauss points."""
    out[:] = kind_of(body).mass_products(body, beams_a[body.name], beams_b[body.name])


def beam_field(system, beam: Beam, states, z, omega, fractions=None):
    """Beam motion (n, g, 6) at Gauss points, or at ``fractions`` of its length from ``start``.

    The state at the beam's input end is transferred over part of the length (eq. 2.12).
    Returns (positions (g, 3) [m], quadrature weights (g,) [m], motion (n, g, 6)).
    """
    topo = system.topology
    index = topo.body_edge(beam.name)
    e = topo.edges[index]
    p_in, p_out = e.point_at(e.input_node), e.point_at(e.output_node)
    z_in = apply_state(states[_member_state_key(topo, beam)], z)
    length = beam.length
    if fractions is None:
        x, wts = _gauss_legendre(gauss_points(beam, omega.max(initial=0.0)))
        s = 0.5 * (x + 1.0) * length
        wts = 0.5 * wts * length
    else:  # fractions from the beam's start; the transfer runs from its input end
        f = np.asarray(fractions, dtype=float)
        reversed_ = e.input_node.endswith("@end")
        s = (1.0 - f if reversed_ else f) * length
        wts = np.full(s.size, np.nan)
    n = omega.size  # one batch over every (point, mode) pair, the states in local axes
    t = system.edge_rotation(index)  # local to global (12, 12): z_in @ t = (t.T z_in)
    y = np.tile(z_in @ t, (s.size, 1))
    local = elements.beam_local_displacement(np.tile(omega, s.size), beam, np.repeat(s, n), y)
    motion = (local @ t[:6, :6].T).reshape(s.size, n, 6).transpose(1, 0, 2)
    motion = np.ascontiguousarray(motion)
    positions = p_in + np.outer(s / length, p_out - p_in)
    return positions, wts, motion


GAUSS_POINTS = 16  # per beam at most (modal-mass integrals to ~1e-12 up to βL ≈ 15)
GAUSS_RTOL = 1e-15  # fewer points where the Gauss error bound allows (see gauss_points)
_GAUSS_ORDERS = np.arange(4, GAUSS_POINTS + 1)
# log of the g-point rule's error bound without its c^(2g+1) factor (see gauss_points)
_GAUSS_LOG_FACTOR = (
    4 * gammaln(_GAUSS_ORDERS + 1)
    - np.log(2 * _GAUSS_ORDERS + 1)
    - 3 * gammaln(2 * _GAUSS_ORDERS + 1)
)


def gauss_points(beam: Beam, omega_max: float) -> int:
    """Gauss-Legendre points for a beam's modal-mass integrals up to ω_max [rad/s].

    The integrands are products of two fields made of e^{±βs}, e^{±iβs} (β the largest
    wavenumber of its parts: bending, axial or torsional), so the g-point rule errs by at most about
    c^(2g+1) (g!)^4 / ((2g + 1) ((2g)!)^3) relative, c = 2βL (the remainder of the rule
    for e^{cx} on [0, 1]); the smallest g with that below GAUSS_RTOL, at least 4 (exact for
    the product of two static cubic fields, which the exponentials cancel down to at small
    βL) and at most GAUSS_POINTS.
    """
    waves = [p.formulation.wavenumber(omega_max) for p in kind_of(beam).parts(beam)]
    c = 2.0 * beam.length * max(*waves, 1e-3)
    log_error = (2 * _GAUSS_ORDERS + 1) * np.log(c) + _GAUSS_LOG_FACTOR
    fine = _GAUSS_ORDERS[log_error <= np.log(GAUSS_RTOL)]
    return int(fine[0]) if fine.size else GAUSS_POINTS


@functools.lru_cache(maxsize=GAUSS_POINTS)
def _gauss_legendre(points: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes and weights on [-1, 1] (read-only, computed once per order)."""
    x, w = np.polynomial.legendre.leggauss(points)
    x.flags.writeable = w.flags.writeable = False
    return x, w


#: body form (:data:`ufmt.kinds.FORMS`) -> how the MSTMM treats it
BODY_RULES: dict[str, BodyRules] = {
    "mass": BodyRules(
        graph=_mass_graph,
        hinge_end=_own_node,
        reference=lambda body, point: body.center_of_mass,
        state_key=_mass_state_key,
        shape=_mass_shape,
        kinetic=_mass_kinetic,
    ),
    "point": BodyRules(
        graph=_point_graph,
        hinge_end=_own_node,
        reference=_at_point,
        state_key=_point_state_key,
        shape=_point_shape,
        kinetic=_no_mass,
    ),
    "member": BodyRules(
        graph=_member_graph,
        hinge_end=beam_end_node,
        reference=_at_point,
        state_key=_member_state_key,
        shape=_member_shape,
        kinetic=_member_kinetic,
        edge_matrix=lambda omega, body, rotation: elements.beam(omega, body, rotation=rotation),
        edge_rotation=elements.beam_rotation,
    ),
}
