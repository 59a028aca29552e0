"""Assembled mass-stiffness model: the "ordinary method" cross-check of the MSTMM.

An independent finite-element model of the same :class:`~ufmt.model.schema.Model`; it shares
no code with :mod:`ufmt.mstmm`.

* 6 dofs per rigid body (translation of its centre of mass and small rotation, global frame),
  6 per virtual body (at its point), 6 per node of each beam's mesh.
* Beams: 3-D Euler-Bernoulli frame elements, 12x12 stiffness and consistent mass (axial and
  torsion linear, bending cubic Hermite in the local x-y and x-z planes, torsional rotary
  inertia rho*J_p, no shear deformation and no bending rotary inertia: the beam of paper
  eq. 3.3).
* Hinges (paper eqs. 2.13, 2.14): springs on the relative motion ``d = u_A(P) - u_B(P)`` of the
  two bodies at the hinge point P, where ``u(P) = [r_C + theta x (P - C); theta]`` for a rigid
  body and a virtual body or beam end moves with its own 6 dofs; ground does not move.
  Stiffness 0 adds nothing (released), ``inf`` imposes ``d_j = 0`` exactly (dependent dofs
  eliminated), a finite k adds ``k d_j^2 / 2`` to the strain energy.
* Massless dofs (virtual bodies) are condensed exactly; zero-frequency (rigid-body and
  mechanism) modes are counted and left out of the frequency list.

Numerics. The stiffness is kept factored, ``K = F^T F`` (F: square-root-weighted deformation
of every spring direction and every beam element), and the natural frequencies are the singular
values of ``F_red L^-T`` (``L L^T`` the reduced mass matrix) instead of eigenvalues of
``(K_red, M_red)``: with a fine beam mesh ``lambda_max / lambda_1`` reaches 1e12 and ``eigh``
loses ``eps * lambda_max`` in every eigenvalue (relative errors 1e-8 to 1e-6 on a 64- to
256-element cantilever), the singular values only ``eps * sqrt(lambda_max)``. The number of
zero-frequency modes comes from geometry alone (which motions strain nothing), never from a
threshold on small frequencies.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from ufmt.errors import ModelError
from ufmt.model.schema import GROUND, Beam, Model, RigidBody, VirtualBody
from ufmt.recent import Recent

COMPONENTS = ("x", "y", "z", "rx", "ry", "rz")

DEFAULT_ELEMENTS_PER_BEAM = 8  # mesh when neither elements_per_beam nor a frequency is given
MIN_ELEMENTS_PER_BEAM = 2
MAX_ELEMENTS_PER_BEAM = 64  # cap of the automatic mesh (cost); see AssembledModel.mesh_error
DEFAULT_RTOL = 1e-8  # target relative frequency error of the automatic mesh below fmax
# Consistent-mass discretisation error of a mode at wavenumber k, element length h (checked in
# tests/test_assembled.py on a cantilever and a fixed-free rod):
#   bending, cubic Hermite:  df/f ~= (beta h)^4 / BENDING_ERROR_DIVISOR
#   axial and torsion, linear:  df/f ~= (k h)^2 / LINEAR_ERROR_DIVISOR
BENDING_ERROR_DIVISOR = 1440.0
LINEAR_ERROR_DIVISOR = 24.0
PARALLEL_SINE = 1e-9  # beam axis taken as parallel to global z below this |sin angle|
RANK_RTOL = 1e-9  # rank of geometric (unweighted) matrices, relative to the largest value
PIVOT_PREFERENCE = 1e3  # column weight that makes massless dofs the dependent ones


# ---------------------------------------------------------------------------------------------
# geometry and elements


def _skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices (..., 3, 3) of vectors (..., 3): ``_skew(a) @ b == a x b``
    (paper eq. 2.10)."""
    s = np.zeros(v.shape + (3,))
    s[..., 0, 1], s[..., 0, 2] = -v[..., 2], v[..., 1]
    s[..., 1, 0], s[..., 1, 2] = v[..., 2], -v[..., 0]
    s[..., 2, 0], s[..., 2, 1] = -v[..., 1], v[..., 0]
    return s


