"""MSTMM engine against closed-form oracles: beams, spring chains, rigid bodies, hinges."""

import numpy as np
import pytest
from scipy.optimize import brentq

from ufmt.kinds import euler_bernoulli
from ufmt.model.load import load_model, model_from_dict, packaged_path
from ufmt.model.schema import Beam
from ufmt.mstmm import elements
from ufmt.mstmm.bodies import GAUSS_POINTS, gauss_points
from ufmt.mstmm.dense_reduction import null_vectors, reduced
from ufmt.mstmm.modes import mode_shapes
from ufmt.mstmm.overall import TransferSystem
from ufmt.mstmm.reduced import ConstantParts
from ufmt.mstmm.roots import OFF_ROOT
from ufmt.mstmm.solve import certified_roots, solve_modes

INF = float("inf")
RIGID = {"stiffness": [INF] * 3, "rotational_stiffness": [INF] * 3}
RELEASED = {"stiffness": [0.0] * 3, "rotational_stiffness": [0.0] * 3}
E, G, RHO, D, L = 2.1e11, 8.1e10, 7850.0, 0.05, 1.0
AREA, I2 = np.pi * D**2 / 4, np.pi * D**4 / 64


def beam_body(name="shaft", start=(0, 0, 0), end=(L, 0, 0), **extra):
    return {
        "name": name,
        "kind": "beam",
        "start": list(start),
        "end": list(end),
        "density": RHO,
        "youngs_modulus": E,
        "shear_modulus": G,
        "diameter": D,
        **extra,
    }


def hinge(name, a, b, at, stiff):
    return {"name": name, "between": [a, b], "at": list(at), **stiff}


def roots_of(char, lo, hi, n=20000):
    """All roots of a scalar characteristic function in [lo, hi] (sign scan + brentq)."""
    x = np.linspace(lo, hi, n)
    y = char(x)
    idx = np.flatnonzero(np.sign(y[1:]) != np.sign(y[:-1]))
    return np.array([brentq(char, x[i], x[i + 1], xtol=1e-15) for i in idx])


def bending_hz(beta_l, second_moment=I2):
    return beta_l**2 / L**2 * np.sqrt(E * second_moment / (RHO * AREA)) / (2 * np.pi)


def solve(model, fmax):
    """(system, roots) below ``fmax`` [Hz] by the product's path (certified brackets)."""
    return certified_roots(model, fmax)


# βL from the characteristic equations, computed here to full precision (the tables
# give 9 digits): cantilever 1 + cos cosh = 0, free-free 1 - cos cosh = 0.
CANTILEVER_BL = roots_of(lambda x: 1 + np.cos(x) * np.cosh(x), 0.5, 18.0)
FREE_FREE_BL = roots_of(lambda x: 1 - np.cos(x) * np.cosh(x), 1.0, 18.0)


def test_characteristic_roots_match_published_values():
    assert np.allclose(CANTILEVER_BL[:3], [1.87510407, 4.69409113, 7.85475744], atol=1e-8)
    assert np.allclose(FREE_FREE_BL[:3], [4.73004074, 7.85320462, 10.99560784], atol=1e-8)


def cantilever(iz_factor=1.0, axis=(L, 0, 0)):
    extra = {}
    if iz_factor != 1.0:
        extra = {
            "area": AREA,
            "second_moment_y": I2,
            "second_moment_z": iz_factor * I2,
            "polar_moment": 2 * I2,
            "orientation": [0.0, 0.0, 1.0],
        }
        body = beam_body(end=axis, **extra)
        del body["diameter"]
    else:
        body = beam_body(end=axis)
    return model_from_dict(
        {
            "name": "cantilever",
            "body": [body],
            "hinge": [hinge("clamp", "ground", "shaft", (0, 0, 0), RIGID)],
        }
    )


