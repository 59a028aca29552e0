"""U_all with its ω-independent columns and rows eliminated exactly (for Newton on det).

About a quarter of U_all's columns do not depend on ω (the ground reactions, the released
directions' jumps, the cut states in the geometric equations), and after they are gone some
rows do not either (geometric equations between rigid points). Both are eliminated with
constant factors, chosen once per solve by scaled partial pivoting:

1. Columns. With B the ω-independent columns and A(ω) the others, a row permutation gives
   P U_all = [[B_p, A_p], [B_o, A_o], [0, A_r]] with B_o = G B_p (p: one pivot row per
   constant column, o: the other rows B touches, r: the rest). Subtracting G times the
   pivot rows from the o rows leaves [[B_p, A_p], [0, S]], S = [A_o - G A_p; A_r], so
   det U_all = ± det B_p · det S, and a null vector z_m of S completes to U_all's with
   z_c = -B_p⁻¹ A_p z_m.
2. Rows. S's ω-independent rows R = [R_p, R_o, 0] (a column permutation; p: one pivot
   column per constant row, o: the other columns R touches) force z_p = -C z_o with
   C = R_p⁻¹ R_o. Subtracting the p columns times C from the o columns leaves the constant
   rows as [R_p, 0, 0], so det S = ± det R_p · det S', S' the other rows' o and r columns,
   and a null vector [z_o; z_r] of S' completes to S's with z_p = -C z_o.

det B_p and det R_p are constants: S' has the same roots as U_all and
tr(S'⁻¹ dS'/dω) = tr(U_all⁻¹ dU_all/dω). On the packaged model the order drops from 138
to 72, so each LU and solve of the Newton iteration costs about a seventh.

Only S's non-constant rows, the pivot rows and the ω-dependent columns are read (the
arranged U_all: U_all[rows][:, columns] of :class:`ConstantParts`). The Newton iteration
builds the dense U_all only at the three frequencies that find the constant parts; at the
others it takes the walk's nonzero entries in that layout (a twentieth of U_all's on the
packaged model) and maps them linearly to S''s nonzero entries (:class:`SparseReduction`:
S' = L A R with A the arranged U_all, L = [I, -G] and R = [I; -C], so each entry of A adds
L[i, a] R[b, j] times itself to S'[i, j]). S' is then solved per diagonal block
(:attr:`ufmt.mstmm.sparse.SparseRows.diagonal_blocks`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from ufmt.mstmm.sparse import SparseRows

# G's and C's multipliers (of the rows or columns scaled to O(1)) this small are rounding
# noise of an exact zero (e.g. a lever arm across the plane of symmetry computed as 1e-17):
# kept, they would couple S''s diagonal blocks and make the sparse structure of a design
# depend on its rounding
ROUNDING_MULTIPLIER = 1e-13


def _pivots(block: np.ndarray, scale: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows of ``block`` (t, k) (rank k) in pivot order, and G (t - k, k) with
    block[other] = G block[pivots], by partial pivoting on the rows scaled by ``scale``."""
    t, k = block.shape
    if k == 0:
        return np.arange(t), np.zeros((t, 0))
    perm, lower, _ = sla.lu(block / scale[:, None], p_indices=True)
    order = np.argsort(perm)  # block / scale = lower[perm] @ upper
    g = sla.solve_triangular(lower[:k], lower[k:].T, trans="T", lower=True, unit_diagonal=True)
    g[np.abs(g) <= ROUNDING_MULTIPLIER] = 0.0  # an exact zero's rounding, not a coupling
    return order, scale[order[k:], None] * g.T / scale[order[:k]][None, :]


