"""Constraints of the assembled model: the motions the rigid hinge directions allow, their
split into directions with and without mass, and the number of motions that strain nothing.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from ufmt.assembled.matrices import AssembledModel
from ufmt.errors import ModelError
from ufmt.kinematics import point_motion

RANK_RTOL = 1e-9  # rank of geometric (unweighted) matrices, relative to the largest value
PIVOT_PREFERENCE = 1e3  # column weight that makes massless dofs the dependent ones


def constraint_basis(constraints: np.ndarray, massless: np.ndarray) -> tuple[np.ndarray, ...]:
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


def split_massless(am: AssembledModel, basis, independent) -> tuple[np.ndarray, np.ndarray]:
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


def check_no_massless_mechanism(am: AssembledModel, t_b: np.ndarray) -> None:
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


def _rigid_carry(am: AssembledModel) -> tuple[np.ndarray, np.ndarray]:
    """E (n, 6B): every body moved rigidly by its 6 rigid-motion dofs q (E carries a beam's
    first node to its other nodes); and ``[C; S] E`` with C the rigid directions and S the
    finite spring directions (rows of unit norm): the strain of each rigid motion."""
    names = list(am.body_dofs)
    dofs = np.concatenate([am.body_dofs[name] for name in names])  # (all nodes, 6)
    offsets = np.concatenate([am.node_positions[n] - am.node_positions[n][0] for n in names])
    body = np.repeat(np.arange(len(names)), [len(am.body_dofs[name]) for name in names])
    carry = np.zeros((len(am.dof_labels), 6 * len(names)))
    carry[dofs[:, :, None], 6 * body[:, None, None] + np.arange(6)] = point_motion(offsets)
    constraints = am.constraints / np.linalg.norm(am.constraints, axis=1, keepdims=True)
    return carry, np.vstack([constraints, am.spring_directions]) @ carry


def zero_modes(am: AssembledModel) -> np.ndarray:
    """Orthonormal basis (n, m) of the motions that strain nothing (rigid-body and mechanism
    modes, e.g. a spindle free to turn), from geometry alone: ``E q`` with ``[C; S] E q = 0``
    (:func:`_rigid_carry`; null space at RANK_RTOL), never from small eigenvalues."""
    carry, strain = _rigid_carry(am)
    q = _null_space(strain, carry.shape[1])
    if q.shape[1] == 0:
        return np.zeros((carry.shape[0], 0))
    return np.linalg.qr(carry @ q)[0]


def zero_mode_count(am: AssembledModel) -> int:
    """Number of independent motions that strain nothing (rigid-body and mechanism modes,
    :func:`zero_modes`)."""
    carry, strain = _rigid_carry(am)
    return carry.shape[1] - _rank(strain)