def analytic_cantilever(iz_factor=1.0):
    """Every frequency of the round cantilever up to its sixth bending pair [Hz]: bending in
    both planes (Euler-Bernoulli), the first two axial and torsional modes."""
    bend = [bending_hz(b) for b in CANTILEVER_BL[:6]]
    bend_z = [bending_hz(b, iz_factor * I2) for b in CANTILEVER_BL[:6]]
    axial = [(2 * k - 1) * np.pi / (2 * L) * np.sqrt(E / RHO) / (2 * np.pi) for k in (1, 2)]
    torsion = [(2 * k - 1) * np.pi / (2 * L) * np.sqrt(G / RHO) / (2 * np.pi) for k in (1, 2)]
    return np.sort(np.array(bend + bend_z + axial + torsion))


@pytest.mark.parametrize("axis", [(L, 0, 0), (0, 0, -L), (0.6 * L, 0, 0.8 * L)])
def test_cantilever_round_shaft_repeated_roots(axis):
    """Round shaft: every bending root is double; the certified brackets find both of each."""
    exact = analytic_cantilever()
    fmax = 3000.0
    exact = exact[exact <= fmax]
    _, r = solve(cantilever(axis=axis), fmax)
    assert r.frequencies_hz.size == exact.size
    assert np.allclose(r.frequencies_hz, exact, rtol=1e-8, atol=0)


def test_cantilever_close_planes():
    """Bending planes 0.05 % apart (I_z = 1.001 I_y): close pairs, not repeated."""
    exact = analytic_cantilever(1.001)
    exact = exact[exact <= 3000.0]
    _, r = solve(cantilever(1.001), 3000.0)
    assert np.allclose(r.frequencies_hz, exact, rtol=1e-9, atol=0)


def test_free_free_beam_on_released_hinge():
    """A beam hung on a hinge with every direction released is free-free."""
    model = model_from_dict(
        {
            "name": "free",
            "body": [beam_body()],
            "hinge": [hinge("h", "ground", "shaft", (0, 0, 0), RELEASED)],
        }
    )
    exact = np.repeat([bending_hz(b) for b in FREE_FREE_BL[:5]], 2)
    exact = np.sort(
        np.concatenate([exact, [np.sqrt(E / RHO) / (2 * L), np.sqrt(G / RHO) / (2 * L)]])
    )
    exact = exact[exact < 2000.0]
    _, r = solve(model, 2000.0)
    assert np.allclose(r.frequencies_hz, exact, rtol=1e-8, atol=0)


def two_mass_chain(k1, k2, m1, m2):
    inertia = [[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]]
    springs = lambda k: {"stiffness": [k, 0.0, 0.0], "rotational_stiffness": [INF] * 3}  # noqa: E731
    return model_from_dict(
        {
            "name": "chain",
            "body": [
                {
                    "name": "m1",
                    "kind": "rigid",
                    "mass": m1,
                    "center_of_mass": [0, 0, 0],
                    "inertia": inertia,
                },
                {
                    "name": "m2",
                    "kind": "rigid",
                    "mass": m2,
                    "center_of_mass": [0, 0, 0],
                    "inertia": inertia,
                },
            ],
            "hinge": [
                hinge("k1", "ground", "m1", (0, 0, 0), springs(k1)),
                hinge("k2", "m1", "m2", (0, 0, 0), springs(k2)),
            ],
        }
    )


def test_two_mass_chain_closed_form_and_released_directions():
    """x: 2-dof chain (closed form); y, z released: zero-frequency modes, not reported."""
    k1, k2, m1, m2 = 3.0e6, 1.0e6, 20.0, 5.0
    a = m1 * m2
    b = -(m1 * k2 + m2 * (k1 + k2))
    c = k1 * k2
    w2 = np.sort([(-b - s * np.sqrt(b * b - 4 * a * c)) / (2 * a) for s in (1, -1)])
    exact = np.sqrt(w2) / (2 * np.pi)
    system, r = solve(two_mass_chain(k1, k2, m1, m2), 200.0)
    assert np.allclose(r.frequencies_hz, exact, rtol=1e-12)
    # released y, z in both hinges: two extra unknowns each in the tree hinge (k1 is tree)
    assert system.order == 6 + 6 + 2 * 2


