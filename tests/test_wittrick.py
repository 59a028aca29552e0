"""The Wittrick-Williams count J(ω) of the exact dynamic stiffness, against closed forms
(clamped-free and free-free beams, a spring-mass chain), against the assembled model's count
at fine meshes (the packaged model, the bridge example), and on repeated roots."""

import json
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla
from scipy.linalg.lapack import dsytrf
from scipy.optimize import brentq
from synthetic import axisymmetric_chain
from test_repeated_roots import rotor_dict, rotor_reference

from ufmt.assembled import assembled_modes
from ufmt.errors import ModelError
from ufmt.model.load import load_model, model_from_dict, packaged_path
from ufmt.mstmm import members, wittrick
from ufmt.mstmm.solve import solve_modes
from ufmt.mstmm.wittrick import RootCounter, inertia, negative_eigenvalues

INF = float("inf")
RIGID = {"stiffness": [INF] * 3, "rotational_stiffness": [INF] * 3}
RELEASED = {"stiffness": [0.0] * 3, "rotational_stiffness": [0.0] * 3}
E, G, RHO, L = 2.1e11, 8.1e10, 7850.0, 1.2
# a rectangular 40 x 25 mm section: two bending planes with different frequencies
B, H = 0.04, 0.025
AREA, I_Y, I_Z = B * H, B * H**3 / 12, H * B**3 / 12
J_T, J_P = 0.2287 * B * H**3, B * H * (B**2 + H**2) / 12
SECTION = {
    "area": AREA,
    "second_moment_y": I_Y,
    "second_moment_z": I_Z,
    "polar_moment": J_P,
    "torsion_constant": J_T,
}


def beam_model(hinges) -> dict:
    body = {"name": "b", "kind": "beam", "start": [0, 0, 0], "end": [L, 0, 0]}
    body |= {"density": RHO, "youngs_modulus": E, "shear_modulus": G} | SECTION
    return {"name": "beam", "body": [body], "hinge": hinges}


def closed_form_hz(bending_roots, rod_factor, count=6) -> np.ndarray:
    """Frequencies [Hz] of the beam, ascending: bending βL roots in both planes, axial and
    torsion κL = rod_factor(n) for n = 1..count; all of them below 0.9 times the lowest of
    the four families' last (so none is left out)."""
    n = np.arange(1, count + 1)
    families = [
        bending_roots**2 / L**2 * np.sqrt(E * second_moment / (RHO * AREA))
        for second_moment in (I_Y, I_Z)
    ]
    families += [rod_factor(n) / L * np.sqrt(E / RHO)]
    families += [rod_factor(n) / L * np.sqrt(G * J_T / (RHO * J_P))]
    out = np.sort(np.concatenate(families)) / (2 * np.pi)
    return out[out < 0.9 * min(f[-1] for f in families) / (2 * np.pi)]


def beta_roots(char, count=8) -> np.ndarray:
    """The first ``count`` positive roots of a characteristic function of βL."""
    x = np.linspace(0.5, 3.2 * count + 3, 20000)
    y = char(x)
    idx = np.flatnonzero(np.sign(y[1:]) != np.sign(y[:-1]))[:count]
    return np.array([brentq(char, x[i], x[i + 1], xtol=1e-14) for i in idx])


def assert_counts_match(counter: RootCounter, exact_hz: np.ndarray, rtol: float) -> None:
    """J at the geometric middles between consecutive exact frequencies (and just below the
    first) equals the number of exact frequencies below; only gaps wider than ``rtol``."""
    gaps = np.flatnonzero(exact_hz[1:] > exact_hz[:-1] * (1 + 10 * rtol))
    test_hz = np.r_[0.5 * exact_hz[0], np.sqrt(exact_hz[gaps] * exact_hz[gaps + 1])]
    expected = np.r_[0, gaps + 1]
    np.testing.assert_array_equal(counter.below(test_hz), expected)


