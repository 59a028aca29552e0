"""The Newton step by inverse iteration (ufmt.mstmm.newton_step) on pencils whose roots are
known in closed form, and its rules for roots other clusters hold."""

import numpy as np

from ufmt.mstmm.newton_step import inverse_iteration, own_step
from ufmt.mstmm.sparse import SparseRows


def linear_pencil(roots, omega, h, seed=0):
    """S(ω) = A (ω I - diag(roots)) B at ω and ω + h, A and B random: det S has exactly
    these roots and S is linear in ω, so the forward difference is the exact derivative."""
    rng = np.random.default_rng(seed)
    n = len(roots)
    a, b = rng.standard_normal((n, n)) + 3 * np.eye(n), rng.standard_normal((n, n)) + 3 * np.eye(n)
    s = [a @ np.diag(w - np.asarray(roots)) @ b for w in (omega, omega + h)]
    return s[0][None], s[1][None]


def dense_step(s0, s1, h, x, start):
    """inverse_iteration of dense matrices S (1, n, n) (every entry in the pattern, no
    scaling)."""
    n = s0.shape[-1]
    every = SparseRows((n, n), np.repeat(np.arange(n), n), np.tile(np.arange(n), n))
    ones = np.ones((1, n))
    values = (s.reshape(1, -1) for s in (s0, s1))
    return inverse_iteration(every, *values, ones, ones, np.array([h]), x, start)


def one_cluster_step(w, ritz, singular, lo=5.0, hi=11.5):
    """own_step of a single cluster of multiplicity 1 at ``w`` in the window [lo, hi]."""
    w, lo, hi = (np.array([v]) for v in (w, lo, hi))
    return own_step(w, np.array([0]), ritz, np.array([1]), lo, hi, singular)[:2]


def test_steps_on_a_linear_pencil_converge_to_the_nearest_root():
    """Oracle: the roots of det S = det(ω I - diag(roots)) up to constant factors. From
    ω = 10.3, steps re-evaluating S at each iterate with the block carried over contract at
    least tenfold each and end on the root 10 to 1e-13, the block's first column S's null
    vector there."""
    roots, w, h = [10.0, 13.0, 17.0, 25.0], 10.3, 1e-6
    start = np.random.default_rng(1).standard_normal((4, 2))
    x, sizes = start[None], []
    for _ in range(4):
        s0, s1 = linear_pencil(roots, w, h)
        x, ritz, singular = dense_step(s0, s1, h, x, start)
        step, finite = one_cluster_step(w, ritz, singular)
        assert finite.all()
        w, sizes = w - step[0], [*sizes, abs(step[0])]
    assert all(b <= 0.1 * a for a, b in zip(sizes[:2], sizes[1:3], strict=True))
    assert abs(w - 10.0) <= 1e-13 * 10.0
    s_root, _ = linear_pencil(roots, 10.0, h)
    assert np.linalg.norm(s_root[0] @ x[0, :, 0]) <= 1e-10 * np.linalg.norm(s_root[0])


def test_a_root_another_cluster_sits_on_is_left_to_it():
    """Two clusters in one window: cluster 0 converged on root 10; cluster 1's Ritz values
    put roots at 10 (the nearer, claimed) and 11: it steps to 11, not onto cluster 0's."""
    w = np.array([10.0, 10.2])
    ritz = np.array([[1 / (10.2 - 10.0), 1 / (10.2 - 11.0)]])
    step, finite, _ = own_step(
        w, np.array([1]), ritz, np.array([1]), np.array([9.0]), np.array([12.0]), np.array([False])
    )
    assert finite.all()
    np.testing.assert_allclose(10.2 - step, 11.0, rtol=1e-14)
    alone, _ = one_cluster_step(10.2, ritz, np.array([False]), 9.0, 12.0)
    np.testing.assert_allclose(10.2 - alone, 10.0, rtol=1e-14)  # without it: the nearer


def test_nothing_projected_is_no_step_and_never_converged():
    """A NaN in S gives no Ritz values: the step is 0 and flagged not finite (the caller
    never certifies it), and the block starts again."""
    s0, s1 = linear_pencil([10.0, 13.0, 17.0], 10.3, 1e-6)
    s0[0, 1, 2] = np.nan
    start = np.random.default_rng(2).standard_normal((3, 2))
    x, ritz, singular = dense_step(s0, s1, 1e-6, start[None], start)
    step, finite = one_cluster_step(10.3, ritz, singular)
    assert not finite.any() and step[0] == 0.0
    np.testing.assert_array_equal(x[0], start)


def test_an_iterate_exactly_on_a_root_is_flagged_and_takes_no_step():
    """S = diag(ω - roots) at ω = 13 exactly: a zero pivot. The factors are taken at ω + h
    instead (the null vector e_2 to O(h)), but the matrix is reported singular, so the
    step is 0 (the iterate is the root), finite, and the block's first column is e_2."""
    roots, h = np.array([10.0, 13.0, 17.0]), 1e-6
    s0, s1 = (np.diag(w - roots)[None] for w in (13.0, 13.0 + h))
    start = np.random.default_rng(3).standard_normal((3, 2))
    x, ritz, singular = dense_step(s0, s1, h, start[None], start)
    assert singular.all()
    step, finite = one_cluster_step(13.0, ritz, singular, 11.0, 15.0)
    assert finite.all() and step[0] == 0.0
    np.testing.assert_allclose(np.abs(x[0, :, 0]), [0.0, 1.0, 0.0], atol=1e-9)


def test_a_nan_in_one_diagonal_block_spoils_the_whole_step():
    """S = diag(S_a, S_b), two diagonal blocks of the pattern, a NaN in S_a only: S_b's
    Ritz values alone would give a finite step to its own root, but S holds a NaN, so
    there is no step and it is flagged not finite (as for a NaN in a single block)."""
    a0, a1 = linear_pencil([10.0, 13.0], 10.3, 1e-6, seed=4)
    b0, b1 = linear_pencil([10.2, 17.0], 10.3, 1e-6, seed=5)
    a0[0, 0, 1] = np.nan
    rows, columns = np.r_[np.repeat([0, 1], 2), np.repeat([2, 3], 2)], np.r_[0, 1, 0, 1, 2, 3, 2, 3]
    pattern = SparseRows((4, 4), rows, columns)
    assert len(pattern.diagonal_blocks) == 2
    s0 = np.concatenate([a0.reshape(1, -1), b0.reshape(1, -1)], axis=1)
    s1 = np.concatenate([a1.reshape(1, -1), b1.reshape(1, -1)], axis=1)
    start = np.random.default_rng(6).standard_normal((4, 2))
    ones = np.ones((1, 4))
    x, ritz, singular = inverse_iteration(
        pattern, s0, s1, ones, ones, np.array([1e-6]), start[None], start
    )
    step, finite = one_cluster_step(10.3, ritz, singular, 10.1, 10.5)
    assert not finite.any() and step[0] == 0.0
