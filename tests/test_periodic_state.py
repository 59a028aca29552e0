"""The periodic path's O(n A sqrt(A)) steady state (periodic_coordinates, from_rest)
against two independent formulas: the sum of the force with the periodic impulse response
(the O(n A^2) formula it replaced, kept here as the oracle) and plain time stepping of the
recurrence over many periods until it is periodic. The record window's motion projected through
the complex modes (DampedModes.projected) against q, q', q'' formed explicitly."""

import numpy as np
import pytest

from ufmt.machining.damping import DampedModes
from ufmt.machining.periodic_path import periodic_coordinates
from ufmt.machining.recurrence import pole_recurrence

N = 60
DT = 1e-4  # [s]


def _poles():
    """Complex poles [1/s] from light to heavy damping, one slow enough that the periodic
    closure 1 / (1 - E^N) matters (|E^N| ~ 0.95)."""
    omega = 2 * np.pi * np.array([30.0, 400.0, 1200.0, 3000.0])
    zeta = np.array([0.05, 0.02, 0.3, 0.05])
    return -zeta * omega + 1j * omega * np.sqrt(1 - zeta**2)


def _run_force(first, a, seed=0):
    """Complex input (m, N) zero outside the circular run of a samples from ``first``."""
    rng = np.random.default_rng(seed)
    active = np.zeros(N, bool)
    active[(first + np.arange(a)) % N] = True
    force = np.where(active, rng.normal(size=(4, N)) + 1j * rng.normal(size=(4, N)), 0.0)
    return force, active


def _impulse_sum(recurrence, force, active):
    """z_j = sum over the run's samples m of the periodic impulse response at lag j - m."""
    run = np.flatnonzero(active)
    lags = np.mod(np.arange(N)[:, None] - run[None, :], N)  # (N, A)
    return np.einsum("sjm,sm->sj", recurrence.impulse(lags), force[:, run])


def _time_stepped(recurrence, force, periods):
    """The recurrence z_k = E z_(k-1) + b0 f_k + b1 f_(k-1) stepped from rest over
    ``periods`` periods, one sample at a time; the last period."""
    e, b0, b1 = recurrence.e, recurrence.b0, recurrence.b1
    z = np.zeros(force.shape[0], complex)
    previous = force[:, -1] * 0
    out = np.empty(force.shape, complex)
    for _ in range(periods):
        for k in range(N):
            z = e * z + b0 * force[:, k] + b1 * previous
            previous = force[:, k]
            out[:, k] = z
    return out


@pytest.mark.parametrize(("first", "a"), [(0, 1), (5, 9), (50, 17), (31, 29), (1, 58)])
def test_periodic_state_equals_the_impulse_sum(first, a):
    recurrence = pole_recurrence(_poles(), DT, N)
    force, active = _run_force(first, a)
    fast = periodic_coordinates(recurrence, force, active)
    oracle = _impulse_sum(recurrence, force, active)
    np.testing.assert_allclose(fast, oracle, rtol=1e-12, atol=1e-12 * np.abs(oracle).max())


def test_periodic_state_equals_time_stepping_to_periodicity():
    recurrence = pole_recurrence(_poles(), DT, N)
    decay = np.abs(recurrence.period).max()
    periods = int(np.ceil(np.log(1e-17) / np.log(decay)))  # transient below rounding
    assert 20 < periods < 2000
    force, active = _run_force(47, 21, seed=3)  # the run wraps around sample 0
    stepped = _time_stepped(recurrence, force, periods)
    fast = periodic_coordinates(recurrence, force, active)
    np.testing.assert_allclose(fast, stepped, rtol=1e-11, atol=1e-11 * np.abs(stepped).max())
    # one more period changes nothing: the stepped reference is periodic
    later = _time_stepped(recurrence, force, periods + 1)
    np.testing.assert_allclose(later, stepped, rtol=1e-12, atol=1e-12 * np.abs(stepped).max())


@pytest.mark.parametrize("a", [1, 2, 4, 5, 16, 17, 59])
def test_state_from_rest_equals_the_stepped_recurrence(a):
    """Every block layout (B = 1, a perfect square, one more, A = N - 1)."""
    recurrence = pole_recurrence(_poles(), DT, N)
    rng = np.random.default_rng(a)
    f = rng.normal(size=(4, a)) + 1j * rng.normal(size=(4, a))
    z, previous = np.zeros(4, complex), np.zeros(4)
    stepped = np.empty((4, a), complex)
    for k in range(a):
        z = recurrence.e * z + recurrence.b0 * f[:, k] + recurrence.b1 * previous
        previous = f[:, k]
        stepped[:, k] = z
    fast = recurrence.from_rest(f)
    np.testing.assert_allclose(fast, stepped, rtol=1e-12, atol=1e-13 * np.abs(stepped).max())


def test_projected_motion_of_complex_modes_equals_the_formed_coordinates():
    """DampedModes.projected against q = 2 Re(P z), q' = 2 Re(P Lambda z) and
    q'' = f - D q' - Omega^2 q formed explicitly."""
    rng = np.random.default_rng(7)
    n = 5
    omega = 2 * np.pi * np.linspace(100.0, 900.0, n)
    damping = np.diag(2 * 0.02 * omega) + 0.3 * omega[0] * rng.uniform(0.0, 1.0, (n, n))
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-np.diag(omega**2), -damping]])
    lam, vectors = np.linalg.eig(a)
    keep = np.flatnonzero(lam.imag > 0)
    assert keep.size == n  # underdamped: conjugate pairs
    modes = DampedModes(
        lam[keep], np.linalg.inv(vectors)[keep, n:], vectors[:n, keep], damping, omega
    )
    z = rng.normal(size=(n, 40)) + 1j * rng.normal(size=(n, 40))
    force = rng.normal(size=(n, 40))
    on_q, on_qd, on_qdd = (rng.normal(size=(n, k)) for k in (4, 2, 3))
    q = 2 * (modes.outputs @ z).real
    qd = 2 * (modes.outputs @ (modes.poles[:, None] * z)).real
    qdd = force - damping @ qd - (omega**2)[:, None] * q
    for got, want in zip(
        modes.projected(z, force, on_q, on_qd, on_qdd),
        (q.T @ on_q, qd.T @ on_qd, qdd.T @ on_qdd),
        strict=True,
    ):
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())