def test_rigid_body_on_springs_uncoupled():
    """Body on a hinge at its centre of mass: ω = √(k/m), √(k'/J) (triple root when equal)."""
    k, kr, m = 4.0e6, 2.0e5, 100.0
    inertia = np.diag([2.0, 3.0, 2.0])
    model = model_from_dict(
        {
            "name": "block",
            "body": [
                {
                    "name": "b",
                    "kind": "rigid",
                    "mass": m,
                    "center_of_mass": [0.1, 0.2, 0.3],
                    "inertia": inertia.tolist(),
                }
            ],
            "hinge": [
                hinge(
                    "h",
                    "ground",
                    "b",
                    (0.1, 0.2, 0.3),
                    {"stiffness": [k] * 3, "rotational_stiffness": [kr] * 3},
                )
            ],
        }
    )
    exact = np.sort(np.r_[[np.sqrt(k / m)] * 3, np.sqrt(kr / np.diag(inertia))]) / (2 * np.pi)
    _, r = solve(model, 200.0)
    assert np.allclose(r.frequencies_hz, exact, rtol=1e-10)


def test_mode_shapes_are_mass_orthonormal():
    """⟨V_r, M V_s⟩ = δ_rs for the cantilever, including the repeated pairs."""
    exact = analytic_cantilever()
    exact = exact[exact <= 3000.0]
    system, r = solve(cantilever(axis=(0.6 * L, 0, 0.8 * L)), 3000.0)
    shapes = mode_shapes(system, r.frequencies_hz)
    _, wts, mot = shapes.beams["shaft"]
    axis = np.array([0.6, 0, 0.8])
    u = mot[:, :, :3]
    twist = mot[:, :, 3:] @ axis
    gram = RHO * AREA * np.einsum("igk,jgk,g->ij", u, u, wts)
    gram += RHO * 2 * I2 * np.einsum("ig,jg,g->ij", twist, twist, wts)
    assert np.allclose(gram, np.eye(r.frequencies_hz.size), atol=1e-8)


def test_beam_transfer_matrix_is_consistent_over_parts():
    """U(L) = U(L - a) U(a) for any split (transfer property of a uniform beam)."""
    model = cantilever(1.7, axis=(0.3, 0.4, 1.2))
    beam = model.body("shaft")
    omega = np.array([10.0, 800.0, 9000.0])
    p0, p1 = beam.start, beam.end
    full = elements.beam(omega, beam, p0, p1)
    a = 0.37 * beam.length
    pa = p0 + (p1 - p0) * a / beam.length
    first = elements.beam(omega, beam, p0, p1, length=a)
    second = elements.beam(omega, beam, pa, p1, length=beam.length - a)
    assert np.allclose(second @ first, full, rtol=1e-10, atol=1e-10 * np.abs(full).max())


def test_krylov_functions_continuous_at_series_switch():
    x4 = np.array([16.0 * (1 - 1e-12), 16.0 * (1 + 1e-12)])
    s = np.array(euler_bernoulli._krylov_scaled(x4))
    assert np.allclose(s[:, 0], s[:, 1], rtol=1e-12)


def test_beam_shape_along_cantilever_matches_closed_form():
    """First bending mode of the round cantilever: v(x) ∝ cosh βx − cos βx − σ(sinh βx − sin βx)."""
    from ufmt.mstmm.modes import beam_shape

    system, r = solve(cantilever(), 100.0)
    shapes = mode_shapes(system, r.frequencies_hz)
    x = np.linspace(0.0, 1.0, 11)
    _, motion = beam_shape(system, shapes, "shaft", x)
    bl = CANTILEVER_BL[0]
    sigma = (np.cosh(bl) + np.cos(bl)) / (np.sinh(bl) + np.sin(bl))
    phi = np.cosh(bl * x) - np.cos(bl * x) - sigma * (np.sinh(bl * x) - np.sin(bl * x))
    for mode in range(2):  # the two planes of the double root
        lateral = motion[mode, :, 1:3]
        amplitude = np.linalg.norm(lateral, axis=1)
        assert np.allclose(amplitude / amplitude[-1], np.abs(phi) / abs(phi[-1]), atol=1e-9)
        assert np.allclose(motion[mode, :, 0], 0.0, atol=1e-12 * amplitude.max())


