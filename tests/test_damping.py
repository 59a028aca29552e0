"""Hinge damping in the modal equations: FRF against a direct damped solve, bitwise identity
without it, the two response paths with it, and the model-file contract."""

import numpy as np
import pandas as pd
import pytest
from synthetic import MACHINE, SMALL, dynamic_surface, synthetic_basis

from ufmt.assembled import assemble
from ufmt.errors import ModelError
from ufmt.kinematics import point_motion
from ufmt.machining.basis import ModalBasis
from ufmt.machining.cut_geometry import cut_geometry
from ufmt.machining.cutting import tool_tip
from ufmt.machining.damping import damped_modes, damping_matrix
from ufmt.machining.frf import tool_workpiece_receptance
from ufmt.machining.modal import modal_basis
from ufmt.machining.periodic_path import periodic_response
from ufmt.machining.process import Process
from ufmt.machining.recurrence import DEFAULT_ZETA
from ufmt.machining.surface import steady_region
from ufmt.machining.time_path import time_response
from ufmt.model.load import model_from_dict
from ufmt.model.machine import machine_of, read_machine
from ufmt.model.schema import Model
from ufmt.model.write import model_to_toml
from ufmt.simulate import simulate

INERTIA = [[4.0, 0.0, 0.0], [0.0, 5.0, 0.0], [0.0, 0.0, 6.0]]


def three_bodies(damping=1.0, machine=MACHINE):
    """Bed on ground, head (the tool body) and slider (the workpiece body) on the bed: 18
    modes, every hinge a spring-damper in all six directions (``damping`` scales them)."""

    def body(name, mass, center):
        return {
            "name": name,
            "kind": "rigid",
            "mass": mass,
            "center_of_mass": center,
            "inertia": INERTIA,
        }

    def hinge(name, between, at, k, c):
        return {
            "name": name,
            "between": between,
            "at": at,
            "stiffness": [k, 1.3 * k, 0.8 * k],
            "rotational_stiffness": [k / 9, k / 7, k / 5],
            "damping": [damping * c, damping * 2 * c, damping * 0.5 * c],
            "rotational_damping": [damping * c / 30, damping * c / 20, damping * c / 10],
        }

    return model_from_dict(
        {
            "name": "three rigid bodies on spring-dampers",
            "body": [
                body("bed", 400.0, [0.0, 0.0, -0.5]),
                body("head", 60.0, [0.0, 0.0, 0.15]),
                body("slider", 90.0, [0.0, 0.0, -0.15]),
            ],
            "hinge": [
                hinge("h_ground", ["ground", "bed"], [0.0, 0.0, -0.8], 4e8, 3e4),
                hinge("h_head", ["bed", "head"], [0.1, 0.0, 0.3], 6e7, 2e3),
                hinge("h_slider", ["bed", "slider"], [0.0, -0.1, -0.3], 9e7, 5e3),
            ],
            "machine": machine,
        }
    )


def direct_damped_receptance(model, machine, freq_hz, tool_angle=0.0):
    """Oracle: z_re per unit force pair from (K - W^2 M + i W C) u = f on the assembled model
    (rigid bodies only: every dof independent, no modal truncation). C = sum over hinges and
    directions of c_j d_j d_j^T, d_j the relative motion u_A(P) - u_B(P) at the hinge point."""
    am = assemble(model)
    n = am.K.shape[0]
    c = np.zeros((n, n))
    for h in model.hinges:
        d = np.zeros((6, n))
        for side, sign in zip(h.between, (1.0, -1.0), strict=True):
            if side != "ground":
                body = model.body(side)
                d[:, am.body_dofs[side][0]] += sign * point_motion(h.at - body.center_of_mass)
        c += (d.T * h.damping6) @ d
    tip = tool_tip(np.array([tool_angle]), machine)[0]
    rows = {}
    for body in (machine.tool_body, machine.workpiece_body):
        row = np.zeros(n)
        row[am.body_dofs[body][0]] = point_motion(tip - am.node_positions[body][0])[2]
        rows[body] = row
    load = rows[machine.tool_body] - rows[machine.workpiece_body]
    w = 2 * np.pi * np.asarray(freq_hz)[:, None, None]
    rhs = np.broadcast_to(load[:, None], (w.size, n, 1))
    u = np.linalg.solve(am.K - w**2 * am.M + 1j * w * c, rhs)[..., 0]
    return u @ load


