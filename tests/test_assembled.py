"""Assembled mass-stiffness model ("ordinary method") against closed forms and properties."""

import math

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.optimize as so
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from ufmt.assembled import assemble, assembled_modes
from ufmt.assembled.mesh import (
    elements_for,
    mesh_error,
)
from ufmt.errors import ModelError
from ufmt.kinds.euler_bernoulli import ERROR_DIVISOR as BENDING_ERROR_DIVISOR
from ufmt.kinds.rod import ERROR_DIVISOR as LINEAR_ERROR_DIVISOR
from ufmt.model.schema import Beam, Hinge, Model, RigidBody, VirtualBody, frozen_array

INF = math.inf
STEEL = dict(density=7850.0, youngs_modulus=2.1e11, shear_modulus=8.1e10)


def hinge(name, a, b, at, k, kr):
    zero = frozen_array([0.0, 0.0, 0.0])
    return Hinge(name, (a, b), frozen_array(at), frozen_array(k), frozen_array(kr), zero, zero)


def rigid(name, mass, com, inertia):
    return RigidBody(name, mass, frozen_array(com), frozen_array(inertia, (3, 3)))


def round_beam(name, start, end, d=0.05, **overrides):
    a, i = math.pi * d**2 / 4, math.pi * d**4 / 64
    section = dict(area=a, second_moment_y=i, second_moment_z=i, polar_moment=2 * i)
    section["torsion_constant"] = 2 * i
    props = {**STEEL, **section, **overrides}
    return Beam(name, frozen_array(start), frozen_array(end), **props)


def closed_form_roots(equation, guesses):
    return [so.brentq(equation, g - 0.5, g + 0.5, xtol=1e-15) for g in guesses]


# beta L of a cantilever (cos cosh = -1) and of a free-free beam (cos cosh = 1)
CANTILEVER = closed_form_roots(lambda x: math.cos(x) * math.cosh(x) + 1, [1.875, 4.694, 7.855])
FREE_FREE = closed_form_roots(lambda x: math.cos(x) * math.cosh(x) - 1, [4.730, 7.853, 10.996])


def bending_hz(beam, beta_l):
    """Euler-Bernoulli bending frequency [Hz] for beta*L (round section)."""
    ei_over_mass = beam.youngs_modulus * beam.second_moment_z / (beam.density * beam.area)
    return (beta_l / beam.length) ** 2 * math.sqrt(ei_over_mass) / (2 * math.pi)


def fixed_free_rod_hz(beam, n):
    """n-th axial and torsional frequency [Hz] of a fixed-free rod: (2n-1) pi / 2."""
    c_axial = math.sqrt(beam.youngs_modulus / beam.density)
    c_torsion = math.sqrt(
        beam.shear_modulus * beam.torsion_constant / (beam.density * beam.polar_moment)
    )
    wave = (2 * n - 1) * math.pi / (2 * beam.length)
    return wave * c_axial / (2 * math.pi), wave * c_torsion / (2 * math.pi)


def skewed_cantilever(length=1.0, d=0.05, **overrides):
    start = np.array([0.1, 0.2, 0.3])
    end = start + length * np.array([1.0, 2.0, 2.0]) / 3.0
    beam = round_beam("shaft", start, end, d, **overrides)
    clamp = hinge("clamp", "ground", "shaft", start, [INF] * 3, [INF] * 3)
    return beam, Model("cantilever", (beam,), (clamp,))


def test_literature_beta_l_values():
    """The brentq roots reproduce the published beta*L to their 9 digits."""
    assert np.allclose(CANTILEVER, [1.87510407, 4.69409113, 7.85475744], rtol=0, atol=6e-9)
    assert np.allclose(FREE_FREE, [4.73004074, 7.85320462, 10.99560784], rtol=0, atol=6e-9)


