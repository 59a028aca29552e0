"""The static correction of a model whose spindle turns freely (a zero-frequency mode).

Model: tests/models/free_spindle.toml, the bridge example drawn far from the origin, its air
bearing's rotation about the spindle axis released. Oracle: a direct solve of its assembled
model (every dof, 8 frame elements per beam) with the zero-frequency motion built by hand (the
spindle, the joint and the head turning about the axis) projected out of the load and the
response: the drive holds the spindle, so only the elastic modes answer.
"""

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from frames import translated

from ufmt.assembled import assemble
from ufmt.assembled.constraints import constraint_basis, zero_modes
from ufmt.kinematics import point_motion
from ufmt.machining.cutting import tool_tip
from ufmt.machining.frf import frf
from ufmt.machining.process import Process
from ufmt.machining.slide import cut_slide_position, model_at_slide
from ufmt.machining.static import RELIEF_ELEMENTS_PER_BEAM, static_flexibility
from ufmt.model.load import as_model
from ufmt.simulate import simulate

MODEL = Path(__file__).parent / "models" / "free_spindle.toml"
SPINNING = ("joint", "shaft", "head")  # the bodies the released rotation turns
ELEMENTS_PER_BEAM = 8
AXES = {"x": 0, "y": 1, "z": 2}


@pytest.fixture(scope="module")
def model():
    """The free-spindle model with a rigid tool (the oracle has no tool spring)."""
    loaded = as_model(MODEL)
    return dataclasses.replace(
        loaded, machine=dataclasses.replace(loaded.machine, tool_compliance_m_per_N=0.0)
    )


def spindle_rotation(am, model) -> np.ndarray:
    """The zero-frequency motion by hand: every dof of the spinning bodies turning by a unit
    angle about the spindle axis (vertical, through the air bearing's point)."""
    axis = model.hinge("air_bearing").at
    motion = np.zeros(am.K.shape[0])
    for name in SPINNING:
        for dofs, point in zip(am.body_dofs[name], am.node_positions[name], strict=True):
            arm = point - axis
            motion[dofs] = [-arm[1], arm[0], 0.0, 0.0, 0.0, 1.0]
    return motion


def elastic_solve(am, model, load, omega=0.0):
    """Oracle: u = P^T (K - W^2 M)^-1 P f with P = I - M phi phi^T (phi the hand-built
    rotation, mass-normalised): the load that would spin the spindle and the rotation in the
    response removed; at W = 0 the solve runs on the motions orthogonal to phi."""
    basis, _ = constraint_basis(am.constraints, am.massless)
    k, m = basis.T @ am.K @ basis, basis.T @ am.M @ basis
    phi = np.linalg.lstsq(basis, spindle_rotation(am, model), rcond=None)[0]
    phi = phi / np.sqrt(phi @ m @ phi)
    f = basis.T @ load
    f = f - m @ phi * (phi @ f)
    if omega == 0.0:
        q = np.linalg.qr(np.column_stack([m @ phi, np.eye(len(phi))]))[0][:, 1:]  # phi^T M q = 0
        y = q @ np.linalg.solve(q.T @ k @ q, q.T @ f)
    else:
        y = np.linalg.solve(k - omega**2 * m, f)
    return basis @ (y - phi * (phi @ m @ y))


def test_zero_modes_are_the_spindle_rotation(model):
    """Geometry finds one zero-frequency motion, the hand-built rotation (and none in the
    packaged model is checked by test_packaged_model_has_no_zero_mode)."""
    am = assemble(model, elements_per_beam=ELEMENTS_PER_BEAM)
    z = zero_modes(am)
    assert z.shape[1] == 1
    rotation = spindle_rotation(am, model)
    rotation /= np.linalg.norm(rotation)
    assert abs(z[:, 0] @ rotation) == pytest.approx(1.0, abs=1e-12)


def test_packaged_model_has_no_zero_mode(packaged):
    """The packaged model keeps its plain Cholesky solve (its numbers do not move)."""
    assert zero_modes(assemble(packaged, elements_per_beam=1)).shape[1] == 0


