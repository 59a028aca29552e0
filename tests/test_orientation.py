"""Any spindle orientation: ``[machine]`` spindle, feed and gravity directions.

Oracle: a rigid rotation of the whole machine (every body, hinge, the ``[machine]``
directions and gravity) is the same machine, so it changes no metric beyond rounding: the
natural frequencies, z_re, the PVs, the PSD bands and the force. Rotated copies of
examples/bridge.toml: 90 degrees about y (the spindle becomes horizontal, along x; hinges
anisotropic, their springs permuted) and an arbitrary rotation (isotropic hinges, which any
rotation leaves unchanged). A ``[machine]`` inconsistent with the model is refused in one line.
"""

from __future__ import annotations

import copy
import math
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from ufmt.errors import ModelError
from ufmt.machining.machine_frame import in_machine_frame
from ufmt.machining.process import Process
from ufmt.machining.static import gravity_deflection
from ufmt.model.load import model_from_dict
from ufmt.model.orientation import frame_matrix
from ufmt.mstmm.solve import solve_modes
from ufmt.simulate import simulate

ROOT = Path(__file__).resolve().parents[1]
BRIDGE = ROOT / "examples" / "bridge.toml"
#: 90 degrees about y: z -> x, x -> -z.
ABOUT_Y = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
METRICS = (
    "pv_nm",
    "pv_aperture_nm",
    "pv_measured_nm",
    "rms_nm",
    "zre_peak_nm",
    "psd2_rms_nm",  # PSD1's 3 x 33 mm exceed the 100 mm plate's 90 mm clear aperture
    "force_peak_n",
    "pv_dynamic_nm",
    "roughness_pv_nm",
    "tip_acc_peak_mm_s2",
)
#: Relative agreement of a rotated copy: rounding of the rotated geometry through the
#: eigen-solution and the static solves (the unrotated metrics are O(1-100) nm).
RTOL = 1e-6


def bridge(**machine) -> dict:
    """examples/bridge.toml as a dict, its [design] and [[uncertain]] dropped (they name
    global components),
    ``machine`` merged into its [machine] table; the error sources that need no parameter
    switched on so that gravity and the geometric terms enter too."""
    data = tomllib.loads(BRIDGE.read_text())
    data.pop("design")
    data.pop("uncertain", None)
    data["machine"].update(
        {"spindle_tilt_rad": 1e-6, "error_motion_m": 2e-9, "straightness_m": 5e-9}, **machine
    )
    return data


def isotropic(data: dict) -> dict:
    """``data`` with every hinge spring equal along x, y and z (their mean; no released
    direction), so that any rotation leaves the hinges as they are."""
    data = copy.deepcopy(data)
    for hinge in data["hinge"]:
        for field in ("stiffness", "rotational_stiffness"):
            values = np.asarray(hinge[field], dtype=float)
            finite = values[np.isfinite(values) & (values > 0)]
            level = float(np.mean(finite)) if finite.size else math.inf
            hinge[field] = [level] * 3
    return data


def rotated(data: dict, q: np.ndarray, directions: bool = True) -> dict:
    """The machine ``data`` rotated rigidly by ``q`` about the origin: points, inertia tensors,
    hinge springs (permuted by a signed permutation ``q``; equal ones kept otherwise) and,
    with ``directions``, the [machine]'s spindle, feed and gravity directions."""
    data = copy.deepcopy(data)
    for body in data["body"]:
        for key in ("center_of_mass", "start", "end", "orientation"):
            if key in body:
                body[key] = (q @ np.asarray(body[key], dtype=float)).tolist()
        if "inertia" in body:
            body["inertia"] = (q @ np.asarray(body["inertia"], dtype=float) @ q.T).tolist()
    for hinge in data["hinge"]:
        hinge["at"] = (q @ np.asarray(hinge["at"], dtype=float)).tolist()
        for key in ("stiffness", "rotational_stiffness", "damping", "rotational_damping"):
            if key in hinge:
                values = np.asarray(hinge[key], dtype=float)
                hinge[key] = values[np.argmax(np.abs(q), axis=1)].tolist()
    if directions:
        machine = data["machine"]
        for key, default in (
            ("spindle_direction", (0.0, 0.0, 1.0)),
            ("feed_direction", (0.0, -1.0, 0.0)),
            ("gravity_direction", (0.0, 0.0, -1.0)),
        ):
            machine[key] = (q @ np.asarray(machine.get(key, default), dtype=float)).tolist()
    return data


