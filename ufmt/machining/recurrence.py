"""Modal damping and the exact recurrence of the modal equations (paper eq. 3.11).

Each modal coordinate obeys q'' + 2 zeta w q' + w^2 q = f_s(t). The force is sampled at equal
steps and taken as piecewise linear between samples (first-order hold); for such a force the
solution is advanced exactly from sample to sample by a two-term recurrence of the complex
pole (:func:`discretise`). Both response paths use it: the time path as real filter
coefficients (:func:`real_recurrence`), the periodic path through its periodic steady state
(:func:`discrete_receptance` per harmonic, :class:`PeriodicRecurrence` per sample).

Structural modal damping (not part of the basis): ``DEFAULT_ZETA`` = 0.01 for every mode, the
damping of the bodies themselves (material, and joints inside a body that the model does not
resolve). Modal damping ratios measured on precision machine structures with bolted and
aerostatic joints lie around 0.01-0.05, most of it in the joints; the model's joints are its
hinges, whose dampers carry that share (zeta 1-5 % per joint, docs/ufmt-model.md), so the
global ratio takes only the low end of the band (with 0.03 on top of the hinges the packaged
modes reached 4-9 %, above what is measured). A per-mode array overrides it. The model's hinge
dampers add to it and couple the modes (:mod:`ufmt.machining.damping`); their complex modes use
the same recurrence with a unit input weight (:func:`discretise_poles`, :func:`pole_transfer`,
:func:`pole_recurrence`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ufmt.model.machine import OPTIONAL_FIELDS

#: the default of ``[machine] modal_damping_ratio`` (:mod:`ufmt.model.machine`)
DEFAULT_ZETA = OPTIONAL_FIELDS["modal_damping_ratio"][0]
#: Bytes [B] of one (modes, samples) complex array of a block of modes
#: (:meth:`PeriodicRecurrence.from_rest`; its temporaries are a few such arrays).
MODE_BLOCK_BYTES = 2**22


def modal_damping(zeta, n_modes: int) -> np.ndarray:
    """Per-mode damping ratios (n,) from a scalar or an (n,) array; each must be in (0, 1)."""
    z = np.broadcast_to(np.asarray(zeta, dtype=float), (n_modes,)).copy()
    if not np.all((z > 0) & (z < 1)):
        raise ValueError(f"modal damping ratios must lie in (0, 1), got {zeta!r}")
    return z


def _phi1_phi2(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """phi1 = (e^x - 1)/x and phi2 = (e^x - 1 - x)/x^2 for complex x, stable at small |x|."""
    small = np.abs(x) < 0.1
    xs = np.where(small, 1.0, x)
    p1 = np.expm1(xs) / xs
    p2 = (p1 - 1.0) / xs
    if not small.any():
        return p1, p2
    t = np.where(small, x, 0.0)
    s1 = 1 + t / 2 + t**2 / 6 + t**3 / 24 + t**4 / 120 + t**5 / 720
    s2 = 0.5 + t / 6 + t**2 / 24 + t**3 / 120 + t**4 / 720 + t**5 / 5040
    return np.where(small, s1, p1), np.where(small, s2, p2)


def discretise(omega, zeta, dt: float):
    """Exact first-order-hold discretisation of q'' + 2 zeta w q' + w^2 q = f (eq. 3.11).

    With the pole lambda = -zeta w + i w_d and z' = lambda z + f / (2 i w_d), q = 2 Re z and
    q' = 2 Re(lambda z). For f linear between samples the exact recurrence is
    z_k = E z_{k-1} + b0 f_k + b1 f_{k-1}.

    Returns
    -------
    lam, E, b0, b1 : (n,) complex pole [1/s], e^(lambda dt), and input weights [s^2].
    """
    omega = np.asarray(omega, dtype=float)
    zeta = np.asarray(zeta, dtype=float)
    wd = omega * np.sqrt(1.0 - zeta**2)
    lam = -zeta * omega + 1j * wd
    return (lam, *_hold(lam, 1.0 / (2j * wd), dt))


def discretise_poles(poles, dt: float):
    """Exact first-order-hold discretisation of z' = lambda z + u for complex poles.

    The recurrence of :func:`discretise` with unit input weight: z_k = E z_{k-1} + b0 u_k +
    b1 u_{k-1} for u linear between samples (the complex modes of
    :mod:`ufmt.machining.damping`). Returns lam, E, b0, b1 (m,) [1/s, -, s, s].
    """
    lam = np.asarray(poles, dtype=complex)
    return (lam, *_hold(lam, 1.0, dt))


def _hold(lam: np.ndarray, weight, dt: float):
    """e^(lambda dt) and the first-order-hold input weights of z' = lambda z + weight u."""
    x = lam * dt
    p1, p2 = _phi1_phi2(x)
    return np.exp(x), weight * dt * p2, weight * dt * (p1 - p2)