def test_gauss_points_of_the_beam_fields_meet_their_error_bound():
    """Oracle: closed-form integrals on [0, 1]. The rule chosen for a beam up to ω integrates
    the products the modal mass sees, e^{cx} with c = 2βL (β the bending wavenumber of the
    weaker axis) and a static cubic squared, to 1e-14; it never takes fewer than 4 points."""
    beam = next(b for b in load_model(packaged_path()).bodies if isinstance(b, Beam))
    ei = beam.youngs_modulus * min(beam.second_moment_y, beam.second_moment_z)
    for f_hz in (0.0, 10.0, 300.0, 2000.0, 8000.0):
        omega = 2 * np.pi * f_hz
        g = gauss_points(beam, omega)
        assert 4 <= g <= GAUSS_POINTS
        x, w = np.polynomial.legendre.leggauss(g)
        x, w = 0.5 * (x + 1.0), 0.5 * w
        cubic = 1.0 - 3 * x**2 + 2 * x**3 + 0.7 * x  # a static bending field
        exact_cubic = np.polynomial.polynomial.Polynomial([1.0, 0.7, -3.0, 2.0]) ** 2
        assert w @ cubic**2 == pytest.approx(exact_cubic.integ()(1.0), rel=1e-14)
        c = 2 * beam.length * (beam.density * beam.area * omega**2 / ei) ** 0.25
        if c > 0 and g < GAUSS_POINTS:
            assert w @ np.exp(c * x) == pytest.approx(np.expm1(c) / c, rel=1e-14)


def test_topology_shared_by_stiffness_designs_gives_the_fresh_u_all():
    """Designs that change stiffness values share the cached topology (oracle: U_all of a
    topology built from scratch for each design, bitwise); a released direction is a new
    structure (more unknowns), never a cache hit."""
    from ufmt.mstmm.topology import build_topology, redundant_rigid, with_released

    base = load_model(packaged_path("ufmt-prior.toml"))
    h = next(h for h in base.hinges if np.all(np.isfinite(h.stiffness6) & (h.stiffness6 > 0)))
    omega = 2 * np.pi * np.array([37.0, 410.0])
    TransferSystem(base)  # the structure is now cached
    for six in (h.stiffness6 * 3.0, np.r_[0.0, h.stiffness6[1:]]):
        design = base.with_hinge(h.name, stiffness=six[:3], rotational_stiffness=six[3:])
        system = TransferSystem(design, fmax_hz=500.0)
        fresh = TransferSystem(design, fmax_hz=500.0)
        fresh.topology = build_topology(with_released(design, redundant_rigid(design)))
        assert system.order == fresh.order
        assert np.array_equal(system.evaluate(omega), fresh.evaluate(omega))
    assert TransferSystem(design).order > TransferSystem(base).order


def test_eliminating_the_constant_columns_and_rows_keeps_det_and_null_vectors():
    """S'(ω) of ufmt.mstmm.reduced (ω-independent columns and rows eliminated): det U_all /
    det S' is one constant over ω (Schur complement property), the eliminated columns are
    ω-independent at a third set of frequencies, and S''s null vectors at the roots complete
    to null vectors of U_all."""
    model = load_model(packaged_path("ufmt-prior.toml"))
    system = TransferSystem(model, fmax_hz=800.0)
    omega = 2 * np.pi * np.array([3.0, 40.0, 155.0, 420.0, 790.0])
    u = system.evaluate(omega)
    reduction = ConstantParts.of(np.concatenate([u[:2], system.evaluate(omega[:1] * 1.013)]))
    assert 0 < reduction.order < system.size
    other = system.evaluate(omega * 0.97)
    assert np.array_equal(other[:, :, reduction.constant], u[:, :, reduction.constant])
    sign_u, log_u = np.linalg.slogdet(u)
    sign_s, log_s = np.linalg.slogdet(reduced(reduction, u))
    assert np.all(sign_u * sign_s == sign_u[0] * sign_s[0])
    np.testing.assert_allclose(log_u - log_s, log_u[0] - log_s[0], rtol=0, atol=1e-11)
    f = solve_modes(model, count=12, shapes=False).frequencies_hz
    at_roots = system.evaluate(2 * np.pi * f)
    _, _, vh = np.linalg.svd(reduced(reduction, at_roots))
    z = null_vectors(reduction, at_roots, vh[:, -1, :, None])[:, :, 0]
    residual = np.linalg.norm(np.einsum("nij,nj->ni", at_roots, z), axis=1)
    scale = np.linalg.norm(at_roots, axis=(1, 2)) * np.linalg.norm(z, axis=1)
    assert np.all(residual <= 1e-12 * scale)


