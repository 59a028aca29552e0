"""Every body kind and every beam theory: its three formulations give one set of frequencies.

A small model per case (a rigid body on a spring to ground; the same through a virtual joint;
a skew beam on springs at both ends, once per theory of ``ufmt.kinds.beam.THEORIES``), solved
three ways that share no solver code:

* the MSTMM: the roots of det U_all(ω) from the kinds' transfer matrices;
* the Wittrick-Williams count on the kinds' exact dynamic stiffness and clamped-clamped
  count, bisected root by root (J(ω) ≥ k from the k-th root on);
* the assembled model from the kinds' finite elements.

Oracles: for masses on springs the finite-element model is exact, so all three agree to
rounding; for a member, the finite-element frequencies are upper bounds (consistent mass,
Rayleigh-Ritz) that converge at the observed rate of its elements (measured on 8, 16, 32
elements: 4 for the cubic Euler-Bernoulli bending modes, 2 for the linear rods and the
Timoshenko element, the slowest part governing a mode), and their Richardson extrapolation in
h² and h⁴ lands on the exact frequencies (it removes at least 98 % of the fine mesh's error:
measured 99.2 % and more).
"""

from __future__ import annotations

import numpy as np
import pytest

from ufmt.assembled import assembled_modes
from ufmt.kinds import BODY_KINDS, KINDS
from ufmt.kinds.beam import THEORIES, parts
from ufmt.model.load import load_model_text
from ufmt.mstmm.solve import solve_modes
from ufmt.mstmm.wittrick import RootCounter

MODES = 6
MESHES = (8, 16, 32)  # elements per beam: three meshes give the rate, two the extrapolation
RIGID = """
[[body]]
name = "b"
kind = "rigid"
mass = 40.0
center_of_mass = [0.1, 0.2, 0.3]
inertia = [[2.0, 0.1, 0.0], [0.1, 3.0, 0.2], [0.0, 0.2, 2.5]]
"""
SPRING = """
[[hinge]]
name = "{name}"
between = ["{a}", "{b}"]
at = [{at}]
stiffness = [{k}]
rotational_stiffness = [{r}]
"""
MASS_MODELS = {
    "rigid": RIGID
    + SPRING.format(
        name="h", a="ground", b="b", at="0, 0, 0", k="1e7, 2e7, 3e7", r="1e6, 2e6, 1.5e6"
    ),
    "virtual": RIGID
    + '[[body]]\nname = "v"\nkind = "virtual"\n'
    + SPRING.format(
        name="h1", a="ground", b="v", at="0, 0, 0", k="1e7, 2e7, 3e7", r="1e6, 2e6, 1.5e6"
    )
    + SPRING.format(name="h2", a="v", b="b", at="0, 0, 0", k="3e7, 2e7, 1e7", r="2e6, 1e6, 3e6"),
}
END = "0.4, 0.1, 0.05"  # a skew beam: its parts' local axes are not the global ones
MEMBER = (
    """
[[body]]
name = "b"
kind = "beam"
start = [0.0, 0.0, 0.0]
end = [{end}]
density = 7850.0
youngs_modulus = 2.1e11
shear_modulus = 8.1e10
diameter = 0.1
theory = "{theory}"
"""
    + SPRING.format(
        name="h0", a="ground", b="b", at="0, 0, 0", k="3e9, 2e9, 1e9", r="1e9, 1e8, 2e8"
    )
    + SPRING.format(name="h1", a="ground", b="b", at=END, k="1e9, 2e9, 3e9", r="2e8, 3e8, 1e8")
)
#: the slowest element rate of a member's parts (cubic bending 4, linear rods 2, the
#: Timoshenko element 2): every mode converges at least this fast
SLOWEST_RATE = 2.0


def _cases() -> list[str]:
    """Each kind; a member kind once per beam theory."""
    return [
        f"{name}:{theory}" if BODY_KINDS[name].FORM == "member" else name
        for name in KINDS
        for theory in (THEORIES if BODY_KINDS[name].FORM == "member" else (None,))
    ]


def _model(case: str):
    name, _, theory = case.partition(":")
    text = MASS_MODELS[name] if not theory else MEMBER.format(end=END, theory=theory)
    return load_model_text(f'name = "{case}"\n' + text, f"{name}.toml")


def _counted_roots(model, upper_hz: float, count: int) -> np.ndarray:
    """The first ``count`` frequencies [Hz] from the Wittrick-Williams count alone: for each
    k the least ω with J(ω) ≥ k, bisected (all k at once) to 1e-12 relative."""
    counter = RootCounter(model)
    lo, hi = np.zeros(count), np.full(count, upper_hz)
    k = np.arange(1, count + 1)
    assert np.all(counter.below(hi) >= k), "the bracket holds every root"
    while np.any(hi - lo > 1e-12 * hi):
        mid = 0.5 * (lo + hi)
        above = counter.below(mid) >= k
        hi, lo = np.where(above, mid, hi), np.where(above, lo, mid)
    return hi


