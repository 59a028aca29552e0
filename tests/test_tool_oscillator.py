"""The tool and holder as an oscillator on the head (ufmt.machining.tool).

Oracles: the two-degree-of-freedom characteristic equation (the tool's mode against the head's
impedance, and sqrt(k / m) on a rigid head); the massless spring's quasi-static answer as the
carrier's mass goes to zero; a direct solve of the assembled model with the carrier as an
extra body on a z spring and dashpot (an independent assembly of the same machine).
"""

import dataclasses

import numpy as np
import pytest
from machine_text import set_machine_keys  # tests/ helper
from synthetic import packaged_text
from test_frf_direct import direct_receptance

from ufmt.errors import ModelError
from ufmt.machining.basis import ModalBasis
from ufmt.machining.damping import damping_matrix
from ufmt.machining.frf import frf, tool_workpiece_receptance
from ufmt.machining.process import Process
from ufmt.machining.static import residual_flexibility
from ufmt.machining.tool import tool_point, with_tool
from ufmt.model.load import load_model_text
from ufmt.model.machine import machine_of
from ufmt.simulate import simulate

#: a soft, heavy tool whose mode lies inside the default basis' band (5 kHz): 1e-7 m/N,
#: 30 g: sqrt(k / m) / 2 pi = 2.91 kHz
SOFT = {"tool_compliance_m_per_N": 1e-7, "tool_mass_kg": 0.03, "tool_damping_ratio": 0.03}


def one_mode_basis(omega: float, phi_z: float, mass: float = 1.0) -> ModalBasis:
    """A head with one mode: z translation ``phi_z`` at its centre, which is the tool point."""
    shape = np.array([[0.0, 0.0, phi_z, 0.0, 0.0, 0.0]])
    return ModalBasis(
        omega=np.array([omega]),
        modal_mass=np.array([mass]),
        body_shapes={"head": shape, "slider": np.zeros((1, 6))},
        body_centers={"head": np.zeros(3), "slider": np.zeros(3)},
    )


def small_machine(**tool):
    """A machine whose tool point is the origin (the head's centre in one_mode_basis)."""
    from ufmt.model.machine import read_machine

    table = {
        "tool_body": "head",
        "workpiece_body": "slider",
        "spindle_axis_xy": [0.0, -0.25],
        "cutting_plane_z": 0.0,
        "tool_radius": 0.25,
        "workpiece_size": [0.2, 0.2],
        "workpiece_center_xy": [0.0, -0.25],
        "rotation": "cw",
        **tool,
    }
    machine = read_machine(table)
    np.testing.assert_allclose(tool_point(machine), 0.0, atol=1e-15)
    return machine


@pytest.mark.parametrize("omega_head", [2 * np.pi * 3000.0, 2 * np.pi * 20000.0])
def test_the_tool_mode_is_the_two_degree_of_freedom_root(omega_head):
    """Closed form: M = diag(M_1, m), K = [[M_1 w_1^2 + k phi^2, -k phi], [-k phi, k]] has
    det(K - lambda M) = 0 at m M_1 lambda^2 - (m (M_1 w_1^2 + k phi^2) + k M_1) lambda
    + k M_1 w_1^2 = 0: the head's impedance moves the tool's mode off sqrt(k / m)."""
    machine = small_machine(tool_compliance_m_per_N=1.34e-8, tool_mass_kg=0.015)
    m1, phi = 2.5, 0.7
    basis = with_tool(one_mode_basis(omega_head, phi, m1), machine)
    k, m = 1 / 1.34e-8, 0.015
    a, b, c = m * m1, -(m * (m1 * omega_head**2 + k * phi**2) + k * m1), k * m1 * omega_head**2
    roots = np.sort(np.roots([a, b, c]).real)
    np.testing.assert_allclose(basis.omega**2, roots, rtol=1e-10)
    assert basis.tool.mode == int(np.argmin(np.abs(basis.omega - np.sqrt(k / m))))
    # the head's impedance moves it by more than the tolerance (the test can fail)
    assert abs(basis.omega[basis.tool.mode] / np.sqrt(k / m) - 1) > 1e-4


