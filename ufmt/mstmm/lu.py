"""LU factors of a stack of square matrices, kept for repeated solves (LAPACK getrf/getrs).

``numpy.linalg.solve`` factors its matrices anew at every call; the Newton iteration on
det U_all (:mod:`ufmt.mstmm.roots`) solves with one matrix per root several times (its
inverse iteration), so the factors (2/3 n³ each) are computed once and every later solve
costs 2 n² per right-hand side. One LAPACK call per matrix: the matrices are small and
few (one per root), so a Python loop over them costs little beside the factorisation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg.lapack import dgetrf, dgetrs


@dataclass(frozen=True)
class Factors:
    """P L U of each matrix of a stack, stored as LAPACK leaves them for its transpose (the
    stack is C-ordered, LAPACK reads Fortran order); ``singular``: the matrices with an
    exactly zero pivot, whose factors cannot be solved with (see :meth:`refactor`)."""

    lu: np.ndarray  # (n, m, m)
    pivots: np.ndarray  # (n, m) int32
    singular: np.ndarray  # (n,) bool

    def solve(self, b: np.ndarray) -> np.ndarray:
        """a⁻¹ b for each matrix a of the stack and b (n, m, k)."""
        out = np.empty(b.shape, dtype=float)
        for i, (lu, piv) in enumerate(zip(self.lu, self.pivots, strict=True)):
            # lu holds Aᵀ's factors: A x = b is the transposed solve
            out[i] = dgetrs(lu.T, piv, b[i], trans=1)[0]
        return out

    def refactor(self, i: int, matrix: np.ndarray) -> None:
        """Matrix ``i`` of the stack replaced by ``matrix`` (m, m) and factored, in place."""
        self.lu[i] = matrix
        self.pivots[i], self.singular[i] = _factor_in_place(self.lu[i])


def _factor_in_place(matrix: np.ndarray) -> tuple[np.ndarray, bool]:
    """LU of the C-ordered ``matrix`` (m, m) in place (LAPACK factors its transpose, the
    Fortran-ordered view of the same memory); returns (pivots, exactly singular)."""
    lu, pivots, info = dgetrf(matrix.T, overwrite_a=1)
    if not np.shares_memory(lu, matrix):  # f2py copied after all: keep its factors
        matrix.T[...] = lu
    return pivots, info > 0


def factor(a: np.ndarray) -> Factors:
    """LU factors (partial pivoting) of each matrix of the stack ``a`` (n, m, m), which is
    overwritten if C-contiguous float64 (else copied); matrices with an exactly zero pivot
    are flagged ``singular``."""
    if not (a.flags.c_contiguous and a.dtype == np.float64):
        a = np.array(a, dtype=float, order="C")
    n, m = a.shape[:2]
    pivots = np.empty((n, m), dtype=np.int32)
    singular = np.zeros(n, dtype=bool)
    for i in range(n):
        pivots[i], singular[i] = _factor_in_place(a[i])
    return Factors(a, pivots, singular)
