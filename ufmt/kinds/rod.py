"""A prismatic rod, axial or in torsion (the beam's u'' + β²u = 0 parts of paper eq. 3.3): its
exact transfer matrix, exact dynamic stiffness and clamped-clamped count, and its finite
element with the mesh's element length rule.

State ``[u, q]`` (displacement or twist, and the end force or moment) with ``q = sign · k u'``:
the MSTMM's axial state has ``q = -N`` (sign -1), its torsion ``m = +GJ θ'`` (sign +1);
β² = μω²/k with k the rigidity (EA [N] or GJ [N m²]) and μ the inertia per length (ρA [kg/m]
or ρI_p [kg m]). The member and the element act on the end motions ``[u₁, u₂]``.
"""

from __future__ import annotations

import math

import numpy as np

# a member's 2x2 per term (f cos βL, -f): its entries (row, column, sign)
ENTRIES = (((0, 0, 1), (1, 1, 1)), ((0, 1, 1), (1, 0, 1)))
ERROR_DIVISOR = 24.0  # linear element, consistent mass: df/f ~= (βh)² / ERROR_DIVISOR
_UNIT = np.array([[1.0, -1.0], [-1.0, 1.0]])
_MASS = np.array([[2.0, 1.0], [1.0, 2.0]])


class Rod:
    """An axial or torsional rod: rigidity k (EA [N] or GJ [N m²]), inertia μ per length
    [kg/m or kg m], the sign of its force in the transfer state (module docstring)."""

    def __init__(self, rigidity: float, inertia: float, sign: float):
        self.rigidity, self.inertia, self.sign = rigidity, inertia, sign
        self.key = (rigidity, inertia, sign)  # equal keys: equal formulations

    def transfer(self, w2: np.ndarray, length, motion_only: bool = False) -> np.ndarray:
        """Transfer matrix (n, 2, 2) of ``[u, q]`` over ``length`` [m] (scalar or one per ω)
        at ω² ``w2`` [rad²/s²]; ``motion_only``: its displacement row only, (n, 1, 2)."""
        k = self.rigidity
        c, sl, bs = _waves(np.asarray(w2, dtype=float), k, self.inertia, length)
        rows = [c, self.sign * sl / k]
        if not motion_only:
            rows += [-self.sign * k * bs, c]
        return np.stack(rows, axis=-1).reshape(c.size, -1, 2)

    def stiffness(self, omega, length: float) -> np.ndarray:
        """Exact dynamic stiffness (n, 2, 2) on ``[u₁, u₂]`` at ω [rad/s] (end forces on the
        member)."""
        terms = Rods([(self, length)]).terms(omega)
        return _matrix(terms, ENTRIES, 2)

    def clamped(self, omega, length: float) -> np.ndarray:
        """J₀ (n,): the clamped-clamped frequencies below ω [rad/s], ⌊βL/π⌋."""
        return Rods([(self, length)]).clamped(omega)

    def element(self, h: float) -> tuple[np.ndarray, np.ndarray]:
        """Stiffness and consistent mass (2, 2) of a linear element of length ``h`` [m]."""
        return self.rigidity / h * _UNIT, self.inertia * (_MASS * h / 6.0)

    def wavenumber(self, omega):
        """β [1/m] at ω [rad/s]."""
        return np.asarray(omega, dtype=float) * math.sqrt(self.inertia / self.rigidity)

    def mesh_error(self, omega: float, h: float) -> float:
        """Estimated relative frequency error of a mode at ω [rad/s] on elements of ``h`` [m]:
        (βh)² / ERROR_DIVISOR (Rayleigh-Ritz: from above)."""
        return (self.wavenumber(omega) * h) ** 2 / ERROR_DIVISOR

    def element_length(self, omega: float, rtol: float) -> float:
        """The longest element [m] with :meth:`mesh_error` <= ``rtol`` at ω [rad/s]."""
        beta = self.wavenumber(omega)
        return math.sqrt(ERROR_DIVISOR * rtol) / beta if beta > 0 else math.inf


def _waves(w2: np.ndarray, stiffness, inertia, length):
    """cos(βL), sin(βL)/β, β sin(βL) for u'' + β²u = 0, β² = μω²/k, stable at β → 0."""
    b2 = w2 * inertia / stiffness
    bl = np.sqrt(b2) * length
    sinc = np.sinc(bl / np.pi)  # sin(βL)/(βL)
    return np.cos(bl), length * sinc, b2 * length * sinc


def _matrix(terms: np.ndarray, entries, size: int) -> np.ndarray:
    """(n, size, size) from one member's terms (n, t) and each term's entries."""
    out = np.zeros((terms.shape[0], size, size))
    for column, places in enumerate(entries):
        for a, b, s in places:
            out[:, a, b] = s * terms[:, column]
    return out


class Rods:
    """Many rods (``(Rod, length)`` pairs) at once: the terms of their exact dynamic stiffness
    and their clamped-clamped count, a few array operations for all of them."""

    ENTRIES = ENTRIES

    def __init__(self, members):
        self.members = list(members)
        table = np.array(
            [(r.rigidity, r.inertia, length) for r, length in self.members], dtype=float
        ).reshape(-1, 3)
        self._stiffness, inertia, self._length = table.T
        self._slowness = np.sqrt(inertia / self._stiffness)  # β/ω [s/m]

    def terms(self, omega) -> np.ndarray:
        """Terms (len(ω), 2 per rod) at ω [rad/s]: f cos βL and -f, f = (k/L) βL/sin βL."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))[:, None]
        k, length = self._stiffness, self._length
        kl = omega * self._slowness * length
        factor = k / (length * np.sinc(kl / np.pi))
        return np.stack([factor * np.cos(kl), -factor], axis=-1).reshape(omega.size, -1)

    def clamped(self, omega) -> np.ndarray:
        """J₀ (len(ω),): the rods' clamped-clamped frequencies below ω [rad/s], Σ ⌊βL/π⌋."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))[:, None]
        kl = omega * self._slowness * self._length
        return np.floor(kl / np.pi).astype(int).sum(axis=1)


Rod.STACK = Rods