def test_on_a_rigid_head_the_tool_mode_is_sqrt_k_over_m():
    """As the head's mode rises the tool's mode tends to sqrt(k / m), the error falling as
    (w_t / w_1)^2 (the head's quasi-static compliance in series)."""
    machine = small_machine(tool_compliance_m_per_N=1.34e-8, tool_mass_kg=0.015)
    w_t = np.sqrt(1 / 1.34e-8 / 0.015)
    errors = []
    for ratio in (1e2, 1e3):
        basis = with_tool(one_mode_basis(ratio * w_t, 0.3, 30.0), machine)
        errors.append(abs(basis.omega[basis.tool.mode] / w_t - 1))
    assert errors[1] < 2e-6 and errors[0] / errors[1] == pytest.approx(100.0, rel=0.01)


def test_the_shank_dashpot_and_the_structural_damping_are_carried_to_the_modes():
    """With the tool at a node of the head's mode (phi = 0) the modes do not couple: the
    damping is diag(2 zeta w_1, c / m) [1/s], c = 2 zeta_t sqrt(k m)."""
    machine = small_machine(
        tool_compliance_m_per_N=1e-8, tool_mass_kg=0.02, tool_damping_ratio=0.04
    )
    basis = with_tool(one_mode_basis(2 * np.pi * 500.0, 0.0), machine)
    d = damping_matrix(basis, 0.01)
    k, m = 1e8, 0.02
    want = np.diag([2 * 0.01 * 2 * np.pi * 500.0, 2 * 0.04 * np.sqrt(k * m) / m])
    np.testing.assert_allclose(d, want, rtol=1e-12, atol=1e-9)


def test_the_head_shapes_are_the_machine_modes_combined():
    """The head's z shape is the machine's mode shape times the machine coordinate in each
    mode, and the carrier's is the head's plus the stretch (u - phi q)."""
    machine = small_machine(tool_compliance_m_per_N=1e-8, tool_mass_kg=0.02)
    base = one_mode_basis(2 * np.pi * 900.0, 0.5, 4.0)
    basis = with_tool(base, machine)
    q = basis.tool.structure[0] / np.sqrt(4.0)  # the machine coordinate per mode
    carrier = basis.body_shapes["head"][:, 2]
    np.testing.assert_allclose(carrier - basis.tool.stretch, 0.5 * q, rtol=1e-12)
    # mass-normalised: M_1 q^2 + m u^2 = 1 per mode
    np.testing.assert_allclose(4.0 * q**2 + 0.02 * carrier**2, 1.0, rtol=1e-12)


def soft_model(mass_kg: float):
    """The packaged model (force scale 1) with the tool keys given."""
    keys = {k: repr(v) for k, v in {**SOFT, "tool_mass_kg": mass_kg}.items()}
    return load_model_text(set_machine_keys(packaged_text(), **keys), "u.toml")


def with_carrier_body(model, machine):
    """Independent assembly: the model with the carrier as a rigid body of mass m at the tool
    point, joined to the head by a z spring k and dashpot c (released in every other
    direction), the machine's tool body the carrier."""
    from ufmt.model.schema import Hinge, RigidBody

    p = tool_point(machine)
    m, k = machine.tool_mass_kg, 1 / machine.tool_compliance_m_per_N
    c = 2 * machine.tool_damping_ratio * np.sqrt(k * m)
    carrier = RigidBody(name="carrier", mass=m, center_of_mass=p, inertia=np.eye(3) * 1e-9 * m)
    hinge = Hinge(
        name="shank",
        between=(machine.tool_body, "carrier"),
        at=p,
        stiffness=np.array([0.0, 0.0, k]),
        rotational_stiffness=np.zeros(3),
        damping=np.array([0.0, 0.0, c]),
        rotational_damping=np.zeros(3),
    )
    moved = dataclasses.replace(
        model, bodies=(*model.bodies, carrier), hinges=(*model.hinges, hinge)
    )
    return moved, dataclasses.replace(machine, tool_body="carrier")


