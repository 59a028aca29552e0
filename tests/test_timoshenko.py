"""The Timoshenko beam (shear deformation and rotary inertia): its formulations and its keys.

Oracles: the closed-form frequencies of a simply supported Timoshenko beam (Timoshenko 1921:
for k = nπ/L the lower root of ρIρA/(κGA) ω⁴ - (ρA + k²(ρI + EIρA/κGA)) ω² + EI k⁴ = 0);
the Euler-Bernoulli formulations (Krylov-Duncan closed forms) as κGA → ∞, ρI → 0, and the
slender limit, whose gap closes as (D/L)²; a finite-element reference converged by
Richardson extrapolation at the element's observed rate; the zeros of the clamped-clamped
determinant (det of the transfer's displacement-from-force block) for the clamped count;
and Cowper's (1966) shear coefficient of a circle (every kind's and theory's three
formulations against each other: tests/test_kind_formulations.py).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from ufmt.assembled import assembled_modes
from ufmt.cli import main
from ufmt.errors import ModelError
from ufmt.kinds.timoshenko import Plane, cowper_circle, expm_batched
from ufmt.model.load import load_model, load_model_text
from ufmt.model.schema import Beam
from ufmt.model.write import model_to_toml
from ufmt.mstmm import elements
from ufmt.mstmm.members import member_stiffness
from ufmt.mstmm.modes import beam_shape, kinetic_terms
from ufmt.mstmm.overall import TransferSystem
from ufmt.mstmm.solve import solve_modes

E, G, RHO = 2.1e11, 8.1e10, 7850.0  # steel [Pa, Pa, kg/m^3]
CANTILEVER = "examples/timoshenko-cantilever.toml"


def beam_text(length, diameter, ends, theory="timoshenko", extra=""):
    """A beam along x with hinges ``ends`` (rotational stiffness at both ends) to ground."""
    hinges = "".join(
        f"""
[[hinge]]
name = "h{i}"
between = ["ground", "b"]
at = [{x}, 0.0, 0.0]
stiffness = [inf, inf, inf]
rotational_stiffness = {rot}
"""
        for i, (x, rot) in enumerate(zip((0.0, length), ends, strict=True))
        if rot is not None
    )
    return f"""name = "beam"
