"""The body motions of the mode shapes against the computations they replace: beam fields
(displacement rows applied to the states, no 12 x 12 matrices) against the full transfer
matrices, rigid bodies against the carried full states, the Krylov-Duncan functions against
their power series."""

import math

import numpy as np
import pytest

from ufmt.kinds import euler_bernoulli
from ufmt.kinematics import carried_motion
from ufmt.model.load import load_model
from ufmt.model.schema import Beam, RigidBody
from ufmt.mstmm import elements
from ufmt.mstmm.bodies import ShapeParts, apply_state, beam_field, gauss_points, rules_of
from ufmt.mstmm.modes import shape_state_keys
from ufmt.mstmm.overall import TransferSystem
from ufmt.mstmm.solve import solve_modes


def rectangular_beam() -> Beam:
    """A steel bar with I_y != I_z and a tilted axis (both bending planes differ)."""
    b, h, length = 0.03, 0.05, 0.8
    return Beam(
        "bar",
        np.zeros(3),
        np.array([0.2, 0.3, 0.7]) * length / np.linalg.norm([0.2, 0.3, 0.7]),
        7850.0,
        2.1e11,
        8.1e10,
        b * h,
        b * h**3 / 12,
        h * b**3 / 12,
        b * h * (b * b + h * h) / 12,
        0.196 * b**3 * h,
    )


@pytest.mark.parametrize("omega_max", [0.0, 2e3, 3e5])  # static, series and closed forms
def test_displacement_rows_are_the_transfer_matrix_rows(omega_max):
    """Oracle: the first six rows of beam_local (the 12 x 12 transfer matrix) times the
    state, at random points along the bar and random frequencies."""
    beam = rectangular_beam()
    rng = np.random.default_rng(4)
    omega = rng.uniform(0.0, omega_max, 200)
    length = rng.uniform(0.0, beam.length, 200)
    state = rng.standard_normal((200, 12)) * np.r_[np.ones(6), np.full(6, 1e5)]
    full = (elements.beam_local(omega, beam, length)[:, :6] @ state[:, :, None])[..., 0]
    rows = elements.beam_local_displacement(omega, beam, length, state)
    scale = np.abs(full).max(axis=1, keepdims=True)
    assert np.all(np.abs(rows - full) <= 1e-14 * scale)


def test_beam_fields_of_the_packaged_modes_match_the_transfer_matrices(packaged):
    """Oracle: the former evaluation, every point's global 12 x 12 transfer matrix
    T U_local(s) Tᵀ (its displacement rows) applied to the input state, for every mode to
    5 kHz of the packaged model's two beams: equal to rounding (1e-13 of each mode's
    largest motion along the beam)."""
    solution = solve_modes(packaged, fmax_hz=5000.0)
    system = TransferSystem(packaged, 5000.0)
    omega, z = solution.shapes.omega, solution.shapes.z_all
    states = system.states(omega)
    assert set(shape_state_keys(system)) <= set(states)
    for beam in (b for b in packaged.bodies if isinstance(b, Beam)):
        positions, weights, motion = beam_field(system, beam, states, z, omega)
        index = system.topology.body_edge(beam.name)
        edge = system.topology.edges[index]
        z_in = apply_state(states[("edge_in", index)], z)
        x = np.linalg.norm(positions - edge.point_at(edge.input_node), axis=1)
        assert x.size == gauss_points(beam, omega.max()) == weights.size
        t = system.edge_rotation(index)
        for g, s in enumerate(x):
            local = elements.beam_local(omega, beam, np.full(omega.size, s))
            u = t[None, :6, :6] @ local[:, :6, :] @ t.T[None]
            expected = np.einsum("nij,nj->ni", u, z_in)
            peak = np.abs(motion).max(axis=(1, 2))[:, None]
            assert np.all(np.abs(motion[:, g] - expected) <= 1e-13 * peak)


def test_beam_fields_at_fractions_follow_the_beam_from_its_start():
    """beam_shape's points: fractions from the beam's start whichever end the transfer
    enters; oracle: the Gauss-point field of the same modes at the same positions."""
    model = load_model()
    solution = solve_modes(model, fmax_hz=2000.0)
    system = TransferSystem(model, 2000.0)
    omega, z = solution.shapes.omega, solution.shapes.z_all
    states = system.states(omega)
    for beam in (b for b in model.bodies if isinstance(b, Beam)):
        gauss_pos, _, gauss_motion = beam_field(system, beam, states, z, omega)
        along = (gauss_pos - beam.start) @ (beam.end - beam.start) / beam.length**2
        pos, _, motion = beam_field(system, beam, states, z, omega, along)
        assert np.allclose(pos, gauss_pos, rtol=0, atol=1e-15)
        peak = np.abs(gauss_motion).max()
        assert np.allclose(motion, gauss_motion, rtol=0, atol=1e-13 * peak)


def krylov_by_series(x: float) -> np.ndarray:
    """Oracle: S, T/x, U/x², V/x³ as their power series Σ x⁴ᵏ / (4k + j)!, j = 0..3, summed
    exactly rounded (every term positive: no cancellation at any x)."""
    return np.array(
        [math.fsum(x ** (4 * k) / math.factorial(4 * k + j) for k in range(30)) for j in range(4)]
    )


@pytest.mark.parametrize(
    "x",
    [np.float64(1.3), np.array([0.0, 0.4, 1.9]), np.array([2.0, 3.7, 6.5]), np.linspace(0, 6, 13)],
    ids=["scalar", "series only", "closed forms only", "both"],
)
def test_krylov_functions_match_their_power_series(x):
    """The scaled Krylov-Duncan functions on either side of the series/closed-form switch
    (x = 2), for a scalar and for arrays on one side or both."""
    got = np.array(euler_bernoulli._krylov_scaled(np.asarray(x) ** 4))
    expected = np.array([krylov_by_series(v) for v in np.atleast_1d(x)]).T.reshape(got.shape)
    assert np.allclose(got, expected, rtol=1e-14, atol=0)


def test_rigid_body_motions_are_the_carried_input_states(packaged):
    """Oracle: the full state at each rigid body's first input (apply_state, 12 rows)
    carried to its centre of mass by kinematics.carried_motion (eq. 2.5), every mode to
    5 kHz of the packaged model: equal to rounding."""
    solution = solve_modes(packaged, fmax_hz=5000.0)
    system = TransferSystem(packaged, 5000.0)
    omega, z = solution.shapes.omega, solution.shapes.z_all
    states = system.states(omega)
    parts = ShapeParts()
    rigid = [b for b in packaged.bodies if isinstance(b, RigidBody)]
    for body in rigid:
        rules_of(body).shape(system, body, states, z, omega, parts)
        state = apply_state(states[rules_of(body).state_key(system.topology, body)], z)
        point = system.topology.first_input_point(body.name)
        expected = carried_motion(state, point, body.center_of_mass)
        peak = np.abs(expected).max(axis=1, keepdims=True)
        assert np.all(np.abs(parts.rigid[body.name] - expected) <= 1e-14 * peak)
    assert len(parts.rigid) == len(rigid) >= 10