def test_two_mass_chain_matches_quadratic():
    """ground -k1- m1 -k2- m2 along x; every other direction rigid (closed form 2x2)."""
    m1, m2, k1, k2 = 3.0, 5.0, 2.0e6, 7.0e5
    eye = np.eye(3)
    model = Model(
        "chain",
        (rigid("m1", m1, [0, 0, 0], eye), rigid("m2", m2, [1, 0, 0], 2 * eye)),
        (
            hinge("h1", "ground", "m1", [-0.5, 0.1, 0], [k1, INF, INF], [INF] * 3),
            hinge("h2", "m1", "m2", [0.5, 0, 0.2], [k2, INF, INF], [INF] * 3),
        ),
    )
    modes = assembled_modes(model)
    # det([[k1 + k2 - m1 w2, -k2], [-k2, k2 - m2 w2]]) = 0
    a, b, c = m1 * m2, -(m1 * k2 + m2 * (k1 + k2)), k1 * k2
    w2 = np.sort([(-b - s * math.sqrt(b * b - 4 * a * c)) / (2 * a) for s in (1, -1)])
    assert modes.rigid_body_modes == 0
    assert np.allclose(modes.frequencies_hz, np.sqrt(w2) / (2 * math.pi), rtol=1e-12)
    x1, x2 = modes.body_motion("m1")[:, 0], modes.body_motion("m2")[:, 0]
    assert np.allclose(x1 / x2, (k2 - m2 * w2) / k2, rtol=1e-9)  # row 2 of the 2x2 problem
    assert np.allclose(modes.body_motion("m1")[:, 1:], 0.0, atol=1e-15)


def test_rigid_body_on_springs_at_its_centre_of_mass():
    """Uncoupled: omega = sqrt(k/m) and sqrt(k'/J) for a diagonal inertia tensor."""
    m, inertia = 40.0, np.array([2.0, 3.0, 5.0])
    k, kr = np.array([1e6, 2e6, 3e6]), np.array([1e4, 4e4, 9e4])
    model = Model(
        "box",
        (rigid("box", m, [0.3, -0.2, 1.0], np.diag(inertia)),),
        (hinge("mount", "ground", "box", [0.3, -0.2, 1.0], k, kr),),
    )
    expected = np.sort(np.concatenate([np.sqrt(k / m), np.sqrt(kr / inertia)])) / (2 * math.pi)
    assert np.allclose(assembled_modes(model).frequencies_hz, expected, rtol=1e-12)


def test_full_inertia_tensor_gives_principal_moments():
    """Isotropic rotational springs: omega^2 = k'/J_i with J_i the principal moments."""
    inertia = np.array([[4.0, 0.5, -0.3], [0.5, 6.0, 0.8], [-0.3, 0.8, 9.0]])
    kr = 5e4
    model = Model(
        "tilted",
        (rigid("body", 10.0, [0, 0, 0], inertia),),
        (hinge("mount", "ground", "body", [0, 0, 0], [INF] * 3, [kr] * 3),),
    )
    expected = np.sqrt(kr / np.linalg.eigvalsh(inertia))[::-1] / (2 * math.pi)
    assert np.allclose(assembled_modes(model).frequencies_hz, expected, rtol=1e-12)


def test_cantilever_converges_from_above_at_h4_rate():
    """Bending errors > 0 fall 16x per mesh doubling; rod modes 4x; the documented estimate."""
    beam, model = skewed_cantilever()
    bending = np.array([bending_hz(beam, bl) for bl in CANTILEVER])
    axial, torsion = fixed_free_rod_hz(beam, 1)
    errors = []
    for n in (4, 8, 16, 32):
        f = assembled_modes(model, elements_per_beam=n).frequencies_hz
        # spectrum: two bending planes (round section), torsion at 803 Hz, axial at 1293 Hz
        assert f[6] == pytest.approx(torsion, rel=0.01)
        pairs = f[:6].reshape(3, 2)
        assert np.allclose(pairs[:, 0], pairs[:, 1], rtol=1e-12)  # repeated roots
        rod = [f[6] / torsion - 1, f[np.argmin(abs(f - axial))] / axial - 1]
        errors.append(np.concatenate([pairs[:, 0] / bending - 1, rod]))
    errors = np.array(errors)
    assert np.all(errors > 0)
    rates = np.log2(errors[:-1] / errors[1:])
    assert np.all(np.abs(rates[1:, :3] - 4.0) < 0.1), rates  # bending: h^4
    assert np.all(np.abs(rates[:, 3:] - 2.0) < 0.01), rates  # linear axial/torsion: h^2
    h = beam.length / 32
    estimate_bending = (np.array(CANTILEVER) * h / beam.length) ** 4 / BENDING_ERROR_DIVISOR
    estimate_rod = (math.pi / 2 * h / beam.length) ** 2 / LINEAR_ERROR_DIVISOR
    assert np.all((errors[-1, :3] / estimate_bending > 0.99) & (errors[-1, :3] <= estimate_bending))
    assert np.allclose(errors[-1, 3:], estimate_rod, rtol=1e-3)