@pytest.fixture(scope="module")
def soft(packaged_basis):
    model = soft_model(0.03)
    machine = machine_of(model)
    freq = np.sort(
        np.concatenate([np.geomspace(1.0, 4000.0, 120), np.linspace(2700.0, 3100.0, 41)])
    )
    return model, machine, packaged_basis, freq


def test_the_oscillator_matches_the_direct_solve_of_the_assembled_carrier(soft):
    """No damping but the shank's (hinge dampers and structural damping off): the basis with
    the carrier, plus the head's static residual, equals the direct solve of the assembled
    model with the carrier as a body on a spring within 1e-3 up to 4 kHz, through the tool's
    resonance at 2.9 kHz; the massless spring misses that resonance (the test can fail)."""
    model, machine, packaged_basis, freq = soft
    undamped = ModalBasis(
        omega=packaged_basis.omega,
        modal_mass=packaged_basis.modal_mass,
        body_shapes=packaged_basis.body_shapes,
        body_centers=packaged_basis.body_centers,
        slide_y=packaged_basis.slide_y,
    )
    from ufmt.machining.slide import model_at_slide

    basis = with_tool(undamped, machine)
    residual = residual_flexibility(model, basis, machine)
    got = tool_workpiece_receptance(basis, machine, freq, zeta=1e-12, residual=residual)
    assembled, carried = with_carrier_body(model_at_slide(model, machine, basis.slide_y), machine)
    no_hinge_damping = dataclasses.replace(
        assembled,
        hinges=tuple(
            h
            if h.name == "shank"
            else dataclasses.replace(h, damping=np.zeros(3), rotational_damping=np.zeros(3))
            for h in assembled.hinges
        ),
    )
    oracle = direct_receptance(no_hinge_damping, carried, freq)
    np.testing.assert_allclose(got, oracle, rtol=1e-3, atol=1e-3 * abs(oracle[0]))
    peak = np.argmax(np.abs(oracle))
    assert 2700.0 < freq[peak] < 3100.0 and np.abs(oracle[peak]) > 5 * np.abs(oracle[0])
    massless = dataclasses.replace(machine, tool_mass_kg=0.0)
    quasi = tool_workpiece_receptance(
        undamped,
        massless,
        freq,
        zeta=1e-12,
        residual=residual_flexibility(model, undamped, massless),
    )
    assert np.max(np.abs(quasi / oracle - 1)) > 0.5


def test_with_hinge_damping_the_oscillator_matches_the_direct_solve(soft):
    """Hinge dampers on (structural damping off): within 1 % as the machine's FRF without the
    tool (tests/test_frf_direct.py: the dampers' coupling with the modes far above the basis)."""
    model, machine, packaged_basis, freq = soft
    from ufmt.machining.slide import model_at_slide

    basis = with_tool(packaged_basis, machine)
    residual = residual_flexibility(model, basis, machine)
    got = tool_workpiece_receptance(basis, machine, freq, zeta=1e-9, residual=residual)
    assembled, carried = with_carrier_body(model_at_slide(model, machine, basis.slide_y), machine)
    oracle = direct_receptance(assembled, carried, freq)
    error = np.abs(got / oracle - 1)
    assert error.max() < 1e-2, f"worst {error.max():.3g} at {freq[np.argmax(error)]:.1f} Hz"


def test_ufmt_frf_carries_the_tool_mode(soft):
    """`frf` puts the carrier in the basis: its peak is the tool's resonance near 2.9 kHz,
    and far below it the carrier's mass does not matter (the massless spring's receptance
    within 1e-4 at 1 Hz: the shank's dashpot adds 2 zeta_t f / f_t = 2e-5 of its share)."""
    model, _, _, _ = soft
    result = frf(model, fmin_hz=1.0, fmax_hz=4000.0, points=400, zeta=1e-9)
    peak = result.frequencies_hz[np.argmax(np.abs(result.values))]
    assert 2700.0 < peak < 3100.0
    massless = frf(soft_model(0.0), fmin_hz=1.0, fmax_hz=4000.0, points=400, zeta=1e-9)
    assert result.values[0] == pytest.approx(massless.values[0], rel=1e-4)
    assert massless.frequencies_hz[np.argmax(np.abs(massless.values))] < 2000.0


