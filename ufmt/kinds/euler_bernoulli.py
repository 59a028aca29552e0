"""Bending of an Euler-Bernoulli beam in one plane (paper eq. 3.3): its exact transfer matrix,
exact dynamic stiffness and clamped-clamped count, and its finite element with the mesh's
element length rule.

One bending plane in the beam's local axes, the x1-y plane's state ``[v, θ, m, q]`` with
``θ = v'``, ``m = EI v''``, ``q = EI v'''`` (the x1-z plane is the same with the signs of θ and
m flipped: :data:`ufmt.kinds.beam.PLANE_SIGNS`); β⁴ = ρAω²/EI. The transfer matrix is written
with the Krylov-Duncan functions of βL, the dynamic stiffness on the end motions
``[v₁, θ₁, v₂, θ₂]`` with the scaled functions of λ = βL below; both are power series in
λ⁴ for λ < 2 (no cancellation as ω → 0), closed forms above. The clamped-clamped count is
Williams and Wittrick's closed form.
"""

from __future__ import annotations

import math

import numpy as np

# S, T/x, U/x², V/x³ = Σ_k x⁴ᵏ / (4k + j)!, j = 0..3; 12 terms: 16¹²/48! is below eps
_KRYLOV_SERIES = 1.0 / np.array(
    [[math.factorial(4 * k + j) for j in range(4)] for k in range(12)], dtype=float
)
SERIES_TERMS = 12  # (4·16)¹² / 48! is far below eps: the series in λ⁴ for λ⁴ < 16
SERIES_BELOW = 16.0  # λ⁴ below which the power series are used
ERROR_DIVISOR = 1440.0  # cubic Hermite, consistent mass: df/f ~= (βh)⁴ / ERROR_DIVISOR
# a bending member's 4x4 on [v₁, θ₁, v₂, θ₂] per term (k11, k12, k13, k14, k22, k24): its
# entries (row, column, sign), for either theory (a symmetric prismatic member)
ENTRIES = (
    ((0, 0, 1), (2, 2, 1)),
    ((0, 1, 1), (1, 0, 1), (2, 3, -1), (3, 2, -1)),
    ((0, 2, 1), (2, 0, 1)),
    ((0, 3, 1), (3, 0, 1), (1, 2, -1), (2, 1, -1)),
    ((1, 1, 1), (3, 3, 1)),
    ((1, 3, 1), (3, 1, 1)),
)
#: where each term (k11, k12, k13, k14, k22, k24) sits in a 4x4 member matrix
TERM_PLACES = ([0, 0, 0, 0, 1, 1], [0, 1, 2, 3, 1, 3])