def test_clamped_free_beam_count_and_roots_match_the_closed_form():
    """Oracle: cantilever bending 1 + cos βL cosh βL = 0 (two planes), axial and torsion
    κL = (2n - 1)π/2."""
    model = model_from_dict(
        beam_model([{"name": "root", "between": ["ground", "b"], "at": [0, 0, 0]} | RIGID])
    )
    exact = closed_form_hz(
        beta_roots(lambda x: 1 + np.cos(x) * np.cosh(x)), lambda n: (2 * n - 1) * np.pi / 2
    )
    counter = RootCounter(model)
    assert counter.rigid_body_modes == 0
    assert_counts_match(counter, exact, 1e-9)
    assert exact.size >= 12
    sol = solve_modes(model, fmax_hz=float(exact[-1]) * 1.0001)
    # the roots themselves come from the transfer matrices, which carry cosh βL (4e8 at the
    # last bending mode here, βL = 20.4): good to ~1e-8 there, as in test_mstmm's beams
    np.testing.assert_allclose(sol.frequencies_hz, exact, rtol=1e-8)
    assert sol.expected == exact.size


def test_free_free_beam_counts_six_rigid_body_modes_and_the_closed_form():
    """Oracle: free-free bending 1 - cos βL cosh βL = 0, axial and torsion κL = nπ, and the
    six rigid-body motions (a hinge with every direction released holds nothing)."""
    model = model_from_dict(
        beam_model([{"name": "none", "between": ["ground", "b"], "at": [0, 0, 0]} | RELEASED])
    )
    bending = beta_roots(lambda x: 1 - np.cos(x) * np.cosh(x))
    exact = closed_form_hz(bending, lambda n: n * np.pi)
    counter = RootCounter(model)
    assert counter.rigid_body_modes == 6
    assert_counts_match(counter, exact, 1e-9)
    assert exact.size >= 12
    sol = solve_modes(model, count=exact.size)
    np.testing.assert_allclose(sol.frequencies_hz, exact, rtol=1e-8)  # as above: cosh βL
    assert sol.rigid_body_modes == 6


def spring_chain():
    """Three point masses in a line on x springs (every other direction rigid to ground):
    the model and its exact frequencies [Hz] (eigenvalues of the chain's 3x3 (K, M))."""
    k, m = np.array([4e6, 2.5e6, 1e6]), np.array([12.0, 7.0, 3.0])
    bodies, hinges = [], []
    for i in range(3):
        at = [0.3 * i, 0, 0]
        inertia = (1e-3 * np.eye(3)).tolist()
        bodies.append(
            {
                "name": f"m{i}",
                "kind": "rigid",
                "mass": m[i],
                "center_of_mass": at,
                "inertia": inertia,
            }
        )
        spring = {"stiffness": [k[i], 0.0, 0.0], "rotational_stiffness": [0.0] * 3}
        other = "ground" if i == 0 else f"m{i - 1}"
        hinges.append({"name": f"k{i}", "between": [other, f"m{i}"], "at": at} | spring)
        guide = {"stiffness": [0.0, INF, INF], "rotational_stiffness": [INF] * 3}
        hinges.append({"name": f"guide{i}", "between": ["ground", f"m{i}"], "at": at} | guide)
    model = model_from_dict({"name": "chain", "body": bodies, "hinge": hinges})
    stiffness = np.diag(k + np.r_[k[1:], 0.0]) - np.diag(k[1:], 1) - np.diag(k[1:], -1)
    return model, np.sqrt(sla.eigh(stiffness, np.diag(m), eigvals_only=True)) / (2 * np.pi)


def test_spring_mass_chain_counts_its_eigenvalues():
    """Oracle: the eigenvalues of the chain's (K, M) (:func:`spring_chain`)."""
    model, exact = spring_chain()
    counter = RootCounter(model)
    assert counter.total_modes() == 3
    assert_counts_match(counter, exact, 1e-12)
    assert counter.below(10 * exact[-1])[0] == 3
    np.testing.assert_allclose(solve_modes(model, count=3).frequencies_hz, exact, rtol=1e-10)