def test_cantilever_fine_mesh_reaches_1e8():
    """128 elements: the three bending pairs within 1e-8 of the closed form."""
    beam, model = skewed_cantilever()
    f = assembled_modes(model, elements_per_beam=128).frequencies_hz
    bending = np.array([bending_hz(beam, bl) for bl in CANTILEVER])
    assert np.allclose(f[:6].reshape(3, 2), bending[:, None], rtol=1e-8, atol=0)


def test_automatic_mesh_meets_its_tolerance():
    """elements_for(fmax, rtol): every mode below fmax within rtol, from above."""
    # slender, torsionally stiff section, so that bending sets the mesh
    beam, model = skewed_cantilever(d=0.01, torsion_constant=100 * math.pi * 0.01**4 / 32)
    bending = np.array([bending_hz(beam, bl) for bl in CANTILEVER])
    fmax, rtol = 1.01 * bending[-1], 1e-6
    modes = assembled_modes(model, fmax_hz=fmax, rtol=rtol)
    n = modes.assembled.elements_per_beam["shaft"]
    assert n == elements_for(beam, fmax, rtol) < 64
    assert modes.assembled.mesh_error["shaft"] <= rtol
    errors = modes.frequencies_hz.reshape(3, 2) / bending[:, None] - 1
    assert np.all((errors > 0) & (errors <= rtol))
    assert mesh_error(beam, n - 1, fmax) > rtol  # and it is the fewest elements


def test_automatic_mesh_cap_is_reported():
    beam, model = skewed_cantilever()
    am = assemble(model, fmax_hz=700.0, max_elements_per_beam=4)
    assert am.elements_per_beam == {"shaft": 4}
    assert am.mesh_error["shaft"] == mesh_error(beam, 4, 700.0) > 1e-3


def test_free_free_beam():
    """Six rigid-body modes reported apart; bending beta L 4.730, 7.853, 10.996 from above."""
    beam = round_beam("bar", [0, 0, 0], [0, 0.8, 0.6])
    model = Model("free", (beam,), (hinge("none", "ground", "bar", [0, 0, 0], [0] * 3, [0] * 3),))
    n = 64
    modes = assembled_modes(model, elements_per_beam=n)
    assert modes.rigid_body_modes == 6
    f = modes.frequencies_hz[:6].reshape(3, 2)
    errors = f / np.array([bending_hz(beam, bl) for bl in FREE_FREE])[:, None] - 1
    estimate = (np.array(FREE_FREE) / n) ** 4 / BENDING_ERROR_DIVISOR
    assert np.all((errors > 0) & (errors <= estimate[:, None]))
    # elastic modes carry no momentum: M-orthogonal to the rigid translations
    am = modes.assembled
    translation = np.zeros((am.K.shape[0], 3))
    translation[am.body_dofs["bar"][:, :3].ravel()] = np.tile(np.eye(3), (n + 1, 1))
    momentum = modes.shapes @ am.M @ translation
    assert np.max(np.abs(momentum)) < 1e-12 * math.sqrt(beam.mass)


