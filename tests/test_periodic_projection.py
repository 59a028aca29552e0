"""The record window's projection without its state (periodic_projection, the recurrence's
powers formed where read) against the formed quantities: the state of periodic_coordinates
(itself checked against time stepping in test_periodic_state) projected as 2 Re(z^T W), the
table of E^l against the exponentials themselves, and the real product against numpy's
complex one."""

import numpy as np
import pytest

from ufmt.machining.periodic_path import periodic_coordinates, periodic_projection
from ufmt.machining.recurrence import pole_recurrence, real_part_product

N = 60
DT = 1e-4  # [s]


def poles():
    """Complex poles [1/s] from light to heavy damping, one slow enough that the periodic
    closure 1 / (1 - E^N) matters."""
    omega = 2 * np.pi * np.array([30.0, 400.0, 1200.0, 3000.0])
    zeta = np.array([0.05, 0.02, 0.3, 0.05])
    return -zeta * omega + 1j * omega * np.sqrt(1 - zeta**2)


@pytest.mark.parametrize(("n", "first", "a"), [(60, 0, 1), (60, 5, 9), (60, 50, 17), (61, 1, 59)])
def test_the_projection_equals_the_projected_state(n, first, a):
    """Runs that wrap around sample 0 or not, one sample or all but one, N a perfect square
    plus one or not."""
    recurrence = pole_recurrence(poles(), DT, n)
    rng = np.random.default_rng(first)
    active = np.zeros(n, bool)
    run = (first + np.arange(a)) % n
    active[run] = True
    force = np.zeros((4, n), complex)
    force[:, run] = rng.normal(size=(4, a)) + 1j * rng.normal(size=(4, a))
    weights = rng.normal(size=(4, 3)) + 1j * rng.normal(size=(4, 3))
    z = periodic_coordinates(recurrence, force, active)
    expected = 2 * (z.T @ weights).real
    got = periodic_projection(recurrence, force[:, run], active, weights)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-13 * np.abs(expected).max())


@pytest.mark.parametrize("n", [8, 9, 60, 64, 65])
def test_powers_where_read_equal_the_exponentials(n):
    recurrence = pole_recurrence(poles(), DT, n)
    lags = np.arange(n)
    exact = np.exp(np.outer(poles(), DT * lags))
    np.testing.assert_allclose(recurrence.power(lags), exact, rtol=1e-13)
    np.testing.assert_array_equal(recurrence.powers, recurrence.power(lags))
    weights = np.random.default_rng(n).normal(size=(4, 2)) * (1 + 1j)
    for length in (1, n // 2, n):
        expected = 2 * (exact[:, :length].T @ weights).real
        got = recurrence.projected_powers(weights, length)
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-13 * np.abs(expected).max())


def test_real_part_product_equals_the_complex_product():
    rng = np.random.default_rng(2)
    x = rng.normal(size=(7, 5)) + 1j * rng.normal(size=(7, 5))
    w = rng.normal(size=(5, 3)) + 1j * rng.normal(size=(5, 3))
    np.testing.assert_allclose(real_part_product(x, w), 2 * (x @ w).real, rtol=1e-14)
    np.testing.assert_allclose(real_part_product(x.T.T[:, ::-1], w[::-1]), 2 * (x @ w).real)