def discrete_receptance(omega, zeta, dt: float, theta) -> tuple[np.ndarray, np.ndarray]:
    """Periodic steady-state transfer of the exact recurrence at angles theta = 2 pi k / N.

    Returns (H_q, H_v), each (n, K) complex [s^2, s]: the DFT of q (of q') over one period is
    H times the DFT of the sampled modal force. As dt -> 0 at fixed frequency, H_q tends to the
    modal receptance 1 / (w^2 - W^2 + 2 i zeta w W).
    """
    lam, e, b0, b1 = (a[:, None] for a in discretise(omega, zeta, dt))
    tf_p, tf_m = _hold_transfer(e, b0, b1, theta)
    return tf_p + np.conj(tf_m), lam * tf_p + np.conj(lam * tf_m)


def pole_transfer(poles, dt: float, theta) -> tuple[np.ndarray, np.ndarray]:
    """Periodic steady-state transfer of the unit-weight recurrence of
    :func:`discretise_poles` at angles theta = 2 pi k / N, and of its complex conjugate.

    Returns (T, T_conj), each (m, K) complex [s]: the DFT of z over one period is T times the
    DFT of the sampled input u; that of conj(z) under conj(u) is T_conj times the DFT of
    conj(u). For real modes (:func:`discrete_receptance`) H_q = weight T + conj(weight) T_conj.
    """
    _, e, b0, b1 = (a[:, None] for a in discretise_poles(poles, dt))
    tf_p, tf_m = _hold_transfer(e, b0, b1, theta)
    return tf_p, np.conj(tf_m)


def _hold_transfer(e, b0, b1, theta):
    """(b0 + b1 Z) / (1 - E Z) at Z = e^(-i theta) and at Z = e^(+i theta)."""
    zp = np.exp(-1j * np.asarray(theta, dtype=float))[None, :]
    zm = np.conj(zp)
    tf_p = (b0 + b1 * zp) / (1.0 - e * zp)
    tf_m = (b0 + b1 * zm) / (1.0 - e * zm)
    return tf_p, tf_m


