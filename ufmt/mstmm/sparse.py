"""Stacks of sparse matrices that share one pattern of entries, for the Newton iteration's S'
(:mod:`ufmt.mstmm.reduced`): on the packaged model an eighth of S''s entries are nonzero and
a twentieth of U_all's, so products, scalings and the dense matrix for LAPACK are built from
the nonzero entries alone."""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class SparseRows:
    """Positions of a (rows, columns) matrix's entries, sorted by row (:meth:`of`); a stack
    of such matrices is its values (n, entries), in this order."""

    shape: tuple[int, int]
    rows: np.ndarray  # (q,) ascending
    columns: np.ndarray  # (q,)

    @classmethod
    def of(cls, shape, rows, columns) -> tuple[SparseRows, np.ndarray]:
        """The pattern of entries at (``rows``, ``columns``) and the order (q,) that sorts
        values given in their order into the pattern's."""
        order = np.argsort(rows, kind="stable")
        return cls(tuple(shape), rows[order], columns[order]), order

    @property
    def size(self) -> int:
        """Number of entries."""
        return self.rows.size

    @functools.cached_property
    def _row_groups(self) -> tuple[np.ndarray, np.ndarray]:
        """(the rows with entries, where each one's entries start)."""
        starts = np.flatnonzero(np.r_[True, np.diff(self.rows) != 0]) if self.size else []
        return self.rows[starts], np.asarray(starts, dtype=int)

    @functools.cached_property
    def _column_groups(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(the entries sorted by column, the columns with entries, where each one's start)."""
        by_column = np.argsort(self.columns, kind="stable")
        sorted_columns = self.columns[by_column]
        starts = np.flatnonzero(np.r_[True, np.diff(sorted_columns) != 0]) if self.size else []
        return by_column, sorted_columns[starts], np.asarray(starts, dtype=int)

    @functools.cached_property
    def _flat(self) -> np.ndarray:
        """Each entry's position in a flattened (rows, columns) matrix."""
        return self.rows * self.shape[1] + self.columns

    def dense(self, values: np.ndarray) -> np.ndarray:
        """The matrices (n, rows, columns) of ``values`` (n, q), zero elsewhere."""
        out = np.zeros((values.shape[0], *self.shape))
        out.reshape(values.shape[0], -1)[:, self._flat] = values
        return out

    def times(self, values: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Each matrix times its block of ``x`` (n, columns, b): (n, rows, b); ``values``
        (n, q), or (q,) for one matrix shared by the stack."""
        products = values[..., None] * x[:, self.columns]
        rows, starts = self._row_groups
        if rows.size == self.shape[0]:
            return np.add.reduceat(products, starts, axis=1)
        out = np.zeros((x.shape[0], self.shape[0], x.shape[-1]))
        if rows.size:
            out[:, rows] = np.add.reduceat(products, starts, axis=1)
        return out

    def equilibrate(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Row and column scalings (n, rows), (n, columns) making each matrix's rows and
        columns O(1): 1/(largest |entry| of the row), then 1/(largest of the column after
        the row scaling); 1 for an empty row or column. The same numbers as
        :func:`ufmt.mstmm.overall.equilibrate` of the dense matrices."""
        n = values.shape[0]
        a = np.abs(values)
        rows, starts = self._row_groups
        r = np.zeros((n, self.shape[0]))
        if rows.size:
            r[:, rows] = np.maximum.reduceat(a, starts, axis=1)
        r[r == 0] = 1.0
        a /= r[:, self.rows]
        by_column, columns, column_starts = self._column_groups
        c = np.zeros((n, self.shape[1]))
        if columns.size:
            c[:, columns] = np.maximum.reduceat(a[:, by_column], column_starts, axis=1)
        c[c == 0] = 1.0
        return 1.0 / r, 1.0 / c