[[body]]
name = "b"
kind = "beam"
start = [0.0, 0.0, 0.0]
end = [{length}, 0.0, 0.0]
density = {RHO}
youngs_modulus = {E}
shear_modulus = {G}
diameter = {diameter}
theory = "{theory}"
{extra}
{hinges}"""


PINNED = "[inf, 0.0, 0.0]"  # bending rotations free, torsion held
CLAMPED = "[inf, inf, inf]"


def simply_supported_hz(length, diameter, kappa, n):
    """Closed-form bending frequency [Hz] of mode n of a simply supported Timoshenko beam."""
    a, i = math.pi * diameter**2 / 4, math.pi * diameter**4 / 64
    kga, k = kappa * G * a, n * math.pi / length
    c2 = RHO * i * RHO * a / kga
    c1 = RHO * a + k * k * (RHO * i + E * i * RHO * a / kga)
    c0 = E * i * k**4
    w2 = (c1 - math.sqrt(c1 * c1 - 4 * c2 * c0)) / (2 * c2)
    return math.sqrt(w2) / (2 * math.pi)


def test_simply_supported_frequencies_match_the_closed_form():
    length, diameter = 0.6, 0.12  # L/D = 5: shear matters
    model = load_model_text(beam_text(length, diameter, (PINNED, PINNED)), "ss.toml")
    kappa = model.body("b").shear_coefficient
    f = solve_modes(model, fmax_hz=1.05 * simply_supported_hz(length, diameter, kappa, 3))
    found = f.frequencies_hz
    for n in (1, 2, 3):
        exact = simply_supported_hz(length, diameter, kappa, n)
        close = np.abs(found - exact) <= 1e-9 * exact
        assert np.count_nonzero(close) == 2, (n, exact, found)  # one per bending plane
    eb = simply_supported_hz(length, diameter, 1e12, 1)  # κ → ∞ (rotary inertia kept)
    assert found[0] < eb


def test_cantilever_matches_a_converged_finite_element_reference():
    model = load_model(CANTILEVER)
    exact = solve_modes(model, count=6).frequencies_hz
    fe = [assembled_modes(model, count=6, elements_per_beam=n).frequencies_hz for n in (8, 16, 32)]
    errors = [f - exact for f in fe]
    assert all(np.all(e > 0) for e in errors)  # consistent mass: upper bounds
    bending = [0, 1, 4, 5]  # the two bending pairs (torsion and axial between)
    rate = np.log2(errors[1][bending] / errors[2][bending])
    assert np.all(np.abs(rate - rate[0]) < 0.05) and rate.min() > 1.9  # converging, one rate
    limit = fe[2] + (fe[2] - fe[1]) / (2.0 ** rate.mean() - 1.0)  # Richardson
    np.testing.assert_allclose(exact[bending], limit[bending], rtol=2e-6)


def test_the_cli_gives_the_timoshenko_bending_frequencies(capsys):
    assert main(["modes", CANTILEVER, "--json", "--count", "6"]) == 0
    out = json.loads(capsys.readouterr().out)
    model = load_model(CANTILEVER)
    assert model.body("shaft").shear_coefficient == 0.9
    reference = solve_modes(model, count=6).frequencies_hz
    np.testing.assert_allclose(out["frequencies_hz"], reference, rtol=1e-12)
    eb = load_model_text(
        open(CANTILEVER, encoding="utf-8")
        .read()
        .replace('"timoshenko"', '"euler-bernoulli"')
        .replace("shear_coefficient = 0.9", ""),
        "eb.toml",
    )
    first_eb = solve_modes(eb, count=1).frequencies_hz[0]
    # Euler-Bernoulli cantilever: (1.8751)² / (2π L²) sqrt(EI / ρA)
    closed = 1.87510407**2 / (2 * math.pi * 0.3**2) * math.sqrt(E * 0.15**2 / (16 * RHO))
    assert first_eb == pytest.approx(closed, rel=1e-8)
    assert out["frequencies_hz"][0] < 0.95 * first_eb  # L/D = 2: shear lowers it


def test_the_slender_limit_is_euler_bernoulli_at_the_rate_of_the_slenderness_squared():
    gaps = []
    for length in (1.0, 2.0):  # D = 0.02: L/D = 50 and 100
        text = beam_text(length, 0.02, (CLAMPED, None))
        tim = solve_modes(load_model_text(text, "t.toml"), count=1).frequencies_hz[0]
        eb_text = text.replace('"timoshenko"', '"euler-bernoulli"')
        eb = solve_modes(load_model_text(eb_text, "e.toml"), count=1).frequencies_hz[0]
        gaps.append((eb - tim) / eb)
    assert gaps[0] > 0 and gaps[1] > 0
    assert gaps[0] / gaps[1] == pytest.approx(4.0, rel=0.02)


def _plane(diameter=0.05, kappa=0.9):
    a, i = math.pi * diameter**2 / 4, math.pi * diameter**4 / 64
    return Plane(E * i, RHO * a, RHO * i, kappa * G * a)


def _eb_beam(length=0.8, diameter=0.05):
    a, i = math.pi * diameter**2 / 4, math.pi * diameter**4 / 64
    return Beam(
        name="b",
        start=np.zeros(3),
        end=np.array([length, 0.0, 0.0]),
        density=RHO,
        youngs_modulus=E,
        shear_modulus=G,
        area=a,
        second_moment_y=i,
        second_moment_z=i,
        polar_moment=2 * i,
        torsion_constant=2 * i,
    )


def test_infinite_shear_stiffness_and_no_rotary_inertia_give_the_euler_bernoulli_plane():
    beam = _eb_beam()
    omega = np.array([0.0, 100.0, 2000.0])
    eb = _plane()
    plane = Plane(eb.ei, eb.rho_a, 1e-30 * eb.rho_i, 1e30 * eb.kga)
    xy = [1, 5, 8, 10]  # y, θz, mz, qy
    krylov = elements.beam_local(omega, beam)[:, xy][:, :, xy]
    np.testing.assert_allclose(plane.transfer(omega**2, beam.length), krylov, rtol=1e-12, atol=0)
    ends = [1, 5, 7, 11]  # v, θz of both ends
    omega = np.r_[omega, 2e5]  # λL ≈ 45: the whole member's transfer has lost every digit
    closed = member_stiffness(omega, beam)[:, ends][:, :, ends]
    scale = np.abs(closed).max(axis=(1, 2))
    gap = np.abs(plane.stiffness(omega, beam.length) - closed).max(axis=(1, 2))
    assert np.all(gap <= 1e-11 * scale)


def test_batched_exponential_is_the_series_of_a_diagonalisable_matrix():
    rng = np.random.default_rng(3)
    values = rng.normal(scale=6.0, size=(20, 4))
    vectors = rng.normal(size=(20, 4, 4))
    a = vectors @ (values[:, :, None] * np.linalg.inv(vectors))
    expected = vectors @ (np.exp(values)[:, :, None] * np.linalg.inv(vectors))
    np.testing.assert_allclose(expm_batched(a), expected, rtol=1e-9 * np.exp(12))


def test_clamped_count_counts_the_zeros_of_the_clamped_determinant():
    """J₀ by subdivision against the sign changes of det T₁₂(ω) (clamped-clamped frequencies,
    simple roots) on a fine grid, through the second spectrum (above √(κGA/ρI))."""
    plane, length = _plane(diameter=0.15), 0.6
    cutoff = math.sqrt(plane.kga / plane.rho_i)
    omega = np.linspace(1.0, 2.5 * cutoff, 20001)
    t = plane.transfer(omega**2, length)
    det = np.linalg.det(t[:, :2, 2:] / np.abs(t[:, :2, 2:]).max(axis=(1, 2))[:, None, None])
    zeros = np.cumsum(np.r_[0, np.diff(np.sign(det)) != 0])
    counted = plane.clamped(omega, length)
    far = np.abs(det) > 1e-6  # away from a root, where the grid resolves the sign
    assert zeros[-1] >= 6 and np.array_equal(counted[far], zeros[far])


def test_shear_coefficient_defaults_and_the_file_keys():
    nu = E / (2 * G) - 1
    solid = load_model_text(beam_text(0.3, 0.15, (CLAMPED, None)), "c.toml").body("b")
    assert solid.shear_coefficient == pytest.approx(6 * (1 + nu) / (7 + 6 * nu), rel=1e-15)
    text = beam_text(0.3, 0.15, (CLAMPED, None), extra="inner_diameter = 0.1")
    hollow = load_model_text(text, "h.toml").body("b")
    m2 = (0.1 / 0.15) ** 2  # Cowper (1966), hollow circle
    expected = 6 * (1 + nu) * (1 + m2) ** 2 / ((7 + 6 * nu) * (1 + m2) ** 2 + (20 + 12 * nu) * m2)
    assert hollow.shear_coefficient == pytest.approx(expected, rel=1e-15)
    thin = cowper_circle(nu, 0.999)  # thin-walled tube: 2(1+ν)/(4+3ν) (Cowper 1966)
    assert thin == pytest.approx(2 * (1 + nu) / (4 + 3 * nu), rel=1e-3)
    default = load_model_text(beam_text(0.3, 0.15, (CLAMPED, None), theory="euler-bernoulli"), "")
    assert default.body("b").shear_coefficient is None
    assert "theory" not in model_to_toml(default)  # an Euler-Bernoulli file writes as before
    again = load_model_text(model_to_toml(load_model(CANTILEVER)), "again.toml").body("shaft")
    assert (again.theory, again.shear_coefficient) == ("timoshenko", 0.9)


@pytest.mark.parametrize(
    ("theory", "extra", "field"),
    [
        ("bernoulli", "", "theory"),
        ("euler-bernoulli", "shear_coefficient = 0.9", "shear_coefficient"),
        ("timoshenko", "shear_coefficient = 1.5", "shear_coefficient"),
        ("timoshenko", "shear_coefficient = nan", "shear_coefficient"),
    ],
)
def test_bad_theory_keys_are_one_line_naming_the_field(theory, extra, field):
    with pytest.raises(ModelError) as error:
        load_model_text(beam_text(0.3, 0.15, (CLAMPED, None), theory, extra), "bad.toml")
    message = str(error.value)
    assert "\n" not in message and "bad.toml" in message and f"'{field}'" in message


def test_timoshenko_modes_are_mass_orthogonal_with_the_rotary_inertia():
    """Distinct modes of a conservative structure are orthogonal in the mass inner product
    that its equations carry: here with the sections' rotary inertia (without it the bending
    pairs of this thick cantilever would be coupled at the rotary share of their energy)."""
    model = load_model(CANTILEVER)
    shapes = solve_modes(model, count=9).shapes
    n = shapes.frequencies_hz.size

    def picked(m):
        return {k: v[[m]] for k, v in shapes.rigid.items()}, {
            k: (p, w, v[[m]]) for k, (p, w, v) in shapes.beams.items()
        }

    gram = np.array(
        [[kinetic_terms(model, *picked(i), *picked(j)).sum() for j in range(n)] for i in range(n)]
    )
    scale = np.sqrt(np.outer(np.diag(gram), np.diag(gram)))
    distinct = np.abs(shapes.frequencies_hz[:, None] - shapes.frequencies_hz[None]) > 1e-6
    assert np.abs(gram / scale)[distinct].max() < 1e-8


def test_timoshenko_beam_field_is_finite_and_continuous_up_to_its_ends():
    """The field at fractions of the length (the hinge dampers read it at 0 and 1): zero at
    the clamp, finite, and continuous at the ends (a transfer over zero length is the
    identity)."""
    model = load_model(CANTILEVER)
    shapes = solve_modes(model, count=6).shapes
    system = TransferSystem(model)
    _, motion = beam_shape(system, shapes, "shaft", [0.0, 1e-9, 1.0 - 1e-9, 1.0])
    assert np.all(np.isfinite(motion))
    scale = np.abs(motion).max(axis=(1, 2))[:, None]
    assert np.all(np.abs(motion[:, 0]).max(axis=1) <= 1e-12 * scale[:, 0])
    np.testing.assert_allclose(motion[:, 0], motion[:, 1], atol=1e-7 * scale.max())
    np.testing.assert_allclose(motion[:, 3], motion[:, 2], atol=1e-7 * scale.max())
