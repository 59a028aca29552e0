"""The assembled model's matrices: dofs on the mesh, mass and stiffness, the beams'
deformation rows and every hinge direction's relative motion (before constraints)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ufmt.assembled.bodies import body_kind
from ufmt.assembled.mesh import (
    DEFAULT_RTOL,
    MAX_ELEMENTS_PER_BEAM,
    mesh_error,
)
from ufmt.kinematics import point_motion
from ufmt.model.schema import GROUND, Model
from ufmt.recent import Recent

COMPONENTS = ("x", "y", "z", "rx", "ry", "rz")


@dataclass(frozen=True, eq=False)
class AssembledModel:
    """Mass-stiffness model of a :class:`Model` on all dofs, before constraints.

    Attributes
    ----------
    K, M : (n, n) stiffness [N/m, N/rad, N m/rad] and mass [kg, kg m, kg m^2].
    deformation : (r, n) F with ``K = F^T F``: ``sqrt(k) d_j`` per finite spring direction,
        ``R^T D`` per beam element (D: motion of node 2 relative to node 1 carried rigidly,
        ``R^T R`` the element stiffness with node 1 clamped).
    spring_directions : (s, n) the finite spring rows ``d_j`` scaled to unit norm.
    constraints : (c, n) the rows ``d_j`` of the rigid (inf) hinge directions: ``C u = 0``.
    massless : (n,) True for the dofs of virtual bodies.
    dof_labels : (body name, node, component) per dof; node 0 for a rigid body (centre of
        mass) or virtual body (its point), 0..n_elements from start to end of a beam.
    body_dofs : body name -> (n_nodes, 6) dof indices.
    node_positions : body name -> (n_nodes, 3) [m].
    elements_per_beam : beam name -> number of frame elements.
    mesh_error : beam name -> :func:`mesh_error` at the mesh frequency (empty without one).
    structure_key : what everything but the stiffness values is built from (the model's
        :meth:`~ufmt.model.schema.Model.structure_key` and the mesh arguments): the key of
        the cached stiffness-free parts, here (:class:`_Frame`) and in the solution
        (:class:`ufmt.assembled.solve.Structure`).
    source : the model's file, for messages.

    M, massless and the arrays in body_dofs and node_positions are read-only: the designs of
    a stiffness study share them (see :func:`assemble`).
    """

    K: np.ndarray
    M: np.ndarray
    deformation: np.ndarray
    spring_directions: np.ndarray
    constraints: np.ndarray
    massless: np.ndarray
    dof_labels: tuple[tuple[str, int, str], ...]
    body_dofs: dict[str, np.ndarray]
    node_positions: dict[str, np.ndarray]
    elements_per_beam: dict[str, int]
    mesh_error: dict[str, float]
    structure_key: tuple
    source: str = "<memory>"


def assemble(
    model: Model,
    elements_per_beam: int | None = None,
    fmax_hz: float | None = None,
    rtol: float = DEFAULT_RTOL,
    max_elements_per_beam: int = MAX_ELEMENTS_PER_BEAM,
) -> AssembledModel:
    """Assemble the mass-stiffness model of ``model``.

    Parameters
    ----------
    elements_per_beam : frame elements per beam. Default: :func:`elements_for` at ``fmax_hz``
        [Hz] and ``rtol`` (at most ``max_elements_per_beam``), or DEFAULT_ELEMENTS_PER_BEAM
        without ``fmax_hz``.

    Everything but the hinge stiffness values (:class:`_Frame`) is built once per structure
    and mesh and shared by the designs of a stiffness study.
    """
    if elements_per_beam is not None and elements_per_beam < 1:
        raise ValueError(f"elements_per_beam must be >= 1, got {elements_per_beam}")
    mesh = (elements_per_beam, fmax_hz, rtol, max_elements_per_beam)
    key = (model.structure_key(), mesh)
    frame = _FRAMES.get(key, lambda: _frame(model, *mesh))
    stiffness = np.array([hinge.stiffness6 for hinge in model.hinges]).reshape(-1)
    rigid = np.isinf(stiffness)
    finite = ~rigid & (stiffness > 0.0)
    springs = frame.directions[finite]
    K = frame.K.copy()
    _add_springs(springs, stiffness[finite], K)
    return AssembledModel(
        K=K,
        M=frame.M,
        deformation=np.concatenate(
            [frame.element_rows, np.sqrt(stiffness[finite])[:, None] * springs]
        ),
        spring_directions=springs / np.linalg.norm(springs, axis=1, keepdims=True),
        constraints=frame.directions[rigid],
        massless=frame.massless,
        dof_labels=frame.labels,
        body_dofs=dict(frame.body_dofs),  # the dicts are the design's own, their arrays shared
        node_positions=dict(frame.positions),
        elements_per_beam=dict(frame.counts),
        mesh_error={}
        if fmax_hz is None
        else {name: mesh_error(model.body(name), c, fmax_hz) for name, c in frame.counts.items()},
        structure_key=key,
        source=model.source,
    )


@dataclass(frozen=True, eq=False)
class _Frame:
    """The stiffness-free part of an assembled model: the mesh (``positions``, ``counts``),
    dofs (``body_dofs``, ``labels``), M, the beams' K and deformation rows
    (``element_rows``), the massless dofs (``massless``) and every hinge direction's
    relative-motion row (``directions`` (6 hinges, n)). Arrays are read-only: designs share
    them."""

    positions: dict[str, np.ndarray]
    counts: dict[str, int]
    body_dofs: dict[str, np.ndarray]
    labels: tuple[tuple[str, int, str], ...]
    K: np.ndarray
    M: np.ndarray
    element_rows: np.ndarray
    massless: np.ndarray
    directions: np.ndarray


FRAMES_KEPT = 8
_FRAMES = Recent(FRAMES_KEPT)  # (Model.structure_key(), mesh arguments) -> _Frame


def _frame(model: Model, elements_per_beam, fmax_hz, rtol, max_elements) -> _Frame:
    """:class:`_Frame` of ``model`` on its mesh (see :func:`assemble`)."""
    positions, counts = _mesh(model, (elements_per_beam, fmax_hz, rtol, max_elements))
    body_dofs: dict[str, np.ndarray] = {}
    labels: list[tuple[str, int, str]] = []
    for body in model.bodies:
        n_nodes = len(positions[body.name])
        body_dofs[body.name] = len(labels) + np.arange(6 * n_nodes).reshape(n_nodes, 6)
        labels += [(body.name, i, c) for i in range(n_nodes) for c in COMPONENTS]
    n = len(labels)
    K = np.zeros((n, n))
    M = np.zeros((n, n))
    element_rows = np.zeros((6 * sum(counts.values()), n))  # deformation rows of elements
    massless = np.zeros(n, dtype=bool)
    row = 0
    for body in model.bodies:
        rows = element_rows[row : row + 6 * counts.get(body.name, 0)]
        dofs, nodes = body_dofs[body.name], positions[body.name]
        body_kind(body).add(body, dofs, nodes, K, M, massless, rows)
        row += len(rows)
    directions = _relative_motion(model, body_dofs, positions, n).reshape(-1, n)
    for a in (K, M, element_rows, massless, directions, *positions.values(), *body_dofs.values()):
        a.flags.writeable = False
    return _Frame(
        positions, counts, body_dofs, tuple(labels), K, M, element_rows, massless, directions
    )


def _mesh(model: Model, mesh) -> tuple[dict, dict]:
    """Node positions [m] per body and element counts per meshed body (``mesh``: the mesh
    arguments of :func:`assemble`)."""
    positions: dict[str, np.ndarray] = {}
    counts: dict[str, int] = {}
    for body in model.bodies:
        positions[body.name], elements = body_kind(body).nodes(model, body, mesh)
        if elements is not None:
            counts[body.name] = elements
    return positions, counts


def _relative_motion(model: Model, body_dofs, positions, n: int) -> np.ndarray:
    """(hinges, 6, n) maps from all dofs to ``d = u_A(P) - u_B(P)`` at each hinge point P."""
    hinge_index, signs, first_dofs, points, ats = [], [], [], [], []
    for i, hinge in enumerate(model.hinges):
        for side, sign in zip(hinge.between, (1.0, -1.0), strict=True):
            if side == GROUND:
                continue
            body = model.body(side)
            node = body_kind(body).hinge_node(model, hinge, body, positions[side])
            hinge_index.append(i)
            signs.append(sign)
            first_dofs.append(body_dofs[side][node, 0])
            points.append(positions[side][node])
            ats.append(hinge.at)
    offsets = np.reshape(ats, (-1, 3)) - np.reshape(points, (-1, 3))
    blocks = np.reshape(signs, (-1, 1, 1)) * point_motion(offsets)
    columns = np.array(first_dofs, dtype=int).reshape(-1, 1, 1) + np.arange(6)
    rows = np.array(hinge_index, dtype=int).reshape(-1, 1, 1)
    d = np.zeros((len(model.hinges), 6, n))
    d[rows, np.arange(6)[:, None], columns] += blocks  # the two sides touch different dofs
    return d


def _add_springs(directions: np.ndarray, stiffness: np.ndarray, K: np.ndarray) -> None:
    """Add ``sum_j k_j d_j d_j^T`` to K in place (d_j: rows of directions, k_j [N/m, N m/rad])."""
    touched = np.flatnonzero(np.any(directions != 0.0, axis=0))
    d = directions[:, touched]
    K[np.ix_(touched, touched)] += (d.T * stiffness) @ d