def test_mode_shapes_have_their_largest_translation_positive():
    """Sign convention (stable under rounding): in every mode the first translation within
    1e-6 of the largest, in body order, is positive."""
    shapes = solve_modes(load_model(packaged_path("ufmt-prior.toml")), count=30).shapes
    n = shapes.frequencies_hz.size
    t = np.concatenate(
        [v[:, :3] for v in shapes.rigid.values()]
        + [m[:, :, :3].reshape(n, -1) for _, _, m in shapes.beams.values()],
        axis=1,
    )
    first = np.argmax(np.abs(t) >= (1 - 1e-6) * np.abs(t).max(axis=1, keepdims=True), axis=1)
    assert np.all(t[np.arange(n), first] > 0)


def test_newton_null_vectors_are_null_vectors_on_a_looped_beam_model():
    """Oracle: the definition of a null vector. Two bodies joined by a beam, each on a hinge
    to ground (a loop, released directions): at every root, the row-scaled residual of the
    null vector that comes with the Newton iteration is at the level the roots' own accuracy
    allows (≤ 4e-12 at the highest root, 1e-16 at most). Errors of order δ, δ ≤ 1e-8 the last
    iterate's distance from the root, left residuals up to 7e-9 here and a shape 6 % wrong:
    the bound 1e-10 separates the two."""
    from ufmt.assembled import assembled_modes
    from ufmt.mstmm.overall import equilibrate

    def rigid(name, mass, com):
        inertia = np.diag([1.0, 2.0, 1.5]).tolist()
        return {
            "name": name,
            "kind": "rigid",
            "mass": mass,
            "center_of_mass": list(com),
            "inertia": inertia,
        }

    elastic = {"stiffness": [1e7] * 3, "rotational_stiffness": [1e6] * 3}
    partly = {"stiffness": [1e7, 0.0, 1e7], "rotational_stiffness": [0.0, 1e6, 1e6]}
    model = model_from_dict(
        {
            "name": "beam-loop",
            "body": [rigid("a", 10.0, (0, 0, 0)), beam_body("s"), rigid("b", 5.0, (L, 0, 0))],
            "hinge": [
                hinge("ga", "ground", "a", (0, 0, 0), elastic),
                hinge("as", "a", "s", (0, 0, 0), RIGID),
                hinge("sb", "s", "b", (L, 0, 0), RIGID),
                hinge("gb", "ground", "b", (L, 0, 0), partly),
            ],
        }
    )
    estimates = assembled_modes(model, fmax_hz=3300.0, shapes=False).frequencies_hz
    system, roots = certified_roots(model, 3000.0)
    assert roots.frequencies_hz.size == np.sum(estimates <= 3000.0)
    assert roots.newton == roots.frequencies_hz.size > 10
    omega = 2 * np.pi * roots.frequencies_hz
    u = system.evaluate(omega)
    r, c = equilibrate(system.evaluate(omega * OFF_ROOT))  # scaling taken off the root
    z = roots.null_vectors
    residual = np.linalg.norm(r[:, :, 0] * np.einsum("nij,nj->ni", u, z), axis=1)
    assert np.all(residual <= 1e-10 * np.linalg.norm(z / c[:, 0], axis=1))
