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
tr(S'⁻¹ dS'/dω) = tr(U_all⁻¹ dU_all/dω). On the packaged model the order drops from 102
to 64, so each LU and solve of the Newton iteration costs about a third.

Only S's non-constant rows, the pivot rows and the ω-dependent columns are read (the
arranged layout, :meth:`ConstantParts.arrange`); the Newton iteration places its walk's
entries straight there (:meth:`ConstantParts.placement`, :func:`ufmt.mstmm.overall.place`)
and builds the dense U_all only at the three frequencies that find the constant parts.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla


def _pivots(block: np.ndarray, scale: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows of ``block`` (t, k) (rank k) in pivot order, and G (t - k, k) with
    block[other] = G block[pivots], by partial pivoting on the rows scaled by ``scale``."""
    t, k = block.shape
    if k == 0:
        return np.arange(t), np.zeros((t, 0))
    perm, lower, _ = sla.lu(block / scale[:, None], p_indices=True)
    order = np.argsort(perm)  # block / scale = lower[perm] @ upper
    g = sla.solve_triangular(lower[:k], lower[k:].T, trans="T", lower=True, unit_diagonal=True)
    return order, scale[order[k:], None] * g.T / scale[order[:k]][None, :]


@dataclass(frozen=True, eq=False)
class ConstantParts:
    """The elimination of U_all's ω-independent columns and rows (module docstring).

    rows, columns: the rows and ω-dependent columns of U_all that :meth:`reduce` reads, in
    its order (S's non-constant rows of step 1's o and r rows, then its k pivot rows; o, r, p
    columns of step 2); constant: the eliminated columns; row_combine (o, k): G;
    pivot_block (k, k): B_p; kept: positions of S's non-constant rows among the o and r
    rows; column_combine (k2, o2): C.
    """

    rows: np.ndarray
    columns: np.ndarray
    constant: np.ndarray
    row_combine: np.ndarray
    pivot_block: np.ndarray
    kept: np.ndarray
    column_combine: np.ndarray

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
        return cls(read, columns, constant, g, pivot_block, kept, g2.T)

    @property
    def order(self) -> int:
        """Order of S'."""
        return self.kept.size

    @property
    def arranged_shape(self) -> tuple[int, int]:
        """Rows and columns of an arranged U_all (:meth:`arrange`)."""
        return self.rows.size, self.columns.size

    def placement(self) -> tuple[np.ndarray, np.ndarray]:
        """Where U_all's rows and columns go in the arranged matrix (-1: left out), for
        :func:`ufmt.mstmm.overall.place`, which builds it without U_all."""
        size = self.constant.size + self.columns.size
        row_to, col_to = np.full(size, -1), np.full(size, -1)
        row_to[self.rows] = np.arange(self.rows.size)
        col_to[self.columns] = np.arange(self.columns.size)
        return row_to, col_to

    def arrange(self, u: np.ndarray) -> np.ndarray:
        """U_all (n, size, size) cut to :attr:`rows` and :attr:`columns`, one gather."""
        return u[:, self.rows[:, None], self.columns]

    def reduce(self, a: np.ndarray) -> np.ndarray:
        """S'(ω) (n, m', m'), a new C-contiguous array, from U_all(ω) arranged
        (:meth:`arrange`), ``a``, whose other rows are changed in place; its pivot rows are
        kept for :meth:`null_vectors`. dS'/dω from dU_all/dω likewise (the map is
        linear)."""
        n_kept, k2, o = self.kept.size, self.column_combine.shape[0], self.row_combine.shape[0]
        m = self.columns.size
        combined = np.matmul(self.row_combine, a[:, n_kept:])  # G times the pivot rows
        n_o = int(np.searchsorted(self.kept, o))  # S's o rows come first
        a[:, :n_o] -= combined if n_o == o else combined[:, self.kept[:n_o]]
        s = a[:, :n_kept]
        # C padded with zero columns to S's width: the result contiguous in one pass
        out = np.matmul(s[:, :, m - k2 :], self._padded_column_combine)
        return np.subtract(s[:, :, : m - k2], out, out=out)

    @functools.cached_property
    def _padded_column_combine(self) -> np.ndarray:
        """C (k2, o2) followed by zero columns up to S's order."""
        k2, o2 = self.column_combine.shape
        padded = np.zeros((k2, self.columns.size - k2))
        padded[:, :o2] = self.column_combine
        return padded

    def pivot_rows(self, a: np.ndarray) -> np.ndarray:
        """The pivot rows (n, k, columns) of an :meth:`arrange` d U_all (a view): all that
        :meth:`null_vectors` reads of it."""
        return a[:, self.kept.size :]

    def null_vectors(self, pivot_rows: np.ndarray, z_reduced: np.ndarray) -> np.ndarray:
        """U_all's null vectors (n, size, q) from S''s (n, m', q), with ``pivot_rows`` those
        (:meth:`pivot_rows`) of U_all at the same ω."""
        o2 = self.column_combine.shape[1]
        z_p = -self.column_combine @ z_reduced[:, :o2]
        z_m = np.concatenate([z_reduced, z_p], axis=1)  # in the order of ``columns``
        size = self.constant.size + self.columns.size
        z = np.empty((z_m.shape[0], size, z_m.shape[-1]), dtype=z_reduced.dtype)
        z[:, self.columns] = z_m
        if self.constant.size:
            z[:, self.constant] = -np.linalg.solve(self.pivot_block, pivot_rows @ z_m)
        return z