@pytest.mark.parametrize("case", _cases())
def test_transfer_matrix_exact_stiffness_and_finite_elements_agree(case):
    """MSTMM roots = Wittrick-Williams roots (both exact: to 1e-9) = finite elements (exact for
    masses; for a member upper bounds converging at the observed rate >= SLOWEST_RATE whose
    Richardson extrapolation lands on the exact roots: module docstring)."""
    model = _model(case)
    exact = solve_modes(model, count=MODES, shapes=False).frequencies_hz
    counted = _counted_roots(model, 2.0 * exact[-1], MODES)
    np.testing.assert_allclose(counted, exact, rtol=1e-9)
    if ":" not in case:  # masses on springs: no mesh, the finite elements are exact
        fe = assembled_modes(model, count=MODES).frequencies_hz
        np.testing.assert_allclose(fe, exact, rtol=1e-9)
        return
    coarse, middle, fine = (
        assembled_modes(model, count=MODES, elements_per_beam=n).frequencies_hz for n in MESHES
    )
    assert np.all(fine >= exact * (1 - 1e-10)) and np.all(middle >= fine * (1 - 1e-10))
    rate = np.log2((coarse - middle) / (middle - fine))
    assert np.all(rate >= SLOWEST_RATE - 0.1), rate
    # the elements' errors run in even powers of h: f_n = f + a h² + b h⁴ through the three
    # meshes removes at least 98 % of the fine mesh's error
    powers = np.array([[1.0, n**-2.0, n**-4.0] for n in MESHES])
    extrapolated = np.linalg.solve(powers, np.array([coarse, middle, fine]))[0]
    assert np.all(np.abs(extrapolated - exact) <= 0.02 * (fine - exact) + 1e-12 * exact)


def test_every_kind_and_theory_is_a_case():
    """The cases follow the registries: a new beam theory is a case without an edit (a new
    kind of another form needs its small model in MASS_MODELS)."""
    cases = _cases()
    assert {c.partition(":")[0] for c in cases} == set(KINDS)
    assert {c.partition(":")[2] for c in cases if ":" in c} == set(THEORIES)


# -- each formulation of a member's parts: transfer matrix, exact stiffness, finite element ----

LENGTH = 0.5  # [m] a short steel member, diameter 0.1 m (L/D = 5: shear matters)


def _formulations() -> dict:
    """Every distinct formulation of a member's parts: its rods once, its bending planes once
    per theory of the registry."""
    found = {}
    for theory in THEORIES:
        model = _model(f"beam:{theory}")
        beam = model.body("b")
        for part, label in zip(parts(beam), ("axial", "torsion", "xy", "xz"), strict=True):
            if label in ("axial", "torsion"):
                found[label] = part.formulation
            elif label == "xy":  # the circle's x1-z plane is the same formulation
                found[f"{theory}:{label}"] = part.formulation
    return found


FORMULATIONS = _formulations()


def _first_clamped(f, k: int) -> float:
    """ω [rad/s] of the k-th clamped-clamped frequency, bisected on the formulation's count."""
    lo, hi = 0.0, 1e3
    while f.clamped(np.array([hi]), LENGTH)[0] < k:
        hi *= 2.0
    while hi - lo > 1e-12 * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if f.clamped(np.array([mid]), LENGTH)[0] >= k else (mid, hi)
    return hi


def _condensed(f, n: int, omega: float) -> np.ndarray:
    """End dynamic stiffness of ``n`` equal finite elements in a row at ω [rad/s]: K - ω²M
    assembled, the inner nodes condensed exactly."""
    k, m = f.element(LENGTH / n)
    d = k.shape[0] // 2  # dofs per node
    size = d * (n + 1)
    dyn = np.zeros((size, size))
    for e in range(n):
        at = slice(d * e, d * e + 2 * d)
        dyn[at, at] += k - omega**2 * m
    ends = np.r_[0:d, size - d : size]
    inner = np.arange(d, size - d)
    cross = dyn[np.ix_(ends, inner)]
    return dyn[np.ix_(ends, ends)] - cross @ np.linalg.solve(dyn[np.ix_(inner, inner)], cross.T)


@pytest.mark.parametrize("name", FORMULATIONS)
def test_a_formulations_elements_converge_to_its_exact_stiffness(name):
    """Finite elements against the exact dynamic stiffness: n elements with their inner nodes
    condensed tend to ``stiffness(ω)`` at the element's rate (>= SLOWEST_RATE), below and
    between the first two clamped-clamped frequencies."""
    f = FORMULATIONS[name]
    first, second = _first_clamped(f, 1), _first_clamped(f, 2)
    for omega in (0.6 * first, 0.5 * (first + second)):
        exact = f.stiffness(np.array([omega]), LENGTH)[0]
        np.testing.assert_allclose(exact, exact.T, rtol=1e-9, atol=1e-9 * np.abs(exact).max())
        errors = [np.abs(_condensed(f, n, omega) - exact).max() for n in MESHES]
        rates = np.log2(np.array(errors[:-1]) / errors[1:])
        assert np.all(rates >= SLOWEST_RATE - 0.1), rates


@pytest.mark.parametrize("name", FORMULATIONS)
def test_a_formulations_clamped_count_counts_the_zeros_of_its_transfer(name):
    """The clamped-clamped count against the transfer matrix: the member clamped at both ends
    vibrates where the block of end motions from start forces, T_uf, is singular, so J₀(ω) is
    the number of sign changes of det T_uf(ω') for ω' below ω (simple zeros)."""
    f = FORMULATIONS[name]
    top = 1.2 * _first_clamped(f, 3)
    omega = np.linspace(1e-3 * top, top, 6001)
    t = f.transfer(omega**2, LENGTH)
    half = t.shape[1] // 2
    det = np.linalg.det(t[:, :half, half:])
    changes = np.r_[0, np.cumsum(np.sign(det[1:]) != np.sign(det[:-1]))]
    np.testing.assert_array_equal(f.clamped(omega, LENGTH)[::50], changes[::50])
