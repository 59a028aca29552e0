"""A certified count of the natural frequencies below any ω, and brackets of every root,
without a mesh: the Wittrick-Williams algorithm.

The number of natural frequencies below ω is ``J(ω) = J₀(ω) + s{K(ω)}`` (Wittrick and
Williams, 1971): J₀ the beams' clamped-clamped frequencies below ω (closed form,
:meth:`ufmt.mstmm.members.Members.clamped`) and s{K} the number of negative eigenvalues of
the nodal exact dynamic stiffness matrix (:mod:`ufmt.mstmm.nodal`). The coordinates no beam
touches are condensed exactly through their own modes
(:class:`ufmt.mstmm.nodal.Condensation`: s{K} = #{λ_i < ω²} + s{C(ω)}, Haynsworth), and
s{C} is the inertia of an LDLᵀ factorisation (LAPACK ``dsytrf``, Bunch-Kaufman pivoting:
backward stable for indefinite matrices; by Sylvester's law the signs of D's 1x1 and 2x2
blocks give the inertia; the condensed matrix is several times smaller than K, and the
factorisation's cost falls with its cube: docs/benchmarks.md). One counter serves a stack of
designs of one structure (a design index beside every frequency): each J evaluation,
bisection and secant step is one pass for all of them.
Zero-frequency (rigid-body and mechanism) modes lie below every ω > 0 and are subtracted
(counted from geometry, :mod:`ufmt.mstmm.nodal`).

Bisection on J brackets every root: an interval [a, b] with J(b) - J(a) = m holds exactly m
roots, and splitting it until each holds one (or is narrower than CLUSTER_RTOL, a repeated
root of multiplicity m: J jumps by m there) certifies both the count and where each root is.
Where to look first comes from the linearisation K(0) - ω²M₀ (one symmetric eigenproblem);
each single root's bracket is then narrowed by a secant (inverse quadratic interpolation)
on det K (the product of the same LDLᵀ's pivots), J deciding every side, the last step a pair
of points closely around the secant's point, so that Newton on det U_all
(:mod:`ufmt.mstmm.roots`) starts within SECANT_RTOL of the root and certifies it in one step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg.lapack import dsytrf

from ufmt.errors import UfmtError
from ufmt.model.schema import Model
from ufmt.mstmm.nodal import CondensationStack, NodalStiffness, nodal_stiffness

TWO_PI = 2.0 * np.pi
CLUSTER_RTOL = 1e-7  # an interval this narrow (relative) holding m > 1 roots: a repeated root
START_RTOL = 1e-4  # single roots det K cannot sharpen are bisected this narrowly (relative)
SECANT_FROM = 1e-3  # single roots are bisected this narrowly (relative) before the secant
SECANT_RTOL = 1e-9  # the secant on det K narrows brackets to this (relative): Newton on
# det U_all then certifies the root in one step (ufmt.mstmm.roots.ACCEPT_STEP is 1e-8)
SEED_RTOLS = np.array([1e-5, 1e-3])  # the first points lie this far (relative) beside
# each linearised estimate (most are good to 1e-6, those of modes the beams carry to ~1e-2)
SECANT_ITERATIONS = 12  # secant steps at most (2 reach SECANT_RTOL from ±1e-5 mostly)
GUARD_FROM = 1e-6  # a secant step shorter than this (relative): its point is good to
# ~1e-10, and the pair at ±GUARD (relative) of it brackets the root to SECANT_RTOL at once
GUARD = 0.4 * SECANT_RTOL
GRID_POINTS = 48  # the first, geometric grid of the search below the upper frequency
GRID_DECADES = 6.0  # ... spanning this many decades below it (extended while roots remain)
SPLIT_LEVELS = 2  # each wide interval is cut into 2**SPLIT_LEVELS parts per J evaluation
MAX_BISECTIONS = 200  # levels of bisection before giving up (never reached: ~60 reach eps)


def negative_eigenvalues(k: np.ndarray) -> np.ndarray:
    """s{K}: the number of negative eigenvalues of each symmetric matrix of the stack
    (n_ω, n, n), from the D of its LDLᵀ (Bunch-Kaufman) factorisation: each 1x1 block's
    sign, and each 2x2 block's from its determinant and trace."""
    return inertia(k)[0]