def test_bisection_on_the_count_finds_the_roots_alone():
    """The fallback when Newton cannot certify a bracket: bisection on J from 1 % brackets
    reaches the chain's eigenvalues to 1e-12 (oracle as above)."""
    model, exact = spring_chain()
    counter = RootCounter(model)
    brackets = counter.brackets(2 * exact[-1], start_rtol=1e-2)
    assert np.all(brackets.hi_hz - brackets.lo_hz > 1e-3 * brackets.hi_hz)
    np.testing.assert_allclose(counter.refine(brackets.lo_hz, brackets.hi_hz), exact, rtol=1e-12)


@pytest.mark.parametrize(
    "path, fmax_hz",
    [(packaged_path(), 5000.0), (packaged_path().parents[2] / "examples" / "bridge.toml", 3000.0)],
    ids=["packaged", "bridge"],
)
def test_count_equals_the_assembled_count_at_a_fine_mesh(path, fmax_hz):
    """Oracle: the assembled model with 48 elements per beam (its frequencies converge from
    above, within ~1e-6 here), J at the middle of every gap wider than 1e-4."""
    model = load_model(path)
    fine = assembled_modes(model, fmax_hz=1.2 * fmax_hz, elements_per_beam=48, shapes=False)
    exact = fine.frequencies_hz[fine.frequencies_hz <= fmax_hz]
    counter = RootCounter(model)
    assert counter.rigid_body_modes == fine.rigid_body_modes
    assert_counts_match(counter, exact, 1e-5)
    assert counter.below(fmax_hz)[0] == exact.size


def test_repeated_roots_jump_the_count_by_their_multiplicity():
    """The isotropic rotor's bending modes are double roots: J jumps by 2 there (oracle: the
    Richardson-extrapolated assembled reference, each pair equal to 1e-9), and the
    axisymmetric chains (rigid bodies: the assembled model is exact) likewise."""
    fine = rotor_reference()
    brackets = RootCounter(model_from_dict(rotor_dict())).brackets(5000.0)
    expected = np.diff(np.r_[0, np.flatnonzero(np.diff(fine) > 1e-9 * fine[1:]) + 1, fine.size])
    np.testing.assert_array_equal(brackets.multiplicity, expected)
    assert (brackets.multiplicity == 2).sum() >= 5
    for seed in (1, 2, 3):
        model = model_from_dict(axisymmetric_chain(seed))
        exact = assembled_modes(model).frequencies_hz
        found = RootCounter(model).brackets(1.01 * exact[-1])
        np.testing.assert_array_equal(
            np.repeat(np.sqrt(found.lo_hz * found.hi_hz), found.multiplicity).size, exact.size
        )
        assert np.all(
            (np.repeat(found.lo_hz, found.multiplicity) <= exact * (1 + 1e-9))
            & (exact <= np.repeat(found.hi_hz, found.multiplicity) * (1 + 1e-9))
        )
        assert (found.multiplicity == 2).sum() >= 3


def test_member_stiffness_tends_to_the_static_frame_element():
    """At ω → 0 the exact dynamic stiffness is the static Euler-Bernoulli frame element
    (oracle: 12EI/L³, 6EI/L², 4EI/L, 2EI/L, EA/L, GJ/L); symmetric at every ω."""
    body = model_from_dict(
        beam_model([{"name": "r", "between": ["ground", "b"], "at": [0, 0, 0]} | RIGID])
    ).bodies[0]
    k = members.member_stiffness(np.array([1e-6, 3e3]), body)
    np.testing.assert_allclose(k[1], k[1].T, rtol=1e-12, atol=1e-12 * np.abs(k[1]).max())
    s = k[0]
    np.testing.assert_allclose([s[0, 0], s[3, 3]], [E * AREA / L, G * J_T / L], rtol=1e-9)
    np.testing.assert_allclose(
        [s[1, 1], s[1, 5], s[5, 5], s[5, 11]],
        np.array([12, 6 * L, 4 * L**2, 2 * L**2]) * E * I_Z / L**3,
        rtol=1e-9,
    )
    np.testing.assert_allclose(
        [s[2, 2], s[2, 4], s[4, 4]], np.array([12, -6 * L, 4 * L**2]) * E * I_Y / L**3, rtol=1e-9
    )


