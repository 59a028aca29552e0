"""LU factors of a stack of square matrices, kept for repeated solves (LAPACK getrf/getrs).

``numpy.linalg.solve`` factors its matrices anew at every call; the Newton iteration on
det U_all (:mod:`ufmt.mstmm.roots`) solves with one matrix per root several times (its
inverse iteration), so the factors (2/3 n³ each) are computed once and every later solve
costs 2 n² per right-hand side. One LAPACK call per matrix: the matrices are small (order
~70) and few (one per root), so the loop costs a few µs per matrix against ~30 µs of
factorisation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg.lapack import dgetrf, dgetrs

# an exactly zero pivot becomes this (relative to U's largest entry): a perturbation at the
# level of rounding, like the one that left the other pivots of a (nearly) repeated root
# nonzero, so that inverse iteration amplifies every null direction alike
SINGULAR_PIVOT = np.finfo(float).eps


@dataclass(frozen=True)
class Factors:
    """P L U of each matrix of a stack, stored as LAPACK leaves them for its transpose (the
    stack is C-ordered, LAPACK reads Fortran order); ``singular``: the matrices with an
    exactly zero pivot (see :func:`factor`)."""

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


def factor(a: np.ndarray) -> Factors:
    """LU factors (partial pivoting) of each matrix of the stack ``a`` (n, m, m), which is
    overwritten if C-contiguous float64 (else copied). A matrix that is exactly singular (ω
    on a root to the last bit) gets each exactly zero pivot of U replaced by SINGULAR_PIVOT
    times U's largest entry (and is flagged ``singular``): its solutions are finite and
    dominated by the null space, so inverse iteration still finds it."""
    if not (a.flags.c_contiguous and a.dtype == np.float64):
        a = np.array(a, dtype=float, order="C")
    n, m = a.shape[:2]
    pivots = np.empty((n, m), dtype=np.int32)
    singular = np.zeros(n, dtype=bool)
    for i in range(n):
        _, pivots[i], info = dgetrf(a[i].T, overwrite_a=1)
        if info > 0:  # U(j, j) = 0 exactly for some j; the factorisation is complete
            singular[i] = True
            upper = np.triu(a[i].T)
            diagonal = a[i].diagonal().copy()
            diagonal[diagonal == 0.0] = SINGULAR_PIVOT * np.abs(upper).max()
            np.fill_diagonal(a[i], diagonal)
    return Factors(a, pivots, singular)
