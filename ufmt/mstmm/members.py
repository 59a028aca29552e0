"""Exact dynamic stiffness of a beam member and its clamped-clamped count (a Timoshenko
beam's bending planes from :mod:`ufmt.kinds.timoshenko`).

The two ingredients a beam brings to the Wittrick-Williams count (:mod:`ufmt.mstmm.wittrick`):
its exact dynamic stiffness matrix (12x12 on the six small motions of each end, no mesh;
axial, torsion and bending in two planes, the beam of paper eq. 3.3), and J₀, the number of
its natural frequencies with both ends clamped that lie below ω (closed forms).

Local axes as the MSTMM's (:func:`ufmt.mstmm.elements.beam_frame` from start to end); end
dofs ``[u v w θx θy θz]`` of the start then the end, with ``θz = dv/dx`` (x-y plane, I_z) and
``θy = -dw/dx`` (x-z plane, I_y). Bending entries are written with the scaled functions of
λ = βL (β⁴ = ρA ω²/EI) below, power series in λ⁴ for λ < 2 (no cancellation as ω → 0, where
the matrix tends to the static one), closed forms above.
"""

from __future__ import annotations

import math

import numpy as np

from ufmt.kinds.timoshenko import planes
from ufmt.model.schema import Beam
from ufmt.mstmm.elements import beam_frame

SERIES_TERMS = 12  # (4·16)¹² / 48! is far below eps: the series in λ⁴ for λ⁴ < 16
SERIES_BELOW = 16.0  # λ⁴ below which the power series are used


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


# end dofs (start, end) of each deformation in the local 12-vector
AXIAL, TORSION = [0, 6], [3, 9]
BENDING_XY, BENDING_XZ = [1, 5, 7, 11], [2, 4, 8, 10]
XZ_SIGN = np.array([1.0, -1.0, 1.0, -1.0])  # θy = -dw/dx
# entries of a rod's 2x2 matrix per term (f cos κL, -f), and of a bending member's 4x4 on
# [v₁, v₁', v₂, v₂'] per term (k11, k12, k13, k14, k22, k24), with their signs
ROD_ENTRIES = (((0, 0, 1), (1, 1, 1)), ((0, 1, 1), (1, 0, 1)))
BENDING_ENTRIES = (
    ((0, 0, 1), (2, 2, 1)),
    ((0, 1, 1), (1, 0, 1), (2, 3, -1), (3, 2, -1)),
    ((0, 2, 1), (2, 0, 1)),
    ((0, 3, 1), (3, 0, 1), (1, 2, -1), (2, 1, -1)),
    ((1, 1, 1), (3, 3, 1)),
    ((1, 3, 1), (3, 1, 1)),
)