def test_a_vanishing_carrier_mass_gives_the_massless_spring():
    """m -> 0: the tool's mode leaves the band and the simulation tends to the quasi-static
    series spring (tool_mass_kg = 0): z_re's peak, the accelerations and the dynamic surface
    within 1e-4 at a 1 ug carrier (tool mode 160 kHz; error of order (f / f_t)^2)."""
    process = Process(rpm=300.0, feed_mm_min=15.0, depth_um=4.0)
    runs = [simulate(soft_model(m), process, n_phi=8192) for m in (1e-9, 0.0)]
    light, massless = runs
    assert light.n_modes == massless.n_modes and light.tool_mode_hz > 1e6 > light.samples_per_rev
    for key in ("zre_peak_nm", "tip_acc_peak_mm_s2", "pv_nm", "pv_measured_nm"):
        assert light.metrics[key] == pytest.approx(massless.metrics[key], rel=1e-4), key
    np.testing.assert_allclose(
        light.response.z_re,
        massless.response.z_re,
        rtol=0,
        atol=1e-4 * np.ptp(massless.response.z_re),
    )


def test_the_tool_keys_are_checked():
    text = set_machine_keys(packaged_text(), tool_mass_kg=0.5)
    with pytest.raises(ModelError, match="tool_mass_kg"):
        load_model_text(text, "ufmt.toml")
    text = set_machine_keys(packaged_text(), tool_damping_ratio="nan")
    with pytest.raises(ModelError, match="tool_damping_ratio"):
        load_model_text(text, "ufmt.toml")


def test_the_peak_between_samples_is_the_parabola_s_vertex():
    """Oracle: A (1 + cos(2 pi t)) / 2 sampled 17 times per period with its peaks half way
    between samples: the refined peak is within 5e-4 of A (the parabola's error on a cosine,
    (A / 2) 4.3e-4), where the largest sample misses it by (A / 2) (1 - cos(pi / 17))."""
    from ufmt.simulate import _mean_peak, _mean_smooth_peak

    n, periods, amp = 1700, 2, 3.0
    t = (np.arange(periods * n) + 0.5) / 17.0
    signal = amp * (1 + np.cos(2 * np.pi * t)) / 2
    assert _mean_peak(signal, periods) == pytest.approx(amp * (1 + np.cos(np.pi / 17)) / 2)
    assert _mean_smooth_peak(signal, periods) == pytest.approx(amp, rel=5e-4)


def test_both_response_paths_carry_the_carrier():
    """A synthetic machine (modes 8-400 Hz) with a 50 g carrier at 2.25 kHz: the time path's
    record window, in its periodic steady state mid-cut, equals the periodic path's for the
    tool tip, the head's and the carrier's acceleration (two solvers of one basis); the
    carrier rings (its acceleration is far above the head's)."""
    from synthetic import SMALL, synthetic_basis

    from ufmt.machining.cut_geometry import cut_geometry
    from ufmt.machining.periodic_path import periodic_response
    from ufmt.machining.time_path import time_response
    from ufmt.model.machine import read_machine

    machine = read_machine({**SMALL, "tool_compliance_m_per_N": 1e-7, "tool_mass_kg": 0.05})
    basis = with_tool(synthetic_basis(slider_turns=False), machine)
    assert basis.omega[basis.tool.mode] / (2 * np.pi) == pytest.approx(2251.0, rel=0.05)
    process = Process(400, 16, 4)
    geo = cut_geometry(basis, machine, n_phi=4096)
    per, tim = periodic_response(geo, process), time_response(geo, process)
    n = per.t.size
    mid = tim.periods // 2
    one = slice(mid * n, (mid + 1) * n)
    for a, b in (
        (tim.carrier_acc[one], per.carrier_acc),
        (tim.tip_acc[one], per.tip_acc),
        (tim.tip_disp[one], per.tip_disp),
    ):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-7 * np.abs(b).max())
    assert np.abs(per.carrier_acc).max() > 10 * np.abs(per.tip_acc[:, 2]).max()