@pytest.fixture(scope="module")
def damped():
    model = three_bodies()
    return model, modal_basis(model, 18, slide_y=0.0), machine_of(model)


def test_frf_matches_the_direct_damped_solve(damped):
    """Every mode in the basis, structural damping off (zeta ~ 0): the complex-mode FRF is the
    direct solve of the damped assembled model to 1e-8 relative, across and between the
    resonances."""
    model, basis, machine = damped
    assert basis.n_modes == 18 and basis.hinge_damping is not None
    freq = np.geomspace(1.0, 3e3, 400)
    got = tool_workpiece_receptance(basis, machine, freq, zeta=1e-12)
    oracle = direct_damped_receptance(model, machine, freq)
    np.testing.assert_allclose(got, oracle, rtol=1e-8, atol=0)
    # the dampers matter here: without them the peaks are far higher
    bare = tool_workpiece_receptance(
        modal_basis(three_bodies(damping=0.0), 18, slide_y=0.0), machine, freq, zeta=1e-12
    )
    assert np.abs(bare).max() > 2 * np.abs(got).max()


def test_complex_modes_diagonalise_the_first_order_system(damped):
    """z' = lambda z + L f, q = 2 Re(P z) reproduce (Omega^2 - W^2 + i W D)^-1 at any W."""
    _, basis, _ = damped
    modes = damped_modes(basis, 0.02)
    d = damping_matrix(basis, 0.02)
    w = 2 * np.pi * 123.0
    direct = np.linalg.inv(np.diag(basis.omega**2) - w**2 * np.eye(18) + 1j * w * d)
    lam = modes.poles[:, None]
    pl = modes.outputs[:, :, None] * modes.inputs[None, :, :]  # (n, m, n)
    via_modes = np.einsum("imj,m->ij", pl, 1 / (1j * w - lam[:, 0]))
    via_modes += np.einsum("imj,m->ij", np.conj(pl), 1 / (1j * w - np.conj(lam[:, 0])))
    np.testing.assert_allclose(via_modes, direct, rtol=0, atol=1e-9 * np.abs(direct).max())


def test_zero_hinge_damping_keeps_the_diagonal_path_bitwise():
    """A model whose hinges carry no damping gives a basis without hinge damping, whose FRF
    is bitwise the diagonal modal sum; the same basis given a zero hinge matrix takes the
    coupled path (complex modes) and agrees with the diagonal one to round-off in the FRF,
    the periodic and the time response. (That the whole diagonal path stays bitwise as it was
    is checked against the previous release's outputs, not here.)"""
    assert modal_basis(three_bodies(damping=0.0), 18).hinge_damping is None
    basis = synthetic_basis()
    m = read_machine(SMALL)
    p = Process(400, 16, 4)
    geo = cut_geometry(basis, m)
    zero = ModalBasis(
        basis.omega,
        basis.modal_mass,
        basis.body_shapes,
        basis.body_centers,
        hinge_damping=np.zeros((basis.n_modes,) * 2),
    )
    geo0 = cut_geometry(zero, m)
    freq = np.geomspace(1.0, 1e3, 50)
    h, h0 = (tool_workpiece_receptance(b, m, freq) for b in (basis, zero))
    # the diagonal modal sum, term for term as before hinge damping existed: bitwise
    tip = tool_tip(np.array([0.0]), m)
    c = (basis.point_shapes("head", tip) - basis.point_shapes("slider", tip))[:, 0, 2]
    w, om, z = (
        2 * np.pi * freq[None, :],
        basis.omega[:, None],
        np.full((basis.n_modes, 1), DEFAULT_ZETA),
    )
    den = basis.modal_mass[:, None] * (om**2 - w**2 + 2j * z * om * w)
    np.testing.assert_array_equal(h, np.sum(c[:, None] ** 2 / den, axis=0))
    np.testing.assert_allclose(h0, h, rtol=1e-10)
    for run in (periodic_response, time_response):
        r, r0 = run(geo, p), run(geo0, p)
        assert damped_modes(basis, DEFAULT_ZETA) is None
        ref = np.abs(r.table.values).max()
        np.testing.assert_allclose(r0.table.values, r.table.values, rtol=0, atol=1e-9 * ref)
        np.testing.assert_allclose(r0.z_re, r.z_re, rtol=0, atol=1e-9 * np.abs(r.z_re).max())
        np.testing.assert_allclose(
            r0.tip_acc, r.tip_acc, rtol=0, atol=1e-9 * np.abs(r.tip_acc).max()
        )