def test_virtual_body_between_springs_in_series():
    """ground -k1- hub -k2- body, all at the centre of mass: 1/k = 1/k1 + 1/k2."""
    m, j = 12.0, np.array([0.4, 0.5, 0.6])
    k1, k2 = np.array([1e6, 2e6, 3e6]), np.array([4e6, 1e6, 6e6])
    r1, r2 = np.array([1e3, 2e3, 3e3]), np.array([3e3, 2e3, 1e3])
    at = [0.2, 0.0, 0.1]
    model = Model(
        "series",
        (VirtualBody("hub"), rigid("body", m, at, np.diag(j))),
        (hinge("a", "ground", "hub", at, k1, r1), hinge("b", "hub", "body", at, k2, r2)),
    )
    k = 1 / (1 / k1 + 1 / k2)
    kr = 1 / (1 / r1 + 1 / r2)
    expected = np.sort(np.sqrt(np.concatenate([k / m, kr / j]))) / (2 * math.pi)
    modes = assembled_modes(model)
    assert np.allclose(modes.frequencies_hz, expected, rtol=1e-12)
    # the hub moves k2/(k1+k2) of the body's motion in each direction
    hub, body = modes.body_motion("hub"), modes.body_motion("body")
    share = np.concatenate([k2 / (k1 + k2), r2 / (r1 + r2)])
    assert np.allclose(hub, body * share, atol=1e-12 * np.abs(body).max())


def test_released_and_rigid_directions_with_lever_arm():
    """Hinge below the centre of mass: x spring, y released, z rigid; ry spring, rx rz rigid.

    Free coordinates r_x, r_y, theta_y; r_y strains nothing (one zero mode). Hinge-point motion
    in x is r_x - a theta_y, so K = [[k, -k a], [-k a, k a^2 + k']], M = diag(m, J_y).
    """
    m, jy, k, kr, a = 20.0, 0.7, 3e5, 2e4, 0.25
    model = Model(
        "lever",
        (rigid("body", m, [0, 0, a], np.diag([0.5, jy, 0.9])),),
        (hinge("pivot", "ground", "body", [0, 0, 0], [k, 0, INF], [INF, kr, INF]),),
    )
    modes = assembled_modes(model)
    stiffness = np.array([[k, -k * a], [-k * a, k * a * a + kr]])
    w2 = sla.eigh(stiffness, np.diag([m, jy]), eigvals_only=True)
    assert modes.rigid_body_modes == 1
    assert np.allclose(modes.frequencies_hz, np.sqrt(w2) / (2 * math.pi), rtol=1e-12)
    motion = modes.body_motion("body")
    assert np.allclose(motion[:, [1, 2, 3, 5]], 0.0, atol=1e-14)


def mixed_model():
    """Rigid base, round shaft (one rotation released), virtual hub, explicit-section arm."""
    base = rigid("base", 250.0, [0, 0, -0.1], [[20, 0.5, 0], [0.5, 22, 0], [0, 0, 30]])
    shaft = round_beam("shaft", [0, 0, 0], [0, 0, 0.5], d=0.05)
    arm = Beam(
        "arm",
        frozen_array([0, 0, 0.5]),
        frozen_array([0.3, 0, 0.5]),
        density=2700.0,
        youngs_modulus=7.0e10,
        shear_modulus=2.6e10,
        area=1.2e-3,
        second_moment_y=4.0e-7,
        second_moment_z=9.0e-7,
        polar_moment=1.3e-6,
        torsion_constant=1.3e-6,
        orientation=frozen_array([0, 1, 1]),
    )
    hinges = (
        hinge("h_ground", "ground", "base", [0, 0, -0.2], [1e9, 1e9, 2e9], [1e8] * 3),
        hinge("h_shaft", "base", "shaft", [0, 0, 0], [INF] * 3, [INF, INF, 0]),
        hinge("h_hub", "shaft", "hub", [0, 0, 0.5], [5e8, 5e8, INF], [0, 0, 0]),
        hinge("h_arm", "hub", "arm", [0, 0, 0.5], [INF] * 3, [INF] * 3),
    )
    return Model("mixed", (base, shaft, VirtualBody("hub"), arm), hinges)