def arbitrary_rotation() -> np.ndarray:
    """A rotation about an oblique axis by 0.7 rad (Rodrigues' formula)."""
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(0.7) * k + (1 - math.cos(0.7)) * k @ k


def run(data: dict) -> dict:
    model = model_from_dict(data, "bridge.toml")
    return simulate(model, Process(rpm=300.0, feed_mm_min=15.0, depth_um=4.0)).to_dict()


def assert_same_metrics(got: dict, want: dict) -> None:
    for key in METRICS:
        assert got[key] == pytest.approx(want[key], rel=RTOL, abs=1e-9), key
    for key, value in want["pv_by_source_nm"].items():
        assert got["pv_by_source_nm"][key] == pytest.approx(value, rel=RTOL, abs=1e-9), key


def test_frame_of_the_default_directions_is_the_global_frame():
    """Oracle: the default spindle "z" and feed "-y" give F = I exactly (today's machine)."""
    assert np.array_equal(frame_matrix((0, 0, 1), (0, -1, 0)), np.eye(3))


@pytest.mark.parametrize("q", [ABOUT_Y, arbitrary_rotation()], ids=["about-y", "arbitrary"])
def test_frame_is_a_rotation_carried_by_a_rotation(q):
    """Oracle: F is orthonormal and right-handed, and rotating both directions by q gives q F."""
    frame = frame_matrix(q @ [0, 0, 1], q @ [0, -1, 0])
    assert frame.T @ frame == pytest.approx(np.eye(3), abs=1e-15)
    assert np.linalg.det(frame) == pytest.approx(1.0, abs=1e-15)
    assert frame == pytest.approx(q, abs=1e-15)


def test_upright_model_is_not_copied():
    """The default directions leave the model as it is: today's results bitwise."""
    model = model_from_dict(bridge(), "bridge.toml")
    assert in_machine_frame(model) is model


@pytest.mark.parametrize(
    "base, q",
    [(bridge, ABOUT_Y), (lambda: isotropic(bridge()), arbitrary_rotation())],
    ids=["horizontal", "arbitrary"],
)
def test_rotated_model_in_its_machine_frame_is_the_original(base, q):
    """Oracle: the rotated machine seen in its machine frame is the file's machine again."""
    original = base()
    data = rotated(original, q)
    framed = in_machine_frame(model_from_dict(data, "bridge.toml"))
    base = model_from_dict(original, "bridge.toml")
    for a, b in zip(framed.bodies, base.bodies, strict=True):
        for key in ("center_of_mass", "inertia", "start", "end"):
            if hasattr(b, key):
                assert getattr(a, key) == pytest.approx(getattr(b, key), abs=1e-12)
    for a, b in zip(framed.hinges, base.hinges, strict=True):
        assert a.at == pytest.approx(b.at, abs=1e-12)
        assert np.array_equal(a.stiffness6, b.stiffness6)
    assert framed.machine.gravity_direction == pytest.approx((0.0, 0.0, -1.0), abs=1e-15)


def test_horizontal_spindle_natural_frequencies_are_unchanged():
    """Oracle: a rigid rotation changes no natural frequency (the structural solve runs in
    the file's frame, whatever the spindle's direction)."""
    want = solve_modes(model_from_dict(bridge(), "b.toml"), fmax_hz=3000.0).frequencies_hz
    got = solve_modes(model_from_dict(rotated(bridge(), ABOUT_Y), "b.toml"), fmax_hz=3000.0)
    assert got.frequencies_hz == pytest.approx(want, rel=1e-9)


