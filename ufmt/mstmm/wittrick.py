"""A certified count of the natural frequencies below any ω, and brackets of every root,
without a mesh: the Wittrick-Williams algorithm.

The number of natural frequencies below ω is ``J(ω) = J₀(ω) + s{K(ω)}`` (Wittrick and
Williams, 1971): J₀ the beams' clamped-clamped frequencies below ω (closed form,
:func:`ufmt.mstmm.members.clamped_count`) and s{K} the number of negative eigenvalues of the
nodal exact dynamic stiffness matrix (:mod:`ufmt.mstmm.nodal`). s{K} is the inertia of an
LDLᵀ factorisation (LAPACK ``dsytrf``, Bunch-Kaufman pivoting: backward stable for
indefinite matrices; by Sylvester's law the signs of D's 1x1 and 2x2 blocks give the inertia;
23 µs per matrix of order 78 on the packaged model, against 165 µs for the eigenvalues
``eigvalsh`` would compute only to read their signs; CPU time, one BLAS thread).
Zero-frequency (rigid-body and mechanism) modes lie below every ω > 0 and are subtracted
(counted from geometry, :mod:`ufmt.mstmm.nodal`).

Bisection on J brackets every root: an interval [a, b] with J(b) - J(a) = m holds exactly m
roots, and splitting it until each holds one (or is narrower than CLUSTER_RTOL, a repeated
root of multiplicity m: J jumps by m there) certifies both the count and where each root is.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg.lapack import dsytrf

from ufmt.errors import UfmtError
from ufmt.model.schema import Model
from ufmt.mstmm.nodal import NodalStiffness, nodal_stiffness

TWO_PI = 2.0 * np.pi
CLUSTER_RTOL = 1e-7  # an interval this narrow (relative) holding m > 1 roots: a repeated root
START_RTOL = 1e-4  # single roots are bracketed this narrowly (relative): Newton then
# certifies them in two steps (from 1e-3 it takes three, each dearer than 3 bisections)
GRID_POINTS = 48  # the first, geometric grid of the search below the upper frequency
GRID_DECADES = 6.0  # ... spanning this many decades below it (extended while roots remain)
MAX_BISECTIONS = 200  # levels of bisection before giving up (never reached: ~60 reach eps)


def negative_eigenvalues(k: np.ndarray) -> np.ndarray:
    """s{K}: the number of negative eigenvalues of each symmetric matrix of the stack
    (n_ω, n, n), from the D of its LDLᵀ (Bunch-Kaufman) factorisation: each 1x1 block's
    sign, and each 2x2 block's from its determinant and trace."""
    n_omega, n = k.shape[:2]
    diagonal, below, pivots = np.empty((n_omega, n)), np.zeros((n_omega, n)), np.empty((n_omega, n))
    for i, matrix in enumerate(k):  # LAPACK per matrix, the rest batched
        lu, pivots[i], _ = dsytrf(matrix.T, lower=1)  # symmetric: the transpose is Fortran order
        diagonal[i], below[i, :-1] = np.diag(lu), np.diag(lu, -1)
    # a 2x2 block D(j:j+2, j:j+2) has ipiv < 0 at both j and j + 1: pairs of negative pivots
    start = pivots < 0
    for j in range(1, n):  # the second of each pair starts no block
        start[:, j] &= ~start[:, j - 1]
    single = ~start
    single[:, 1:] &= ~start[:, :-1]
    a, c = diagonal, np.roll(diagonal, -1, axis=1)
    det = a * c - below * below
    two = np.where(det < 0, 1, np.where((det > 0) & (a + c < 0), 2, 0))
    return np.count_nonzero(single & (diagonal < 0), axis=1) + np.sum(two * start, axis=1)


@dataclass(frozen=True)
class Brackets:
    """Certified brackets [lo, hi] [Hz] of the roots below an upper frequency: bracket j
    holds exactly ``multiplicity[j]`` natural frequencies (a repeated root, or roots closer
    than CLUSTER_RTOL, when more than one); ``below_hz`` is the upper frequency."""

    lo_hz: np.ndarray
    hi_hz: np.ndarray
    multiplicity: np.ndarray
    below_hz: float

    @property
    def total(self) -> int:
        """Number of nonzero natural frequencies below ``below_hz``."""
        return int(self.multiplicity.sum())