def test_mixed_model_shapes_are_mass_orthonormal_and_satisfy_everything():
    """shapes^T M shapes = I, shapes^T K shapes = diag(omega^2), constraints hold."""
    modes = assembled_modes(mixed_model(), elements_per_beam=6)
    am, shapes = modes.assembled, modes.shapes
    omega2 = (2 * math.pi * modes.frequencies_hz) ** 2
    assert np.allclose(shapes @ am.M @ shapes.T, np.eye(len(shapes)), atol=1e-9)
    stiffness = shapes @ am.K @ shapes.T
    assert np.allclose(stiffness, np.diag(omega2), atol=1e-9 * omega2.max())
    scale = np.abs(shapes).max()
    assert np.max(np.abs(am.constraints @ shapes.T)) < 1e-12 * scale
    # released rotations: the shaft spins about z on the base (1), and hub + arm pivot freely
    # about the shaft's top in all three directions (3)
    assert modes.rigid_body_modes == 4
    assert np.allclose(am.deformation.T @ am.deformation, am.K, atol=1e-12 * np.abs(am.K).max())


def textbook_spectrum(am):
    """Independent algebra (as a textbook would): orthonormal null space of the constraints,
    eigenbasis split of the projected mass, Schur complement, scipy.linalg.eigh.
    Returns every omega^2, zero modes included, ascending."""
    n = sla.null_space(am.constraints) if len(am.constraints) else np.eye(len(am.K))
    if n.shape[1] == 0:  # the constraints hold every dof (seed 41562): no motion, no mode
        return np.empty(0)
    k, m = n.T @ am.K @ n, n.T @ am.M @ n
    mu, q = np.linalg.eigh(m)
    heavy = mu > 1e-12 * mu.max()
    kq = q.T @ k @ q
    kmm, kms, kss = kq[np.ix_(heavy, heavy)], kq[np.ix_(heavy, ~heavy)], kq[np.ix_(~heavy, ~heavy)]
    k_red = kmm - kms @ np.linalg.solve(kss, kms.T)
    return sla.eigh(k_red, np.diag(mu[heavy]), eigvals_only=True)


def textbook_modes(am):
    """(omega^2 of the elastic modes, number of zero modes) of :func:`textbook_spectrum`."""
    w2 = textbook_spectrum(am)
    zero = w2 < 1e-9 * w2.max(initial=0.0)
    return w2[~zero], int(zero.sum())


def test_matches_textbook_eigh_on_a_coarse_mesh():
    modes = assembled_modes(mixed_model(), elements_per_beam=3)
    w2, zero_modes = textbook_modes(modes.assembled)
    assert zero_modes == modes.rigid_body_modes
    assert np.allclose(modes.frequencies_hz, np.sqrt(w2) / (2 * math.pi), rtol=1e-8)


def test_frequencies_without_shapes_are_the_singular_values_alone():
    """shapes=False (the MSTMM's estimates) returns the same frequencies as the full
    solution (same matrix, singular values with and without vectors) and no shapes."""
    full = assembled_modes(mixed_model(), elements_per_beam=3)
    alone = assembled_modes(mixed_model(), elements_per_beam=3, shapes=False)
    assert alone.shapes is None
    assert alone.rigid_body_modes == full.rigid_body_modes
    assert np.allclose(alone.frequencies_hz, full.frequencies_hz, rtol=1e-12, atol=0)


