"""LU factors kept for repeated solves (ufmt.mstmm.lu) against numpy.linalg.solve, and the
exactly singular case the Newton iteration meets on a root to the last bit."""

import numpy as np

from ufmt.mstmm.lu import factor


def test_solves_match_numpy_on_a_stack():
    """Oracle: numpy.linalg.solve (LAPACK gesv) on the same stack, several right-hand sides;
    the factors serve any number of later solves."""
    rng = np.random.default_rng(3)
    a = rng.standard_normal((9, 12, 12)) + 4 * np.eye(12)
    b = rng.standard_normal((9, 12, 3))
    lu = factor(a.copy())
    assert not lu.singular.any()
    for _ in range(2):
        np.testing.assert_allclose(lu.solve(b), np.linalg.solve(a, b), rtol=1e-12, atol=1e-12)


def test_an_exactly_singular_matrix_is_flagged_and_can_be_refactored():
    """A matrix with a zero column has an exactly zero pivot (elimination keeps the column
    zero): flagged, and replaced by another matrix whose solutions then match numpy's."""
    rng = np.random.default_rng(4)
    a = rng.standard_normal((3, 6, 6))
    a[1, :, 3] = 0.0
    lu = factor(a.copy())
    assert lu.singular.tolist() == [False, True, False]
    replacement = rng.standard_normal((6, 6)) + 3 * np.eye(6)
    lu.refactor(1, replacement)
    assert not lu.singular.any()
    b = rng.standard_normal((3, 6, 1))
    expected = np.linalg.solve(np.stack([a[0], replacement, a[2]]), b)
    np.testing.assert_allclose(lu.solve(b), expected, rtol=1e-12, atol=1e-12)
