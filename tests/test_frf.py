"""ufmt.frf: every direction and end against an independent solution, and its contracts."""

from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import null_space

import ufmt
from ufmt.assembled.matrices import assemble
from ufmt.cli import main
from ufmt.errors import UfmtError
from ufmt.kinematics import point_motion
from ufmt.machining.cutting import tool_tip
from ufmt.machining.frf import frf, tool_workpiece_receptance
from ufmt.machining.modal import modal_basis
from ufmt.machining.slide import cut_slide_position, model_at_slide
from ufmt.machining.static import residual_flexibility
from ufmt.model.machine import machine_of

ROOT = Path(__file__).resolve().parents[1]
BRIDGE = ROOT / "examples" / "bridge.toml"
HEAD = ("head", (0.0, 0.0, 0.93))  # on the spindle axis
OFF_AXIS = ("head", (0.1, 0.05, 0.93))
BRIDGE_POINT = ("bridge", (0.3, 0.1, 1.6))  # the bridge carries the spindle: coupled to the head
AXIS = {"x": 0, "y": 1, "z": 2}


def direct_receptance(model, ends, axes, freq_hz):
    """Oracle: the assembled mass-stiffness model solved directly, undamped,
    H = t_out N (N^T (K - W^2 M) N)^-1 N^T t_in^T (N: the motions the rigid hinges allow)."""
    am = assemble(model)
    n = null_space(am.constraints) if am.constraints.size else np.eye(am.K.shape[0])
    rows = []
    for terms, axis in zip(ends, axes, strict=True):
        t = np.zeros(am.K.shape[0])
        for body, point, weight in terms:
            centre = np.asarray(model.body(body).center_of_mass)
            t[am.body_dofs[body][0]] += (
                weight * point_motion(np.asarray(point) - centre)[AXIS[axis], :]
            )
        rows.append(t @ n)
    k, m = n.T @ am.K @ n, n.T @ am.M @ n
    return np.array(
        [rows[0] @ np.linalg.solve(k - (2 * np.pi * f) ** 2 * m, rows[1]) for f in freq_hz]
    )


def _terms(spec, machine):
    """The (body, point, weight) terms of an FRF end: None = the tool-workpiece pair."""
    if spec is None:
        tip = tuple(tool_tip(np.array([0.0]), machine)[0])
        return ((machine.tool_body, tip, 1.0), (machine.workpiece_body, tip, -1.0))
    return ((spec[0], spec[1], 1.0),)


@pytest.mark.parametrize(
    ("direction", "output", "input"),
    [("z", None, None), ("xz", HEAD, BRIDGE_POINT), ("yy", HEAD, HEAD), ("zy", None, None)],
)
def test_frf_matches_the_assembled_model_solved_directly(direction, output, input):
    """Below the first mode and between modes, with a basis to 5 kHz and the static
    correction, the FRF equals the direct solution of the independent assembled model.
    (Points and directions the free spindle rotation does not move: the FRF leaves the
    zero-frequency modes out, the spindle being driven.)"""
    model = ufmt.load_model(BRIDGE)
    result = frf(  # the basis with the slide where it cuts (the default)
        BRIDGE,
        direction,
        output=output,
        input=input,
        fmin_hz=20.0,
        fmax_hz=200.0,
        points=4,
        basis_cutoff_hz=5000.0,
        zeta=1e-9,
    )
    machine = machine_of(model)
    # the oracle: the assembled model with its carriage moved to that slide position, where
    # the workpiece material point under the tip is the tip itself (the carried bodies'
    # points of the file are moved with them; HEAD and BRIDGE_POINT are not carried)
    moved = model_at_slide(model, machine, cut_slide_position(machine))
    ends = (_terms(output, machine), _terms(input, machine))
    axes = direction * 2 if len(direction) == 1 else direction
    expected = direct_receptance(moved, ends, axes, result.frequencies_hz)
    scale = np.max(np.abs(expected))
    np.testing.assert_allclose(result.values.real, expected, rtol=0, atol=1e-6 * scale)


def test_the_z_receptance_is_the_response_path_s():
    """The tool-workpiece z-z case equals tool_workpiece_receptance with its residual (the
    function the simulation's z_re rests on)."""
    model = ufmt.load_model(BRIDGE)
    basis = modal_basis(model)
    machine = machine_of(model)
    result = frf(model, "z", fmin_hz=10.0, fmax_hz=900.0, points=50)
    h = tool_workpiece_receptance(
        basis, machine, result.frequencies_hz, residual=residual_flexibility(model, basis, machine)
    )
    np.testing.assert_allclose(result.values, h, rtol=1e-10)


def test_mobility_and_accelerance_are_receptance_times_iw():
    base = frf(BRIDGE, "xz", output=HEAD, input=BRIDGE_POINT, points=20)
    w = 2j * np.pi * base.frequencies_hz
    for kind, factor in (("mobility", w), ("accelerance", w**2)):
        other = frf(BRIDGE, "xz", kind, output=HEAD, input=BRIDGE_POINT, points=20)
        np.testing.assert_allclose(other.values, factor * base.values, rtol=1e-12)
        assert f"magnitude_{other.unit}" in other.to_frame().columns


def test_reciprocity():
    """Maxwell-Betti: the x response at A to a z force at B is the z response at B to x at A."""
    a = frf(BRIDGE, "xz", output=OFF_AXIS, input=BRIDGE_POINT, points=30)
    b = frf(BRIDGE, "zx", output=BRIDGE_POINT, input=OFF_AXIS, points=30)
    np.testing.assert_allclose(a.values, b.values, rtol=1e-9)


def test_bad_arguments_are_one_clear_error():
    for kwargs, message in (
        ({"direction": "w"}, "FRF direction 'w'"),
        ({"kind": "compliance"}, "FRF kind 'compliance'"),
        ({"output": ("shaft", (0, 0, 1))}, "not a rigid body"),
    ):
        with pytest.raises(UfmtError, match=message):
            frf(BRIDGE, **kwargs)


def test_frf_cli_writes_the_users_folder_with_the_model_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["frf", str(BRIDGE), "--points", "50", "--direction", "xz"]) == 0
    folder = tmp_path / "results" / "bridge" / "frf"
    table = (folder / "frf-xz-receptance.csv").read_text().splitlines()
    assert table[0].startswith("frequency_hz,magnitude_m_per_N")
    assert table[1].endswith("spindle on a bridge")
    assert (folder / "frf-xz-receptance.png").exists()
