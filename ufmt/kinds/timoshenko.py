"""Bending of a Timoshenko beam (shear deformation and rotary inertia) in one plane: its exact
transfer matrix, exact dynamic stiffness and clamped-clamped count, and its finite element with
the mesh's element length rule (the interface of :class:`ufmt.kinds.euler_bernoulli.Plane`).

One bending plane in the beam's local axes, the state ``[v, θ, m, q]`` of the Euler-Bernoulli
plane of :mod:`ufmt.kinds.euler_bernoulli` (x1-y plane: v, θz, mz, qy), θ now the
rotation of the section: ``v' = θ - q/(κGA)``, ``θ' = m/EI``, ``m' = q - ρIω²θ``,
``q' = ρAω² v`` (Timoshenko 1921; the x1-z plane is the same with the signs of θ and m
flipped). κGA → ∞ and ρI → 0 give the Euler-Bernoulli plane. The transfer matrix is the
exponential of that first-order system over the length, computed in scaled variables
(``[v/L, θ, mL/EI, qL²/EI]``) by scaling and squaring of its Taylor series, batched over ω.

The dynamic stiffness and the clamped-clamped count J₀(ω) (the member frequencies with both
ends clamped below ω, which the Wittrick-Williams count adds to s{K}) come from 2ᵖ equal
pieces joined pairwise: each piece's stiffness from its transfer matrix, two joined pieces'
by condensing their middle node, whose 2x2 stiffness adds its negative eigenvalues to the
count (J₀(2ℓ) = 2 J₀(ℓ) + s{K_mm}: the Wittrick-Williams count of the two pieces clamped at
their outer ends). Short pieces keep the stiffness accurate where the transfer matrix of a
long member would lose digits to its growing waves, and start the count at zero: a piece
of length ℓ has no clamped-clamped frequency below ω when ω² is below the lower bound of
:meth:`Plane.lowest_clamped`; the pieces are chosen with half of it.

The shear coefficient of a circular section by default: Cowper (1966), "The shear
coefficient in Timoshenko's beam theory", J. Appl. Mech. 33, 335-340, Table 1:
solid ``6(1+ν)/(7+6ν)``, hollow (m = inner/outer diameter)
``6(1+ν)(1+m²)² / ((7+6ν)(1+m²)² + (20+12ν)m²)``.
"""

from __future__ import annotations

import math

import numpy as np

from ufmt.kinds.euler_bernoulli import ENTRIES, TERM_PLACES

TAYLOR_TERMS = 14  # ‖Â/2ˢ‖ ≤ 1/2: the remainder (1/2)¹⁵/15! is below eps/10
PIECE_MARGIN = 0.5  # pieces of the count: ω² below this fraction of the bound below
MAX_HALVINGS = 40  # pieces down to 2⁻⁴⁰ of the member (far beyond any frequency asked)
MAX_KH = 0.5 * math.pi  # elements up to a quarter wavelength: the mesh error's domain
BISECTIONS = 60  # of the element length: 2⁻⁶⁰ of the longest, below rounding
_END_SIGNS = np.array([1.0, -1.0, -1.0, 1.0])


def cowper_circle(poisson: float, ratio: float = 0.0) -> float:
    """Shear coefficient κ of a solid (``ratio`` 0) or hollow circle (``ratio`` = inner /
    outer diameter) of Poisson's ratio ``poisson`` (Cowper 1966, Table 1)."""
    m2 = ratio * ratio
    p = (1.0 + m2) ** 2
    return 6.0 * (1.0 + poisson) * p / ((7.0 + 6.0 * poisson) * p + (20.0 + 12.0 * poisson) * m2)


