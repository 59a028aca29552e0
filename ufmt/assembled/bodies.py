"""How each body kind enters the assembled model: its mesh nodes (6 dofs each), its mass,
stiffness and massless dofs, and the node a hinge on it acts on.

:data:`BODY_KINDS` maps each body form of :mod:`ufmt.kinds` (``FORM`` of a kind's module:
"mass", "point", "member") to its :class:`BodyKind`: a new body kind of an existing form needs
nothing here; its node points, node mass and its members' parts' finite elements come from its
kind's module (the MSTMM has its own table, :mod:`ufmt.mstmm.bodies`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ufmt.assembled.mesh import DEFAULT_ELEMENTS_PER_BEAM, beam_frame, elements_for, frame_element
from ufmt.errors import ModelError
from ufmt.kinds import kind_of
from ufmt.kinematics import point_motion
from ufmt.model.schema import Beam, Body, Model


@dataclass(frozen=True)
class BodyKind:
    """The assembled model's handlers for one body form.

    nodes(model, body, mesh) -> (positions (n_nodes, 3) [m], elements): its mesh nodes and,
        for a meshed body, its number of elements (6 deformation rows each; None otherwise);
        mesh = (elements_per_beam, fmax_hz, rtol, max_elements), see
        :func:`ufmt.assembled.matrices.assemble`.
    add(body, dofs, nodes, K, M, massless, rows) -> None: adds its stiffness to K and its mass
        to M, marks its massless dofs and writes its deformation rows (its block of F, zeros),
        all in place; dofs (n_nodes, 6) are its dof indices.
    hinge_node(model, hinge, body, nodes) -> int: the index of its node a hinge acts on.
    meshed: its dofs depend on the mesh (then the count of modes needs a first solution).
    """

    nodes: Callable
    add: Callable
    hinge_node: Callable
    meshed: bool


def body_kind(body: Body) -> BodyKind:
    """The handlers of ``body``'s form (its kind's ``FORM``)."""
    return BODY_KINDS[kind_of(body).FORM]


def _node(model: Model, body: Body, mesh) -> tuple[np.ndarray, None]:
    """Its kind's one node (1, 3) [m] (a rigid body's centre of mass, a point's hinge point)."""
    return kind_of(body).node_points(model, body), None


def _member_nodes(model: Model, body: Beam, mesh) -> tuple[np.ndarray, int]:
    """Equally spaced nodes from start to end: the given number of elements, or
    :func:`elements_for` at the mesh frequency (capped), or DEFAULT_ELEMENTS_PER_BEAM."""
    elements_per_beam, fmax_hz, rtol, max_elements = mesh
    if elements_per_beam is not None:
        n = int(elements_per_beam)
    elif fmax_hz is not None:
        n = min(elements_for(body, fmax_hz, rtol), max_elements)
    else:
        n = DEFAULT_ELEMENTS_PER_BEAM
    s = np.linspace(0.0, 1.0, n + 1)[:, None]
    return body.start + s * (body.end - body.start), n


def _add_node(body: Body, dofs, nodes, K, M, massless, rows) -> None:
    """Its kind's node mass block (6x6) at its node's dofs, or its six dofs massless."""
    block = kind_of(body).node_mass(body)
    if block is None:
        massless[dofs[0]] = True
    else:
        M[np.ix_(dofs[0], dofs[0])] = block


def _add_member(beam: Beam, dofs, nodes, K, M, massless, F) -> None:
    """Add a meshed beam's elements to K and M and write its deformation rows into F (zeros,
    6 per element), in place.

    An element's stiffness is ``D^T K22 D`` with ``D = [-point_motion(x2 - x1), I]`` the motion
    of node 2 relative to node 1 carried rigidly and K22 the stiffness with node 1 clamped;
    the rows returned are ``R D`` per element, ``K22 = R^T R``.
    """
    n_el = len(nodes) - 1
    k_local, m_local = frame_element(beam, beam.length / n_el)
    rot = np.zeros((4, 3, 4, 3))  # local = rot @ global, block diagonal
    rot[range(4), :, range(4), :] = beam_frame(beam)
    rot = rot.reshape(12, 12)
    k_global = rot.T @ k_local @ rot
    m_global = rot.T @ m_local @ rot
    relative = np.hstack([-point_motion(nodes[1] - nodes[0]), np.eye(6)])
    rows = np.linalg.cholesky(k_global[6:, 6:]).T @ relative
    _add_chain(K, dofs, k_global)
    _add_chain(M, dofs, m_global)
    element = np.arange(n_el)[:, None, None]
    columns = dofs[0, 0] + 6 * element + np.arange(12)
    F.reshape(n_el, 6, -1)[element, np.arange(6)[:, None], columns] = rows


def _add_chain(target: np.ndarray, dofs: np.ndarray, element: np.ndarray) -> None:
    """Add equal 2-node elements (12x12, 6 dofs per node) joining consecutive nodes of a chain
    (dofs: (nodes, 6)) to target in place [units of ``element``]."""
    blocks = element.reshape(2, 6, 2, 6)
    for i in range(2):
        for j in range(2):
            rows, columns = dofs[i : len(dofs) - 1 + i], dofs[j : len(dofs) - 1 + j]
            target[rows[:, :, None], columns[:, None, :]] += blocks[i, :, j, :]


def _first_node(model: Model, hinge, body: Body, nodes: np.ndarray) -> int:
    """A body with one node: the hinge acts on it."""
    return 0


def _member_end(model: Model, hinge, beam: Beam, nodes: np.ndarray) -> int:
    """Index of the mesh node of ``beam`` at the hinge point (ModelError unless an end)."""
    node = int(np.argmin(np.linalg.norm(nodes - hinge.at, axis=1)))
    if node not in (0, len(nodes) - 1):
        raise ModelError(
            f"{model.source}: hinge {hinge.name!r}: field 'at': {hinge.at.tolist()} is not at "
            f"an end of beam {beam.name!r}"
        )
    return node


#: body form (:data:`ufmt.kinds.FORMS`) -> how the assembled model treats it
BODY_KINDS: dict[str, BodyKind] = {
    "mass": BodyKind(_node, _add_node, _first_node, meshed=False),
    "point": BodyKind(_node, _add_node, _first_node, meshed=False),
    "member": BodyKind(_member_nodes, _add_member, _member_end, meshed=True),
}