def test_static_flexibility_is_that_of_the_elastic_modes(model):
    """Each unit wrench on the head's and the table's centres: the static correction's
    flexibility equals the projected direct solve on a finer mesh (64 elements per beam
    against its 32: the relief's O(h^2) error in the shaft's twist, 2e-4 measured)."""
    bodies = ("head", "table")
    am = assemble(model, elements_per_beam=2 * RELIEF_ELEMENTS_PER_BEAM)
    dofs = np.concatenate([am.body_dofs[b][0] for b in bodies])
    direct = np.empty((12, 12))
    for j, dof in enumerate(dofs):
        load = np.zeros(am.K.shape[0])
        load[dof] = 1.0
        direct[:, j] = elastic_solve(am, model, load)[dofs]
    got = static_flexibility(model, bodies)
    np.testing.assert_allclose(got, direct, rtol=1e-3, atol=1e-9 * np.abs(direct).max())
    assert np.abs(got).max() < 1e-6  # the failure measured was 5.8e6 rad/(N m)


def direct_receptance(model, axis: str, freq_hz) -> np.ndarray:
    """Oracle: tool-workpiece receptance along ``axis`` (force pair at the tip, relative
    displacement) with the slide where the FRF's basis is, by :func:`elastic_solve`."""
    machine = model.machine
    moved = model_at_slide(model, machine, cut_slide_position(machine))
    am = assemble(moved, elements_per_beam=ELEMENTS_PER_BEAM)
    tip = tool_tip(np.array([0.0]), machine)[0]
    row = np.zeros(am.K.shape[0])
    for body, sign in ((machine.tool_body, 1.0), (machine.workpiece_body, -1.0)):
        arm = tip - am.node_positions[body][0]
        row[am.body_dofs[body][0]] += sign * point_motion(arm)[AXES[axis]]
    return np.array([row @ elastic_solve(am, moved, row, 2 * np.pi * f) for f in freq_hz])


@pytest.mark.parametrize("axis", ["x", "z"])
def test_receptance_matches_the_direct_solve_across_the_band(model, axis):
    """`ufmt.frf` (default basis below 5 kHz, static correction) against the projected direct
    solve, 1 Hz to 1 kHz, off the resonances (undamped oracle): within 1e-3 of the static
    compliance. Without the fix the x receptance peaked at 1.3e5 m/N in this frame."""
    result = frf(model, axis, fmin_hz=1.0, fmax_hz=1000.0, points=120, zeta=1e-9)
    freq, got = result.frequencies_hz, result.values
    oracle = direct_receptance(model, axis, freq)
    # the oracle is undamped: compare where both are off a resonance by more than 2 %
    off = np.abs(np.abs(got) / np.abs(oracle) - 1) < 0.5
    assert off.mean() > 0.9
    np.testing.assert_allclose(got[off], oracle[off], rtol=1e-3, atol=1e-3 * abs(oracle[0]))
    assert abs(got).max() < 1e-4


@pytest.mark.parametrize(
    "change",
    [
        ("translated", (0.0, 0.0, 0.0)),
        ("translated", (-4.58, 2.2, -10.1)),
        ("translated", (0.01, -0.01, 0.06)),
        ("stiffer", 1 + 1e-12),
        ("stiffer", 1 - 3e-12),
    ],
)
def test_same_answer_under_rounding_size_changes(model, change):
    """A rigid translation of the whole file and relative stiffness changes of 1e-12 give the
    same flexibility (before, some of them let a Cholesky factorisation succeed on the
    singular stiffness: 5.8e6 instead of 1e-10 rad/(N m) about the axis)."""
    bodies = ("head", "table")
    reference = static_flexibility(model, bodies)
    kind, value = change
    if kind == "translated":
        other = translated(model, value)
    else:
        other = dataclasses.replace(
            model,
            hinges=tuple(
                dataclasses.replace(h, stiffness=h.stiffness * value) for h in model.hinges
            ),
        )
    got = static_flexibility(other, bodies)
    np.testing.assert_allclose(got, reference, rtol=0, atol=1e-7 * np.abs(reference).max())


@pytest.mark.parametrize("method", ["periodic", "time"])
def test_simulate_is_that_of_the_file_in_its_own_frame(model, method):
    """Both response paths on the moved file equal those on examples/bridge.toml (the same
    machine where the file draws it; a rigid translation changes no response): before, the
    moved file's tool tip swung by 5e4 m in x."""
    bridge = as_model(Path(__file__).parents[1] / "examples" / "bridge.toml")
    bridge = dataclasses.replace(
        bridge, machine=dataclasses.replace(bridge.machine, tool_compliance_m_per_N=0.0)
    )
    process = Process(300, 15, 4)
    moved = simulate(model, process, method=method).response
    here = simulate(bridge, process, method=method).response
    for name in ("tip_disp", "work_disp", "z_re"):
        a, b = getattr(moved, name), getattr(here, name)
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-6 * np.abs(b).max(), err_msg=name)