def inertia(k: np.ndarray, overwrite: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(s{K}, log|det K|) of each symmetric matrix of the stack (n_ω, n, n) from one LDLᵀ
    (Bunch-Kaufman) factorisation each: det K = det D (det L = 1), the product of the 1x1
    blocks and the 2x2 blocks' determinants; sign det K = (-1)^s{K}. ``overwrite``: the
    factors may overwrite ``k`` (C-contiguous float64)."""
    n_omega, n = k.shape[:2]
    if n == 0:  # nothing left to factor (every coordinate condensed)
        return np.zeros(n_omega, dtype=int), np.zeros(n_omega)
    if not (overwrite and k.flags.c_contiguous and k.dtype == np.float64):
        k = np.array(k, dtype=float, order="C")
    pivots = np.empty((n_omega, n), dtype=np.int32)
    for i, matrix in enumerate(k):  # LAPACK per matrix in place, the rest batched
        # symmetric: the transpose is Fortran order, its lower triangle matrix's upper one
        _, pivots[i], _ = dsytrf(matrix.T, lower=1, overwrite_a=1)
    diagonal, below = k.diagonal(axis1=1, axis2=2), np.zeros((n_omega, n))
    below[:, :-1] = k.diagonal(offset=1, axis1=1, axis2=2)
    # a 2x2 block D(j:j+2, j:j+2) has ipiv < 0 at both j and j + 1: in a run of negative
    # pivots the blocks start at its even places (the run's place: since the last ipiv > 0)
    negative_pivot = pivots < 0
    places = np.arange(n)
    last_positive = np.maximum.accumulate(np.where(negative_pivot, -1, places), axis=1)
    start = negative_pivot & ((places - last_positive) % 2 == 1)
    single = ~start
    single[:, 1:] &= ~start[:, :-1]
    a, c = diagonal, np.concatenate([diagonal[:, 1:], diagonal[:, :1]], axis=1)
    det = a * c - below * below
    two = np.where(det < 0, 1, np.where((det > 0) & (a + c < 0), 2, 0))
    negative = np.count_nonzero(single & (diagonal < 0), axis=1) + np.sum(two * start, axis=1)
    with np.errstate(divide="ignore"):
        log_det = np.sum(np.log(np.abs(np.where(single, a, 1.0))), axis=1) + np.sum(
            np.log(np.abs(np.where(start, det, 1.0))), axis=1
        )
    return negative, log_det


@dataclass(frozen=True)
class Brackets:
    """Certified brackets [lo, hi] [Hz] of the roots below an upper frequency: bracket j
    holds exactly ``multiplicity[j]`` natural frequencies (a repeated root, or roots closer
    than CLUSTER_RTOL, when more than one); ``below_hz`` is the upper frequency."""

    lo_hz: np.ndarray
    hi_hz: np.ndarray
    multiplicity: np.ndarray
    below_hz: float
    start_hz: np.ndarray | None = None  # where Newton starts in each (None: the centre)

    @property
    def total(self) -> int:
        """Number of nonzero natural frequencies below ``below_hz``."""
        return int(self.multiplicity.sum())


class RootCounter:
    """J(ω) of one model, or of several designs of one structure at once (module docstring):
    counts and brackets their natural frequencies. Every frequency goes with the design it
    belongs to (``design``: index into ``models``, default 0); one J evaluation serves all
    designs (one pass of numpy calls for the whole batch)."""

    def __init__(self, models: Model | list[Model]):
        self.models = [models] if isinstance(models, Model) else list(models)
        self.model = self.models[0]
        self.nodals: list[NodalStiffness] = [nodal_stiffness(m) for m in self.models]
        self.nodal = self.nodals[0]
        self.stack = CondensationStack([n.condensation for n in self.nodals])
        self.zero_modes = np.array([n.zero_modes for n in self.nodals])
        self._seen: list = []  # (keys, values) of every evaluation, for _recall

    @property
    def rigid_body_modes(self) -> int:
        """Zero-frequency (rigid-body and mechanism) modes (of the first design)."""
        return self.nodal.zero_modes

    def below(self, hz, design=None) -> np.ndarray:
        """J: the number of nonzero natural frequencies below each frequency of ``hz`` [Hz]
        (of design ``design``, an index or one per frequency; default the first)."""
        return self._evaluate(hz, design)[0]

    def _evaluate(self, hz, design=None):
        """(J, J₀, log|det K|, sign det K) at each frequency of ``hz`` [Hz] of its design;
        kept for :meth:`_recall`."""
        hz = np.atleast_1d(np.asarray(hz, dtype=float))
        design = _designs(design, hz.size)
        omega = TWO_PI * hz
        complement, inner_negative, inner_log_det = self.stack.complement(omega, design)
        negative, log_det = inertia(complement, overwrite=True)
        negative, log_det = negative + inner_negative, log_det + inner_log_det
        clamped = self.stack.members.clamped(omega)
        sign = np.where(negative % 2 == 1, -1.0, 1.0)
        values = (clamped + negative - self.zero_modes[design], clamped, log_det, sign)
        self._seen.append((design + 1j * hz, np.stack(values)))
        return values

    def _recall(self, hz, design):
        """:meth:`_evaluate` at ``hz`` [Hz] of ``design``, the pairs evaluated before not
        again."""
        keys = _designs(design, hz.size) + 1j * hz  # (design, hz) pairs, sorted as such
        seen_keys = np.concatenate([k for k, _ in self._seen] or [np.zeros(0, complex)])
        seen = np.concatenate([v for _, v in self._seen], axis=1) if self._seen else None
        order = np.argsort(seen_keys)
        at = np.minimum(np.searchsorted(seen_keys[order], keys), max(seen_keys.size - 1, 0))
        known = seen_keys[order][at] == keys if seen_keys.size else np.zeros(hz.size, bool)
        out = np.empty((4, hz.size))
        if known.any():
            out[:, known] = seen[:, order[at[known]]]
        if not known.all():
            out[:, ~known] = np.stack(self._evaluate(hz[~known], keys.real[~known].astype(int)))
        return out[0].astype(int), out[1].astype(int), out[2], out[3]

    def total_modes(self) -> float:
        """Number of nonzero natural frequencies (inf with a beam: a continuum)."""
        if self.nodal.beams:
            return np.inf
        return float(np.linalg.matrix_rank(self.nodal.mass) - self.nodal.zero_modes)

    def upper_for(self, count: int, start_hz: float = 1000.0) -> np.ndarray:
        """A frequency [Hz] per design with at least ``count`` natural frequencies below
        it."""
        if count > self.total_modes():
            raise UfmtError(
                f"number of modes: {count} asked for, but the model has only "
                f"{int(self.total_modes())} nonzero modes; ask for fewer"
            )
        hz, design = np.full(len(self.models), float(start_hz)), np.arange(len(self.models))
        while np.any(short := self.below(hz, design) < count):
            hz[short] *= 2.0
        return hz

    def brackets(self, below_hz, start_rtol: float | None = None, first=None):
        """Brackets of every natural frequency below ``below_hz`` [Hz] (only the ``first``
        ones, if given), by cutting on J (each wide bracket into 2**SPLIT_LEVELS parts of equal
        ratio per evaluation, :func:`_cuts`, all brackets of all designs at once): single
        roots to ``start_rtol`` (relative width), clusters to CLUSTER_RTOL. By
        default (``start_rtol`` None) single roots are bisected to SECANT_FROM only, then
        sharpened by :meth:`_sharpen` (``start_hz``: Newton's start within SECANT_RTOL of the
        root). The first J points lie beside the linearised estimates
        (:meth:`_first_counts`).
        ``below_hz`` and ``first`` may be one per design; one :class:`Brackets` for a
        counter of one design, else a list of them."""
        n = len(self.models)
        top = np.broadcast_to(np.asarray(below_hz, dtype=float), (n,))
        wanted = np.broadcast_to(np.iinfo(int).max if first is None else first, (n,))
        sharpen = start_rtol is None
        start_rtol = SECANT_FROM if sharpen else start_rtol
        steps = np.geomspace(10.0**-GRID_DECADES, 1.0, GRID_POINTS)
        grid, design, counts = self._first_counts(top, wanted, steps, sharpen)
        while np.any(low := counts[np.r_[0, np.flatnonzero(np.diff(design)) + 1]] > 0):
            # roots below the grid: extend it downwards
            lowest = grid[np.r_[0, np.flatnonzero(np.diff(design)) + 1]][low]
            lower = (lowest[:, None] * steps[:-1]).ravel()
            lower_design = np.repeat(np.flatnonzero(low), steps.size - 1)
            grid, design, counts = self._added(grid, design, counts, lower, lower_design)
        keep = np.flatnonzero((np.diff(counts) > 0) & (np.diff(design) == 0))
        lo, hi, lo_c, hi_c = grid[keep], grid[keep + 1], counts[keep], counts[keep + 1]
        des = design[keep]
        for _ in range(MAX_BISECTIONS):
            keep = lo_c < wanted[des]  # intervals above the wanted roots: not refined
            lo, hi, lo_c, hi_c, des = lo[keep], hi[keep], lo_c[keep], hi_c[keep], des[keep]
            m = hi_c - lo_c
            wide = np.where(m > 1, CLUSTER_RTOL, start_rtol) * hi < hi - lo
            if not wide.any():
                break
            cuts = _cuts(lo[wide], hi[wide], SPLIT_LEVELS)
            c = self.below(cuts.ravel(), des[wide].repeat(cuts.shape[1])).reshape(cuts.shape)
            lo, hi, lo_c, hi_c, des = _split(lo, hi, lo_c, hi_c, des, wide, cuts, c)
        m, start = hi_c - lo_c, np.sqrt(lo * hi)
        if sharpen and np.any(m == 1):
            one = m == 1
            lo[one], hi[one], start[one] = self._sharpen(lo[one], hi[one], des[one])
        found = [
            Brackets(lo[des == d], hi[des == d], m[des == d], float(top[d]), start[des == d])
            for d in range(n)
        ]
        return found[0] if n == 1 else found

    def _first_counts(self, top, wanted, steps, seeded: bool):
        """(hz, design, J): the first points [Hz] of the search, ascending per design, and J
        there. The geometric grid ``top * steps``; ``seeded``: in two passes, first only the
        grid's ends and the points just beside each linearised estimate (:func:`_seeds`,
        SEED_RTOLS[0]: most roots isolated there), then the other seeds and grid points
        where J still rises between two of them (a root not yet isolated beside its
        estimate)."""
        n = len(self.models)
        grid = [top[d] * steps for d in range(n)]
        if not seeded:
            hz, design = np.concatenate(grid), np.repeat(np.arange(n), steps.size)
            return hz, design, self.below(hz, design)
        est = [self._estimates(d, g[0], top[d], wanted[d]) for d, g in enumerate(grid)]
        near = [
            np.unique(np.concatenate([g[[0, -1]], _seeds(e, g[0], g[-1], SEED_RTOLS[:1], False)]))
            for e, g in zip(est, grid, strict=True)
        ]
        design = np.repeat(np.arange(n), [p.size for p in near])
        hz, counts = np.concatenate(near), self.below(np.concatenate(near), design)
        more = []
        for d, g in enumerate(grid):  # the other points, where J rises between the first
            at, c = hz[design == d], counts[design == d]
            others = np.concatenate([g, _seeds(est[d], g[0], g[-1], SEED_RTOLS)])
            i = np.clip(np.searchsorted(at, others), 1, at.size - 1)
            more.append(
                np.unique(others[(c[i] > c[i - 1]) & (others > at[i - 1]) & (others < at[i])])
            )
        more_design = np.repeat(np.arange(n), [p.size for p in more])
        more = np.concatenate(more)
        if more.size == 0:
            return hz, design, counts
        return self._added(hz, design, counts, more, more_design)

    def _added(self, hz, design, counts, new_hz, new_design):
        """(hz, design, J) with J at the points ``new_hz`` [Hz] of ``new_design`` added,
        ascending per design (the new points are none of the old ones)."""
        hz, design = np.concatenate([hz, new_hz]), np.concatenate([design, new_design])
        order = np.lexsort((hz, design))
        counts = np.concatenate([counts, self.below(new_hz, new_design)])[order]
        return hz[order], design[order], counts

    def _estimates(self, design: int, lo_hz: float, hi_hz: float, wanted: int) -> np.ndarray:
        """The linearised estimates [Hz] in (lo_hz, hi_hz) of ``design``
        (:meth:`ufmt.mstmm.nodal.NodalStiffness.estimates`), only the ``wanted`` + 1 lowest
        (the next root bounds the last wanted one)."""
        est = self.nodals[design].estimates() / TWO_PI
        return est[(est > lo_hz) & (est < hi_hz)][: min(wanted, est.size) + 1]

    def _sharpen(self, lo, hi, design, retry: bool = True):
        """Newton's start in brackets [Hz] of one root each: inverse quadratic interpolation
        of det K(ω) (the secant while only two points are known; Illinois after a step that
        kept the same end, :func:`_next_points`), every point's side decided by J (the
        brackets it narrows stay certified), to a width below SECANT_RTOL (bisection on J
        after SECANT_ITERATIONS steps); a step that moved less than GUARD_FROM (relative)
        evaluates the pair at ±GUARD of its point instead of the point: most roots are
        then certified within SECANT_RTOL one step sooner. Returns (lo, hi, start): the
        brackets as given (the root may sit within rounding of a narrowed end) and the last
        point proposed, or, where the secant does not apply, the brackets bisected to
        START_RTOL and their centres.

        Between two of its poles (no clamped member frequency in the bracket: J₀ constant)
        det K = det D of the LDLᵀ that counts J changes sign exactly at the root, smoothly:
        superlinear where bisection gains one bit per J. A bracket where J₀ jumps, det K
        does not change sign or J and det K disagree on a side is bisected to START_RTOL and
        (``retry``) tried once more: a clamped member frequency near a root is left out.
        """
        n, lo_in, hi_in = lo.size, lo, hi
        ends, designs = np.concatenate([lo, hi]), np.concatenate([design, design])
        count, clamped, log_det, sign = self._recall(ends, designs)
        base, ref = count[:n], np.maximum(log_det[:n], log_det[n:])
        with np.errstate(all="ignore"):
            f_lo, f_hi = sign[:n] * np.exp(log_det[:n] - ref), sign[n:] * np.exp(log_det[n:] - ref)
        ok = (count[n:] - base == 1) & (clamped[:n] == clamped[n:]) & (sign[:n] != sign[n:])
        ok &= np.isfinite(f_lo) & np.isfinite(f_hi)
        state = _Secant(lo.copy(), hi.copy(), f_lo, f_hi)
        start, last = np.sqrt(lo * hi), np.full(n, np.nan)  # last: the last point proposed
        for _ in range(SECANT_ITERATIONS):
            act = np.flatnonzero(ok & (state.hi - state.lo > SECANT_RTOL * state.hi))
            if act.size == 0:
                break
            x, points, owner = _next_points(state, act, last[act])
            c, c0, ld, sg = self._evaluate(points, design[owner])
            with np.errstate(all="ignore"):
                f = sg * np.exp(ld - ref[owner])
            agree = (c0 == clamped[owner]) & np.isfinite(f)
            agree &= (sg == np.sign(state.f_hi[owner])) == (c > base[owner])
            ok[owner[: act.size]] &= agree[: act.size]
            ok[owner[act.size :]] &= agree[act.size :]
            for part in (slice(0, act.size), slice(act.size, None)):  # a pair's lower one first
                state.update(points[part], owner[part], f[part], (c > base[owner])[part])
            start[act], last[act] = x, x
        lo, hi = state.lo, state.hi
        # a start between two roots 1e-8 apart can pass for a root after one Newton step:
        # brackets the secant has not narrowed enough are bisected to SECANT_RTOL
        slow = ok & (hi - lo > SECANT_RTOL * hi)
        lo[slow], hi[slow] = self._narrow(lo[slow], hi[slow], SECANT_RTOL, design[slow])
        start[slow] = np.sqrt(lo[slow] * hi[slow])
        lo, hi = np.where(ok, lo_in, lo), np.where(ok, hi_in, hi)
        lo[~ok], hi[~ok] = self._narrow(lo[~ok], hi[~ok], START_RTOL, design[~ok])
        start[~ok] = np.sqrt(lo[~ok] * hi[~ok])
        if retry and not ok.all():  # narrower, the bracket may have left the pole behind
            again = self._sharpen(lo[~ok], hi[~ok], design[~ok], retry=False)
            lo[~ok], hi[~ok], start[~ok] = again
        return lo, hi, start

    def refine(self, lo_hz, hi_hz, rtol: float = 1e-13, design=None) -> np.ndarray:
        """The roots [Hz] in brackets [lo, hi] of one root each (of ``design``), by bisection
        on J to ``rtol`` (the fallback when Newton on det U_all cannot certify one)."""
        lo, hi = self._narrow(lo_hz, hi_hz, rtol, design)
        return 0.5 * (lo + hi)

    def _narrow(self, lo_hz, hi_hz, rtol: float, design=None):
        """Brackets [Hz] of one root each (of ``design``), bisected on J to relative width
        ``rtol``."""
        lo, hi = np.array(lo_hz, dtype=float), np.array(hi_hz, dtype=float)
        if lo.size == 0:
            return lo, hi
        design = _designs(design, lo.size)
        base = self.below(lo, design)
        for _ in range(MAX_BISECTIONS):
            wide = hi - lo > rtol * hi
            if not wide.any():
                break
            mid = np.sqrt(lo[wide] * hi[wide])
            above = self.below(mid, design[wide]) > base[wide]
            hi[np.flatnonzero(wide)[above]] = mid[above]
            lo[np.flatnonzero(wide)[~above]] = mid[~above]
        return lo, hi


@dataclass
class _Secant:
    """The secant's brackets [lo, hi] [Hz] and det K's (scaled) values there, the end each
    replaced last (``x``, ``f``; NaN before any: the third point of the next inverse
    quadratic interpolation), which end moved last (``moved``: -1 lo, +1 hi) and whether
    the same one moved twice (``again``)."""

    lo: np.ndarray
    hi: np.ndarray
    f_lo: np.ndarray
    f_hi: np.ndarray

    def __post_init__(self):
        self.x, self.f = np.full(self.lo.size, np.nan), np.full(self.lo.size, np.nan)
        self.moved = np.zeros(self.lo.size, dtype=int)
        self.again = np.zeros(self.lo.size, dtype=bool)

    def update(self, points, owner, f, above) -> None:
        """The ``points`` [Hz] of brackets ``owner`` (one each) with det K's values ``f`` as
        new upper ends (``above``: J counts the root below) or lower ends, where inside."""
        inside = (points > self.lo[owner]) & (points < self.hi[owner])
        p, j, up, fp = points[inside], owner[inside], above[inside], f[inside]
        side = np.where(up, 1, -1)
        self.again[j] = side == self.moved[j]
        self.moved[j] = side
        self.x[j] = np.where(up, self.hi[j], self.lo[j])  # the end replaced
        self.f[j] = np.where(up, self.f_hi[j], self.f_lo[j])
        self.hi[j], self.f_hi[j] = np.where(up, p, self.hi[j]), np.where(up, fp, self.f_hi[j])
        self.lo[j], self.f_lo[j] = np.where(up, self.lo[j], p), np.where(up, self.f_lo[j], fp)


def _next_points(state: _Secant, act, last):
    """(x, points, owner): the next point x [Hz] in each bracket ``act`` of ``state`` (the
    inverse quadratic interpolation of det K through its ends and the end replaced last,
    else the secant through its ends, Illinois: the end kept twice in a row at half its
    value; else the geometric centre), and the points to evaluate with the bracket each
    belongs to: x itself, or where x lies within GUARD_FROM (relative) of the ``last``
    point proposed the pair x(1 ∓ GUARD) (the lower ones first, one per bracket)."""
    a, b, fa, fb = state.lo[act], state.hi[act], state.f_lo[act], state.f_hi[act]
    c, fc = state.x[act], state.f[act]
    again, moved = state.again[act], state.moved[act]
    with np.errstate(all="ignore"):
        x = a * fb * fc / ((fa - fb) * (fa - fc)) + b * fa * fc / ((fb - fa) * (fb - fc))
        x += c * fa * fb / ((fc - fa) * (fc - fb))
        wa, wb = (
            np.where(again & (moved == 1), 0.5, 1.0) * fa,
            np.where(again & (moved == -1), 0.5, 1.0) * fb,
        )
        secant = b - wb * (b - a) / (wb - wa)
    x = np.where(np.isfinite(x) & (x > a) & (x < b), x, secant)
    x = np.where(np.isfinite(x) & (x > a) & (x < b), x, np.sqrt(a * b))
    guard = np.abs(x - last) < GUARD_FROM * x  # NaN (no point yet): no guard
    points = np.concatenate([np.where(guard, x * (1 - GUARD), x), x[guard] * (1 + GUARD)])
    return x, points, np.concatenate([act, act[guard]])


def _seeds(est, lo_hz: float, hi_hz: float, rtols, middles: bool = True) -> np.ndarray:
    """Frequencies [Hz] in (lo_hz, hi_hz) ``rtols`` (relative) below and above each estimate
    ``est`` [Hz] and (``middles``) half-way between them."""
    rings = np.concatenate([1 - rtols, 1 + rtols])
    seeds = np.outer(est, rings).ravel()
    if middles:
        seeds = np.concatenate([seeds, np.sqrt(est[1:] * est[:-1])])
    return seeds[(seeds > lo_hz) & (seeds < hi_hz)]


def _cuts(lo, hi, levels: int) -> np.ndarray:
    """(len(lo), 2**levels - 1) points [Hz] cutting each [lo, hi] into 2**levels parts of
    equal ratio, ascending: geometric middles, ``levels`` deep."""
    ends = np.stack([lo, hi], axis=1)
    for _ in range(levels):
        middles = np.sqrt(ends[:, :-1] * ends[:, 1:])
        ends = np.stack([ends[:, :-1], middles], axis=2).reshape(lo.size, -1)
        ends = np.concatenate([ends, hi[:, None]], axis=1)
    return ends[:, 1:-1]


def _split(lo, hi, lo_c, hi_c, design, wide, cuts, c):
    """Intervals [Hz] (of each its design) and the counts at their ends with the ``wide`` ones
    cut at ``cuts`` (wide, k) (counts ``c`` there); intervals that hold no root dropped;
    ascending per design."""
    ends = np.concatenate([lo[wide, None], cuts, hi[wide, None]], axis=1)
    counts = np.concatenate([lo_c[wide, None], c, hi_c[wide, None]], axis=1)
    lo = np.concatenate([lo[~wide], ends[:, :-1].ravel()])
    hi = np.concatenate([hi[~wide], ends[:, 1:].ravel()])
    lo_c = np.concatenate([lo_c[~wide], counts[:, :-1].ravel()])
    hi_c = np.concatenate([hi_c[~wide], counts[:, 1:].ravel()])
    design = np.concatenate([design[~wide], design[wide].repeat(cuts.shape[1] + 1)])
    keep = np.flatnonzero(hi_c > lo_c)
    order = keep[np.lexsort((lo[keep], design[keep]))]
    return lo[order], hi[order], lo_c[order], hi_c[order], design[order]


def _designs(design, n: int) -> np.ndarray:
    """The design index of each of ``n`` frequencies: ``design`` (one, or one each) as ints;
    None is the first design."""
    return np.broadcast_to(np.asarray(0 if design is None else design, dtype=int), (n,)).copy()