def test_negative_eigenvalues_match_eigvalsh_on_indefinite_matrices():
    """Oracle: the signs of numpy's eigenvalues, on random symmetric matrices with zero
    diagonals (forcing 2x2 pivots)."""
    rng = np.random.default_rng(4)
    for n in (2, 5, 17, 40):
        a = rng.standard_normal((6, n, n))
        a = a + a.transpose(0, 2, 1)
        a[::2, np.arange(n), np.arange(n)] = 0.0
        np.testing.assert_array_equal(
            negative_eigenvalues(a), (np.linalg.eigvalsh(a) < 0).sum(axis=1)
        )


def test_a_massless_mechanism_is_a_model_error():
    """A virtual body whose rotation about x nothing holds: no count is defined."""
    hub = {"stiffness": [1e8] * 3, "rotational_stiffness": [0.0, 1e6, 1e6]}
    model = model_from_dict(
        {
            "name": "m",
            "body": [
                {"name": "hub", "kind": "virtual"},
                {
                    "name": "mass",
                    "kind": "rigid",
                    "mass": 5.0,
                    "center_of_mass": [0.1, 0, 0],
                    "inertia": (0.01 * np.eye(3)).tolist(),
                },
            ],
            "hinge": [
                {"name": "a", "between": ["ground", "hub"], "at": [0, 0, 0]} | hub,
                {"name": "b", "between": ["hub", "mass"], "at": [0, 0, 0]} | hub,
            ],
        }
    )
    with pytest.raises(ModelError, match=r"body 'hub': massless mechanism.*\(rx\)"):
        RootCounter(model)


def assert_each_root_is_where_the_count_steps(model, f: np.ndarray) -> None:
    """Oracle: J (the exact dynamic stiffness, no transfer matrix) just below and above each
    distinct root found steps from the number of roots below to that plus its multiplicity."""
    distinct, first, multiplicity = np.unique(
        np.round(f / f[0], 8), return_index=True, return_counts=True
    )
    roots = f[first]
    counter = RootCounter(model)
    np.testing.assert_array_equal(counter.below(roots * (1 - 1e-8)), first)
    np.testing.assert_array_equal(counter.below(roots * (1 + 1e-8)), first + multiplicity)


@pytest.mark.slow
def test_packaged_model_first_150_modes_are_all_found():
    """count=150 (up to 108 kHz) lost 11 roots with the assembled brackets."""
    model = load_model()
    sol = solve_modes(model, count=150, shapes=False)
    assert sol.frequencies_hz.size == sol.expected == 150
    assert_each_root_is_where_the_count_steps(model, sol.frequencies_hz)