def random_model(seed):
    """Rigid bodies and virtual hubs in a tree plus loops (some through ground); hinge
    directions released, rigid or springs of 1e4..1e8 (none released on a hub)."""
    rng = np.random.default_rng(seed)
    bodies, hinges = [], []
    n_rigid, n_virtual = rng.integers(1, 5), rng.integers(0, 3)
    for i in range(n_rigid):
        a = rng.normal(size=(3, 3))
        inertia = a @ a.T + 0.1 * np.eye(3)
        bodies.append(rigid(f"r{i}", rng.uniform(1, 100), rng.normal(size=3), inertia))
    rigid_names = ["ground"] + [b.name for b in bodies]

    def directions(allow_release):
        k = 10 ** rng.uniform(4, 8, size=6)
        k[rng.random(6) < 0.2] = INF
        if allow_release:
            k[rng.random(6) < 0.2] = 0.0
        return k

    for i in range(1, n_rigid + 1):  # tree over the rigid bodies
        k = directions(True)
        other = rigid_names[rng.integers(0, i)]
        hinges.append(hinge(f"t{i}", other, rigid_names[i], rng.normal(size=3), k[:3], k[3:]))
    for i in range(rng.integers(0, 3)):  # loops
        a, b = rng.choice(len(rigid_names), size=2, replace=False)
        k = directions(True)
        hinges.append(
            hinge(f"l{i}", rigid_names[a], rigid_names[b], rng.normal(size=3), k[:3], k[3:])
        )
    for i in range(n_virtual):  # hubs between two rigid bodies (or ground)
        bodies.append(VirtualBody(f"v{i}"))
        point = rng.normal(size=3)
        for j, other in enumerate(rng.choice(rigid_names, size=2, replace=False)):
            k = directions(False)
            hinges.append(hinge(f"v{i}{j}", other, f"v{i}", point, k[:3], k[3:]))
    return Model(f"random {seed}", tuple(bodies), tuple(hinges))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
@example(seed=38)  # every massive dof constrained: no mode
@example(seed=41562)  # every dof constrained: no motion at all
def test_random_rigid_models_match_textbook_eigh(seed):
    model = random_model(seed)
    modes = assembled_modes(model)
    # eigh resolves omega^2 only to ~eps * max(omega^2): a near-mechanism between rounding
    # level (1e-13) and 1e-8 of the stiffest mode can be neither told from a zero mode nor
    # checked to 1e-7 by this reference (e.g. seed 4064: a 5 mHz mode at 1e-10)
    spectrum = textbook_spectrum(modes.assembled)
    # the constraints may leave no massive dof at all (seed 38): then no mode, none found
    ratio = spectrum / spectrum.max(initial=np.finfo(float).tiny)
    assume(not np.any((ratio > 1e-13) & (ratio < 1e-8)))
    w2, zero_modes = textbook_modes(modes.assembled)
    assert modes.rigid_body_modes == zero_modes
    assert np.allclose(modes.frequencies_hz, np.sqrt(w2) / (2 * math.pi), rtol=1e-7)
    shapes, am = modes.shapes, modes.assembled
    assert np.allclose(shapes @ am.M @ shapes.T, np.eye(len(shapes)), atol=1e-9)


def test_very_soft_mode_beside_a_stiff_beam_is_not_a_rigid_mode():
    """A 1.6 mHz mount next to a finely meshed beam (lambda_max ~ 1e16) stays a frequency."""
    m, k = 1e4, 1.0
    beam, _ = skewed_cantilever()
    model = Model(
        "soft",
        (rigid("block", m, [5, 0, 0], np.eye(3) * 1e3), beam),
        (
            hinge("mount", "ground", "block", [5, 0, 0], [k, INF, INF], [INF] * 3),
            hinge("clamp", "ground", "shaft", beam.start, [INF] * 3, [INF] * 3),
        ),
    )
    modes = assembled_modes(model, elements_per_beam=64)
    assert modes.rigid_body_modes == 0
    assert modes.frequencies_hz[0] == pytest.approx(math.sqrt(k / m) / (2 * math.pi), rel=1e-9)


def test_local_axes_follow_the_orientation_vector():
    """second_moment_z bends in the local x-y plane; local y = orientation (default global z)."""
    start, end = [0, 0, 0], [1, 0, 0]
    weak = dict(second_moment_z=1e-9, second_moment_y=1e-7)
    for orientation, direction in ((None, 2), (frozen_array([0, 1, 0]), 1)):
        beam = round_beam("b", start, end, orientation=orientation, **weak)
        model = Model("b", (beam,), (hinge("c", "ground", "b", start, [INF] * 3, [INF] * 3),))
        tip = assembled_modes(model, elements_per_beam=8, count=1).body_motion("b")[0, -1]
        assert np.argmax(np.abs(tip[:3])) == direction