class Members:
    """The deformations of a set of beams stacked (each beam's axial and torsion rods, its two
    bending planes), so that the exact dynamic stiffness and J₀ of all of them at all
    frequencies are a few array operations: the stiffness is Σ_t term_t(ω) E_t with fixed
    12x12 patterns E_t (:attr:`patterns`, of beam :attr:`owner`) and scalar terms
    (:meth:`terms`): per rod f cos κL and -f, f = (k/L) κL/sin κL; per bending plane
    EI·(k11, k12, k13, k14, k22, k24) of the matrix below (module docstring).
    """

    def __init__(self, beams):
        rods, bends, patterns, owner = [], [], [], []
        self.shear_planes = []  # Timoshenko planes: (Plane, L)
        for j, beam in enumerate(beams):
            for dofs, kind, stiffness, inertia in _parts(beam):
                sign = XZ_SIGN if dofs == BENDING_XZ else np.ones(len(dofs))
                if kind == "timoshenko":
                    self.shear_planes.append((stiffness, beam.length))
                else:
                    (rods if kind == "rod" else bends).append((stiffness, inertia, beam.length))
                for entries in ROD_ENTRIES if kind == "rod" else BENDING_ENTRIES:
                    e = np.zeros((12, 12))
                    for a, b, s in entries:
                        e[dofs[a], dofs[b]] = s * sign[a] * sign[b]
                    patterns.append((kind, e))
                    owner.append(j)
        self.rods = np.array(rods, dtype=float).reshape(-1, 3)  # (k or GJ, ρA or ρI_p, L)
        self.bends = np.array(bends, dtype=float).reshape(-1, 3)  # (EI, ρA, L)
        # terms are computed rods first, then bending planes, then Timoshenko planes
        kinds = ("rod", "bending", "timoshenko")
        order = [i for kind in kinds for i, p in enumerate(patterns) if p[0] == kind]
        self.patterns = np.array([patterns[i][1] for i in order]).reshape(-1, 12, 12)
        self.owner = np.array(owner, dtype=int)[order]
        k, mu, _ = self.rods.T
        self._slowness = np.sqrt(mu / k)  # κ/ω [s/m]
        length = self.bends[:, 2]
        self._bend_length4 = length**4
        # per bending term (k11, k12, k13, k14, k22, k24): its power of L, f's row and sign
        self._bend_powers = np.array([length**3, length**2, length**3, length**2, length, length])
        self._bend_rows, self._bend_signs = [1, 3, 5, 4, 2, 6], np.array([1, 1, -1, 1, 1, 1.0])

    def terms(self, omega) -> np.ndarray:
        """The scalar terms (len(ω), 2 rods + 6 bending planes) at ω [rad/s]."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))[:, None]
        k, _, length = self.rods.T
        kl = omega * self._slowness * length
        factor = k / (length * np.sinc(kl / np.pi))
        rod = np.stack([factor * np.cos(kl), -factor], axis=-1).reshape(omega.size, -1)
        ei, rho_a, _ = self.bends.T
        lam4 = rho_a * omega**2 / ei * self._bend_length4
        f = _bending_functions(lam4.ravel()).reshape(7, *lam4.shape)
        # EI f / (δ Lᵖ) for f = (a1, p2, -t1, u2, a3, v3) (module docstring), (6, len(ω), m)
        bend = ei * (f[self._bend_rows] * self._bend_signs[:, None, None])
        bend /= f[0] * self._bend_powers[:, None, :]
        shear, done = [], {}  # equal planes (a circle's two) computed once
        for plane, length in self.shear_planes:
            key = (plane.key, length)
            if key not in done:
                k = plane.stiffness(omega[:, 0], length)
                done[key] = k[:, [0, 0, 0, 0, 1, 1], [0, 1, 2, 3, 1, 3]]
            shear.append(done[key])
        bend = bend.transpose(1, 2, 0).reshape(omega.size, -1)
        return np.concatenate([rod, bend, *shear], axis=1)

    def clamped(self, omega) -> np.ndarray:
        """J₀: the number (len(ω),) of clamped-clamped member frequencies below ω [rad/s], all
        members together. Rods: ⌊κL/π⌋. Bending: i - (1 - (-1)ⁱ sgn δ)/2 with i = ⌊λ/π⌋ and
        δ = 1 - cos λ cosh λ (Williams and Wittrick's closed form)."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))[:, None]
        _, _, length = self.rods.T
        count = np.floor(omega * self._slowness * length / np.pi).astype(int).sum(axis=1)
        ei, rho_a, _ = self.bends.T
        lam = np.sqrt(np.sqrt(rho_a * omega**2 / ei * self._bend_length4))
        i = np.floor(lam / np.pi).astype(int)
        # δ = λ⁴/6 + ... > 0 below λ = 2 (the first zero is at 4.73): the closed form above
        with np.errstate(over="ignore"):
            sign = np.where(lam < 2.0, 1.0, np.sign(1.0 - np.cos(lam) * np.cosh(lam)))
        count += (i - np.rint((1 - (-1.0) ** i * sign) / 2).astype(int)).sum(axis=1)
        done = {}  # equal planes (a circle's two) counted once
        for plane, length in self.shear_planes:  # by subdivision
            key = (plane.key, length)
            if key not in done:
                done[key] = plane.clamped(omega[:, 0], length)
            count += done[key]
        return count


def _parts(beam: Beam):
    """(dofs, kind, stiffness, inertia per length) of the beam's four deformations; a
    Timoshenko plane: (dofs, "timoshenko", its :class:`~ufmt.kinds.timoshenko.Plane`, None)."""
    rho, a = beam.density, beam.area
    rods = (
        (AXIAL, "rod", beam.youngs_modulus * a, rho * a),
        (TORSION, "rod", beam.shear_modulus * beam.torsion_constant, rho * beam.polar_moment),
    )
    if beam.timoshenko:
        xy, xz = planes(beam)
        return (*rods, (BENDING_XY, "timoshenko", xy, None), (BENDING_XZ, "timoshenko", xz, None))
    return (
        *rods,
        (BENDING_XY, "bending", beam.youngs_modulus * beam.second_moment_z, rho * a),
        (BENDING_XZ, "bending", beam.youngs_modulus * beam.second_moment_y, rho * a),
    )


def member_stiffness(omega: np.ndarray, beam: Beam) -> np.ndarray:
    """Exact dynamic stiffness (n, 12, 12) of the beam in its local axes (module docstring)
    at ω (n,) [rad/s]; symmetric, real, infinite only at its clamped-clamped frequencies;
    at ω = 0 the static one (bending: ``EI/L³ [[12, 6L, -12, 6L], [6L, 4L², -6L, 2L²],
    ...]``)."""
    members = Members([beam])
    return np.einsum("nt,tij->nij", members.terms(omega), members.patterns)


def local_to_global(beam: Beam) -> np.ndarray:
    """(12, 12) map from the global end motions (start, end) to the local ones."""
    return np.kron(np.eye(4), beam_frame(beam, beam.start, beam.end).T)