def damped_synthetic(strength=0.1, seed=11):
    """The synthetic basis of test_response with a random positive semi-definite hinge
    matrix coupling its modes (diagonal share up to ``strength`` of critical); the slider only
    translates, so the chip pattern is periodic over the steady span."""
    basis = synthetic_basis(slider_turns=False)
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(basis.n_modes, 3))
    scale = np.sqrt(2 * strength * basis.omega * basis.modal_mass)
    c = (scale[:, None] * a) @ (scale[:, None] * a).T / 3
    return ModalBasis(
        basis.omega, basis.modal_mass, basis.body_shapes, basis.body_centers, hinge_damping=c
    )


@pytest.fixture(scope="module")
def damped_paths():
    basis = damped_synthetic()
    m = read_machine(SMALL)
    p = Process(400, 16, 4)
    geo = cut_geometry(basis, m)
    return basis, m, p, periodic_response(geo, p), time_response(geo, p)


def test_periodic_and_time_paths_agree_with_hinge_damping(damped_paths):
    """With coupled (non-proportional) damping the two paths still solve the same problem:
    PV within 1 % over the steady part, pointwise there and in the record windows."""
    basis, m, p, per, tim = damped_paths
    s_per, s_tim = (dynamic_surface(r.table, m, p.feed_per_rev_m, spacing=1e-3) for r in (per, tim))
    settle = 20 / (DEFAULT_ZETA * basis.omega[0]) * p.feed_m_s
    steady = steady_region(s_tim, m, settle=settle)
    assert steady.sum() > 0.2 * steady.size
    assert np.ptp(s_tim.z[steady]) == pytest.approx(np.ptp(s_per.z[steady]), rel=0.01)
    assert np.abs(s_per.z - s_tim.z)[steady].max() < 1e-6 * np.ptp(s_per.z[steady])
    # the periodic table at the samples the surface reads (impulse response) and by the
    # harmonics (the whole table) are the same table
    table = per.table
    phi = np.linspace(0.1, 1.2, 7)[None, :]
    np.testing.assert_allclose(
        table.columns(phi),
        sum(w * table.values[:, (s + 1) % (table.values.shape[1])] for s, w in _stencil(phi, m)),
        rtol=0,
        atol=1e-9 * np.abs(table.values).max(),
    )
    n = per.t.size
    mid = tim.periods // 2
    one = slice(mid * n, (mid + 1) * n)
    for a, b in ((tim.tip_acc[one], per.tip_acc), (tim.tip_disp[one], per.tip_disp)):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-7 * np.abs(b).max())


def _stencil(phi, machine):
    from ufmt.machining.response import cubic_weights

    samples, weights = cubic_weights(phi, 512)
    return list(zip(samples, weights, strict=True))


def test_hinge_damping_lowers_the_resonance_peak(damped_paths):
    """At a resonance the response is set by damping: at the largest peak of the receptance
    without hinge damping, the hinge-damped receptance is lower."""
    basis, m, _, _, _ = damped_paths
    bare = synthetic_basis(slider_turns=False)
    freq = np.geomspace(5.0, 500.0, 4000)
    h_bare = np.abs(tool_workpiece_receptance(bare, m, freq))
    peak = freq[[int(np.argmax(h_bare))]]
    assert np.abs(tool_workpiece_receptance(basis, m, peak))[0] < h_bare.max()