def test_fmax_and_count_select_the_lowest_modes():
    beam, model = skewed_cantilever()
    all_modes = assembled_modes(model, elements_per_beam=8).frequencies_hz
    assert np.array_equal(
        assembled_modes(model, count=3, elements_per_beam=8).frequencies_hz, all_modes[:3]
    )
    below = assembled_modes(model, fmax_hz=500.0, elements_per_beam=8).frequencies_hz
    assert np.array_equal(below, all_modes[all_modes <= 500.0])
    refined = assembled_modes(model, count=2)  # mesh set by a first solution's 2nd mode
    assert refined.assembled.elements_per_beam["shaft"] > 8
    assert np.allclose(refined.frequencies_hz, bending_hz(beam, CANTILEVER[0]), rtol=1e-8)


def test_rigidly_clamped_body_has_no_modes():
    model = Model(
        "welded",
        (rigid("b", 1.0, [0, 0, 0], np.eye(3)),),
        (hinge("w", "ground", "b", [1, 0, 0], [INF] * 3, [INF] * 3),),
    )
    modes = assembled_modes(model)
    assert modes.frequencies_hz.shape == (0,) and modes.rigid_body_modes == 0


def test_massless_mechanism_is_a_model_error():
    """A virtual hub whose x-rotation is released on both of its hinges."""
    model = Model(
        "loose hub",
        (VirtualBody("hub"), rigid("body", 1.0, [0, 0, 0], np.eye(3))),
        (
            hinge("a", "ground", "hub", [0, 0, 0], [1e6] * 3, [0, 1e3, 1e3]),
            hinge("b", "hub", "body", [0, 0, 0], [1e6] * 3, [0, 1e3, 1e3]),
        ),
    )
    with pytest.raises(ModelError, match=r"body 'hub': massless mechanism.*\(rx\)"):
        assembled_modes(model)


def test_stiffness_independent_parts_are_shared_and_give_the_fresh_solution(monkeypatch):
    """A design that changes a stiffness value reuses the cached mesh, mass matrix, beam
    elements and hinge maps (the frame), bases, zero-mode count and mass factor; its K,
    deformation rows, frequencies and shapes equal those with the caches emptied (bitwise)."""
    from ufmt.assembled import matrices, solve
    from ufmt.model.load import load_model, packaged_path

    base = load_model(packaged_path("ufmt-prior.toml"))
    h = next(h for h in base.hinges if np.all(np.isfinite(h.stiffness6) & (h.stiffness6 > 0)))
    six = 2.5 * h.stiffness6
    design = base.with_hinge(h.name, stiffness=six[:3], rotational_stiffness=six[3:])
    assembled_modes(base, count=20, elements_per_beam=6)
    kept = len(solve._STRUCTURES)
    built = []
    monkeypatch.setattr(
        matrices, "_frame", lambda *a: built.append(a) or pytest.fail("frame rebuilt")
    )
    shared = assembled_modes(design, count=20, elements_per_beam=6)
    shared_am = assemble(design, elements_per_beam=6)
    assert len(solve._STRUCTURES) == kept and not built  # cache hits
    monkeypatch.undo()
    solve._STRUCTURES.clear()
    matrices._FRAMES.clear()
    fresh_am = assemble(design, elements_per_beam=6)
    for name in ("K", "M", "deformation", "constraints", "spring_directions", "massless"):
        assert np.array_equal(getattr(shared_am, name), getattr(fresh_am, name)), name
    fresh = assembled_modes(design, count=20, elements_per_beam=6)
    assert np.array_equal(shared.frequencies_hz, fresh.frequencies_hz)
    assert np.array_equal(shared.shapes, fresh.shapes)
    assert shared.rigid_body_modes == fresh.rigid_body_modes