@dataclass(frozen=True, eq=False)
class ConstantParts:
    """The elimination of U_all's ω-independent columns and rows (module docstring).

    rows, columns: the rows and ω-dependent columns of U_all that S' is made of (the
    arranged U_all), in its order (S's non-constant rows of step 1's o and r rows, then its
    k pivot rows; o, r, p columns of step 2); constant: the eliminated columns;
    row_combine (o, k): G; pivot_block (k, k): B_p; kept: positions of S's non-constant
    rows among the o and r rows; column_combine (k2, o2): C; nonzero (size, size): U_all's
    entries that are not exactly zero in every sample (structurally zero otherwise, as a
    column bitwise equal at frequencies 1e-7 and 40 % apart is constant).
    """

    rows: np.ndarray
    columns: np.ndarray
    constant: np.ndarray
    row_combine: np.ndarray
    pivot_block: np.ndarray
    kept: np.ndarray
    column_combine: np.ndarray
    nonzero: np.ndarray

    @classmethod
    def of(cls, samples: np.ndarray) -> ConstantParts:
        """The elimination for U_all sampled at a few distinct frequencies (q, size, size),
        q >= 2, some close and some far apart: a column or row is ω-independent when it is
        bitwise equal in all of them."""
        size = samples.shape[-1]
        u0 = samples[0]
        moves = np.any(samples[1:] != u0, axis=(0, 1))
        moving, constant = np.flatnonzero(moves), np.flatnonzero(~moves)
        touches = np.any(u0[:, constant] != 0.0, axis=1)
        touched = np.flatnonzero(touches)
        # scaled partial pivoting: each row measured against its largest entry in U_all
        order, g = _pivots(u0[np.ix_(touched, constant)], np.abs(u0[touched]).max(axis=1))
        k = constant.size
        rest = np.flatnonzero(~touches)
        rows = np.concatenate([touched[order[k:]], rest, touched[order[:k]]])

        def s_of(u):  # step 1 on U_all (n, size, size), columns in U_all's order
            a = u[:, rows][:, :, moving]
            a[:, : g.shape[0]] -= g @ a[:, size - k :]
            return a[:, : moving.size]

        s = s_of(samples)
        changes = np.any(s[1:] != s[0], axis=(0, 2))
        still, kept = np.flatnonzero(~changes), np.flatnonzero(changes)
        r = s[0][still]
        touches2 = np.any(r != 0.0, axis=0)
        touched2 = np.flatnonzero(touches2)
        # columns measured against their largest entry in S
        order2, g2 = _pivots(r[:, touched2].T, np.abs(s[0][:, touched2]).max(axis=0))
        k2 = still.size
        rest2 = np.flatnonzero(~touches2)
        columns = moving[np.concatenate([touched2[order2[k2:]], rest2, touched2[order2[:k2]]])]
        pivot_block = u0[np.ix_(rows[size - k :], constant)]
        read = np.concatenate([rows[kept], rows[size - k :]])  # S's constant rows: unread
        nonzero = np.any(samples != 0.0, axis=0)
        return cls(read, columns, constant, g, pivot_block, kept, g2.T, nonzero)

    @property
    def order(self) -> int:
        """Order of S'."""
        return self.kept.size

    @property
    def arranged_shape(self) -> tuple[int, int]:
        """Rows and columns of the arranged U_all."""
        return self.rows.size, self.columns.size

    def placement(self) -> tuple[np.ndarray, np.ndarray]:
        """Where U_all's rows and columns go in the arranged matrix (-1: left out)."""
        size = self.constant.size + self.columns.size
        row_to, col_to = np.full(size, -1), np.full(size, -1)
        row_to[self.rows] = np.arange(self.rows.size)
        col_to[self.columns] = np.arange(self.columns.size)
        return row_to, col_to

    def completed(self, z_reduced: np.ndarray, pivot_times) -> np.ndarray:
        """U_all's null vectors (n, size, q) from S''s (n, m', q); ``pivot_times(z_m)``: U_all's
        pivot rows (at the same ω) times z_m (n, columns, q), the null vectors' ω-dependent
        part in the order of :attr:`columns`."""
        o2 = self.column_combine.shape[1]
        z_p = -self.column_combine @ z_reduced[:, :o2]
        z_m = np.concatenate([z_reduced, z_p], axis=1)  # in the order of ``columns``
        size = self.constant.size + self.columns.size
        z = np.empty((z_m.shape[0], size, z_m.shape[-1]), dtype=z_reduced.dtype)
        z[:, self.columns] = z_m
        if self.constant.size:
            rhs = pivot_times(z_m)  # (n, k, q): one solve with B_p for all of them
            n, k, q = rhs.shape
            flat = np.ascontiguousarray(rhs.transpose(1, 0, 2)).reshape(k, n * q)
            solved = sla.lu_solve(self._pivot_factors, flat, check_finite=False)
            z[:, self.constant] = -solved.reshape(k, n, q).transpose(1, 0, 2)
        return z

    @functools.cached_property
    def _pivot_factors(self):
        """B_p's LU factors (scipy.linalg.lu_factor)."""
        return sla.lu_factor(self.pivot_block, check_finite=False)