def test_model_file_with_hinge_damping_changes_pv_and_frf(tmp_path):
    """The contract: the same model file with and without hinge damping gives different
    dynamic PV and FRF (the damping values act). On the small plate: the contract is the
    same on any plate, and the whole-plate simulation is what the test spends its time on."""
    paths = []
    for scale in (1.0, 0.0):
        path = tmp_path / f"damping-{scale:g}.toml"
        path.write_text(model_to_toml(three_bodies(damping=scale, machine=SMALL)))
        paths.append(path)
    process = Process(400, 16, 4)
    results = [
        simulate(path, process, n_modes=18, sources=("dynamic",), static_correction=False)
        for path in paths
    ]
    pv = [r.metrics["pv_nm"] for r in results]
    assert pv[0] > 0 and pv[1] > 0 and abs(pv[0] - pv[1]) > 1e-3 * pv[1]
    freq = np.geomspace(10.0, 2e3, 200)
    frf = []
    for path in paths:
        from ufmt.model.load import load_model

        model = load_model(path)
        frf.append(tool_workpiece_receptance(modal_basis(model, 18), machine_of(model), freq))
    assert np.abs(frf[0]).max() < 0.9 * np.abs(frf[1]).max()


def test_beam_ends_and_virtual_bodies_enter_the_hinge_matrix():
    """Oracle: the assembled model's damping C (beam-end nodes, the virtual hub, a released
    direction with a damper) projected on its own mass-normalised modes; the diagonal of
    Phi^T C Phi (sign-free) matches the MSTMM basis' hinge matrix for the first 8 modes."""
    from ufmt.assembled import assembled_modes
    from ufmt.model.load import load_model

    model = load_model("tests/models/good_mixed.toml")
    model = model.with_hinge("h_hub", damping=[300.0, 500.0, 0.0], rotational_damping=[1.0] * 3)
    model = model.with_hinge("h_shaft", damping=[0.0] * 3, rotational_damping=[0.0, 0.0, 7.0])
    basis = modal_basis(model, 8, slide_y=0.0)
    modes = assembled_modes(model, count=8, elements_per_beam=32)
    am = modes.assembled
    n = am.K.shape[0]
    c = np.zeros((n, n))
    for h in model.hinges:
        d = np.zeros((6, n))
        for side, sign in zip(h.between, (1.0, -1.0), strict=True):
            if side == "ground":
                continue
            nodes = am.node_positions[side]
            node = int(np.argmin(np.linalg.norm(nodes - h.at, axis=1)))
            d[:, am.body_dofs[side][node]] += sign * point_motion(h.at - nodes[node])
        c += (d.T * np.where(h.rigid, 0.0, h.damping6)) @ d
    oracle = np.einsum("ki,ij,kj->k", modes.shapes, c, modes.shapes)
    np.testing.assert_allclose(np.diag(basis.hinge_damping), oracle, rtol=1e-5)


def test_the_machines_modal_damping_ratio_is_the_default_zeta():
    """Oracle: the explicit argument. A model whose ``[machine]`` sets modal_damping_ratio
    simulates and gives the FRF exactly as the default model with that ``zeta`` passed; the
    default ratio is DEFAULT_ZETA."""
    assert read_machine(SMALL).modal_damping_ratio == DEFAULT_ZETA
    basis = synthetic_basis()
    process = Process(300.0, 15.0, 4.0)
    plain = Model("syn", (), (), machine=read_machine(SMALL))
    damped = Model("syn", (), (), machine=read_machine({**SMALL, "modal_damping_ratio": 0.03}))
    options = {"basis": basis, "static_correction": False}  # a model without bodies
    got = pd.Series(simulate(damped, process, **options).metrics)
    want = pd.Series(simulate(plain, process, zeta=0.03, **options).metrics)
    pd.testing.assert_series_equal(got, want, rtol=0, atol=0)  # NaN (unresolved) equal NaN
    assert got["zre_peak_nm"] != simulate(plain, process, **options).metrics["zre_peak_nm"]
    freq = np.linspace(50.0, 2000.0, 40)
    np.testing.assert_array_equal(
        tool_workpiece_receptance(basis, damped.machine, freq),
        tool_workpiece_receptance(basis, plain.machine, freq, zeta=0.03),
    )


def test_a_modal_damping_ratio_outside_its_band_is_one_line():
    """Oracle: the band of OPTIONAL_FIELDS. Zero (which the response cannot take: the
    recurrence needs a positive ratio) and 0.5 are refused on load with the file and key."""
    for value in (0.0, 0.5):
        with pytest.raises(ModelError, match="modal_damping_ratio"):
            read_machine({**SMALL, "modal_damping_ratio": value}, "m.toml")