class Plane:
    """One bending plane of a Timoshenko beam: EI [N m²], ρA [kg/m], ρI [kg m], κGA [N]."""

    def __init__(self, ei: float, rho_a: float, rho_i: float, kga: float):
        self.ei, self.rho_a, self.rho_i, self.kga = ei, rho_a, rho_i, kga
        self.key = (ei, rho_a, rho_i, kga)  # equal keys: equal formulations

    def scaled_system(self, w2: np.ndarray, length) -> np.ndarray:
        """Â (n, 4, 4): the first-order system times the length in the variables scaled by
        :meth:`scales` (a zero length gives Â = 0: the identity transfer)."""
        w2 = np.asarray(w2, dtype=float)
        length = np.broadcast_to(np.asarray(length, dtype=float), w2.shape)
        s = _scale_length(length)
        a = np.zeros((w2.size, 4, 4))
        a[:, 0, 1] = a[:, 1, 2] = a[:, 2, 3] = length / s
        a[:, 0, 3] = -self.ei * length / (self.kga * s**3)
        a[:, 2, 1] = -self.rho_i * w2 * s * length / self.ei
        a[:, 3, 0] = self.rho_a * w2 * s**3 * length / self.ei
        return a

    def scales(self, length) -> np.ndarray:
        """The state scales (n, 4): ``[s, 1, EI/s, EI/s²]``, s the length (1 m where it is 0)
        (the state is scales × scaled)."""
        s = _scale_length(np.atleast_1d(np.asarray(length, dtype=float)))
        return np.stack([s, np.ones_like(s), self.ei / s, self.ei / s**2], axis=-1)

    def transfer(self, w2: np.ndarray, length, motion_only: bool = False) -> np.ndarray:
        """Transfer matrix (n, 4, 4) of ``[v, θ, m, q]`` over ``length`` [m] (scalar or one per
        ω, 0 allowed) at ω² ``w2`` [rad²/s²] (module docstring); ``motion_only``: its rows of
        v and θ, (n, 2, 4)."""
        w2 = np.atleast_1d(np.asarray(w2, dtype=float))
        length = np.broadcast_to(np.asarray(length, dtype=float), w2.shape)
        d = self.scales(length)
        t = d[:, :, None] * expm_batched(self.scaled_system(w2, length)) / d[:, None, :]
        return t[:, :2] if motion_only else t

    def stiffness(self, omega, length: float) -> np.ndarray:
        """Exact dynamic stiffness (n, 4, 4) on the end motions ``[v₁, θ₁, v₂, θ₂]`` of a member
        of ``length`` [m] at ω [rad/s], in the sign convention of
        :mod:`ufmt.mstmm.members` (end forces and moments on the member)."""
        return self._halved(omega, length)[0]

    def clamped(self, omega, length: float) -> np.ndarray:
        """J₀ (n,): the member's clamped-clamped frequencies below ω [rad/s]."""
        return self._halved(omega, length)[1]

    def _halved(self, omega, length: float) -> tuple[np.ndarray, np.ndarray]:
        """(dynamic stiffness (n, 4, 4), J₀ (n,)) of the member as 2ᵖ equal pieces joined
        pairwise (module docstring): each piece has no clamped-clamped frequency below ω and
        is at most a radian of the bending wave long (its transfer is accurate)."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        pieces = length / 2.0 ** np.arange(MAX_HALVINGS + 1)[:, None]  # (levels, 1)
        fine = (PIECE_MARGIN * self.lowest_clamped(pieces) > omega**2) & (
            self.wavenumber(omega) * pieces <= 1.0
        )
        levels = np.argmax(fine, axis=0)  # the fewest halvings that make the pieces fine
        k = np.empty((omega.size, 4, 4))
        count = np.zeros(omega.size, dtype=int)
        for p in np.unique(levels):
            at = np.flatnonzero(levels == p)
            k[at] = self._direct(omega[at], length / 2.0**p)
            for _ in range(p):
                k[at], negative = _joined(k[at])
                count[at] = 2 * count[at] + negative
        return k, count

    def _direct(self, omega: np.ndarray, length: float) -> np.ndarray:
        """:meth:`stiffness` from the transfer matrix of the whole ``length`` (accurate while
        its bending wave is short of a few radians over it)."""
        t = expm_batched(self.scaled_system(omega**2, np.full(omega.size, length)))
        t11, t12, t21, t22 = t[:, :2, :2], t[:, :2, 2:], t[:, 2:, :2], t[:, 2:, 2:]
        inv = np.linalg.inv(t12)  # scaled [m, q]₁ = t12⁻¹ ([v, θ]₂ - t11 [v, θ]₁)
        g = np.empty((omega.size, 4, 4))  # scaled [m₁, q₁, m₂, q₂] from [v₁, θ₁, v₂, θ₂]
        g[:, :2, :2], g[:, :2, 2:] = -inv @ t11, inv
        g[:, 2:, :2], g[:, 2:, 2:] = t21 - t22 @ inv @ t11, t22 @ inv
        force = np.array([1.0 / length, 1.0 / length**2] * 2) * self.ei
        motion = np.array([length, 1.0] * 2)
        g *= force[:, None] / motion[None, :]
        # end loads on the member [F₁, M₁, F₂, M₂] = [q₁, -m₁, -q₂, m₂]
        return g[:, [1, 0, 3, 2]] * _END_SIGNS[:, None]

    def element(self, h: float) -> tuple[np.ndarray, np.ndarray]:
        """Stiffness and consistent mass (4, 4) of a two-node element of length ``h`` [m] on
        ``[v₁, θ₁, v₂, θ₂]``: the interdependent-interpolation element (exact static
        stiffness; Przemieniecki 1968, Theory of Matrix Structural Analysis, sections 5.6 and
        11.5; its mass, consistent with that interpolation, in Friedman & Kosmatka 1993,
        Comput. Struct. 47, 473-481), φ = 12EI/(κGAh²). Its shear strain is constant along
        the element, so its frequencies converge at rate 2 in h (:meth:`mesh_error`)."""
        phi = 12.0 * self.ei / (self.kga * h * h)
        k = np.array(
            [
                [12.0, 6 * h, -12.0, 6 * h],
                [6 * h, (4 + phi) * h * h, -6 * h, (2 - phi) * h * h],
                [-12.0, -6 * h, 12.0, -6 * h],
                [6 * h, (2 - phi) * h * h, -6 * h, (4 + phi) * h * h],
            ]
        ) * (self.ei / ((1 + phi) * h**3))
        p2 = phi * phi
        a, b = 13 / 35 + 7 * phi / 10 + p2 / 3, (11 / 210 + 11 * phi / 120 + p2 / 24) * h
        c, d = 9 / 70 + 3 * phi / 10 + p2 / 6, (13 / 420 + 3 * phi / 40 + p2 / 24) * h
        e, f = (1 / 105 + phi / 60 + p2 / 120) * h * h, (1 / 140 + phi / 60 + p2 / 120) * h * h
        translation = np.array([[a, b, c, -d], [b, e, d, -f], [c, d, a, -b], [-d, -f, -b, e]]) * (
            self.rho_a * h / (1 + phi) ** 2
        )
        g, r = (1 / 10 - phi / 2) * h, (2 / 15 + phi / 6 + p2 / 3) * h * h
        s = (-1 / 30 - phi / 6 + p2 / 6) * h * h
        rotary = np.array(
            [[6 / 5, g, -6 / 5, g], [g, r, -g, s], [-6 / 5, -g, 6 / 5, -g], [g, s, -g, r]]
        ) * (self.rho_i / ((1 + phi) ** 2 * h))
        return k, translation + rotary

    def lowest_clamped(self, length):
        """A lower bound [rad²/s²] of the squared first clamped-clamped frequency of a piece
        of ``length`` [m]: the Rayleigh quotient's, with Poincaré's inequality on v and θ
        and (v' - θ)² ≥ (1 - ε) v'² - (1/ε - 1) θ², 1/ε - 1 = a = EIπ²/(2κGAℓ²):
        ``min(EIπ⁴ / (2ρAℓ⁴(1 + a)), EIπ² / (2ρIℓ²))``."""
        length = np.asarray(length, dtype=float)
        a = self.ei * math.pi**2 / (2.0 * self.kga * length**2)
        bending = self.ei * math.pi**4 / (2.0 * self.rho_a * length**4 * (1.0 + a))
        return np.minimum(bending, self.ei * math.pi**2 / (2.0 * self.rho_i * length**2))

    def wavenumber(self, omega):
        """The larger bending wavenumber [1/m] at ω [rad/s] (the propagating one): the root
        k² of EI k⁴ - ω²(ρI + EIρA/κGA) k² - ρAω² + ρIρAω⁴/κGA = 0."""
        w2 = np.asarray(omega, dtype=float) ** 2
        s = self.rho_i / self.ei + self.rho_a / self.kga
        dif = self.rho_i / self.ei - self.rho_a / self.kga
        k2 = 0.5 * w2 * s + np.sqrt(0.25 * w2 * w2 * dif * dif + self.rho_a * w2 / self.ei)
        return np.sqrt(k2)

    def mesh_error(self, omega: float, h: float) -> float:
        """Estimated relative frequency error of a mode at ω [rad/s] on elements of ``h`` [m]:
        that of the wave of ω's wavenumber k (:meth:`wavenumber`) on an endless row of equal
        elements (:meth:`_lattice_w2`). Exact for a simply supported member, whose modes are
        such waves; a member's ends lower it. Rate 2 in h (:meth:`element`): as h → 0 it
        tends to h²((ρAω²)²/κGA + (ρIω²r)²/EI) / (24ω²(ρA + ρIr²)) + O(h⁴), r = k -
        ρAω²/(kκGA) the wave's section rotation per unit deflection; ∞ from kh = MAX_KH on
        (the mesh does not resolve the wave)."""
        k = float(self.wavenumber(omega))
        if not k > 0:
            return 0.0
        if k * h > MAX_KH:
            return math.inf
        return math.sqrt(self._lattice_w2(k, h)) / omega - 1.0

    def element_length(self, omega: float, rtol: float) -> float:
        """The longest element [m] with :meth:`mesh_error` <= ``rtol`` at ω [rad/s] (the error
        grows with h up to kh = MAX_KH: bisected to rounding)."""
        k = float(self.wavenumber(omega))
        if not k > 0:
            return math.inf
        lo, hi = 0.0, MAX_KH / k
        if self.mesh_error(omega, hi) <= rtol:
            return hi
        for _ in range(BISECTIONS):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if self.mesh_error(omega, mid) <= rtol else (lo, mid)
        return lo

    def _lattice_w2(self, k: float, h: float) -> float:
        """ω² [rad²/s²] of the lower (bending) wave of wavenumber k [1/m] on an endless row of
        :meth:`element` of length ``h`` [m], 0 < kh < π: nodal motions ``(v, hθ) e^{ikjh}``
        reduce K - ω²M to 2x2, [[a + c cos kh, d sin kh], [d sin kh, e + f cos kh]] from
        each matrix's entries a = (1,1), c = (1,3), d = (2,3), e = (2,2), f = (2,4); its
        determinant's lower root. The stiffness's three, in units EI/((1 + φ)h³): 24s²,
        6 - 2(2 - φ)s², -6 sin kh, their determinant 48(1 + φ)s⁴ (s = sin(kh/2); the
        cancellation done by hand: no digits lost as kh → 0)."""
        phi = 12.0 * self.ei / (self.kga * h * h)
        scale = np.array([1.0, 1.0 / h, 1.0, 1.0 / h])
        m = self.element(h)[1] * scale[:, None] * scale[None, :]
        s, c, sn = math.sin(0.5 * k * h), math.cos(k * h), math.sin(k * h)
        ma, me, md = m[0, 0] + m[0, 2] * c, m[1, 1] + m[1, 3] * c, m[1, 2] * sn
        unit = self.ei / ((1.0 + phi) * h**3)
        ka, ke, kd = 24.0 * s * s * unit, (6.0 - 2.0 * (2.0 - phi) * s * s) * unit, -6.0 * sn * unit
        det_k = 48.0 * (1.0 + phi) * s**4 * unit * unit
        det_m, b = ma * me - md * md, ka * me + ke * ma - 2.0 * kd * md
        return 2.0 * det_k / (b + math.sqrt(b * b - 4.0 * det_m * det_k))


class Planes:
    """Many Timoshenko bending members (``(Plane, length)`` pairs): the terms
    (k11, k12, k13, k14, k22, k24) of their exact dynamic stiffness (:data:`ENTRIES`) and their
    clamped-clamped count, each by subdivision; equal members (a circle's two planes) once."""

    ENTRIES = ENTRIES

    def __init__(self, members):
        self.members = list(members)

    def terms(self, omega) -> np.ndarray:
        """Terms (len(ω), 6 per member) at ω [rad/s]."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        out, done = [], {}
        for plane, length in self.members:
            key = (plane.key, length)
            if key not in done:
                done[key] = plane.stiffness(omega, length)[:, TERM_PLACES[0], TERM_PLACES[1]]
            out.append(done[key])
        return np.concatenate(out, axis=1) if out else np.zeros((omega.size, 0))

    def clamped(self, omega) -> np.ndarray:
        """J₀ (len(ω),): the members' clamped-clamped frequencies below ω [rad/s], summed."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        count, done = np.zeros(omega.size, dtype=int), {}
        for plane, length in self.members:
            key = (plane.key, length)
            if key not in done:
                done[key] = plane.clamped(omega, length)
            count += done[key]
        return count


Plane.STACK = Planes


def _scale_length(length: np.ndarray) -> np.ndarray:
    """The scaling length [m] of a transfer over ``length``: itself, 1 m where it is 0."""
    return np.where(length > 0.0, length, 1.0)


def _joined(k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two equal members ``k`` (n, 4, 4) in a row, their middle node condensed: (the
    stiffness of the joined member (n, 4, 4), s{K_mm} (n,), the negative eigenvalues of the
    middle node's 2x2 stiffness, which the count adds)."""
    k11, k12, k21, k22 = k[:, :2, :2], k[:, :2, 2:], k[:, 2:, :2], k[:, 2:, 2:]
    middle = k22 + k11
    det = middle[:, 0, 0] * middle[:, 1, 1] - middle[:, 0, 1] * middle[:, 1, 0]
    trace = middle[:, 0, 0] + middle[:, 1, 1]
    negative = np.where(det < 0, 1, np.where(trace < 0, 2, 0))
    left, right = np.linalg.solve(middle, k21), np.linalg.solve(middle, k12)
    out = np.empty_like(k)
    out[:, :2, :2], out[:, :2, 2:] = k11 - k12 @ left, -k12 @ right
    out[:, 2:, :2], out[:, 2:, 2:] = -k21 @ left, k22 - k21 @ right
    return out, negative


def expm_batched(a: np.ndarray) -> np.ndarray:
    """exp(a) (n, k, k) of a batch of small matrices: each scaled by 2⁻ˢ to norm ≤ 1/2,
    Taylor series (TAYLOR_TERMS), then squared s times (its own s per matrix)."""
    norm = np.abs(a).sum(axis=2).max(axis=1)
    with np.errstate(divide="ignore"):
        s = np.maximum(0, np.ceil(np.log2(np.maximum(norm, 1e-300) / 0.5))).astype(int)
    x = a * (0.5**s)[:, None, None]
    eye = np.broadcast_to(np.eye(a.shape[1]), a.shape)
    out = eye + x / TAYLOR_TERMS
    for j in range(TAYLOR_TERMS - 1, 0, -1):  # Horner: I + x/1 (I + x/2 (I + ...))
        out = eye + (x @ out) / j
    for step in range(1, s.max(initial=0) + 1):
        more = s >= step
        out[more] = out[more] @ out[more]
    return out


def planes(beam) -> tuple[Plane, Plane]:
    """The x1-y (I_z) and x1-z (I_y) bending planes of a Timoshenko ``beam``."""
    rho, a = beam.density, beam.area
    kga = beam.shear_coefficient * beam.shear_modulus * a
    return tuple(
        Plane(beam.youngs_modulus * i, rho * a, rho * i, kga)
        for i in (beam.second_moment_z, beam.second_moment_y)
    )
