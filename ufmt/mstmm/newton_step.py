"""One Newton step on det S (:mod:`ufmt.mstmm.roots`): inverse iteration with
P = S⁻¹ dS/dω on a block per cluster (S's LU kept, :mod:`ufmt.mstmm.lu`) and the step from
the Ritz values of each cluster's own roots, every other root divided out exactly."""

from __future__ import annotations

import numpy as np

from ufmt.mstmm.lu import factor

NULL_SPACE_PRODUCTS = 3  # products of S⁻¹ dS with the block per Newton step
# a Ritz root within this fraction of its distance from the iterate of another cluster's
# target is that root (Ritz roots far from the iterate are off by O(distance²): S is not
# linear in ω)
AIMED = 1e-2


def inverse_iteration(pattern, s0, s1, r, c, h, x, start):
    """NULL_SPACE_PRODUCTS products of P = S⁻¹ dS/dω (rows and columns scaled by r, c (n, m');
    S at ω and ω + h: its entries s0, s1 (n, q) at ``pattern``'s positions
    (:class:`ufmt.mstmm.sparse.SparseRows`), dS/dω their forward difference) with the blocks
    ``x`` (n, m', b), orthonormalised after each (a block that a NaN or inf in S spoiled
    starts again from ``start``, and that S gives no Ritz values at all: no step, never
    converged). P is block diagonal as S is (:attr:`SparseRows.diagonal_blocks`): each
    diagonal block is factored and iterated on its own, with the rows of ``x`` at its columns.
    Returns (the last blocks, each diagonal block's orthonormal; the Ritz values (n, blocks · b)
    of P on them before the last product, diagonal block by block, b per block (0: none, a
    block of order below b); which S are exactly singular: ω is a root of det S there)."""
    row_scale, column_scale = r[:, pattern.rows], c[:, pattern.columns]
    ds = np.subtract(s1, s0)
    ds *= row_scale / h[:, None]
    ds *= column_scale
    scale = np.multiply(row_scale, column_scale, out=row_scale)
    n, b = s0.shape[0], x.shape[2]
    blocks = pattern.diagonal_blocks
    x, ritz = x.copy(), np.zeros((n, len(blocks) * b), complex)
    singular, spoiled = np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
    for k, block in enumerate(blocks):
        on, width = block.entries, min(b, block.columns.size)  # a block of order < b: all of it
        x[:, block.columns, :width], ritz[:, k * b : k * b + width], *flags = _block_iteration(
            block.local,
            s0[:, on] * scale[:, on],
            ds[:, on],
            lambda i, on=on: s1[i : i + 1, on] * scale[i, on],
            x[:, block.columns, :width],
            start[block.columns, :width],
        )
        singular |= flags[0]
        spoiled |= flags[1]
    ritz[spoiled] = 0.0
    return x, ritz, singular


def _block_iteration(local, s0, ds, s1, x, start):
    """:func:`inverse_iteration` on one diagonal block: its scaled S at ω and dS/dω (entries
    at ``local``'s positions), ``s1(i)``: matrix i's scaled S at ω + h (1, entries), its
    rows of the blocks and of the start. Returns (blocks, Ritz values, exactly singular,
    spoiled by a NaN or inf)."""
    ds = local.dense(ds)  # three products: dense matmuls beat sparse gathers here
    lu = factor(local.dense(s0))
    singular = lu.singular.copy()
    for i in np.flatnonzero(singular):  # ω a root to the last bit: S at ω + h instead,
        lu.refactor(i, local.dense(s1(i))[0])  # the same null space to O(h²)
    with np.errstate(all="ignore"):
        for k in range(NULL_SPACE_PRODUCTS):
            y = lu.solve(ds @ x)
            if k == NULL_SPACE_PRODUCTS - 1:
                projected = np.swapaxes(x, 1, 2) @ y
            x = orthonormal(y)
    spoiled = ~np.isfinite(projected).all(axis=(1, 2))
    projected[spoiled] = 0.0
    x[~np.isfinite(x).all(axis=(1, 2))] = start
    return x, np.linalg.eigvals(projected), singular, spoiled


def own_step(w, act, ritz, mult, lo, hi, singular):
    """The Newton step on det S of each active cluster ``act`` (of all clusters' current
    iterates ``w``) with the other roots divided out [rad/s].

    The Ritz values λ of P (:func:`inverse_iteration`) put roots at ω - 1/λ. The
    cluster's own are its ``mult`` = m largest |λ| among those inside its window
    [lo, hi] and not claimed by another cluster (the Aberth idea: a root another cluster
    is on belongs to that one, e.g. where two tracked roots cross): claimed means another
    cluster's iterate is nearer to it and either sits on it (converged) or aims at it
    this iteration (its own first choice, the largest |λ| in its window); the others only
    if too few qualify. The step is m / Σ Re λ over them (an exact repeated root: m equal
    λ); 0 where S is exactly ``singular`` (ω is the root). Returns (the steps, finite, own):
    where nothing was projected (a NaN in S) the step is 0 and not finite (never converged);
    own (n, columns of ``ritz``): the Ritz values in order of choice, the first m taken."""
    wa = w[act]
    with np.errstate(all="ignore"):
        at = wa[:, None] - 1.0 / ritz.real
        inside = (at >= lo[:, None]) & (at <= hi[:, None])
        own_distance = np.abs(at - wa[:, None])
        # each active cluster's first choice: the largest |λ| inside its window
        first = np.take_along_axis(at, np.lexsort((-np.abs(ritz), ~inside), axis=-1)[:, :1], 1)
        target = w.copy()  # done clusters sit on their roots; active ones aim at `first`
        target[act] = first[:, 0]
        distance = np.abs(at[:, :, None] - w[None, None, :])  # (active, b, clusters)
        aimed = np.abs(at[:, :, None] - target[None, None, :]) < AIMED * own_distance[:, :, None]
        distance = np.where(aimed, distance, np.inf)
        distance[np.arange(act.size), :, act] = np.inf
        claimed = distance.min(axis=2) < own_distance
        order = np.lexsort((-np.abs(ritz), claimed, ~inside), axis=-1)
        own = np.arange(ritz.shape[1])[None, :] < mult[:, None]
        total = np.sum(np.take_along_axis(ritz.real, order, axis=1) * own, axis=1)
        step = np.where(singular, 0.0, mult / total)
    finite = np.isfinite(step)
    return np.where(finite, step, 0.0), finite, order


def orthonormal(x: np.ndarray) -> np.ndarray:
    """Orthonormal basis (…, n, m) of each block's columns: Gram-Schmidt, each column
    orthogonalised twice against the ones before (CGS2: orthonormal to rounding however
    close the columns; the blocks have a few), then normalised. A block whose columns are
    dependent to the last bit (Gram-Schmidt leaves a zero column) gets LAPACK's QR."""
    q = np.empty_like(x)
    with np.errstate(all="ignore"):
        for j in range(x.shape[-1]):
            v = x[..., j : j + 1]
            for _ in range(2 if j else 0):
                v = v - q[..., :j] @ (np.swapaxes(q[..., :j], -1, -2) @ v)
            q[..., j : j + 1] = v / np.linalg.norm(v, axis=-2, keepdims=True)
    dependent = ~np.isfinite(q).all(axis=(-2, -1)) & np.isfinite(x).all(axis=(-2, -1))
    if dependent.any():
        q[dependent] = np.linalg.qr(x[dependent])[0]
    return q
