"""The Timoshenko element's mesh rule (``Plane.mesh_error``, ``Plane.element_length``).

Oracles: the element's matrices against their integrals over the interdependent
interpolation (Friedman & Kosmatka 1993: v cubic, θ quadratic, v' - θ constant along the
element), which is why it converges at rate 2; exact frequencies from the roots of the
transfer matrix (clamped-free: det of its moment-and-shear-from-end-loads block; simply
supported: det of its deflection-and-moment-from-rotation-and-shear block); finite-element
frequencies from an assembly written here (not ``ufmt.assembled``) on meshes of 4, 8, 16 and
32 elements (h, 2h, 4h, 8h) over slenderness L/D 1 to 20; the rule's leading term in h and
its Euler-Bernoulli limit (kh)⁴/1440; and the automatic mesh of ``ufmt.assembled`` on a
thick cantilever against its exact (MSTMM) frequencies.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.optimize as so

from ufmt.assembled import assembled_modes
from ufmt.assembled.mesh import mesh_error
from ufmt.kinds.euler_bernoulli import ERROR_DIVISOR
from ufmt.kinds.timoshenko import MAX_KH, Plane
from ufmt.model.load import load_model
from ufmt.mstmm.solve import solve_modes

E, G, RHO, KAPPA = 2.1e11, 8.1e10, 7850.0, 0.9  # steel [Pa, Pa, kg/m^3], shear coefficient
DIAMETER = 0.05  # [m]
SLENDERNESS = (1.0, 2.0, 5.0, 20.0)  # L/D
MESHES = (4, 8, 16, 32)  # elements: h, 2h, 4h, 8h
MODES = 4
CANTILEVER = "examples/timoshenko-cantilever.toml"  # steel, L 0.3 m, D 0.15 m


def _plane(diameter=DIAMETER, kga_factor=1.0, rho_i_factor=1.0) -> Plane:
    a, i = math.pi * diameter**2 / 4, math.pi * diameter**4 / 64
    return Plane(E * i, RHO * a, RHO * i * rho_i_factor, KAPPA * G * a * kga_factor)


def _interpolation(plane: Plane, h: float):
    """The interdependent interpolation (Friedman & Kosmatka 1993, eqs. 14-15) at 6 Gauss
    points of an element of length ``h`` [m]: (v, θ, θ', v' - θ) shape functions (4, 6) on
    ``[v₁, θ₁, v₂, θ₂]`` and the weights (6,) [m]."""
    phi = 12.0 * plane.ei / (plane.kga * h * h)
    x, w = np.polynomial.legendre.leggauss(6)
    xi, w = 0.5 * (x + 1.0), 0.5 * w * h
    c = 1.0 / (1.0 + phi)
    v = c * np.array(
        [
            2 * xi**3 - 3 * xi**2 - phi * xi + 1 + phi,
            h * (xi**3 - (2 + phi / 2) * xi**2 + (1 + phi / 2) * xi),
            -(2 * xi**3 - 3 * xi**2 - phi * xi),
            h * (xi**3 - (1 - phi / 2) * xi**2 - phi / 2 * xi),
        ]
    )
    dv = c * np.array(
        [
            (6 * xi**2 - 6 * xi - phi) / h,
            3 * xi**2 - (4 + phi) * xi + 1 + phi / 2,
            -(6 * xi**2 - 6 * xi - phi) / h,
            3 * xi**2 - (2 - phi) * xi - phi / 2,
        ]
    )
    theta = c * np.array(
        [
            6 / h * (xi**2 - xi),
            3 * xi**2 - (4 + phi) * xi + 1 + phi,
            -6 / h * (xi**2 - xi),
            3 * xi**2 - (2 - phi) * xi,
        ]
    )
    dtheta = c * np.array(
        [
            6 / h**2 * (2 * xi - 1),
            (6 * xi - 4 - phi) / h,
            -6 / h**2 * (2 * xi - 1),
            (6 * xi - 2 + phi) / h,
        ]
    )
    return v, theta, dtheta, dv - theta, w


def _fe(plane: Plane, length: float, n: int, held) -> np.ndarray:
    """Frequencies [rad/s] of n equal elements assembled, the ``held`` dofs of
    ``[v₀, θ₀, ..., vₙ, θₙ]`` removed: the eigenvectors of (K, M), each frequency their
    Rayleigh quotient with the strain energy summed from the elements' strains (the
    eigenvalues themselves carry the solver's rounding, eps·λ_max)."""
    h = length / n
    k_e, m_e = plane.element(h)
    size = 2 * (n + 1)
    k, m = np.zeros((size, size)), np.zeros((size, size))
    for e in range(n):
        at = slice(2 * e, 2 * e + 4)
        k[at, at] += k_e
        m[at, at] += m_e
    free = np.setdiff1d(np.arange(size), np.array(held) % size)
    x = np.zeros((size, free.size))
    x[free] = sla.eigh(k[np.ix_(free, free)], m[np.ix_(free, free)])[1]
    _, _, dtheta, shear, w = _interpolation(plane, h)
    ends = x[np.arange(4) + 2 * np.arange(n)[:, None]]  # (element, end dof, mode)
    bending = np.einsum("dg,edj->egj", dtheta, ends) ** 2
    shearing = np.einsum("dg,edj->egj", shear, ends) ** 2
    energy = np.einsum("g,egj->j", w, plane.ei * bending + plane.kga * shearing)
    return np.sqrt(energy / np.einsum("ij,ik,kj->j", x, m, x))


