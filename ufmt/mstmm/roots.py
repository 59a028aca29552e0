"""Natural frequencies: every root of det U_all(ω) = 0 in (0, f_max] (paper eq. 2.23).

det U_all has no poles for these elements, so it changes sign only at roots of odd
multiplicity. The assembled mass-stiffness model of the same file (``ufmt.assembled``) counts
the roots and says where they are; the MSTMM then finds each one on its own:

1. sign of det on a grid refined around every estimate (geometric steps down to 1e-7) and at
   the midpoints between neighbouring estimates, plus a uniform background grid;
2. every sign change is refined by a vectorised Illinois (regula falsi) iteration on det of
   the row/column-equilibrated U_all (positive scaling, so the sign is unchanged);
3. where fewer roots than estimates were found (a repeated root of a symmetric structure, or an
   even-multiplicity cluster) the smallest singular values of U_all are minimised by golden
   section; a root is accepted when they fall by many orders of magnitude, and its multiplicity
   is the number of singular values that vanish together.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ufmt.mstmm.overall import TransferSystem, equilibrate

TWO_PI = 2.0 * np.pi
STEPS = np.array([3e-2, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7])
NOISE_RTOL = 1e-5  # sign flips of det closer than this (relative) are rounding noise
OFF_ROOT = 1.0 + 3.7e-3  # a generic point near a root, where the scaling of U_all is taken


@dataclass(frozen=True)
class Roots:
    """Natural frequencies [Hz] ascending, repeated roots listed once per multiplicity."""

    frequencies_hz: np.ndarray
    expected: int  # how many the assembled model counts in (0, f_max]


def _sign_det(system: TransferSystem, omega: np.ndarray) -> np.ndarray:
    """Sign of det U_all (LU with partial pivoting; positive scalings cannot change it)."""
    sign, _ = np.linalg.slogdet(system.evaluate(omega))
    return sign


def _illinois(system, lo, hi, rtol, max_iter=100):
    """Vectorised Illinois iteration on brackets [lo, hi] of det sign changes [rad/s].

    det is evaluated with a fixed positive scaling per bracket, taken off the root (OFF_ROOT)
    so that rows vanishing at the root are not blown up; the scaling keeps det continuous in
    ω. Each iteration evaluates only the brackets still wider than ``rtol``; a bisection step
    is forced when an Illinois step failed to halve a bracket.
    """
    n = lo.size
    mid = 0.5 * (lo + hi)
    u = system.evaluate(np.concatenate([mid * OFF_ROOT, mid, lo, hi]))
    r, c = equilibrate(u[:n])
    rr, cc = np.tile(r, (3, 1, 1)), np.tile(c, (3, 1, 1))
    sign, logdet = np.linalg.slogdet(u[n:] * rr * cc)
    ref = logdet[:n]
    fa = sign[n : 2 * n] * np.exp(logdet[n : 2 * n] - ref)
    fb = sign[2 * n :] * np.exp(logdet[2 * n :] - ref)
    a, b = lo.copy(), hi.copy()
    # A bracket end that sits on the root (det at noise level) may change sign under the
    # refinement's scaling; that end is then the root itself.
    lost = np.sign(fa) == np.sign(fb)
    on_end = np.where(np.abs(fa) < np.abs(fb), a, b)
    a, b = np.where(lost, on_end, a), np.where(lost, on_end, b)
    previous = np.abs(b - a)
    step = np.abs(b - a)
    for _ in range(max_iter):
        # converged: the bracket, or the last secant step, is below rtol
        active = np.flatnonzero(np.minimum(np.abs(b - a), step) > rtol * np.abs(b))
        if active.size == 0:
            break
        aa, bb, fa_, fb_ = a[active], b[active], fa[active], fb[active]
        with np.errstate(divide="ignore", invalid="ignore"):
            cpt = bb - fb_ * (bb - aa) / (fb_ - fa_)
        slow = np.abs(bb - aa) > 0.5 * previous[active]
        bad = ~np.isfinite(cpt) | (cpt <= np.minimum(aa, bb)) | (cpt >= np.maximum(aa, bb))
        cpt = np.where(bad | slow, 0.5 * (aa + bb), cpt)
        s, ld = np.linalg.slogdet(system.evaluate(cpt) * r[active] * c[active])
        fc = s * np.exp(ld - ref[active])
        previous[active] = np.abs(bb - aa)
        step[active] = np.abs(cpt - bb)
        flip = np.sign(fc) != np.sign(fb_)
        a[active] = np.where(flip, bb, aa)
        fa[active] = np.where(flip, fb_, 0.5 * fa_)
        b[active] = cpt
        fb[active] = fc
        a[active] = np.where(fc == 0, cpt, a[active])
    return b


def _golden_nullity(system, centre, lo, hi, k, iters=48):
    """Minimise the k-th smallest singular value of U_all near ``centre`` within [lo, hi].

    σ_k is V-shaped only close to a root (elsewhere other singular values set a plateau), so
    a grid refined geometrically around the estimate picks the valley first; golden section
    then refines it between the grid neighbours of the best point. Vectorised over windows.
    """
    r, c = equilibrate(system.evaluate(centre * OFF_ROOT))

    def sigma(w):
        s = np.linalg.svd(
            system.evaluate(w.ravel())
            * np.repeat(r, w.size // r.shape[0], 0)
            * np.repeat(c, w.size // c.shape[0], 0),
            compute_uv=False,
        )
        return s[:, -k].reshape(w.shape)

    offsets = np.concatenate([-STEPS, [0.0], STEPS[::-1]])
    grid = np.clip(centre[:, None] * (1.0 + offsets[None, :]), lo[:, None], hi[:, None])
    values = sigma(grid)
    best = np.argmin(values, axis=1)
    rows = np.arange(centre.size)
    a = grid[rows, np.maximum(best - 1, 0)]
    b = grid[rows, np.minimum(best + 1, offsets.size - 1)]
    g = (np.sqrt(5.0) - 1.0) / 2.0
    x1, x2 = b - g * (b - a), a + g * (b - a)
    f1, f2 = sigma(x1[:, None])[:, 0], sigma(x2[:, None])[:, 0]
    for _ in range(iters):
        left = f1 < f2
        b = np.where(left, x2, b)
        a = np.where(left, a, x1)
        x2n = np.where(left, x1, a + g * (b - a))
        x1n = np.where(left, b - g * (b - a), x2)
        fx = sigma(np.where(left, x1n, x2n)[:, None])[:, 0]
        f1, f2 = np.where(left, fx, f2), np.where(left, f1, fx)
        x1, x2 = x1n, x2n
    w = 0.5 * (a + b)
    ends = np.stack([grid[:, 0], grid[:, -1]], axis=1)
    s_min = np.linalg.svd(system.evaluate(w) * r * c, compute_uv=False)
    s_ends = sigma(ends).min(axis=1)
    return w, s_min, s_ends


def natural_frequencies(
    system: TransferSystem, fmax_hz: float, estimates_hz, rtol: float = 1e-12
) -> Roots:
    """Every natural frequency in (0, fmax_hz] [Hz], to relative precision ``rtol``.

    ``estimates_hz`` are the assembled model's nonzero frequencies (ascending, repeated roots
    repeated); they bracket and count the roots, the MSTMM values are computed independently.
    """
    system.segment_for(fmax_hz)
    est = np.sort(np.asarray(estimates_hz, dtype=float))
    est = est[est > 0]
    expected = int(np.sum(est <= fmax_hz))
    if est.size == 0:
        return Roots(np.zeros(0), 0)
    f_lo = 0.5 * est[0]
    near = est[est <= fmax_hz * 1.05]
    grid = [np.linspace(f_lo, fmax_hz, 64), near, np.sqrt(near[1:] * near[:-1])]
    for s in (-1.0, 1.0):
        grid.append((near[:, None] * (1.0 + s * STEPS[None, :])).ravel())
    f = np.unique(np.clip(np.concatenate(grid), f_lo, fmax_hz))
    w = TWO_PI * f
    sign = _sign_det(system, w)
    change = np.flatnonzero((sign[1:] != sign[:-1]) & (sign[1:] != 0) & (sign[:-1] != 0))
    exact = w[1:-1][(sign[1:-1] == 0)]
    roots_w = _illinois(system, w[change], w[change + 1], rtol) if change.size else np.zeros(0)
    found = np.sort(np.concatenate([roots_w, exact])) / TWO_PI
    windows = _windows(near, f_lo, fmax_hz)
    found = _merge_noise_roots(found, windows)
    found = _add_even_roots(system, found, windows, fmax_hz)
    return Roots(found, expected)


def _add_even_roots(system, found, windows, fmax_hz):
    """Find repeated (even-multiplicity) roots the sign scan cannot see, near the estimates."""
    lo_list, hi_list, need, centres = [], [], [], []
    for idx, centre, lo, hi in windows:
        if centre > fmax_hz:
            continue
        have = np.sum((found >= lo) & (found <= hi))
        missing = len(idx) - have
        if missing > 0:
            centres.append(centre)
            lo_list.append(lo)
            hi_list.append(hi)
            need.append(missing)
    if not need:
        return found
    extra = []
    for k in sorted(set(need)):
        sel = [i for i, m in enumerate(need) if m == k]
        centre = TWO_PI * np.array([centres[i] for i in sel])
        lo = TWO_PI * np.array([lo_list[i] for i in sel])
        hi = TWO_PI * np.array([hi_list[i] for i in sel])
        w, s_min, s_ends = _golden_nullity(system, centre, lo, hi, k)
        for j in range(w.size):
            vanished = int(np.sum(s_min[j, -k:] < 1e-7 * s_ends[j]))
            if vanished and w[j] / TWO_PI <= fmax_hz:
                extra.extend([w[j] / TWO_PI] * vanished)
    return np.sort(np.concatenate([found, extra]))


def _windows(near: np.ndarray, f_lo: float, fmax_hz: float):
    """(cluster indices, lo, hi) [Hz]: the search window of each cluster of estimates."""
    out = []
    for idx in _clusters(near):
        centre = near[idx].mean()
        prev_e = near[idx[0] - 1] if idx[0] > 0 else f_lo
        next_e = near[idx[-1] + 1] if idx[-1] + 1 < near.size else fmax_hz * 1.05
        lo = max(np.sqrt(prev_e * near[idx[0]]), centre * (1 - 3e-2))
        hi = min(np.sqrt(next_e * near[idx[-1]]), centre * (1 + 3e-2))
        out.append((idx, centre, lo, hi))
    return out


def _merge_noise_roots(found: np.ndarray, windows) -> np.ndarray:
    """Undo sign flips of det U_all caused by rounding noise near a root.

    At noise level det flips sign an odd number of times within ~NOISE_RTOL of one root.
    Within each cluster window that holds more roots than the assembled model counts there,
    three consecutive roots a < b < c spanning less than NOISE_RTOL are replaced by b.
    """
    out = np.sort(found)
    for idx, _, lo, hi in windows:
        while True:
            inside = np.flatnonzero((out >= lo) & (out <= hi))
            if inside.size <= idx.size or inside.size < 3:
                break
            f = out[inside]
            span = (f[2:] - f[:-2]) / f[2:]
            k = int(np.argmin(span))
            if span[k] > NOISE_RTOL:
                break
            out = np.delete(out, [inside[k], inside[k + 2]])
    return out


def _clusters(est: np.ndarray, rel: float = 1e-6) -> list[np.ndarray]:
    """Group estimates closer than ``rel`` (relative) into clusters of repeated roots."""
    if est.size == 0:
        return []
    breaks = np.flatnonzero(np.diff(est) > rel * est[1:]) + 1
    return np.split(np.arange(est.size), breaks)