def test_packaged_model_to_20_khz_finds_every_counted_root(capsys):
    """``ufmt modes --fmax 20000`` on the packaged model: as many roots as J counts, each
    where J steps."""
    from ufmt.cli import main

    assert main(["modes", "--fmax", "20000", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    model = load_model()
    assert out["count"] == out["expected_count"] == RootCounter(model).below(20000.0)[0] >= 80
    assert_each_root_is_where_the_count_steps(model, np.array(out["frequencies_hz"]))


@pytest.mark.parametrize(
    "model",
    [model_from_dict(rotor_dict()), *(model_from_dict(axisymmetric_chain(s)) for s in (1, 3))],
    ids=["rotor", "chain1", "chain3"],
)
def test_repeated_roots_found_with_their_multiplicity(model):
    """The isotropic rotor to 10 kHz and random axisymmetric chains (every root): each double
    root twice, each root where J steps by its multiplicity."""
    fmax = 10000.0 if model.name == "rotor" else None
    sol = solve_modes(
        model, fmax_hz=fmax, count=None if fmax else int(RootCounter(model).total_modes())
    )
    assert sol.frequencies_hz.size == sol.expected
    assert np.sum(np.diff(sol.frequencies_hz) <= 1e-9 * sol.frequencies_hz[1:]) >= 3
    assert_each_root_is_where_the_count_steps(model, sol.frequencies_hz)


def test_log_det_of_the_ldlt_matches_the_lu_determinant():
    """Oracle: numpy's LU ``slogdet`` (sign and log|det|), on random symmetric matrices with
    zero diagonals (forcing 2x2 pivots): det K from the LDLᵀ's blocks, whose sign, the
    parity of the count, steers the secant that places Newton's starts."""
    rng = np.random.default_rng(5)
    for n in (2, 5, 17, 40):
        a = rng.standard_normal((6, n, n))
        a = a + a.transpose(0, 2, 1)
        a[::2, np.arange(n), np.arange(n)] = 0.0
        negative, log_det = inertia(a)
        sign, expected = np.linalg.slogdet(a)
        np.testing.assert_allclose(log_det, expected, rtol=1e-12, atol=1e-10)
        np.testing.assert_array_equal(np.where(negative % 2 == 1, -1.0, 1.0), sign)


def test_linearised_estimates_are_exact_without_beams():
    """Oracle: the spring-mass chain's (K, M) eigenvalues: without beams K(ω) = K - ω²M,
    so the linearisation that places the first J points is the model itself."""
    model, exact = spring_chain()
    estimates = RootCounter(model).nodal.estimates() / (2 * np.pi)
    np.testing.assert_allclose(estimates, exact, rtol=1e-9)


@pytest.mark.parametrize("bc", ["clamped", "free"])
def test_brackets_hold_the_closed_form_roots_with_starts_inside(bc):
    """Oracle: the beam's closed forms (cantilever 1 + cos βL cosh βL = 0, κL = (2n - 1)π/2;
    free-free 1 - cos βL cosh βL = 0, κL = nπ). Each bracket holds its root and Newton's start
    is within START_RTOL of it: here the linearisation has one element per beam, and the
    free-free beam's roots are the clamped member frequencies themselves (det K keeps its
    sign there), so the secant does not apply and bisection on J places the starts."""
    hinge = {"name": "h", "between": ["ground", "b"], "at": [0, 0, 0]}
    if bc == "clamped":
        model = model_from_dict(beam_model([hinge | RIGID]))
        char, rod = (lambda x: 1 + np.cos(x) * np.cosh(x)), (lambda n: (2 * n - 1) * np.pi / 2)
    else:
        model = model_from_dict(beam_model([hinge | RELEASED]))
        char, rod = (lambda x: 1 - np.cos(x) * np.cosh(x)), (lambda n: n * np.pi)
    exact = closed_form_hz(beta_roots(char), rod)
    found = RootCounter(model).brackets(float(exact[-1]) * 1.0001)
    np.testing.assert_array_equal(found.multiplicity, np.ones(exact.size))
    assert np.all((found.lo_hz <= exact) & (exact <= found.hi_hz))
    np.testing.assert_allclose(found.start_hz, exact, rtol=wittrick.START_RTOL)


def test_newton_starts_on_the_packaged_model_are_within_1e9_of_the_roots():
    """Oracle: bisection on J alone to 1e-13 in the same brackets (the fallback path, tested
    against the spring chain above): on the packaged model the secant on det K places every
    one of the 68 starts below 5 kHz within SECANT_RTOL of its root."""
    counter = RootCounter(load_model())
    found = counter.brackets(5000.0)
    assert found.total == 68 and np.all(found.multiplicity == 1)
    roots = counter.refine(found.lo_hz, found.hi_hz)
    np.testing.assert_allclose(found.start_hz, roots, rtol=wittrick.SECANT_RTOL)


def beam_and_tilting_block() -> dict:
    """A cantilever with a block on its tip, held rigidly along the beam only (springs
    otherwise), centre of mass off the hinge, full inertia tensor: the constraint ties a few of
    the block's coordinates to the beam's end (outer), the others stay inner and couple to
    them by mass; three small blocks on springs hang off it."""
    model = beam_model([{"name": "root", "between": ["ground", "b"], "at": [0, 0, 0]} | RIGID])
    inertia = [[0.02, 0.003, -0.001], [0.003, 0.03, 0.002], [-0.001, 0.002, 0.025]]
    block = {"name": "block", "kind": "rigid", "mass": 8.0}
    block["center_of_mass"] = [L + 0.05, 0.02, 0.03]
    model["body"].append(block | {"inertia": inertia})
    tip = {"stiffness": [INF, 3e7, 2e7], "rotational_stiffness": [4e4, 6e4, 5e4]}
    model["hinge"].append({"name": "tip", "between": ["b", "block"], "at": [L, 0, 0]} | tip)
    spring = {"stiffness": [2e7] * 3, "rotational_stiffness": [3e4] * 3}
    for k in range(3):  # more inner coordinates: small blocks on springs off the tip block
        centre = [L + 0.1 * (k + 1), 0.05, 0.0]
        mass = {"mass": 1.0 + k, "inertia": np.diag([1e-3, 2e-3, 1.5e-3]).tolist()}
        model["body"].append({"name": f"m{k}", "kind": "rigid", "center_of_mass": centre} | mass)
        at = [L + 0.1 * (k + 1), 0.0, 0.0]
        model["hinge"].append({"name": f"s{k}", "between": ["block", f"m{k}"], "at": at} | spring)
    return model


@pytest.mark.parametrize("which", ["packaged", "block", "mixed"])
def test_condensed_count_and_determinant_equal_the_full_ldlt(which):
    """Oracle: the LDLᵀ inertia and log|det| of the whole nodal K(ω) (order 78 on the packaged
    model): the count condensed onto the beams' coordinates (Haynsworth) equals it at every
    frequency, and its log|det K| differs by one constant (-2 log|det Φ|); the block model
    exercises the inner-outer mass coupling, the mixed model a single inner coordinate."""
    model = {
        "packaged": load_model,
        "block": lambda: model_from_dict(beam_and_tilting_block()),
        "mixed": lambda: load_model(Path(__file__).parent / "models" / "good_mixed.toml"),
    }[which]()
    counter = RootCounter(model)
    condensation = counter.nodal.condensation
    assert condensation.inner.size >= 1
    if which == "block":
        assert condensation.mass_coupling is not None
    hz = np.geomspace(1.0, 2e4, 400)
    negative, log_det = inertia(counter.nodal.matrix(2 * np.pi * hz))
    _, clamped, condensed_log_det, sign = counter._evaluate(hz)
    np.testing.assert_array_equal(counter.below(hz), clamped + negative - counter.rigid_body_modes)
    np.testing.assert_array_equal(sign, np.where(negative % 2 == 1, -1.0, 1.0))
    offset = condensed_log_det - log_det
    np.testing.assert_allclose(offset, offset[0], atol=1e-7 * np.abs(log_det).max())


def packaged_designs(n: int, theory: str | None = None):
    """``n`` designs of the packaged model (the head's radial stiffness x 0.7 ... 1.4);
    ``theory``: every beam's theory replaced (None: the file's)."""
    import dataclasses

    from ufmt.design import apply_design, design_value

    model = load_model()
    if theory is not None:
        bodies = tuple(
            dataclasses.replace(b, theory=theory) if b.kind == "beam" else b for b in model.bodies
        )
        model = dataclasses.replace(model, bodies=bodies)
    value = design_value(model, "head_radial_stiffness_N_m")
    return [
        apply_design(model, {"head_radial_stiffness_N_m": value * s})
        for s in np.geomspace(0.7, 1.4, n)
    ]


def test_count_of_a_batch_equals_each_designs_own_count():
    """Oracle: each design's own counter. One stacked counter over designs of one structure
    gives every design the count, brackets and Newton starts its own counter gives it."""
    designs = packaged_designs(3)
    stacked = RootCounter(designs)
    hz = np.geomspace(10.0, 5000.0, 60)
    for d, model in enumerate(designs):
        alone = RootCounter(model)
        np.testing.assert_array_equal(stacked.below(hz, d), alone.below(hz))
    together = stacked.brackets(3000.0)
    for model, found in zip(designs, together, strict=True):
        own = RootCounter(model).brackets(3000.0)
        np.testing.assert_array_equal(found.multiplicity, own.multiplicity)
        np.testing.assert_allclose(found.lo_hz, own.lo_hz, rtol=1e-12)
        np.testing.assert_allclose(found.start_hz, own.start_hz, rtol=1e-9)


def test_solve_modes_batch_equals_the_solve_of_each_design_alone():
    """Oracle: :func:`solve_modes` of each design alone. A batch of designs of one structure
    (and another structure mixed in) returns, in order, the same frequencies to 1e-10, the
    same counts and shapes."""
    from ufmt.mstmm.solve import solve_modes_batch
    from ufmt.solvers import solve_modes_batch as public_batch

    designs = packaged_designs(3)
    rotor = model_from_dict(rotor_dict())
    stack = [designs[0], rotor, designs[1], designs[2]]
    for kwargs in ({"fmax_hz": 2000.0}, {"count": 20}):
        batch = solve_modes_batch(stack, **kwargs)
        assert public_batch(stack[:2], **kwargs)[1].frequencies_hz.size == batch[1].expected
        for model, got in zip(stack, batch, strict=True):
            alone = solve_modes(model, **kwargs)
            assert got.expected == alone.expected and got.order == alone.order
            assert got.rigid_body_modes == alone.rigid_body_modes
            np.testing.assert_allclose(got.frequencies_hz, alone.frequencies_hz, rtol=1e-10)
            for body, motion in alone.shapes.rigid.items():
                scale = np.abs(motion).max()
                np.testing.assert_allclose(got.shapes.rigid[body], motion, atol=1e-8 * scale)


def test_a_designs_modes_do_not_depend_on_its_batch_to_the_last_bit():
    """Oracle: :func:`solve_modes` of each design alone, bitwise. A study's table must not
    depend on how its points are chunked (``--jobs 1`` against ``--jobs 2``): every design of
    a batch of ten, with the default basis, has exactly its own frequencies and shapes."""
    from ufmt.mstmm.solve import solve_modes_batch

    designs = packaged_designs(10)
    for model, got in zip(designs, solve_modes_batch(designs, fmax_hz=5000.0), strict=True):
        alone = solve_modes(model, fmax_hz=5000.0)
        np.testing.assert_array_equal(got.frequencies_hz, alone.frequencies_hz)
        for body, motion in alone.shapes.rigid.items():
            np.testing.assert_array_equal(got.shapes.rigid[body], motion)


def test_inertia_of_runs_of_2x2_pivots_and_singular_matrices_matches_eigvalsh():
    """Oracle: the signs of numpy's eigenvalues (and its LU ``slogdet``), on symmetric
    matrices made for the LDLᵀ's hard cases: chains of zero-diagonal pairs, whose pivots are
    runs of consecutive 2x2 blocks (ipiv < 0 four, six, ... times in a row) between 1x1
    ones, and exactly singular ones (a zero row and column: one zero eigenvalue, counted as
    not negative, log|det| = -inf)."""
    rng = np.random.default_rng(11)
    for n in (4, 8, 18, 30):  # even: a zero-diagonal chain of odd order is singular
        a = np.zeros((40, n, n))
        for m in a:  # pairs (j, j + 1) coupled only across, linked weakly to the next pair
            couple = rng.uniform(1.0, 3.0, n - 1) * rng.choice([-1.0, 1.0], n - 1)
            m[np.arange(n - 1), np.arange(1, n)] = couple * np.where(np.arange(n - 1) % 2, 0.1, 1)
        a += a.transpose(0, 2, 1)
        ones = rng.random((40, n)) < 0.2  # a few 1x1 pivots between the runs
        a[:, np.arange(n), np.arange(n)] += ones * rng.uniform(2.0, 5.0, (40, n))
        eigenvalues = np.linalg.eigvalsh(a)
        clear = np.abs(eigenvalues).min(axis=1) > 1e-8  # counts not decided by rounding
        negative, log_det = inertia(a)
        np.testing.assert_array_equal(negative[clear], (eigenvalues[clear] < 0).sum(axis=1))
        _, expected = np.linalg.slogdet(a)
        np.testing.assert_allclose(log_det[clear], expected[clear], rtol=1e-12, atol=1e-10)
        assert clear.sum() > 30
        pivots = [dsytrf(m, lower=1)[1] for m in a]
        assert max(_longest_run(p < 0) for p in pivots) >= 4  # consecutive 2x2 blocks tried
        singular = np.zeros((40, n + 1, n + 1))  # a zero first row and column added
        singular[:, 1:, 1:] = a
        negative, log_det = inertia(singular)
        np.testing.assert_array_equal(negative[clear], (eigenvalues[clear] < 0).sum(axis=1))
        assert np.all(log_det == -np.inf)


def _longest_run(flags) -> int:
    """The longest run of True in ``flags``."""
    longest = run = 0
    for flag in flags:
        run = run + 1 if flag else 0
        longest = max(longest, run)
    return longest


@pytest.mark.parametrize("which", ["packaged", "block"])
def test_sharpened_starts_are_within_secant_rtol_and_the_brackets_unchanged(which, monkeypatch):
    """Oracle: bisection on J alone to 1e-13 in the same brackets (:meth:`refine`) and the
    brackets of the bisection alone (the secant left out): on three designs of
    the packaged model and on the beam with its tilting block, every start lies within
    SECANT_RTOL of its root, the brackets are those of the bisection (the secant only
    places the starts), and the secant certifies most roots in two steps: on the packaged
    model with Euler-Bernoulli spindle beams at most 3.5 J points per root and 7 passes (the
    pair at ±GUARD closes a bracket as soon as a step is short; regula falsi alone took 3.9
    and 10 there). The packaged model's Timoshenko spindle (its members' count by halving)
    takes 3.54 points per root in 12 passes: a cost recorded in docs/benchmarks.md, not an
    accuracy (the starts and brackets are checked to their tolerances all the same)."""
    if which == "packaged":
        designs, top = packaged_designs(3, theory="euler-bernoulli"), 5000.0
    else:
        designs, top = [model_from_dict(beam_and_tilting_block())], 3000.0
    counter = RootCounter(designs)
    calls = []
    sharpen = RootCounter._sharpen

    def counted(self, lo, hi, design, retry=True):
        evaluate = self._evaluate
        self._evaluate = lambda hz, d=None: calls.append(np.size(hz)) or evaluate(hz, d)
        try:
            return sharpen(self, lo, hi, design, retry)
        finally:
            del self._evaluate

    monkeypatch.setattr(RootCounter, "_sharpen", counted)
    found = counter.brackets(top)
    found = found if isinstance(found, list) else [found]
    monkeypatch.setattr(RootCounter, "_sharpen", lambda self, lo, hi, d: (lo, hi, lo))
    plain = RootCounter(designs).brackets(top)  # the bisection's brackets alone
    plain = plain if isinstance(plain, list) else [plain]
    for d, (got, bisected) in enumerate(zip(found, plain, strict=True)):
        np.testing.assert_array_equal(got.lo_hz, bisected.lo_hz)
        np.testing.assert_array_equal(got.hi_hz, bisected.hi_hz)
        single = got.multiplicity == 1
        roots = counter.refine(got.lo_hz[single], got.hi_hz[single], design=d)
        np.testing.assert_allclose(got.start_hz[single], roots, rtol=wittrick.SECANT_RTOL)
    if which == "packaged":
        assert sum(calls) <= 3.5 * sum(b.total for b in found) and len(calls) <= 7
