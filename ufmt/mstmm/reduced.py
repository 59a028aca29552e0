"""U_all with its ω-independent columns eliminated exactly (for the Newton iteration on det).

About a quarter of U_all's columns do not depend on ω: the ground reactions, the released
directions' jumps, the cut states in the geometric equations. With B those columns, A(ω) the
others and a row permutation P chosen by scaled partial pivoting on B,

    P U_all = [[B_p, A_p(ω)], [B_o, A_o(ω)], [0, A_r(ω)]],  B_o = G' B_p,

(p: one pivot row per constant column, o: the other rows B touches, r: the rows it does not)
so subtracting G' times the pivot rows from the o rows leaves the block triangular form

    [[B_p, A_p], [0, S(ω)]],  S = [A_o - G' A_p; A_r],  det U_all = ± det B_p · det S(ω).

det B_p is a constant: S has the same roots as U_all, tr(S⁻¹ dS/dω) = tr(U_all⁻¹ dU_all/dω)
and a null vector z_m of S gives U_all's as [z_c; z_m] with z_c = -B_p⁻¹ A_p z_m. The order
drops from 102 to 75 on the packaged model, so each LU and solve costs about half.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla


@dataclass(frozen=True, eq=False)
class ConstantColumns:
    """The elimination of U_all's ω-independent columns (module docstring).

    moving (m,): columns of U_all that depend on ω, in S's column order; constant (k,): the
    others; pivot_rows (k,), other_rows, rest_rows: the rows p, o and r; combine (o, k): G';
    pivot_block (k, k): B_p.
    """

    moving: np.ndarray
    constant: np.ndarray
    pivot_rows: np.ndarray
    other_rows: np.ndarray
    rest_rows: np.ndarray
    combine: np.ndarray
    pivot_block: np.ndarray

    @classmethod
    def of(cls, u_a: np.ndarray, u_b: np.ndarray) -> ConstantColumns:
        """The elimination for U_all evaluated at two sets of frequencies (n, size, size)
        (a column is ω-independent when it is bitwise equal in both)."""
        size = u_a.shape[-1]
        moving = np.flatnonzero(np.any(u_a != u_b, axis=(0, 1)))
        constant = np.setdiff1d(np.arange(size), moving)
        b = u_a[0][:, constant]
        touched = np.flatnonzero(np.any(b != 0.0, axis=1))
        # scaled partial pivoting: each row measured against its largest entry in U_all
        scale = np.abs(u_a[0][touched]).max(axis=1)
        perm, lower, _ = sla.lu(b[touched] / scale[:, None], p_indices=True)
        order = np.argsort(perm)  # rows of b[touched] in pivot order
        k = constant.size
        pivots, others = touched[order[:k]], touched[order[k:]]
        # G' = L_o L_p⁻¹ in the scaled rows, back to U_all's rows
        g = sla.solve_triangular(
            lower[:k], lower[k:].T, trans="T", lower=True, unit_diagonal=True
        ).T
        combine = scale[order[k:], None] * g / scale[order[:k]][None, :]
        rest = np.setdiff1d(np.arange(size), touched)
        return cls(
            moving, constant, pivots, others, rest, combine, u_a[0][np.ix_(pivots, constant)]
        )

    @property
    def order(self) -> int:
        """Order of S."""
        return self.moving.size

    @property
    def layout(self) -> tuple[np.ndarray, np.ndarray]:
        """(rows, columns) of U_all that S is made of, in the order :meth:`reduce` reads them:
        o, r, then p rows; the ω-dependent columns."""
        return np.concatenate([self.other_rows, self.rest_rows, self.pivot_rows]), self.moving

    def arrange(self, u: np.ndarray) -> np.ndarray:
        """U_all (n, size, size) cut to :attr:`layout` (n, size, m)."""
        rows, columns = self.layout
        flat = (rows[:, None] * u.shape[-1] + columns[None, :]).ravel()  # one gather
        return np.take(u.reshape(u.shape[0], -1), flat, axis=1).reshape(u.shape[0], rows.size, -1)

    def reduce(self, a: np.ndarray) -> np.ndarray:
        """S(ω) (n, m, m) from U_all(ω) in :attr:`layout` (n, size, m), in place (a view of
        ``a``); dS/dω from dU_all/dω likewise (the map is linear)."""
        s = a[:, : self.order]
        s[:, : self.other_rows.size] -= self.combine @ a[:, self.order :]
        return s

    def null_vectors(self, a: np.ndarray, z_moving: np.ndarray) -> np.ndarray:
        """U_all's null vectors (n, size, q) from S's (n, m, q), with U_all at the same ω in
        :attr:`layout` (n, size, m) (only its pivot rows are read)."""
        z = np.empty((a.shape[0], a.shape[1], z_moving.shape[-1]), dtype=z_moving.dtype)
        z[:, self.moving] = z_moving
        z[:, self.constant] = -np.linalg.solve(self.pivot_block, a[:, self.order :] @ z_moving)
        return z