class RootCounter:
    """J(ω) of one model (module docstring): counts and brackets its natural frequencies."""

    def __init__(self, model: Model):
        self.model = model
        self.nodal: NodalStiffness = nodal_stiffness(model)

    @property
    def rigid_body_modes(self) -> int:
        """Zero-frequency (rigid-body and mechanism) modes."""
        return self.nodal.zero_modes

    def below(self, hz) -> np.ndarray:
        """J: the number of nonzero natural frequencies below each frequency of ``hz`` [Hz]."""
        omega = TWO_PI * np.atleast_1d(np.asarray(hz, dtype=float))
        negative = negative_eigenvalues(self.nodal.matrix(omega))
        return self.nodal.clamped(omega) + negative - self.nodal.zero_modes

    def total_modes(self) -> float:
        """Number of nonzero natural frequencies (inf with a beam: a continuum)."""
        if self.nodal.beams:
            return np.inf
        return float(np.linalg.matrix_rank(self.nodal.mass) - self.nodal.zero_modes)

    def upper_for(self, count: int, start_hz: float = 1000.0) -> float:
        """A frequency [Hz] with at least ``count`` natural frequencies below it."""
        if count > self.total_modes():
            raise UfmtError(
                f"number of modes: {count} asked for, but the model has only "
                f"{int(self.total_modes())} nonzero modes; ask for fewer"
            )
        hz = start_hz
        while self.below(hz)[0] < count:
            hz *= 2.0
        return hz

    def brackets(
        self, below_hz: float, start_rtol: float | None = None, first: int | None = None
    ) -> Brackets:
        """Brackets of every natural frequency below ``below_hz`` [Hz] (only the ``first``
        ones, if given), by bisection on J (geometric middles, all brackets at once): single
        roots to ``start_rtol`` (relative width; default START_RTOL), clusters to
        CLUSTER_RTOL."""
        start_rtol = START_RTOL if start_rtol is None else start_rtol
        top = float(below_hz)
        grid = top * np.geomspace(10.0**-GRID_DECADES, 1.0, GRID_POINTS)
        counts = self.below(grid)
        while counts[0] > 0:  # roots below the grid: extend it downwards
            lower = grid[0] * np.geomspace(10.0**-GRID_DECADES, 1.0, GRID_POINTS)[:-1]
            grid, counts = np.r_[lower, grid], np.r_[self.below(lower), counts]
        keep = np.flatnonzero(np.diff(counts) > 0)
        lo, hi, lo_c, hi_c = grid[keep], grid[keep + 1], counts[keep], counts[keep + 1]
        for _ in range(MAX_BISECTIONS):
            if first is not None:  # intervals above the wanted roots: not refined
                keep = lo_c < first
                lo, hi, lo_c, hi_c = lo[keep], hi[keep], lo_c[keep], hi_c[keep]
            m = hi_c - lo_c
            wide = np.where(m > 1, CLUSTER_RTOL, start_rtol) * hi < hi - lo
            if not wide.any():
                break
            mid = np.sqrt(lo[wide] * hi[wide])
            lo, hi, lo_c, hi_c = _split(lo, hi, lo_c, hi_c, wide, mid, self.below(mid))
        return Brackets(lo, hi, hi_c - lo_c, top)

    def refine(self, lo_hz, hi_hz, rtol: float = 1e-13) -> np.ndarray:
        """The roots [Hz] in brackets [lo, hi] of one root each, by bisection on J to
        ``rtol`` (the fallback when Newton on det U_all cannot certify one)."""
        lo, hi = np.array(lo_hz, dtype=float), np.array(hi_hz, dtype=float)
        if lo.size == 0:
            return lo
        base = self.below(lo)
        for _ in range(MAX_BISECTIONS):
            wide = hi - lo > rtol * hi
            if not wide.any():
                break
            mid = np.sqrt(lo[wide] * hi[wide])
            above = self.below(mid) > base[wide]
            hi[np.flatnonzero(wide)[above]] = mid[above]
            lo[np.flatnonzero(wide)[~above]] = mid[~above]
        return 0.5 * (lo + hi)


def _split(lo, hi, lo_c, hi_c, wide, mid, c):
    """Intervals [Hz] and the counts at their ends with the ``wide`` ones split at ``mid``
    (counts ``c`` there); intervals that hold no root dropped; ascending."""
    lo = np.concatenate([lo[~wide], lo[wide], mid])
    hi = np.concatenate([hi[~wide], mid, hi[wide]])
    lo_c = np.concatenate([lo_c[~wide], lo_c[wide], c])
    hi_c = np.concatenate([hi_c[~wide], c, hi_c[wide]])
    keep = np.flatnonzero(hi_c > lo_c)
    order = keep[np.argsort(lo[keep], kind="stable")]
    return lo[order], hi[order], lo_c[order], hi_c[order]