# end conditions: the dofs held in the assembly; the transfer matrix's rows (state at the far
# end) and columns (unknown state at the near end) whose determinant vanishes at a root
ENDS = {
    "clamped-free": ([0, 1], [2, 3], [2, 3]),
    "simply supported": ([0, -2], [0, 2], [1, 3]),
}


def _exact(plane: Plane, length: float, ends: str, upper: float) -> np.ndarray:
    """The frequencies [rad/s] below ``upper``: roots of the end condition's determinant of
    the transfer matrix, bracketed on a scan, then Brent's method to rounding."""
    _, rows, cols = ENDS[ends]

    def det(omega):
        t = plane.transfer(np.atleast_1d(omega) ** 2, length)
        return np.linalg.det(t[:, rows][:, :, cols])

    scan = np.linspace(1e-3 * upper, upper, 4001)
    d = det(scan)
    brackets = np.flatnonzero(np.sign(d[1:]) != np.sign(d[:-1]))
    return np.array(
        [so.brentq(lambda w: det(w)[0], scan[i], scan[i + 1], xtol=1e-300) for i in brackets]
    )


def _measured(ld: float, ends: str):
    """(plane, length [m], exact [rad/s], {n: finite-element errors}) of the first MODES modes
    of a member of slenderness ``ld``."""
    plane, length = _plane(), ld * DIAMETER
    coarse = _fe(plane, length, MESHES[0], ENDS[ends][0])
    exact = _exact(plane, length, ends, 1.05 * coarse[MODES - 1])[:MODES]
    errors = {n: _fe(plane, length, n, ENDS[ends][0])[:MODES] / exact - 1.0 for n in MESHES}
    return plane, length, exact, errors


def test_the_element_is_consistent_with_its_interpolation():
    """K and M are the integrals of the interdependent interpolation (Friedman & Kosmatka
    1993, eqs. 14-15) by 6-point Gauss quadrature (exact on these polynomials), whose shear
    strain v' - θ is constant along the element: the finite-element space cannot follow the
    linear shear force of a vibrating member, so its frequencies converge at rate 2."""
    plane, h = _plane(), 0.03
    v, theta, dtheta, shear, w = _interpolation(plane, h)
    assert np.ptp(shear, axis=1) == pytest.approx(np.zeros(4), abs=1e-12 / h)
    k = plane.ei * (dtheta * w) @ dtheta.T + plane.kga * (shear * w) @ shear.T
    m = plane.rho_a * (v * w) @ v.T + plane.rho_i * (theta * w) @ theta.T
    k_e, m_e = plane.element(h)
    np.testing.assert_allclose(k_e, k, rtol=1e-12, atol=1e-12 * np.abs(k).max())
    np.testing.assert_allclose(m_e, m, rtol=1e-12, atol=1e-12 * np.abs(m).max())


@pytest.mark.parametrize("ld", SLENDERNESS)
def test_the_rule_bounds_a_cantilevers_measured_errors(ld):
    """Clamped-free, L/D 1 to 20: where the rule applies (kh up to MAX_KH) every mode's
    error is at most the rule at its frequency and at
    least a tenth of it; the observed rate between the two finest meshes is the rule's."""
    plane, length, exact, errors = _measured(ld, "clamped-free")
    rules = {}
    for n, error in errors.items():
        h = length / n
        rule = np.array([plane.mesh_error(w, h) for w in exact])
        rules[n] = rule
        applies = np.isfinite(rule)
        assert np.all(error > 0)  # consistent mass: from above
        assert np.all(error[applies] <= rule[applies]), (n, error, rule)
        assert np.all(error[applies] >= 0.1 * rule[applies]), (n, error, rule)
    assert np.all(np.isfinite(rules[MESHES[-1]]))
    fine, finer = MESHES[-2], MESHES[-1]
    observed = np.log2(errors[fine][0] / errors[finer][0])
    np.testing.assert_allclose(observed, np.log2(rules[fine] / rules[finer]), atol=0.02)


