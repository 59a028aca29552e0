"""Natural frequencies: every root of det U_all(ω) = 0 in (0, f_max] (paper eq. 2.23).

The Wittrick-Williams count (:mod:`ufmt.mstmm.wittrick`) brackets every root, each bracket
holding a known number of them (:func:`bracketed_roots`). The MSTMM then finds each root:

1. **Newton on det, batched over all roots.** A bracket of m roots is a cluster of
   multiplicity m (a repeated root of a symmetric structure). From the cluster's start (the
   Wittrick-Williams secant's last point or the bracket's geometric centre), ω_k ← ω_k - m_k
   / Σ λ: d ln det U_all/dω = tr(U⁻¹ dU/dω) is the sum of the eigenvalues λ of U⁻¹ dU/dω,
   m_k of which are ≈ 1/(ω_k - root) near the cluster, and the step sums only those (found
   by inverse iteration with U's LU kept, the Ritz values of the cluster's own roots): the
   multiplicity-corrected Newton step on det with every other root divided out exactly,
   quadratically convergent for simple and semisimple repeated roots alike; a root another
   cluster's iterate is on is left to it, which keeps two clusters off one root. dU/dω is a
   forward difference of U_all (its entries are smooth in ω). A cluster is certified when
   its steps contract superlinearly (a wrong multiplicity converges linearly or oscillates)
   inside the cluster's bracket (a step that would leave it goes half-way to its end) and no
   two clusters meet. A cluster that does not converge as one repeated root may be a pair
   split by a small asymmetry (multiplicity-2 Newton then 2-cycles): its m roots are solved
   again as m simple ones, each with its own iterate (``_split_clusters``).
2. **Fallback, only for the clusters Newton could not certify:** bisection on the count
   down to 1e-13 (no null vector then).
3. **Never lose a root.** A cluster whose roots neither method finds is reported in
   :attr:`Roots.missing_hz`; :func:`ufmt.mstmm.solve.solve_modes` then raises
   :class:`RootsLostError` naming the missing frequencies.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ufmt.errors import UfmtError
from ufmt.mstmm.newton_step import inverse_iteration, own_step
from ufmt.mstmm.overall import State, TransferSystem, assemble, block_layout
from ufmt.mstmm.reduced import ConstantParts, SparseReduction

TWO_PI = 2.0 * np.pi
OFF_ROOT = 1.0 + 3.7e-3  # a generic point near a root, where the scaling of U_all is taken
NEWTON_ITERATIONS = 8
DERIVATIVE_STEP = 1e-7  # relative forward-difference step for dU/dω
ACCEPT_STEP = 1e-8  # a contracting Newton step this small (relative) ends the iteration
CONTRACTION = 0.1  # |step_k| <= CONTRACTION |step_k-1|: superlinear, right multiplicity


@dataclass(frozen=True)
class Roots:
    """Natural frequencies [Hz] ascending, repeated roots listed once per multiplicity."""

    frequencies_hz: np.ndarray
    expected: int  # how many are counted in (0, f_max]
    missing_hz: np.ndarray  # counted roots in (0, f_max] not found (their bracket's centre)
    newton: int = 0  # roots certified by Newton (the rest came from the count's bisection)
    # (n, size) null vectors of U_all per root, an orthonormal basis over a repeated root
    # (NaN rows for roots of the bisection: see ufmt.mstmm.modes.null_vectors)
    null_vectors: np.ndarray | None = None
    # state maps (ufmt.mstmm.overall.State) at each root, of the keys bracketed_roots
    # was asked for, when every root came from the Newton iteration (else None)
    states: dict | None = None


class RootsLostError(UfmtError):
    """Fewer MSTMM roots than counted: never returned silently."""


def bracketed_roots(system: TransferSystem, brackets, refine, rtol: float = 1e-12, state_keys=()):
    """Every natural frequency in certified brackets (:class:`ufmt.mstmm.wittrick.Brackets`,
    bracket j holds exactly ``multiplicity[j]`` roots) [Hz], to relative precision ``rtol``.

    Newton starts at each bracket's ``start_hz`` (else its geometric centre) and must
    converge inside it; a bracket Newton cannot certify falls back to
    ``refine(lo_hz, hi_hz)``, bisection on the count
    (:meth:`ufmt.mstmm.wittrick.RootCounter.refine`, no null vector then). Parameters and
    result: :class:`Roots`.
    """
    fmax_hz = brackets.below_hz
    system.segment_for(fmax_hz)
    lo, hi = brackets.lo_hz * (1 - 1e-9), brackets.hi_hz * (1 + 1e-9)  # rounding only
    mult = np.asarray(brackets.multiplicity, dtype=int)
    centre = np.sqrt(lo * hi) if brackets.start_hz is None else brackets.start_hz

    def bisect(failed):
        return np.repeat(refine(brackets.lo_hz[failed], brackets.hi_hz[failed]), mult[failed])

    windows = Windows(
        centre, lo, hi, mult, [np.full(m, c) for c, m in zip(centre, mult, strict=True)]
    )
    return roots_in_windows(system, fmax_hz, int(mult.sum()), windows, bisect, rtol, state_keys)


@dataclass(frozen=True)
class Windows:
    """Where the roots are [Hz]: per cluster its start, window [lo, hi], number of roots and
    the estimates of its roots (spread for :func:`_split_clusters`)."""

    centre: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    mult: np.ndarray
    estimates: list


def roots_in_windows(system, fmax_hz, expected, windows: Windows, fallback, rtol, state_keys):
    """The roots in each window (Newton, split clusters, then ``fallback(failed windows)``
    returning roots [Hz] inside those windows); see :func:`bracketed_roots`."""
    centre, lo, hi, mult = windows.centre, windows.lo, windows.hi, windows.mult
    if centre.size == 0:
        return Roots(np.zeros(0), expected, np.zeros(0), 0, np.zeros((0, system.size)))
    root, ok, basis, walked = _newton(
        system, TWO_PI * centre, TWO_PI * lo, TWO_PI * hi, mult, rtol, state_keys
    )
    root /= TWO_PI
    found = np.repeat(root[ok], mult[ok])
    vectors = [basis[j].T for j in np.flatnonzero(ok)]
    split, split_hz, split_vectors = _split_clusters(
        system, root, ~ok & (mult > 1), windows.estimates, lo, hi, found, rtol
    )
    ok |= split
    found = np.concatenate([found, split_hz])
    vectors.append(split_vectors)
    if not ok.all():
        fallen = fallback(np.flatnonzero(~ok))
        found = np.concatenate([found, fallen])
        vectors.append(np.full((fallen.size, system.size), np.nan))
    vectors = np.concatenate(vectors) if vectors else np.zeros((0, system.size))
    keep = np.flatnonzero(found <= fmax_hz)
    order = keep[np.argsort(found[keep], kind="stable")]
    found, vectors = found[order], vectors[order]
    states = None
    if state_keys and ok.all() and split_hz.size == 0:  # every root from the first Newton
        states = {
            key: State(s.cols, np.repeat(s.arr, mult, axis=0)[order]) for key, s in walked.items()
        }
    missing = [
        np.full(m - np.sum((found >= a) & (found <= b)), c)
        for c, a, b, m in zip(centre, lo, hi, mult, strict=True)
        if c <= fmax_hz and np.sum((found >= a) & (found <= b)) < m
    ]
    missing_hz = np.concatenate(missing) if missing else np.zeros(0)
    return Roots(found, expected, missing_hz, int(mult[ok].sum()), vectors, states)


def _split_clusters(system, root_hz, failed, estimates_hz, lo_hz, hi_hz, certified_hz, rtol):
    """Clusters Newton could not certify as one repeated root, solved as m close simple roots.

    A cluster of nearly equal estimates may be a pair split by a small asymmetry (e.g. a
    shaft's bending pair on a support whose inertia differs in x and y) instead of an exact
    repeated root. Near two simple roots c ± d the multiplicity-2 step maps c + e to
    c + d²/e, a 2-cycle that never contracts. Here each of the cluster's m roots gets its own
    iterate, started around the cluster's last Newton iterate (spread as the estimates are,
    at least ACCEPT_STEP relative), each taking the root nearest to it and all kept in the
    cluster's window; the cluster counts as solved when all m iterates are certified,
    distinct (checked by ``_newton``) and none of them is a root already certified
    (``certified_hz``). An exact repeated root cannot pass: its iterates meet on one point.

    Returns (solved clusters (n,) bool, roots [Hz], null vectors (roots, size)).
    """
    clusters = np.flatnonzero(failed)
    solved = np.zeros(failed.size, dtype=bool)
    if clusters.size == 0:
        return solved, np.zeros(0), np.zeros((0, system.size))
    starts, owner = [], []
    for j in clusters:
        e = estimates_hz[j]
        spread = max(e[-1] - e[0], ACCEPT_STEP * root_hz[j])
        starts.append(root_hz[j] + spread * np.linspace(-0.5, 0.5, e.size))
        owner.append(np.full(e.size, j))
    start, owner = np.concatenate(starts), np.concatenate(owner)
    w, ok, basis, _ = _newton(
        system,
        TWO_PI * start,
        TWO_PI * lo_hz[owner],
        TWO_PI * hi_hz[owner],
        np.ones(start.size, dtype=int),
        rtol,
    )
    hz = w / TWO_PI
    ok &= np.all(np.abs(hz[:, None] - certified_hz[None, :]) > 1e-9 * hz[:, None], axis=1)
    solved[clusters] = [ok[owner == j].all() for j in clusters]
    keep = np.flatnonzero(solved[owner])
    vectors = [basis[k].T for k in keep]
    vectors = np.concatenate(vectors) if vectors else np.zeros((0, system.size))
    return solved, hz[keep], vectors


def _newton(system, omega, lo, hi, mult, rtol, state_keys=()):
    """Multiplicity-corrected Newton on det U_all, batched over clusters [rad/s].

    Returns (roots, certified, null bases, state maps): a cluster is certified when its last
    step is below ``rtol`` or, being below ACCEPT_STEP, contracted superlinearly from the
    previous one, inside [lo, hi]. The iteration works on S(ω), U_all with its ω-independent
    columns and rows eliminated (:mod:`ufmt.mstmm.reduced`: det U_all = const · det S, S
    built from U_all's nonzeros and solved per diagonal block), scaled to O(1) once.

    d ln det S/dω = tr(S⁻¹ dS/dω) is the sum of the eigenvalues of P = S⁻¹ dS/dω; near a
    cluster of m roots, m of them are ≈ 1/(ω - ω_k) and all others O(1/gap) to the other
    roots. The step takes only the cluster's own: inverse iteration with P on a block of
    one column more than the largest cluster (S's LU kept, :mod:`ufmt.mstmm.lu`; QR after
    each product, the block carried from one iterate to the next) converges to P's dominant
    invariant subspace by the ratio of the distances to the cluster and to the next root per
    product, and P's Ritz values on it give ω_k ← ω_k - m / Σ λ over the cluster's own
    (:mod:`ufmt.mstmm.newton_step`): Newton on det with every other root divided out
    exactly, at less than half the cost of the whole tr(S⁻¹ dS) (one LU and a few solves
    with a few columns instead of a solve with all of them). The block's first m columns
    are also the null space: P x = λ x means S(ω - 1/λ) x = 0 to first order, so after
    NULL_SPACE_PRODUCTS products they are S's null space at the new iterate to O(δ²) or
    rounding (δ: the step), completed to U_all's (size, m). A step that would leave the
    window (a neighbouring root pulls Newton too far) goes half way to the window's end
    instead; such a step never counts as converged, nor does one where S held a NaN.

    The state maps of ``state_keys`` come at the roots for free as well ({key: State
    (clusters, 12, k)}): the walks that evaluate U_all keep them, and each is interpolated
    to the root from ω and ω + dω, like the pivot rows (an error of order step · dω times
    the maps' second derivative).
    """
    w = omega.astype(float).copy()
    n = w.size
    r = c = None  # the scaling, from the first evaluation (one walk of the transfer graph)
    sparse = None  # S' from U_all's nonzero entries (ufmt.mstmm.reduced.SparseReduction)
    block = None  # each cluster's current block of the inverse iteration
    previous = np.full(n, np.inf)
    basis: dict[int, np.ndarray] = {}
    done = np.zeros(n, dtype=bool)
    at_roots: dict = {}  # state key -> State at each cluster's root
    for _ in range(NEWTON_ITERATIONS):
        act = np.flatnonzero(~done)
        if act.size == 0:
            break
        wa = w[act]
        h = DERIVATIVE_STEP * wa
        sparse, u, walked = _evaluate(system, wa, h, sparse, state_keys)
        s0, s1 = sparse.s_values(u).reshape(2, act.size, -1)
        if r is None:  # row and column maxima: as good at a root as off it
            r, c = sparse.pattern.equilibrate(s0)
            # one column more than the largest cluster: see own_step
            start = np.random.default_rng(0).standard_normal((r.shape[1], mult.max() + 1))
            block = np.broadcast_to(start, (n, *start.shape)).copy()
        x, ritz, singular = inverse_iteration(
            sparse.pattern, s0, s1, r[act], c[act], h, block[act], start
        )
        block[act] = x
        step, finite, own = own_step(w, act, ritz, mult[act], lo[act], hi[act], singular)
        new = wa - step
        size = np.abs(step)
        converged = finite & (
            (size <= rtol * wa)
            | ((size <= ACCEPT_STEP * wa) & (size <= CONTRACTION * previous[act]))
        )
        inside = (new >= lo[act]) & (new <= hi[act])
        w[act] = np.where(inside, new, 0.5 * (wa + np.where(new < lo[act], lo[act], hi[act])))
        previous[act] = size
        done[act] = converged & inside
        for m in np.unique(mult[act[done[act]]]):
            sel = np.flatnonzero(done[act] & (mult[act] == m))
            t = (new[sel] - wa[sel]) / h[sel]  # where the root lies between ω and ω + dω
            z = _own_vectors(sparse.pattern, x[sel], own[sel, :m], start.shape[1])
            z = _null_basis(sparse, z * c[act[sel], :, None], u, act.size, sel, t)
            for k, j in enumerate(act[sel]):
                basis[j] = z[k]
            _states_at_roots(walked, act, sel, t, n, at_roots)
    ok = done.copy()
    order = np.flatnonzero(ok)[np.argsort(w[ok])]  # two clusters on one root: both fail
    close = np.flatnonzero(np.diff(w[order]) <= 1e-9 * w[order][1:])
    ok[order[close]] = ok[order[close + 1]] = False
    return w, ok, basis, at_roots


def _evaluate(system, wa, h, sparse, state_keys):
    """(the map to S' (:class:`ufmt.mstmm.reduced.SparseReduction`), U_all's entries it takes
    at ω = ``wa`` and ω + ``h`` (2n, entries), the walked state maps): one walk; the first
    call (``sparse`` None) also finds U_all's ω-independent parts and its structural zeros,
    bitwise equal (zero) at ω_0, ω_0 + dω and a distant 0.61 ω_0."""
    if sparse is None:
        omega_q = np.concatenate([wa, wa + h, [0.61 * wa[0]]])
        blocks, walked = _walk(system, omega_q, state_keys)
        reduction = ConstantParts.of(assemble(blocks, system.size, [0, wa.size, -1]))
        sparse = SparseReduction.of(reduction, block_layout(blocks))
        return sparse, sparse.values(blocks)[:-1], walked
    blocks, walked = _walk(system, np.concatenate([wa, wa + h]), state_keys)
    return sparse, sparse.values(blocks), walked


def _own_vectors(pattern, x, own, b: int) -> np.ndarray:
    """S''s null basis (roots, m', m) from the inverse iteration's blocks ``x`` (roots, m', b
    per diagonal block of S's ``pattern``) and the m Ritz values each cluster took (``own``,
    indices into b per diagonal block): for c_k taken from diagonal block k, that block's
    first c_k columns (its dominant subspace), zero outside its columns, after the c_l of the
    blocks before."""
    z = np.zeros((*x.shape[:2], own.shape[1]))
    block_of = own // b
    offset = np.zeros(own.shape[0], dtype=int)
    for k, block in enumerate(pattern.diagonal_blocks):
        taken = np.count_nonzero(block_of == k, axis=1)
        for count, start in set(zip(taken[taken > 0], offset[taken > 0], strict=True)):
            at = np.flatnonzero((taken == count) & (offset == start))
            z[np.ix_(at, block.columns, np.arange(start, start + count))] = x[
                np.ix_(at, block.columns, np.arange(count))
            ]
        offset += taken
    return z


def _null_basis(sparse, x, u, n_active, sel, t) -> np.ndarray:
    """U_all's null basis (roots, size, m) at the converged iterates ``sel`` from S''s
    (``x``, (roots, m', m), column scaling undone), completed with U_all's pivot rows at the
    root, not at the iterate (first order in the step from U_all's entries ``u`` at ω and
    at ω + dω: an O(step²) error instead of O(step))."""
    at, above = u[:n_active], u[n_active:]
    if sel.size < n_active:
        at, above = at[sel], above[sel]
    at_root = above - at  # at + t (above - at)
    at_root *= t[:, None]
    at_root += at
    return sparse.null_vectors(at_root, x)


def _states_at_roots(walked: dict, act, sel, t, n: int, at_roots: dict) -> None:
    """The walked state maps interpolated to the roots of the converged iterates ``sel`` (of
    the active ``act``; maps at ω, then at ω + dω), into ``at_roots`` (n clusters) in place."""
    every = sel.size == act.size == n  # every cluster converged at once (the usual case)
    for key, walked_map in walked.items():
        arr = walked_map.arr
        if every:  # slices, no gathers
            at = arr[n : 2 * n] - arr[:n]
            at *= t[:, None, None]
            at += arr[:n]
            at_roots[key] = State(walked_map.cols, at)
            continue
        if key not in at_roots:
            at_roots[key] = State(walked_map.cols, np.empty((n, *arr.shape[1:])))
        at_roots[key].arr[act[sel]] = arr[sel] + t[:, None, None] * (arr[act.size + sel] - arr[sel])


def _walk(system: TransferSystem, omega: np.ndarray, state_keys) -> tuple[list, dict]:
    """U_all's equation blocks at ω and the state maps of ``state_keys`` (none: U_all's
    walk only)."""
    blocks, states = system.equation_blocks(omega, bool(state_keys))
    return blocks, {key: states[key] for key in state_keys}


def batched_solve(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Batched a⁻¹ b. A matrix that is exactly singular (ω on a root to the last bit) is
    shifted on the diagonal by 1e-14 (1e-12, 1e-10) of its largest entry; inf if still
    singular."""
    try:
        return np.linalg.solve(a, b)
    except np.linalg.LinAlgError:
        b = np.broadcast_to(b, (*a.shape[:-1], b.shape[-1]))
        out = np.empty(b.shape, dtype=np.result_type(a, b))
        eye = np.eye(a.shape[-1])
        for k in range(a.shape[0]):
            out[k] = np.inf
            for shift in (0.0, 1e-14, 1e-12, 1e-10):
                try:
                    out[k] = np.linalg.solve(a[k] + shift * np.abs(a[k]).max() * eye, b[k])
                    break
                except np.linalg.LinAlgError:
                    continue
        return out
