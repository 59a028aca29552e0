"""Stacks of sparse matrices that share one pattern of entries, for the Newton iteration's S'
(:mod:`ufmt.mstmm.reduced`): on the packaged model an eighth of S''s entries are nonzero and
a twentieth of U_all's, so products, scalings and the dense matrices for LAPACK are built
from the nonzero entries alone, one per diagonal block (:attr:`SparseRows.diagonal_blocks`:
a structure with a plane of symmetry has two, its in-plane and out-of-plane motions)."""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_array
from scipy.sparse.csgraph import connected_components


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

    @functools.cached_property
    def diagonal_blocks(self) -> tuple[Block, ...]:
        """The square diagonal blocks the rows and columns can be permuted into (components
        of the graph joining each entry's row and column): det = ± Π det(block) and each
        block solves on its own. One block, the whole matrix, unless every component is
        square."""
        n_rows, n_columns = self.shape
        graph = coo_array(
            (np.ones(self.size), (self.rows, n_rows + self.columns)),
            shape=(n_rows + n_columns,) * 2,
        )
        _, label = connected_components(graph, directed=False)
        row_label, column_label = label[:n_rows], label[n_rows:]
        groups = np.unique(row_label)
        square = all(
            np.count_nonzero(row_label == g) == np.count_nonzero(column_label == g) for g in groups
        )
        if not square or groups.size == 1:
            groups, row_label = np.zeros(1), np.zeros(n_rows)
            column_label = np.zeros(n_columns)
        blocks = []
        for g in groups:
            rows, columns = np.flatnonzero(row_label == g), np.flatnonzero(column_label == g)
            entries = np.flatnonzero(row_label[self.rows] == g)
            local_row = np.searchsorted(rows, self.rows[entries])
            local_column = np.searchsorted(columns, self.columns[entries])
            local = SparseRows((rows.size, columns.size), local_row, local_column)
            blocks.append(Block(rows, columns, entries, local))
        return tuple(blocks)


@dataclass(frozen=True, eq=False)
class Block:
    """A diagonal block of a :class:`SparseRows` pattern: its ``rows`` and ``columns`` in
    the whole matrix, its ``entries`` among the pattern's, and ``local``: their positions in
    the block (rows ascending, as the pattern's)."""

    rows: np.ndarray
    columns: np.ndarray
    entries: np.ndarray
    local: SparseRows