def test_horizontal_spindle_cuts_as_the_vertical_one():
    """Oracle: the machine turned 90 degrees about y (spindle along x, gravity along -x in
    the file's frame) gives the vertical machine's metrics to rounding."""
    assert_same_metrics(run(rotated(bridge(), ABOUT_Y)), run(bridge()))


def test_arbitrary_rotation_cuts_as_the_original():
    """Oracle: an oblique rotation of a machine with isotropic hinges changes no metric."""
    base = isotropic(bridge())
    assert_same_metrics(run(rotated(base, arbitrary_rotation())), run(base))


def test_horizontal_spindle_without_its_direction_is_refused():
    """The user's horizontal fly-cutter (shaft along x) read as a vertical spindle: refused at
    load, naming the field, instead of a blown-up z_re."""
    data = rotated(bridge(), ABOUT_Y, directions=False)
    with pytest.raises(ModelError, match=r"machine: field 'spindle_direction'.*'shaft'"):
        model_from_dict(data, "bridge.toml")


@pytest.mark.parametrize(
    "machine, field, words",
    [
        ({"spindle_direction": [0.0, 0.0, 0.9]}, "spindle_direction", "length 0.9"),
        ({"spindle_direction": "w"}, "spindle_direction", "unknown direction"),
        ({"spindle_direction": [0.0, 0.0, math.nan]}, "spindle_direction", "nan"),
        ({"feed_direction": "z"}, "feed_direction", "not normal"),
        ({"gravity_direction": [1.0, 1.0, 0.0]}, "gravity_direction", "not 1"),
        ({"spindle_direction": "x", "feed_direction": "-y"}, "spindle_direction", "'shaft'"),
        ({"spindle_direction": "-z"}, "spindle_direction", "points from the tool body"),
        ({"spindle_direction": [0.0, 0.0, 1.0], "feed_direction": "x"}, "", None),
    ],
)
def test_inconsistent_machine_is_refused_in_one_line(machine, field, words):
    """Not a unit vector, a feed along the spindle, a spindle across the spindle beam or
    pointing from the tool to the workpiece: one line naming the file and the field. A feed
    along x (any direction in the cutting plane) loads."""
    if words is None:
        model_from_dict(bridge(**machine), "bridge.toml")
        return
    with pytest.raises(ModelError) as err:
        model_from_dict(bridge(**machine), "bridge.toml")
    text = str(err.value)
    assert text.startswith(f"bridge.toml: machine: field '{field}") and "\n" not in text
    assert words in text


def test_released_rotation_across_the_spindle_is_refused():
    """A spindle bearing that lets the spindle turn about x while the spindle is along z."""
    data = bridge()
    data["hinge"][1]["rotational_stiffness"] = [0.0, 1e7, 1e7]
    with pytest.raises(ModelError, match=r"spindle_direction.*'air_bearing' releases"):
        model_from_dict(data, "bridge.toml")


def test_oblique_spindle_on_anisotropic_hinges_is_refused():
    """A hinge spring along global axes cannot act along an oblique machine axis: one line
    naming the hinge and the field."""
    data = rotated(isotropic(bridge()), arbitrary_rotation())
    data["hinge"][0]["stiffness"] = [5e9, 5e9, 8e9]
    with pytest.raises(ModelError, match=r"hinge 'bridge_on_ground': field 'stiffness'"):
        in_machine_frame(model_from_dict(data, "bridge.toml"))