def point_motion(offset: np.ndarray) -> np.ndarray:
    """(..., 6, 6) maps from ``[r_C; theta]`` to ``[r_C + theta x offset; theta]`` (paper
    eq. 2.5).

    offset (..., 3) [m]: vectors from the reference point C to the point P.
    """
    offset = np.asarray(offset, dtype=float)
    t = np.zeros(offset.shape[:-1] + (6, 6))
    t[..., range(6), range(6)] = 1.0
    t[..., :3, 3:] = -_skew(offset)
    return t


def beam_frame(beam: Beam) -> np.ndarray:
    """Rows e1, e2, e3 of the beam's local frame (``local = frame @ global``).

    e1 along start -> end; e2 the orientation vector (default global z, or global x when the
    axis is vertical) made orthogonal to e1; e3 = e1 x e2.
    """
    e1 = (beam.end - beam.start) / beam.length
    ref = beam.orientation
    if ref is None:
        vertical = math.hypot(e1[0], e1[1]) <= PARALLEL_SINE  # |e1 x z|
        ref = np.array([1.0, 0.0, 0.0]) if vertical else np.array([0.0, 0.0, 1.0])
    e2 = ref - (ref @ e1) * e1
    e2 = e2 / np.linalg.norm(e2)
    e3 = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ]
    return np.array([e1, e2, e3])


# frame-element dofs (node 1 then node 2, local axes) of each deformation
AXIAL, TORSION = np.ix_([0, 6], [0, 6]), np.ix_([3, 9], [3, 9])
BENDING_XY, BENDING_XZ = np.ix_([1, 5, 7, 11], [1, 5, 7, 11]), np.ix_([2, 4, 8, 10], [2, 4, 8, 10])