@pytest.mark.parametrize("ld", SLENDERNESS)
def test_the_rule_is_a_simply_supported_members_error(ld):
    """Simply supported, its modes on the lower (bending) branch, whose wavenumber at ω is
    jπ/L, are the waves the rule is computed for: their errors equal the rule to the
    rounding on every mesh where it applies; the upper (thickness-shear)
    branch's modes, at the same ω a shorter wave, are still bounded within a factor 10."""
    plane, length, exact, errors = _measured(ld, "simply supported")
    half_waves = np.array([float(plane.wavenumber(w)) for w in exact]) * length / math.pi
    lower = np.abs(half_waves - np.round(half_waves)) < 1e-6
    assert np.count_nonzero(lower) >= 2
    for n, error in errors.items():
        rule = np.array([plane.mesh_error(w, length / n) for w in exact])
        bending = np.isfinite(rule) & lower
        # to the roots' rounding: the transfer of a long member loses digits as e^{kL}
        np.testing.assert_allclose(error[bending], rule[bending], rtol=0, atol=1e-12)
        other = np.isfinite(rule) & ~lower
        assert np.all((error[other] <= rule[other]) & (error[other] >= 0.1 * rule[other]))


def _leading(plane: Plane, omega: float, h: float) -> float:
    """The rule's leading term (rate 2): h²((ρAω²)²/κGA + (ρIω²r)²/EI) / (24ω²(ρA + ρIr²))."""
    k, w2 = float(plane.wavenumber(omega)), omega * omega
    r = k - plane.rho_a * w2 / (k * plane.kga)
    shear = (plane.rho_a * w2) ** 2 / plane.kga + (plane.rho_i * w2 * r) ** 2 / plane.ei
    return h * h * shear / (24.0 * w2 * (plane.rho_a + plane.rho_i * r * r))


def test_the_rule_converges_at_rate_2_to_its_leading_term():
    """The rule over h, h/2, ...: its ratio to the leading term tends to 1 (at rate 2: the
    next term is h⁴), so its own rate tends to 2, the element's."""
    plane = _plane()
    for omega in (2e3, 2e4, 2e5):
        h0 = 0.5 / float(plane.wavenumber(omega))
        hs = h0 / 2.0 ** np.arange(8)
        gap = np.array([plane.mesh_error(omega, h) / _leading(plane, omega, h) - 1 for h in hs])
        rates = np.log2(np.abs(gap[:-1] / gap[1:]))
        np.testing.assert_allclose(rates[-3:], 2.0, atol=0.05)
        assert abs(gap[-1]) < 1e-3


def test_the_euler_bernoulli_limit_is_the_cubic_elements_rule():
    """κGA → ∞ and ρI → 0: the Euler-Bernoulli plane's rule (kh)⁴/ERROR_DIVISOR, its
    leading term (the gap closes as (kh)²)."""
    plane = _plane(kga_factor=1e12, rho_i_factor=1e-12)
    omega = 5e3
    k = float(plane.wavenumber(omega))
    kh = np.array([0.2, 0.1, 0.05])
    gap = np.array([plane.mesh_error(omega, x / k) for x in kh]) / (kh**4 / ERROR_DIVISOR) - 1
    np.testing.assert_allclose(np.log2(np.abs(gap[:-1] / gap[1:])), 2.0, atol=0.05)
    assert abs(gap[-1]) < 1e-4


@pytest.mark.parametrize("rtol", [1e-10, 1e-8, 1e-5, 1e-2])
def test_element_length_is_the_longest_within_the_tolerance(rtol):
    """The rule grows with h up to MAX_KH (sampled); element_length is where it reaches rtol;
    at ω = 0 (statics: the element is exact) the rule is 0 and any length will do."""
    assert _plane().mesh_error(0.0, 0.1) == 0.0 and _plane().element_length(0.0, rtol) == math.inf
    for diameter in (0.02, 0.2):
        plane = _plane(diameter)
        for omega in (1e3, 1e5):
            k = float(plane.wavenumber(omega))
            grid = np.linspace(1e-3, 1.0, 200) * MAX_KH / k
            rule = np.array([plane.mesh_error(omega, h) for h in grid])
            assert np.all(np.diff(rule) > 0)
            h = plane.element_length(omega, rtol)
            if h < MAX_KH / k:
                assert plane.mesh_error(omega, h) == pytest.approx(rtol, rel=1e-6)
            else:
                assert plane.mesh_error(omega, h) <= rtol
            assert plane.mesh_error(omega, 1.0001 * h) > rtol


@pytest.mark.parametrize("rtol", [1e-2, 1e-3, 1e-4])
def test_the_automatic_mesh_of_a_thick_cantilever_meets_its_tolerance(rtol):
    """examples/timoshenko-cantilever.toml (L/D 2) through ufmt.assembled: every mode below
    fmax within rtol of the exact (MSTMM) frequency, from above; the mesh the fewest
    elements whose rule (the worst part's) is within rtol."""
    model = load_model(CANTILEVER)
    exact = solve_modes(model, count=6).frequencies_hz
    fmax = 1.01 * exact[-1]
    modes = assembled_modes(model, fmax_hz=fmax, rtol=rtol)
    errors = modes.frequencies_hz / exact - 1
    assert np.all((errors > 0) & (errors <= rtol)), errors
    n = modes.assembled.elements_per_beam["shaft"]
    assert (
        modes.assembled.mesh_error["shaft"] <= rtol < mesh_error(model.body("shaft"), n - 1, fmax)
    )