class Plane:
    """One bending plane of an Euler-Bernoulli beam: EI [N m²], ρA [kg/m]; no rotary inertia
    (``rho_i`` 0)."""

    rho_i = 0.0

    def __init__(self, ei: float, rho_a: float):
        self.ei, self.rho_a = ei, rho_a
        self.key = (ei, rho_a)  # equal keys: equal formulations

    def transfer(self, w2: np.ndarray, length, motion_only: bool = False) -> np.ndarray:
        """Transfer matrix (n, 4, 4) of ``[v, θ, m, q]`` over ``length`` [m] (scalar or one per
        ω) at ω² ``w2`` [rad²/s²]; ``motion_only``: its rows of v and θ, (n, 2, 4)."""
        w2 = np.asarray(w2, dtype=float)
        ei, L = self.ei, length
        lam4 = self.rho_a * w2 / ei
        s, t, uu, v = _krylov_scaled(lam4 * L**4)
        T_l, U_l2, V_l3 = L * t, L**2 * uu, L**3 * v  # T/λ, U/λ², V/λ³
        lV = lam4 * V_l3  # λV
        rows = [s, T_l, U_l2 / ei, V_l3 / ei, lV, s, T_l / ei, U_l2 / ei]
        if not motion_only:
            l2U, l3T = lam4 * U_l2, lam4 * T_l  # λ²U, λ³T
            rows += [ei * l2U, ei * lV, s, T_l, ei * l3T, ei * l2U, lV, s]
        return np.stack(rows, axis=-1).reshape(w2.size, -1, 4)

    def stiffness(self, omega, length: float) -> np.ndarray:
        """Exact dynamic stiffness (n, 4, 4) on ``[v₁, θ₁, v₂, θ₂]`` of a member of ``length``
        [m] at ω [rad/s] (end forces and moments on the member)."""
        terms = Planes([(self, length)]).terms(omega)
        out = np.zeros((terms.shape[0], 4, 4))
        for column, places in enumerate(ENTRIES):
            for a, b, sign in places:
                out[:, a, b] = sign * terms[:, column]
        return out

    def clamped(self, omega, length: float) -> np.ndarray:
        """J₀ (n,): the member's clamped-clamped frequencies below ω [rad/s]."""
        return Planes([(self, length)]).clamped(omega)

    def element(self, h: float) -> tuple[np.ndarray, np.ndarray]:
        """Stiffness and consistent mass (4, 4) of a cubic Hermite element of length ``h`` [m]
        on ``[v₁, θ₁, v₂, θ₂]``."""
        k = np.array(
            [
                [12.0, 6 * h, -12.0, 6 * h],
                [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                [-12.0, -6 * h, 12.0, -6 * h],
                [6 * h, 2 * h * h, -6 * h, 4 * h * h],
            ]
        )
        m = np.array(
            [
                [156.0, 22 * h, 54.0, -13 * h],
                [22 * h, 4 * h * h, 13 * h, -3 * h * h],
                [54.0, 13 * h, 156.0, -22 * h],
                [-13 * h, -3 * h * h, -22 * h, 4 * h * h],
            ]
        )
        return self.ei * (k / h**3), m * (self.rho_a * h / 420.0)

    def wavenumber(self, omega):
        """β [1/m] at ω [rad/s]: (ρAω²/EI)^¼."""
        return (np.asarray(omega, dtype=float) ** 2 * self.rho_a / self.ei) ** 0.25

    def mesh_error(self, omega: float, h: float) -> float:
        """Estimated relative frequency error of a mode at ω [rad/s] on elements of ``h`` [m]:
        (βh)⁴ / ERROR_DIVISOR (Rayleigh-Ritz: from above)."""
        return (self.wavenumber(omega) * h) ** 4 / ERROR_DIVISOR

    def element_length(self, omega: float, rtol: float) -> float:
        """The longest element [m] with :meth:`mesh_error` <= ``rtol`` at ω [rad/s]."""
        beta = self.wavenumber(omega)
        return (ERROR_DIVISOR * rtol) ** 0.25 / beta if beta > 0 else math.inf


def planes(beam) -> tuple[Plane, Plane]:
    """The x1-y (I_z) and x1-z (I_y) bending planes of ``beam``."""
    rho_a = beam.density * beam.area
    return tuple(
        Plane(beam.youngs_modulus * i, rho_a) for i in (beam.second_moment_z, beam.second_moment_y)
    )


def _krylov_scaled(x4: np.ndarray):
    """Entire Krylov-Duncan functions in terms of x⁴ = (λL)⁴, stable for all x ≥ 0.

    Returns s, t, u, v with S(x) = s, T(x)/x = t, U(x)/x² = u, V(x)/x³ = v, where
    S = (cosh+cos)/2, T = (sinh+sin)/2, U = (cosh-cos)/2, V = (sinh-sin)/2.
    A power series in x⁴ is used below x = 2 (no cancellation), closed forms above.
    """
    x4 = np.asarray(x4, dtype=float)
    big = ~(x4 < 16.0)
    series = np.empty((4, *x4.shape))
    if not big.all():  # Horner in x⁴, all four at once (the function first: long loops)
        terms = _KRYLOV_SERIES.reshape(*_KRYLOV_SERIES.shape, *(1,) * x4.ndim)
        xs = np.where(big, 0.0, x4)
        series[:] = terms[-1]
        for coefficients in terms[-2::-1]:
            series *= xs
            series += coefficients
    s, t, u, v = series
    if big.any():
        x = np.sqrt(np.sqrt(x4[big]))
        ch, c, sh, sn = np.cosh(x), np.cos(x), np.sinh(x), np.sin(x)
        s[big] = (ch + c) / 2
        t[big] = (sh + sn) / 2 / x
        u[big] = (ch - c) / 2 / x**2
        v[big] = (sh - sn) / 2 / x**3
    return s, t, u, v


def _series_table() -> np.ndarray:
    """Coefficients (7, SERIES_TERMS) of the seven scaled functions as series in λ⁴ (rows as
    in :func:`_bending_functions`), from cos λ cosh λ = Σ (-4)ᵏ λ⁴ᵏ/(4k)! and its relatives."""
    k = np.arange(SERIES_TERMS)
    f = np.array([[1.0 / math.factorial(4 * i + j) for j in range(4)] for i in k])
    alt = (-4.0) ** k
    shifted = np.r_[alt[1:], 0.0]  # δ/λ⁴ = -Σ_{k≥1} (-4)ᵏ λ⁴⁽ᵏ⁻¹⁾/(4k)!
    delta = -shifted * np.r_[f[1:, 0], 0.0]
    return np.array(
        [
            delta,  # (1 - cos λ cosh λ) / λ⁴
            2 * alt * f[:, 1],  # (sin λ cosh λ + cos λ sinh λ) / λ
            4 * alt * f[:, 3],  # (sin λ cosh λ - cos λ sinh λ) / λ³
            2 * alt * f[:, 2],  # sin λ sinh λ / λ²
            2 * f[:, 2],  # (cosh λ - cos λ) / λ²
            2 * f[:, 1],  # (sinh λ + sin λ) / λ
            2 * f[:, 3],  # (sinh λ - sin λ) / λ³
        ]
    )


_SERIES = _series_table()
_HORNER = np.ascontiguousarray(_SERIES.T[::-1, :, None])  # (terms, 7, 1): highest power first


def _bending_functions(lam4: np.ndarray) -> np.ndarray:
    """The seven scaled functions of λ (rows of :func:`_series_table`) at λ⁴ = ``lam4``,
    (7, n): entire functions of λ⁴, stable from λ = 0."""
    lam4 = np.asarray(lam4, dtype=float)
    small = lam4 < SERIES_BELOW
    out = np.zeros((7, lam4.size))
    if np.any(small):  # (the series costs as much as a J evaluation's LDLᵀ: only if used)
        x4 = np.where(small, lam4, 0.0)
        for coefficients in _HORNER:  # Horner in λ⁴ (in place)
            out *= x4
            out += coefficients
    if not small.all():
        large = ~small
        x = np.sqrt(np.sqrt(lam4[large]))
        c, s, ch, sh = np.cos(x), np.sin(x), np.cosh(x), np.sinh(x)
        x2 = x**2
        x3 = x**3
        out[0, large] = (1 - c * ch) / x**4
        out[1, large] = (s * ch + c * sh) / x
        out[2, large] = (s * ch - c * sh) / x3
        out[3, large] = s * sh / x2
        out[4, large] = (ch - c) / x2
        out[5, large] = (sh + s) / x
        out[6, large] = (sh - s) / x3
    return out


class Planes:
    """Many Euler-Bernoulli bending members (``(Plane, length)`` pairs) at once: the terms of
    their exact dynamic stiffness and their clamped-clamped count, a few array operations for
    all of them. Per member EI·(k11, k12, k13, k14, k22, k24)/(δLᵖ) (:data:`ENTRIES`)."""

    ENTRIES = ENTRIES

    def __init__(self, members):
        self.members = list(members)
        table = np.array(
            [(p.ei, p.rho_a, length) for p, length in self.members], dtype=float
        ).reshape(-1, 3)
        self._table = table  # (EI, ρA, L)
        length = table[:, 2]
        self._length4 = length**4
        # per term (k11, k12, k13, k14, k22, k24): its power of L, f's row and sign
        self._powers = np.array([length**3, length**2, length**3, length**2, length, length])
        self._rows, self._signs = [1, 3, 5, 4, 2, 6], np.array([1, 1, -1, 1, 1, 1.0])

    def terms(self, omega) -> np.ndarray:
        """Terms (len(ω), 6 per member) at ω [rad/s]."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))[:, None]
        ei, rho_a, _ = self._table.T
        lam4 = rho_a * omega**2 / ei * self._length4
        f = _bending_functions(lam4.ravel()).reshape(7, *lam4.shape)
        # EI f / (δ Lᵖ) for f = (a1, p2, -t1, u2, a3, v3), (6, len(ω), m)
        bend = ei * (f[self._rows] * self._signs[:, None, None])
        bend /= f[0] * self._powers[:, None, :]
        return bend.transpose(1, 2, 0).reshape(omega.size, -1)

    def clamped(self, omega) -> np.ndarray:
        """J₀ (len(ω),): i - (1 - (-1)ⁱ sgn δ)/2 per member with i = ⌊λ/π⌋ and
        δ = 1 - cos λ cosh λ (Williams and Wittrick's closed form), summed."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))[:, None]
        ei, rho_a, _ = self._table.T
        lam = np.sqrt(np.sqrt(rho_a * omega**2 / ei * self._length4))
        i = np.floor(lam / np.pi).astype(int)
        # δ = λ⁴/6 + ... > 0 below λ = 2 (the first zero is at 4.73): the closed form above
        with np.errstate(over="ignore"):
            sign = np.where(lam < 2.0, 1.0, np.sign(1.0 - np.cos(lam) * np.cosh(lam)))
        return (i - np.rint((1 - (-1.0) ** i * sign) / 2).astype(int)).sum(axis=1)


Plane.STACK = Planes