def frame_element(beam: Beam, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Local 12x12 stiffness and consistent mass of a frame element of length h [m].

    Dofs ``[u v w theta_x theta_y theta_z]`` of node 1 then node 2 in the beam's local axes,
    with ``theta_z = dv/dx`` and ``theta_y = -dw/dx``; second_moment_z acts in the x-y plane.
    Returns (k [N/m, N, N m], m [kg, kg m, kg m^2]).
    """
    e, g, rho, a = beam.youngs_modulus, beam.shear_modulus, beam.density, beam.area
    k = np.zeros((12, 12))
    m = np.zeros((12, 12))
    rod_k = np.array([[1.0, -1.0], [-1.0, 1.0]])
    rod_m = np.array([[2.0, 1.0], [1.0, 2.0]]) * h / 6.0
    for idx, stiffness, inertia in (
        (AXIAL, e * a / h, rho * a),
        (TORSION, g * beam.torsion_constant / h, rho * beam.polar_moment),
    ):
        k[idx] += stiffness * rod_k
        m[idx] += inertia * rod_m
    bend_k = (
        np.array(
            [
                [12.0, 6 * h, -12.0, 6 * h],
                [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                [-12.0, -6 * h, 12.0, -6 * h],
                [6 * h, 2 * h * h, -6 * h, 4 * h * h],
            ]
        )
        / h**3
    )
    bend_m = np.array(
        [
            [156.0, 22 * h, 54.0, -13 * h],
            [22 * h, 4 * h * h, 13 * h, -3 * h * h],
            [54.0, 13 * h, 156.0, -22 * h],
            [-13 * h, -3 * h * h, -22 * h, 4 * h * h],
        ]
    ) * (rho * a * h / 420.0)
    flip = np.array([1.0, -1.0, 1.0, -1.0])  # theta_y = -dw/dx
    flip = flip[:, None] * flip
    k[BENDING_XY] += e * beam.second_moment_z * bend_k  # x-y plane: v, theta_z
    m[BENDING_XY] += bend_m
    k[BENDING_XZ] += e * beam.second_moment_y * (bend_k * flip)  # x-z plane: w, theta_y
    m[BENDING_XZ] += bend_m * flip
    return k, m


def _wavenumbers(beam: Beam, fmax_hz: float) -> tuple[float, float]:
    """Bending and largest of axial/torsional wavenumber [1/m] at fmax_hz."""
    omega = 2.0 * math.pi * fmax_hz
    rho, e = beam.density, beam.youngs_modulus
    weakest = min(beam.second_moment_y, beam.second_moment_z)
    bending = (omega**2 * rho * beam.area / (e * weakest)) ** 0.25
    axial = omega * math.sqrt(rho / e)
    torsion = omega * math.sqrt(
        rho * beam.polar_moment / (beam.shear_modulus * beam.torsion_constant)
    )
    return bending, max(axial, torsion)


def mesh_error(beam: Beam, elements: int, fmax_hz: float) -> float:
    """Estimated worst relative frequency error of modes below fmax_hz [Hz] for this mesh.

    ``max((beta h)^4 / BENDING_ERROR_DIVISOR, (k h)^2 / LINEAR_ERROR_DIVISOR)`` with beta the
    bending and k the larger of the axial and torsional wavenumbers at fmax_hz; it bounds a mode
    whose energy is all in this beam (others are proportionally better). Errors are positive:
    consistent mass makes every frequency an upper bound (Rayleigh-Ritz).
    """
    h = beam.length / elements
    bending, linear = _wavenumbers(beam, fmax_hz)
    return max((bending * h) ** 4 / BENDING_ERROR_DIVISOR, (linear * h) ** 2 / LINEAR_ERROR_DIVISOR)


def elements_for(beam: Beam, fmax_hz: float, rtol: float = DEFAULT_RTOL) -> int:
    """Fewest frame elements with :func:`mesh_error` <= rtol at fmax_hz (uncapped, >= 2).

    The element length h satisfies ``beta h <= (BENDING_ERROR_DIVISOR rtol)^(1/4)`` and
    ``k h <= (LINEAR_ERROR_DIVISOR rtol)^(1/2)``.
    """
    bending, linear = _wavenumbers(beam, fmax_hz)
    h = min(
        (BENDING_ERROR_DIVISOR * rtol) ** 0.25 / bending if bending > 0 else math.inf,
        math.sqrt(LINEAR_ERROR_DIVISOR * rtol) / linear if linear > 0 else math.inf,
    )
    return max(MIN_ELEMENTS_PER_BEAM, math.ceil(beam.length / h) if h < math.inf else 0)


# ---------------------------------------------------------------------------------------------
# assembly


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
        (:class:`Structure`).
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
            [frame.beam_rows, np.sqrt(stiffness[finite])[:, None] * springs]
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
    dofs (``body_dofs``, ``labels``), M, the beams' K and deformation rows (``beam_rows``),
    the virtual bodies' dofs (``massless``) and every hinge direction's relative-motion row
    (``directions`` (6 hinges, n)). Arrays are read-only: designs share them."""

    positions: dict[str, np.ndarray]
    counts: dict[str, int]
    body_dofs: dict[str, np.ndarray]
    labels: tuple[tuple[str, int, str], ...]
    K: np.ndarray
    M: np.ndarray
    beam_rows: np.ndarray
    massless: np.ndarray
    directions: np.ndarray


FRAMES_KEPT = 8
_FRAMES = Recent(FRAMES_KEPT)  # (Model.structure_key(), mesh arguments) -> _Frame


def _frame(model: Model, elements_per_beam, fmax_hz, rtol, max_elements) -> _Frame:
    """:class:`_Frame` of ``model`` on its mesh (see :func:`assemble`)."""
    positions, counts = _mesh(model, elements_per_beam, fmax_hz, rtol, max_elements)
    body_dofs: dict[str, np.ndarray] = {}
    labels: list[tuple[str, int, str]] = []
    for body in model.bodies:
        n_nodes = len(positions[body.name])
        body_dofs[body.name] = len(labels) + np.arange(6 * n_nodes).reshape(n_nodes, 6)
        labels += [(body.name, i, c) for i in range(n_nodes) for c in COMPONENTS]
    n = len(labels)
    K = np.zeros((n, n))
    M = np.zeros((n, n))
    beam_rows = np.zeros((6 * sum(counts.values()), n))  # deformation rows of beam elements
    massless = np.zeros(n, dtype=bool)
    row = 0
    for body in model.bodies:
        dofs = body_dofs[body.name]
        if isinstance(body, RigidBody):
            r, t = dofs[0, :3], dofs[0, 3:]  # consecutive: translations, then rotations
            M[r, r] = body.mass
            M[t[0] : t[-1] + 1, t[0] : t[-1] + 1] = body.inertia
        elif isinstance(body, VirtualBody):
            massless[dofs[0]] = True
        else:
            rows = beam_rows[row : row + 6 * counts[body.name]]
            _add_beam(body, dofs, positions[body.name], K, M, rows)
            row += len(rows)
    directions = _relative_motion(model, body_dofs, positions, n).reshape(-1, n)
    for a in (K, M, beam_rows, massless, directions, *positions.values(), *body_dofs.values()):
        a.flags.writeable = False
    return _Frame(
        positions, counts, body_dofs, tuple(labels), K, M, beam_rows, massless, directions
    )


def _mesh(model, elements_per_beam, fmax_hz, rtol, max_elements) -> tuple[dict, dict]:
    """Node positions [m] per body and element counts per beam."""
    points: dict[str, np.ndarray] = {}  # a virtual body sits at its (first) hinge's point
    for hinge in model.hinges:
        for side in hinge.between:
            if side != GROUND and isinstance(model.body(side), VirtualBody):
                points.setdefault(side, np.asarray(hinge.at, dtype=float))
    positions: dict[str, np.ndarray] = {}
    counts: dict[str, int] = {}
    for body in model.bodies:
        if isinstance(body, RigidBody):
            positions[body.name] = np.asarray(body.center_of_mass, dtype=float)[None, :]
        elif isinstance(body, VirtualBody):
            if body.name not in points:
                raise ModelError(f"{model.source}: body {body.name!r}: no hinge names it")
            positions[body.name] = points[body.name][None, :]
        else:
            if elements_per_beam is not None:
                n = int(elements_per_beam)
            elif fmax_hz is not None:
                n = min(elements_for(body, fmax_hz, rtol), max_elements)
            else:
                n = DEFAULT_ELEMENTS_PER_BEAM
            counts[body.name] = n
            s = np.linspace(0.0, 1.0, n + 1)[:, None]
            positions[body.name] = body.start + s * (body.end - body.start)
    return positions, counts


def _add_beam(beam: Beam, dofs, nodes, K, M, F) -> None:
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


def _relative_motion(model: Model, body_dofs, positions, n: int) -> np.ndarray:
    """(hinges, 6, n) maps from all dofs to ``d = u_A(P) - u_B(P)`` at each hinge point P."""
    beams = {body.name for body in model.bodies if isinstance(body, Beam)}
    hinge_index, signs, first_dofs, points, ats = [], [], [], [], []
    for i, hinge in enumerate(model.hinges):
        for side, sign in zip(hinge.between, (1.0, -1.0), strict=True):
            if side == GROUND:
                continue
            node = _beam_end(model, hinge, side, positions[side]) if side in beams else 0
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


def _beam_end(model: Model, hinge, beam: str, nodes: np.ndarray) -> int:
    """Index of the mesh node of ``beam`` at the hinge point (ModelError unless an end)."""
    node = int(np.argmin(np.linalg.norm(nodes - hinge.at, axis=1)))
    if node not in (0, len(nodes) - 1):
        raise ModelError(
            f"{model.source}: hinge {hinge.name!r}: field 'at': {hinge.at.tolist()} is not at "
            f"an end of beam {beam!r}"
        )
    return node


def _add_springs(directions: np.ndarray, stiffness: np.ndarray, K: np.ndarray) -> None:
    """Add ``sum_j k_j d_j d_j^T`` to K in place (d_j: rows of directions, k_j [N/m, N m/rad])."""
    touched = np.flatnonzero(np.any(directions != 0.0, axis=0))
    d = directions[:, touched]
    K[np.ix_(touched, touched)] += (d.T * stiffness) @ d


# ---------------------------------------------------------------------------------------------
# constraints, condensation, eigen-solution


def _constraint_basis(constraints: np.ndarray, massless: np.ndarray) -> tuple[np.ndarray, ...]:
    """Basis N of the motions the rigid directions allow (``u = N v``, ``C N = 0``).

    Dependent dofs are picked by column-pivoted QR of the row-normalised C, massless dofs
    first; the independent dofs are the coordinates v themselves, so N stays local (a dof no
    constraint touches keeps a unit column) and independent coordinates keep their own mass.
    Returns (N, indices of the independent dofs).
    """
    n = constraints.shape[1]
    if len(constraints) == 0:
        return np.eye(n), np.arange(n)
    rows = constraints / np.linalg.norm(constraints, axis=1, keepdims=True)
    weight = np.where(massless, PIVOT_PREFERENCE, 1.0)
    r, perm = sla.qr(rows * weight, mode="r", pivoting=True)
    pivots = np.abs(np.diag(r))
    rank = int(np.count_nonzero(pivots > RANK_RTOL * pivots[0]))
    dependent, independent = perm[:rank], perm[rank:]
    basis = np.zeros((n, len(independent)))
    basis[independent, np.arange(len(independent))] = 1.0
    coupling = sla.solve_triangular(r[:rank, :rank], r[:rank, rank:])
    basis[dependent] = -weight[dependent, None] * coupling / weight[None, independent]
    return basis, independent


def _null_space(a: np.ndarray, columns: int) -> np.ndarray:
    """Orthonormal basis (as columns) of the null space of an (r, columns) geometric matrix."""
    if columns == 0 or a.shape[0] == 0:
        return np.eye(columns)
    return sla.null_space(a, rcond=RANK_RTOL)


def _rank(a: np.ndarray, floor: float = 0.0) -> int:
    """Numerical rank of a geometric matrix: singular values above RANK_RTOL * max(s1, floor)."""
    if a.size == 0:
        return 0
    s = sla.svdvals(a)
    return int(np.count_nonzero(s > RANK_RTOL * max(s[0], floor)))


def _split_massless(am: AssembledModel, basis, independent) -> tuple[np.ndarray, np.ndarray]:
    """Bases T_a (directions with mass) and T_b (massless) of the motions ``u = N v``.

    Every massive independent coordinate moves its own massive dof, so a massless direction
    lies in the span of the massless independent coordinates: T_b is the part of that span
    that drives no massive dependent dof; T_a holds the rest and every massive coordinate.
    """
    light = am.massless[independent]
    cols = np.flatnonzero(light)
    free = _null_space(basis[np.ix_(~am.massless, cols)], len(cols))
    driving = _null_space(free.T, len(cols))
    return np.hstack([basis[:, ~light], basis[:, cols] @ driving]), basis[:, cols] @ free


def _check_no_massless_mechanism(am: AssembledModel, t_b: np.ndarray) -> None:
    """Raise ModelError if a massless motion strains no spring (K_bb singular)."""
    strain = am.spring_directions @ t_b
    if t_b.shape[1] == 0 or _rank(strain, floor=1.0) == t_b.shape[1]:
        return
    z = _null_space(strain, t_b.shape[1])[:, 0]
    body, _, component = am.dof_labels[int(np.argmax(np.abs(t_b @ z)))]
    raise ModelError(
        f"{am.source}: body {body!r}: massless mechanism: it moves ({component}) without "
        "straining any hinge; give the hinges on it a nonzero stiffness in that direction"
    )


def _zero_mode_count(am: AssembledModel) -> int:
    """Number of independent motions that strain nothing (rigid-body and mechanism modes).

    Such a motion moves every beam rigidly, so it is ``E q`` with q the 6 rigid-motion dofs of
    each body (E carries a beam's first node to its other nodes) and ``[C; S] E q = 0``.
    """
    names = list(am.body_dofs)
    dofs = np.concatenate([am.body_dofs[name] for name in names])  # (all nodes, 6)
    offsets = np.concatenate([am.node_positions[n] - am.node_positions[n][0] for n in names])
    body = np.repeat(np.arange(len(names)), [len(am.body_dofs[name]) for name in names])
    carry = np.zeros((len(am.dof_labels), 6 * len(names)))
    carry[dofs[:, :, None], 6 * body[:, None, None] + np.arange(6)] = point_motion(offsets)
    constraints = am.constraints / np.linalg.norm(am.constraints, axis=1, keepdims=True)
    return 6 * len(names) - _rank(np.vstack([constraints, am.spring_directions]) @ carry)


def svd(a: np.ndarray, vectors: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """Singular values (descending) and right singular vectors (rows; None without
    ``vectors``) of a."""

    def run(driver):
        if not vectors:
            return sla.svd(a, compute_uv=False, lapack_driver=driver), None
        _, s, vh = sla.svd(a, full_matrices=False, lapack_driver=driver)
        return s, vh

    try:
        return run("gesdd")
    except np.linalg.LinAlgError:
        return run("gesvd")


def _unit_columns(basis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Row of each column's first nonzero and the columns that are not unit vectors (a single
    1) of a motion basis (whose columns are mostly unit vectors)."""
    nonzero = basis != 0.0
    first = np.argmax(nonzero, axis=0)
    single = np.count_nonzero(nonzero, axis=0) == 1
    return first, np.flatnonzero(~single | (basis[first, np.arange(basis.shape[1])] != 1.0))


def _times_basis(a: np.ndarray, basis: np.ndarray, unit=None) -> np.ndarray:
    """``a @ basis`` [units of a]: unit columns of the basis copy a column of a, only the others
    are multiplied; unit: :func:`_unit_columns` of basis if already known."""
    first, mixed = _unit_columns(basis) if unit is None else unit
    out = a[:, first]
    out[:, mixed] = a @ basis[:, mixed]
    return out


@dataclass(frozen=True, eq=False)
class Structure:
    """The parts of the eigen-solution that do not depend on the stiffness values: bases T_a,
    T_b (:func:`_split_massless`), T_a's unit columns, the zero-mode count, the Jacobi
    scaling S and the Cholesky factor of ``S M_a S`` (see :func:`_solve`)."""

    t_a: np.ndarray
    t_b: np.ndarray
    unit_a: tuple[np.ndarray, np.ndarray]
    zero_modes: int
    scale: np.ndarray
    chol: np.ndarray


STRUCTURES_KEPT = 8
_STRUCTURES = Recent(STRUCTURES_KEPT)  # AssembledModel.structure_key -> Structure


def structure(am: AssembledModel) -> Structure:
    """:class:`Structure` of ``am``, built once per :attr:`AssembledModel.structure_key`
    (mesh, constraints, spring directions and masses: the designs of a stiffness study
    share it)."""
    return _STRUCTURES.get(am.structure_key, lambda: _build_structure(am))


def _build_structure(am: AssembledModel) -> Structure:
    """:class:`Structure` of ``am`` (see :func:`structure`)."""
    basis, independent = _constraint_basis(am.constraints, am.massless)
    t_a, t_b = _split_massless(am, basis, independent)
    _check_no_massless_mechanism(am, t_b)
    unit_a = _unit_columns(t_a)
    m_a = _reduced_mass(am, t_a, unit_a)
    scale = 1.0 / np.sqrt(np.diag(m_a))
    chol = np.linalg.cholesky(scale[:, None] * m_a * scale[None, :])
    for a in (t_a, t_b, scale, chol, *unit_a):
        a.flags.writeable = False
    return Structure(t_a, t_b, unit_a, _zero_mode_count(am), scale, chol)


def _condensed(am: AssembledModel, parts: Structure):
    """Massive and massless bases, ``F_a``, ``F_red = (I - P_b) F_a`` and the QR of F_b
    (see :func:`_solve`); ``parts``: :func:`structure` of ``am``."""
    t_a, t_b = parts.t_a, parts.t_b
    f_a = _times_basis(am.deformation, t_a, parts.unit_a)
    f_b = _times_basis(am.deformation, t_b)
    scale_b = np.linalg.norm(f_b, axis=0)
    q_b, r_b = np.linalg.qr(f_b / scale_b)
    f_red = f_a - q_b @ (q_b.T @ f_a) if t_b.shape[1] else f_a  # nothing massless: F_a
    return t_a, t_b, f_a, f_red, (q_b, r_b, scale_b)


def reduced_matrices(am: AssembledModel) -> tuple[np.ndarray, np.ndarray, int]:
    """Stiffness [N/m...] and mass [kg...] on the independent massive dofs, and the number
    of zero-frequency modes: ``K_red = F_red^T F_red`` (exact static condensation of the
    massless dofs, see :func:`_solve`), ``M_red = T_a^T M T_a``. For eigen-solvers that
    take (K, M), e.g. ``scipy.linalg.eigh(K, M, subset_by_index=...)`` (benchmarks)."""
    parts = structure(am)
    t_a, _, _, f_red, _ = _condensed(am, parts)
    return f_red.T @ f_red, _reduced_mass(am, t_a, parts.unit_a), parts.zero_modes


def _reduced_mass(am: AssembledModel, t_a: np.ndarray, unit) -> np.ndarray:
    """``M_a = T_a^T M T_a`` [kg, kg m, kg m^2] on the massive coordinates (``unit``:
    :func:`_unit_columns` of T_a)."""
    first, mixed = unit
    m_t = _times_basis(am.M, t_a, unit)
    m_a = m_t[first]
    m_a[mixed] = t_a[:, mixed].T @ m_t
    return m_a


def _solve(am: AssembledModel, with_shapes: bool = True):
    """Nonzero angular frequencies [rad/s] ascending, mass-normalised shapes (None without
    ``with_shapes``: singular values only, about half the time), zero-mode count.

    With ``u = T_a a + T_b b`` (b massless), ``F_a = F T_a``, ``F_b = F T_b`` and P_b the
    projector on the range of F_b, the exact static condensation is
    ``K_aa - K_ab K_bb^-1 K_ba = F_red^T F_red``, ``F_red = (I - P_b) F_a``, and
    ``b = -F_b^+ F_a a``. With S the Jacobi scaling of ``M_a = T_a^T M T_a`` and
    ``S M_a S = L L^T``, omega are the singular values of ``F_red S L^-T`` and the right
    singular vectors v give ``a = S L^-T v`` (``a^T M_a a = 1``).
    """
    parts = structure(am)
    t_a, t_b, f_a, f_red, (q_b, r_b, scale_b) = _condensed(am, parts)
    zero_modes, scale, chol = parts.zero_modes, parts.scale, parts.chol
    n_modes = t_a.shape[1] - zero_modes
    sigma, vh = svd(sla.solve_triangular(chol, (f_red * scale).T, lower=True).T, with_shapes)
    omega = sigma[:n_modes][::-1]
    if not with_shapes:
        return omega, None, zero_modes
    coords = scale[:, None] * sla.solve_triangular(chol.T, vh[:n_modes][::-1].T, lower=False)
    condensed = sla.solve_triangular(r_b, q_b.T @ (f_a @ coords)) / scale_b[:, None]
    shapes = (t_a @ coords - t_b @ condensed).T
    sign = np.sign(shapes[np.arange(n_modes), np.argmax(np.abs(shapes), axis=1)])
    return omega, shapes * sign[:, None], zero_modes


@dataclass(frozen=True, eq=False)
class AssembledModes:
    """Natural frequencies and mode shapes of the assembled model.

    Attributes
    ----------
    frequencies_hz : (n_modes,) nonzero natural frequencies [Hz], ascending.
    rigid_body_modes : number of zero-frequency (rigid-body and mechanism) modes (not listed).
    shapes : (n_modes, n_dofs) mass-normalised shapes on all dofs of ``assembled``,
        ``shapes @ M @ shapes.T = I`` [m/sqrt(kg), rad/sqrt(kg)]; largest entry positive;
        None when computed without shapes.
    assembled : the model they belong to (dofs, mesh, K, M).
    """

    frequencies_hz: np.ndarray
    rigid_body_modes: int
    shapes: np.ndarray | None
    assembled: AssembledModel

    @property
    def dof_labels(self) -> tuple[tuple[str, int, str], ...]:
        """(body name, node, component) of each column of ``shapes``."""
        return self.assembled.dof_labels

    def body_motion(self, body_name: str) -> np.ndarray:
        """Motion ``[r; theta]`` of a body in each mode.

        (n_modes, 6) at the centre of mass of a rigid body or the point of a virtual body;
        (n_modes, n_nodes, 6) at the mesh nodes of a beam (``assembled.node_positions``).
        """
        dofs = self.assembled.body_dofs[body_name]
        motion = self.shapes[:, dofs]
        return motion if len(dofs) > 1 else motion[:, 0]


def assembled_modes(
    model: Model,
    fmax_hz: float | None = None,
    count: int | None = None,
    elements_per_beam: int | None = None,
    rtol: float = DEFAULT_RTOL,
    max_elements_per_beam: int = MAX_ELEMENTS_PER_BEAM,
    shapes: bool = True,
) -> AssembledModes:
    """Natural frequencies and mode shapes by the assembled model ("ordinary method").

    Parameters
    ----------
    fmax_hz : keep the modes at or below this frequency [Hz]; also sets the automatic mesh.
    count : keep at most this many (the lowest). Without ``fmax_hz`` and ``elements_per_beam``
        the mesh is set by the ``count``-th frequency of a first solution on the default mesh.
    elements_per_beam : a fixed mesh instead of the automatic one (:func:`elements_for`).
    rtol, max_elements_per_beam : target error and cap of the automatic mesh.
    shapes : False skips the mode shapes (``shapes`` is None; singular values only: the
        estimates that count and bracket the MSTMM roots).

    Every frequency converges from above as the mesh is refined (consistent mass,
    Rayleigh-Ritz), so the number of modes found below ``fmax_hz`` never exceeds the exact one.
    """
    mesh_hz = fmax_hz
    has_beams = any(isinstance(b, Beam) for b in model.bodies)
    if mesh_hz is None and count is not None and elements_per_beam is None and has_beams:
        first = assembled_modes(
            model, count=count, elements_per_beam=DEFAULT_ELEMENTS_PER_BEAM, shapes=False
        )
        if len(first.frequencies_hz):
            mesh_hz = float(first.frequencies_hz[-1])
    am = assemble(model, elements_per_beam, mesh_hz, rtol, max_elements_per_beam)
    omega, vectors, zero_modes = _solve(am, shapes)
    freq = omega / (2.0 * math.pi)
    keep = np.ones(len(freq), dtype=bool) if fmax_hz is None else freq <= fmax_hz
    if count is not None:
        keep &= np.arange(len(freq)) < count
    return AssembledModes(
        frequencies_hz=freq[keep],
        rigid_body_modes=zero_modes,
        shapes=None if vectors is None else vectors[keep],
        assembled=am,
    )