def test_cli_refuses_a_bad_direction_in_one_line(tmp_path):
    """Exit 2, one line on stderr naming the file and the field, no traceback."""
    text = BRIDGE.read_text().replace('rotation = "cw"', 'rotation = "cw"\nfeed_direction = "z"')
    path = tmp_path / "bad.toml"
    path.write_text(text)
    done = subprocess.run(
        [sys.executable, "-m", "ufmt.cli", "simulate", str(path), "--json"],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "field 'feed_direction'" in lines[0] and "Traceback" not in lines[0]


@pytest.mark.parametrize(
    "base, q",
    [(bridge, ABOUT_Y), (lambda: isotropic(bridge()), arbitrary_rotation())],
    ids=["horizontal", "arbitrary"],
)
def test_weight_deflection_rotates_with_the_machine(base, q):
    """Oracle: the static deflection under gravity of a rotated machine, gravity rotated too,
    is the original's rotated (in the file's frame) and the original's (in the machine
    frame); gravity left along -z gives another one (the direction is used)."""
    bodies = ("head", "table")
    original = model_from_dict(base(), "b.toml")
    turned = model_from_dict(rotated(base(), q), "b.toml")
    want = gravity_deflection(original, bodies).reshape(4, 3)
    scale = np.abs(want).max()
    assert scale > 0
    got = gravity_deflection(turned, bodies).reshape(4, 3)
    assert got == pytest.approx(want @ q.T, abs=1e-9 * scale)
    framed = gravity_deflection(in_machine_frame(turned), bodies).reshape(4, 3)
    assert framed == pytest.approx(want, abs=1e-9 * scale)
    data = rotated(base(), q)
    data["machine"]["gravity_direction"] = "-z"
    other = gravity_deflection(model_from_dict(data, "b.toml"), bodies).reshape(4, 3)
    assert np.abs(other - want @ q.T).max() > 1e-3 * scale


def test_weight_deflection_is_linear_in_the_gravity_direction():
    """Oracle: linearity: the deflection along a unit direction d is sum_i d_i u_i, u_i the
    deflection under gravity along global axis i."""
    bodies = ("head", "table")
    d = np.array([0.48, -0.6, 0.64])

    def under(direction):
        model = model_from_dict(bridge(gravity_direction=list(direction)), "b.toml")
        return gravity_deflection(model, bodies)

    axes = np.array([under(e) for e in np.eye(3)])
    want = d @ axes
    assert under(d) == pytest.approx(want, abs=1e-9 * np.abs(axes).max())


def test_frf_of_a_horizontal_spindle_is_the_vertical_one():
    """Oracle: the tool-workpiece receptance along the spindle axis and a point FRF given in
    the file's frame are unchanged by the rotation (their axes are the machine frame's)."""
    from ufmt.machining.frf import frf

    options = {"fmin_hz": 50.0, "fmax_hz": 3000.0, "points": 64}
    original = model_from_dict(bridge(), "b.toml")
    turned = model_from_dict(rotated(bridge(), ABOUT_Y), "b.toml")
    for direction in ("z", "xy"):
        want = frf(original, direction, **options).to_frame().filter(like="_m_per_N").to_numpy()
        got = frf(turned, direction, **options).to_frame().filter(like="_m_per_N").to_numpy()
        assert got == pytest.approx(want, rel=1e-9, abs=1e-9 * np.abs(want).max())
    point = ("head", (0.1, 0.05, 0.965))
    want = frf(original, "z", output=point, **options).to_frame().filter(like="_m_per_N").to_numpy()
    moved = ("head", tuple(ABOUT_Y @ point[1]))
    got = frf(turned, "z", output=moved, **options).to_frame().filter(like="_m_per_N").to_numpy()
    assert got == pytest.approx(want, rel=1e-9, abs=1e-9 * np.abs(want).max())


def test_tool_tip_along_the_spindle_is_unchanged_by_the_rotation():
    """Oracle: the calibration's tool-tip participation (translation along the spindle axis)
    of every mode is the same for the horizontal copy (up to each shape's sign)."""
    from ufmt.calibration.frequencies import modeset_from_mstmm

    def tip(data):
        model = model_from_dict(data, "b.toml")
        return modeset_from_mstmm(model, solve_modes(model, fmax_hz=3000.0).shapes).tool_tip_z

    want = tip(bridge())
    got = tip(rotated(bridge(), ABOUT_Y))
    assert np.abs(want).max() > 0
    assert np.abs(got) == pytest.approx(np.abs(want), abs=1e-9 * np.abs(want).max())


def test_report_lists_the_directions_a_file_gives():
    """The report's machine table shows the directions written in the file (and only then:
    an upright file's table is unchanged)."""
    from ufmt.report import machine_table

    turned = machine_table(model_from_dict(rotated(bridge(), ABOUT_Y), "b.toml"))
    rows = turned.set_index("field")
    assert rows.loc["spindle_direction", "value"] == "1, 0, 0"
    assert rows.loc["gravity_direction", "value"] == "-1, 0, 0"
    upright = machine_table(model_from_dict(bridge(), "b.toml"))
    assert "spindle_direction" not in set(upright["field"])


def cli(*args) -> dict:
    import json

    done = subprocess.run(
        [sys.executable, "-m", "ufmt.cli", *args, "--json"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        check=True,
    )
    return json.loads(done.stdout)


@pytest.mark.slow  # four CLI runs; the in-process twin: test_horizontal_spindle_cuts_...
def test_cli_runs_the_horizontal_model_file_as_the_example():
    """Oracle: tests/models/horizontal_bridge.toml is examples/bridge.toml turned 90 degrees
    about y with its gravity; ``ufmt modes`` and ``ufmt simulate`` give the example's."""
    horizontal = str(ROOT / "tests" / "models" / "horizontal_bridge.toml")
    want, got = cli("modes", str(BRIDGE)), cli("modes", horizontal)
    assert got["frequencies_hz"] == pytest.approx(want["frequencies_hz"], rel=1e-9)
    assert_same_metrics(cli("simulate", horizontal), cli("simulate", str(BRIDGE)))


def test_evaluate_sets_a_design_on_the_horizontal_machine_as_on_the_example():
    """Oracle: the same design (the air bearing's axial stiffness, declared along x in the
    horizontal file and along z in the example) gives the same record."""
    from ufmt.evaluate import evaluate

    design = {"spindle_axial_stiffness_N_m": 8e8}
    horizontal = ROOT / "tests" / "models" / "horizontal_bridge.toml"
    want, got = evaluate(design, {}, BRIDGE), evaluate(design, {}, horizontal)
    assert want["status"] == got["status"] == "ok"
    for key in ("pv_nm", "pv_measured_nm", "zre_peak_nm", "psd2_rms_nm", "f1_hz", "f6_hz"):
        assert got[key] == pytest.approx(want[key], rel=RTOL), key


def test_machine_frame_model_reads_back_as_itself():
    """The rotated model's [machine] table, read again (a design or a fit re-reads it), gives
    the machine-frame machine: no second rotation."""
    from ufmt.model.machine import read_machine

    framed = in_machine_frame(model_from_dict(rotated(bridge(), ABOUT_Y), "b.toml"))
    again = read_machine(framed.machine.table, "b.toml")
    assert again.upright and in_machine_frame(framed) is framed
    assert again.gravity_direction == pytest.approx(framed.machine.gravity_direction, abs=0)


def test_machine_frame_keeps_a_beam_section_turned_as_the_file_has_it():
    """Oracle: a rotation changes no natural frequency: the rotated model in its machine frame
    has the file's frequencies, also for a beam whose section is not round and whose local y
    axis is the default (the machine frame must keep the file's, not take its own default)."""
    data = rotated(isotropic(bridge()), arbitrary_rotation())
    shaft = next(b for b in data["body"] if b["name"] == "shaft")
    del shaft["diameter"]
    shaft.update(area=0.0113, second_moment_y=4e-6, second_moment_z=2e-5, polar_moment=2.4e-5)
    model = model_from_dict(data, "b.toml")
    want = solve_modes(model, fmax_hz=3000.0).frequencies_hz
    got = solve_modes(in_machine_frame(model), fmax_hz=3000.0).frequencies_hz
    assert got == pytest.approx(want, rel=1e-9)
