"""The definition of the Newton matrix S' written out densely: the elimination of
:mod:`ufmt.mstmm.reduced` as S' = L A R with A the arranged U_all (its rows ``rows``, its
ω-dependent columns ``columns``), L = [I, -G on the kept o rows] and R = [I; -C].

The reference the fast sparse map (:class:`ufmt.mstmm.reduced.SparseReduction`) must equal;
too slow for the search itself (dense products of order |U_all|)."""

import numpy as np


def arranged(reduction, u: np.ndarray) -> np.ndarray:
    """U_all (n, size, size) cut to the reduction's rows and ω-dependent columns."""
    return u[:, reduction.rows[:, None], reduction.columns]


def left_right(reduction) -> tuple[np.ndarray, np.ndarray]:
    """L (m', rows) and R (columns, m') with S' = L A R."""
    n_kept, (rows, columns) = reduction.kept.size, reduction.arranged_shape
    order, g, c = reduction.order, reduction.row_combine, reduction.column_combine
    left = np.zeros((n_kept, rows))
    left[:, :n_kept] = np.eye(n_kept)
    o_rows = np.flatnonzero(reduction.kept < g.shape[0])
    left[o_rows, n_kept:] = -g[reduction.kept[o_rows]]
    right = np.zeros((columns, order))
    right[:order] = np.eye(order)
    right[order:, : c.shape[1]] = -c
    return left, right


def reduced(reduction, u: np.ndarray) -> np.ndarray:
    """S' (n, m', m') of U_all (n, size, size)."""
    left, right = left_right(reduction)
    return left @ arranged(reduction, u) @ right


def null_vectors(reduction, u: np.ndarray, z_reduced: np.ndarray) -> np.ndarray:
    """U_all's null vectors (n, size, q) from S''s (n, m', q), U_all (n, size, size) at the
    same ω: completed with its pivot rows."""
    pivots = arranged(reduction, u)[:, reduction.kept.size :]
    return reduction.completed(z_reduced, lambda z_m: pivots @ z_m)