@dataclass(frozen=True, eq=False)
class SparseReduction:
    """S' and U_all's pivot rows from the nonzero entries of U_all's arranged rows and
    columns (module docstring): the structure (:class:`_Plan`, shared by every design of a
    structure) and this design's G and C in it.

    to_s (S''s entries, entries taken): S' = L A R entry by entry, this design's L and R
    values in the plan's structure."""

    reduction: ConstantParts
    plan: _Plan
    to_s: object  # scipy.sparse.csr_matrix

    @classmethod
    def of(cls, reduction: ConstantParts, layout: tuple) -> SparseReduction:
        """The map for equation blocks of ``layout`` (per block its row count and its columns
        as int64 bytes, :func:`ufmt.mstmm.overall.block_layout`); the plan is kept per
        structure and pattern of G and C."""
        g_rows = reduction.kept[reduction.kept < reduction.row_combine.shape[0]]
        g, c = reduction.row_combine[g_rows], reduction.column_combine
        g_mask, c_mask = g != 0, c != 0
        key = (
            layout,
            np.packbits(reduction.nonzero).tobytes(),
            reduction.rows.tobytes(),  # int64 indices
            reduction.columns.tobytes(),
            reduction.kept.size,
            g.shape,
            np.packbits(g_mask).tobytes(),
            c.shape,
            np.packbits(c_mask).tobytes(),
        )
        plan = _PLANS.get(key)
        if plan is None:
            plan = _PLANS[key] = _plan(layout, reduction, g_mask, c_mask)
            if len(_PLANS) > PLANS_KEPT:
                del _PLANS[next(iter(_PLANS))]
        left, right = np.r_[1.0, -g[g_mask]], np.r_[1.0, -c[c_mask]]
        coefficients = left[plan.left] * right[plan.right]
        to_s = sp.csr_matrix((coefficients, plan.entries, plan.starts), shape=plan.to_s_shape)
        return cls(reduction, plan, to_s)

    @property
    def pattern(self) -> SparseRows:
        """S''s entries."""
        return self.plan.pattern

    def values(self, blocks: list) -> np.ndarray:
        """The taken entries (n, q) of equation blocks of this map's layout."""
        return np.concatenate([blocks[k].arr[:, i, j] for k, i, j in self.plan.gather], axis=1)

    def s_values(self, values: np.ndarray) -> np.ndarray:
        """S''s entries (n, :attr:`pattern`) from the taken entries (n, q) (:meth:`values`)."""
        return (self.to_s @ np.ascontiguousarray(values.T)).T

    def null_vectors(self, values: np.ndarray, z_reduced: np.ndarray) -> np.ndarray:
        """U_all's null vectors (n, size, q) from S''s (n, m', q), with ``values`` the taken
        entries (:meth:`values`) of U_all at the same ω."""
        pivot_values = values[:, self.plan.pivot_entries]
        pivots = self.plan.pivots
        return self.reduction.completed(z_reduced, lambda z_m: pivots.times(pivot_values, z_m))


@dataclass(frozen=True, eq=False)
class _Plan:
    """The structure of a :class:`SparseReduction`: gather, per equation block (index, rows,
    columns) of the entries taken (U_all's arranged nonzeros); S''s entry k is the sum over
    ``entries[starts[k]:starts[k + 1]]`` (indices of the taken ones) times L's value
    ``left`` and R's value ``right`` (indices into [1, -G] and [1, -C] at the nonzeros of the
    plan's pattern of G and C); pattern: S''s entries; pivots: the pivot rows' entries,
    ``pivot_entries`` where they are among the taken ones."""

    gather: tuple
    entries: np.ndarray
    starts: np.ndarray
    left: np.ndarray
    right: np.ndarray
    to_s_shape: tuple
    pattern: SparseRows
    pivots: SparseRows
    pivot_entries: np.ndarray