@dataclass(frozen=True, eq=False)
class PeriodicRecurrence:
    """The exact recurrence (:func:`discretise`) over a period of N samples.

    lam, e, b0, b1 (n,) as :func:`discretise` returns them; E^l for l = B a + b is the product
    of two short tables of exponentials (B ~ sqrt(N)), ``blocks`` (n, ceil(N / B)) E^(B a) and
    ``steps`` (n, B) E^b, formed where read (:meth:`power`, :meth:`projected_powers`; the
    whole table ``powers`` (n, N) on first use); period (n,) E^N. Arrays read-only.
    """

    lam: np.ndarray
    e: np.ndarray
    b0: np.ndarray
    b1: np.ndarray
    blocks: np.ndarray
    steps: np.ndarray
    period: np.ndarray
    n_samples: int

    def power(self, lags) -> np.ndarray:
        """E^l (n, ...) at integer ``lags`` in 0..N - 1."""
        lags = np.asarray(lags)
        size = self.steps.shape[1]
        return self.blocks[:, lags // size] * self.steps[:, lags % size]

    @cached_property
    def powers(self) -> np.ndarray:
        """E^l (n, N) for l = 0..N - 1 (the products :meth:`power` forms; read-only)."""
        n = self.lam.size
        out = (self.blocks[:, :, None] * self.steps[:, None, :]).reshape(n, -1)[:, : self.n_samples]
        out.setflags(write=False)
        return out

    def projected_powers(self, weights: np.ndarray, length: int) -> np.ndarray:
        """2 Re sum_s E_s^l W[s, c] (length, k) for l = 0..length - 1 (length <= N) and complex
        weights W (n, k), without the (n, length) table: per block a of B lags one product of
        the steps E^b with the weights times E^(B a), all blocks in one real product (half the
        multiplications of a complex one, :func:`real_part_product`)."""
        n, k = weights.shape
        size = self.steps.shape[1]
        count = -(-length // size)
        scaled = (self.blocks[:, :count, None] * weights[:, None, :]).reshape(n, count * k)
        out = real_part_product(np.ascontiguousarray(self.steps.T), scaled)  # (B, count k)
        return out.reshape(size, count, k).transpose(1, 0, 2).reshape(-1, k)[:length]

    def impulse(self, lags) -> np.ndarray:
        """Complex state z_l (n, ...) at integer ``lags`` in 0..N - 1 of the periodic steady
        state under one unit force sample per period, at sample 0.

        z_l = (b0 E^l + b1 E^((l - 1) mod N)) / (1 - E^N); q = 2 Re z [s^2] and
        q' = 2 Re(lambda z) [s], whose DFTs over the period are :func:`discrete_receptance`'s
        H_q and H_v.
        """
        lags = np.asarray(lags)
        flat = lags.ravel()
        previous = self.power((flat - 1) % self.n_samples)  # E^(N - 1) before lag 0
        z = (self.b0[:, None] * self.power(flat) + self.b1[:, None] * previous) / (
            1.0 - self.period[:, None]
        )
        return z.reshape(-1, *lags.shape)

    def from_rest(self, force: np.ndarray) -> np.ndarray:
        """Complex state z (n, A) over A < N consecutive samples of the input ``force`` (n, A)
        (real or complex), from rest: z_k = E z_{k-1} + b0 f_k + b1 f_{k-1}, z_{-1} = f_{-1} = 0.

        The sum z_k = sum_(m <= k) E^(k - m) g_m (g_m = b0 f_m + b1 f_(m-1)) in blocks of
        B ~ sqrt(A) samples: inside each block one product with the triangle of E^(i - j), the
        blocks' end states by one product with the triangle of E^(B (b - b')), each carried
        into the next block by E^(i + 1): O(n A sqrt(A)), no loop over samples, every power
        one of :meth:`power` (no growing or inverse powers). A block of modes at a time (the
        triangles are n B^2 ~ n A complex each), every mode's arithmetic unchanged.
        """
        n, a = force.shape
        step = max(1, MODE_BLOCK_BYTES // (16 * a))
        if step >= n:
            return self._from_rest(force)
        out = np.empty((n, a), complex)
        for i in range(0, n, step):
            out[i : i + step] = self.subset(slice(i, i + step))._from_rest(force[i : i + step])
        return out

    def subset(self, modes: slice) -> PeriodicRecurrence:
        """The recurrence of the ``modes`` alone."""
        arrays = (self.lam, self.e, self.b0, self.b1, self.blocks, self.steps, self.period)
        return PeriodicRecurrence(*(x[modes] for x in arrays), self.n_samples)

    def _from_rest(self, force: np.ndarray) -> np.ndarray:
        """:meth:`from_rest` of all modes at once."""
        n, a = force.shape
        g = self.b0[:, None] * force
        g[:, 1:] += self.b1[:, None] * force[:, :-1]
        size = math.isqrt(max(a - 1, 0)) + 1  # B; B (blocks - 1) < A < N
        blocks = -(-a // size)
        padded = np.zeros((n, blocks * size), complex)
        padded[:, :a] = g
        local = np.matmul(padded.reshape(n, blocks, size), self._triangle(size, 1))
        ends = np.matmul(local[:, None, :, -1], self._triangle(blocks, size))[:, 0, :-1]
        local[:, 1:] += ends[:, :, None] * self.power(np.arange(1, size + 1))[:, None, :]
        return local.reshape(n, -1)[:, :a]

    def _triangle(self, size: int, step: int) -> np.ndarray:
        """(n, size, size) with E^(step (i - j)) at [i, j] for i >= j and 0 above, transposed
        (the right factor of a product along the last axis)."""
        lag = np.subtract.outer(np.arange(size), np.arange(size))
        upper = np.where(lag >= 0, self.power(step * np.maximum(lag, 0)), 0.0)
        return upper.transpose(0, 2, 1)


def real_part_product(x: np.ndarray, w: np.ndarray) -> np.ndarray:
    """2 Re(x w) (T, k) of complex x (T, n) and w (n, k): one real product of x's real and
    imaginary parts as they lie in memory (interleaved, (T, 2 n)) with the rows of Re w and
    -Im w interleaved (2 n, k)."""
    x = np.ascontiguousarray(x, dtype=complex)
    stacked = np.empty((2 * w.shape[0], w.shape[1]))
    stacked[0::2], stacked[1::2] = w.real, -w.imag
    return 2 * (x.view(float) @ stacked)


def periodic_recurrence(omega, zeta, dt: float, n_samples: int) -> PeriodicRecurrence:
    """:class:`PeriodicRecurrence` of modes ``omega`` [rad/s], ``zeta``, step ``dt`` [s] over
    ``n_samples`` samples."""
    return _periodic(discretise(omega, zeta, dt), dt, n_samples)


def pole_recurrence(poles, dt: float, n_samples: int) -> PeriodicRecurrence:
    """:class:`PeriodicRecurrence` of the unit-weight recurrence of :func:`discretise_poles`
    (complex poles [1/s], step ``dt`` [s]) over ``n_samples`` samples."""
    return _periodic(discretise_poles(poles, dt), dt, n_samples)


def _periodic(discrete, dt: float, n_samples: int) -> PeriodicRecurrence:
    """:class:`PeriodicRecurrence` of a discretisation (lam, E, b0, b1); its arrays read-only."""
    lam, e, b0, b1 = discrete
    step = math.isqrt(n_samples - 1) + 1
    steps = np.exp(np.outer(lam, dt * np.arange(step)))
    blocks = np.exp(np.outer(lam, dt * step * np.arange(-(-n_samples // step))))
    out = PeriodicRecurrence(
        lam, e, b0, b1, blocks, steps, np.exp(lam * (dt * n_samples)), n_samples
    )
    for a in (lam, e, b0, b1, blocks, steps, out.period):
        a.setflags(write=False)
    return out


def real_recurrence(omega, zeta, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """The recurrence of :func:`discretise` for q itself, as real filter coefficients.

    q_k = b[0] f_k + b[1] f_{k-1} + b[2] f_{k-2} - a[1] q_{k-1} - a[2] q_{k-2}
    (``scipy.signal.lfilter(b, a, f)`` form). Returns (b, a), each (n, 3).
    """
    _, e, b0, b1 = discretise(omega, zeta, dt)
    ec = np.conj(e)
    num = np.stack([2 * b0.real, 2 * (b1 - b0 * ec).real, -2 * (b1 * ec).real], axis=1)
    den = np.stack([np.ones_like(e.real), -2 * e.real, np.abs(e) ** 2], axis=1)
    return num, den