_PLANS: dict = {}  # a reduction's structure (SparseReduction.of) -> its plan
PLANS_KEPT = 64


def _plan(layout: tuple, reduction: ConstantParts, g_mask, c_mask) -> _Plan:
    """The :class:`_Plan` of ``reduction`` for equation blocks of ``layout``, with G (on
    the kept o rows) and C taken as nonzero at ``g_mask`` and ``c_mask``."""
    nonzero, n_kept = reduction.nonzero, reduction.kept.size
    row_to, col_to = reduction.placement()
    gather, a, b, r0 = [], [], [], 0
    for k, (r, cols) in enumerate(layout):
        cols = np.frombuffer(cols, dtype=np.int64)
        block_rows = np.arange(r0, r0 + r)
        take = nonzero[np.ix_(block_rows, cols)]
        take &= (row_to[block_rows] >= 0)[:, None] & (col_to[cols] >= 0)[None, :]
        i, j = np.nonzero(take)
        if i.size:
            gather.append((k, i, j))
            a.append(row_to[block_rows[i]])
            b.append(col_to[cols[j]])
        r0 += r
    a, b = np.concatenate(a), np.concatenate(b)
    n_rows, n_columns = reduction.arranged_shape
    order = n_columns - c_mask.shape[0]  # S''s order
    gi, gp = np.nonzero(g_mask)
    cq, cj = np.nonzero(c_mask)
    # L's columns: S's kept rows as they are (value 1, index 0); pivot row p: -G on the
    # kept o rows; R's rows: S's first `order` columns as they are; p column q: -C
    left = _by_source(n_rows, np.r_[np.arange(n_kept), n_kept + gp], np.r_[np.arange(n_kept), gi])
    left_value = np.r_[np.zeros(n_kept, int), 1 + np.arange(gi.size)][left[2]]
    right = _by_source(n_columns, np.r_[np.arange(order), order + cq], np.r_[np.arange(order), cj])
    right_value = np.r_[np.zeros(order, int), 1 + np.arange(cq.size)][right[2]]
    # every entry e of A adds L[i, a_e] R[b_e, j] A_e to S'[i, j]
    n_left, n_right = np.diff(left[0])[a], np.diff(right[0])[b]
    count = n_left * n_right
    entry = np.repeat(np.arange(a.size), count)
    k = np.arange(entry.size) - np.repeat(np.cumsum(count) - count, count)
    at_left = left[0][a[entry]] + k // n_right[entry]
    at_right = right[0][b[entry]] + k % n_right[entry]
    target = left[1][at_left] * order + right[1][at_right]
    flat, slot = np.unique(target, return_inverse=True)
    by_slot = np.argsort(slot, kind="stable")
    starts = np.searchsorted(slot[by_slot], np.arange(flat.size + 1))
    pattern = SparseRows((order, order), flat // order, flat % order)  # rows ascending
    pivot = np.flatnonzero(a >= n_kept)
    pivots, by_row = SparseRows.of((n_rows - n_kept, n_columns), a[pivot] - n_kept, b[pivot])
    return _Plan(
        tuple(gather),
        entry[by_slot],
        starts,
        left_value[at_left][by_slot],
        right_value[at_right][by_slot],
        (flat.size, a.size),
        pattern,
        pivots,
        pivot[by_row],
    )


def _by_source(n: int, source: np.ndarray, target: np.ndarray):
    """A sparse map's entries grouped by source (0..n-1): (start of each source's entries
    (n + 1,), their targets, the order that sorts entries given in this order)."""
    order = np.argsort(source, kind="stable")
    starts = np.searchsorted(source[order], np.arange(n + 1))
    return starts, target[order], order
