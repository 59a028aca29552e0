"""Process validation, machine geometry, fly-cutting kinematics and force."""

import math
import warnings

import numpy as np
import pytest
from synthetic import MACHINE

from ufmt.errors import ModelError, ProcessError
from ufmt.machining.basis import ModalBasis
from ufmt.machining.cut_geometry import cut_geometry
from ufmt.machining.cutting import (
    ForceCoefficients,
    chip_factor,
    chip_factor_cells,
    cutting_force,
    tool_over_workpiece,
    tool_tip,
    tool_tip_rates,
)
from ufmt.machining.process import Process, ProcessRangeWarning
from ufmt.model.machine import machine_of, read_machine
from ufmt.model.schema import Model

# --- process ------------------------------------------------------------------------------


@pytest.mark.parametrize("field", ["rpm", "feed_mm_min", "depth_um"])
@pytest.mark.parametrize("bad", [0.0, -3.0, float("nan"), float("inf")])
def test_process_rejects_non_physical_values_naming_the_field(field, bad):
    values = {"rpm": 300.0, "feed_mm_min": 15.0, "depth_um": 4.0, field: bad}
    with pytest.raises(ProcessError, match=f"field '{field}'"):
        Process(**values)


def test_process_rejects_non_numbers():
    with pytest.raises(ProcessError, match="field 'rpm': 'fast' is not a number"):
        Process("fast", 15, 4)


@pytest.mark.parametrize(
    "values, field",
    [((500, 15, 4), "rpm"), ((300, 2, 4), "feed_mm_min"), ((300, 15, 10), "depth_um")],
)
def test_process_outside_table1_warns(values, field):
    with pytest.warns(ProcessRangeWarning, match=f"field '{field}'.*outside the validated range"):
        Process(*values)


def test_process_inside_table1_is_silent_and_converts_units():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        p = Process(300, 15, 4)
    assert p.spindle_hz == 5.0
    assert p.feed_m_s == pytest.approx(15e-3 / 60)
    assert p.depth_m == pytest.approx(4e-6)
    assert p.feed_per_rev_m == pytest.approx(15e-3 / 300)  # v / n: 0.05 mm per revolution


# --- machine table ------------------------------------------------------------------------


def test_read_machine_accepts_the_documented_table():
    m = read_machine(MACHINE, "ufmt.toml")
    assert (m.tool_radius, m.workpiece_size, m.sense, m.force_scale) == (
        0.25,
        (0.41, 0.41),
        1.0,
        1.0,
    )
    # leading arc first touches at Y = -(Ly/2 + R); trailing arc leaves at +(Ly/2 + R)
    assert m.cut_span == pytest.approx((-0.455, 0.455))
    # cutting stops when the arc's ends at the plate's x edges pass the far y edge
    assert m.cutting_span[1] == pytest.approx(0.205 - math.sqrt(0.25**2 - 0.205**2))


@pytest.mark.parametrize(
    "change, message",
    [
        (
            {"tool_radius": -0.2},
            r"ufmt.toml: machine: field 'tool_radius': -0.2 is not positive \(allowed: > 0 \[m\]\)",
        ),
        ({"tool_radius": 0.2}, "field 'tool_radius': 0.2 must exceed"),
        ({"rotation": "left"}, r"field 'rotation': unknown rotation 'left' \(valid rotations: cw"),
        ({"workpiece_size": [0.4]}, "field 'workpiece_size'"),
        ({"workpiece_size": [0.4, -1]}, r"field 'workpiece_size\[1\]': -1 is not positive"),
        (
            {"cutting_plane_z": "top"},
            "field 'cutting_plane_z': expected a number, got string 'top'",
        ),
        ({"workpiece_center_xy": [0.0, 0.1]}, "field 'workpiece_center_xy'"),
        ({"tool_body": ""}, "field 'tool_body'"),
        ({"force_scale": 0.0}, r"field 'force_scale': 0 is outside the allowed range \[0.3, 3\]"),
        ({"force_scale": 36.3}, r"field 'force_scale': 36.3 is outside the allowed range"),
        ({"force_scale": float("inf")}, "field 'force_scale': inf is not finite"),
        (
            {"force_scal": 1.0},
            "machine: unknown field 'force_scal' \\(did you mean 'force_scale'\\?\\)",
        ),
        ({"nose_radius": 0.5}, r"field 'nose_radius': 0.5 is outside the allowed range .* \[m\]"),
        ({"spindle_tilt_rad": 1e-3}, "field 'spindle_tilt_rad'"),
        ({"error_motion_m": -1e-9}, "field 'error_motion_m'"),
        ({"straightness_wavelength_m": 0.0}, "field 'straightness_wavelength_m'"),
        ({"rake_angle_deg": "neg"}, "field 'rake_angle_deg': expected a number, got string 'neg'"),
    ],
)
def test_read_machine_errors_name_file_and_field(change, message):
    with pytest.raises(ModelError, match=message):
        read_machine({**MACHINE, **change}, "ufmt.toml")


def test_read_machine_missing_field():
    table = {k: v for k, v in MACHINE.items() if k != "tool_radius"}
    with pytest.raises(ModelError, match="ufmt.toml: machine: field 'tool_radius': missing"):
        read_machine(table, "ufmt.toml")


def test_machine_bodies_must_exist_in_the_model():
    from ufmt.model.schema import RigidBody, frozen_array

    body = RigidBody("head", 1.0, frozen_array([0, 0, 0]), frozen_array(np.eye(3)))
    model = Model("m", (body,), (), machine=read_machine(MACHINE), source="m.toml")
    with pytest.raises(ModelError, match="m.toml: machine: field 'workpiece_body': 'slider'"):
        machine_of(model)


# --- kinematics (eq. 4.1) ---------------------------------------------------------------------


def test_tool_tip_follows_eq_4_1_and_its_derivatives():
    axis = {"spindle_axis_xy": [0.01, -0.02], "workpiece_center_xy": [0.0, -0.02]}
    m = read_machine({**MACHINE, **axis, "cutting_plane_z": 0.3})
    phi = np.linspace(0, 2 * np.pi, 7)
    p = tool_tip(phi, m)
    np.testing.assert_allclose(p[:, 0], 0.01 + 0.25 * np.sin(phi))
    np.testing.assert_allclose(p[:, 1], -0.02 + 0.25 * np.cos(phi))
    np.testing.assert_allclose(p[:, 2], 0.3)
    # velocity and acceleration against central differences in time (f = 5 Hz)
    f, dt = 5.0, 1e-6
    vel, acc = tool_tip_rates(phi, m, f)
    w = 2 * np.pi * f
    num_v = (tool_tip(phi + w * dt, m) - tool_tip(phi - w * dt, m)) / (2 * dt)
    num_a = (tool_tip(phi + w * dt, m) - 2 * p + tool_tip(phi - w * dt, m)) / dt**2
    np.testing.assert_allclose(vel, num_v, atol=1e-6)
    np.testing.assert_allclose(acc, num_a, atol=1e-2)
    # eq. 4.1 turns clockwise seen from +z: angular momentum (p x v)_z < 0
    assert np.all(np.cross(p - [0.01, -0.02, 0.3], vel)[:, 2] < 0)


def test_ccw_mirrors_x():
    cw, ccw = read_machine(MACHINE), read_machine({**MACHINE, "rotation": "ccw"})
    phi = np.linspace(0, 6, 5)
    np.testing.assert_allclose(tool_tip(phi, ccw)[:, 0], -tool_tip(phi, cw)[:, 0])
    np.testing.assert_allclose(tool_tip(phi, ccw)[:, 1:], tool_tip(phi, cw)[:, 1:])


def test_tool_cuts_only_on_the_leading_arc_over_the_workpiece():
    m = read_machine(MACHINE)
    delta = 5e-5
    # workpiece centred under the spindle (Y = 0): the plate edge y = 0.205 cuts the arc
    # at cos(phi) = 0.82, its x edges at sin(phi) = 0.82
    phi = np.radians([0, 30, 40, 50, 60, 140, 180, 220, 320])
    h = delta * chip_factor(phi, 0.0, m)
    over = tool_over_workpiece(phi, 0.0, m)
    expect_over = [False, False, True, True, False, True, False, True, True]
    np.testing.assert_array_equal(over, expect_over)
    cutting = over & (np.cos(phi) > 0)
    np.testing.assert_allclose(h, np.where(cutting, delta * np.cos(phi), 0.0))


@pytest.mark.parametrize("slide", [-0.44, -0.25, -0.03, 0.05])
def test_cell_means_of_the_chip_factor(slide):
    """Cell means = fine average of the point chip factor; their sum keeps the exact integral."""
    m = read_machine(MACHINE)
    n = 256
    width = 2 * np.pi / n
    phi = width * np.arange(n)
    cells = chip_factor_cells(phi, slide, m, width)
    fine = phi[:, None] + width * ((np.arange(4000) + 0.5) / 4000 - 0.5)[None, :]
    np.testing.assert_allclose(cells, chip_factor(fine, slide, m).mean(axis=1), atol=2e-3)
    # integral of cos over the cut: |phi| within asin(0.82) (x edges) and the y-edge bounds
    p1 = np.arccos(np.clip((0.205 - slide) / 0.25, -1, 1))
    p2 = np.arccos(np.clip((-0.205 - slide) / 0.25, 0, 1))
    lo, hi = p1, min(p2, np.arcsin(0.82))
    exact = 2 * max(np.sin(hi) - np.sin(lo), 0.0)
    assert cells.sum() * width == pytest.approx(exact, rel=1e-12, abs=1e-15)


def test_cutting_force_components_and_scaling():
    m = read_machine(MACHINE)
    k = ForceCoefficients(cutting=2e9, thrust=3e9, feed=0.5e9)
    p = Process(300, 15, 4)
    phi = np.radians([-40.0, 0.0, 25.0])
    slide = -0.25  # arc fully over the plate
    f = cutting_force(phi, slide, p, m, k, force_scale=1.5, parts=("area",))
    area = 1.5 * p.depth_m * p.feed_per_rev_m * np.cos(phi)
    vel, _ = tool_tip_rates(phi, m, p.spindle_hz)
    t = vel / np.linalg.norm(vel, axis=1, keepdims=True)
    n = (tool_tip(phi, m) - [0, 0, 0]) * [1, 1, 0] / 0.25
    np.testing.assert_allclose(np.einsum("ij,ij->i", f, t), -k.cutting * area)  # opposes v
    np.testing.assert_allclose(np.einsum("ij,ij->i", f, n), -k.feed * area)  # pushed back
    np.testing.assert_allclose(f[:, 2], k.thrust * area)  # tool pushed up, away from the cut
    # linear in depth and in feed per revolution
    f2 = cutting_force(phi, slide, Process(300, 15, 8), m, k, force_scale=1.5, parts=("area",))
    np.testing.assert_allclose(f2, 2 * f)
    f3 = cutting_force(phi, slide, Process(400, 16, 4), m, k, parts=("area",))
    f4 = cutting_force(phi, slide, Process(200, 16, 4), m, k, parts=("area",))
    np.testing.assert_allclose(f4, 2 * f3)


def test_edge_term_is_k_e_times_the_contact_arc_and_independent_of_the_feed():
    """F = K_e b + K_c A per component, b = sqrt(2 r_n a_p) wherever the edge engages."""
    m = read_machine({**MACHINE, "nose_radius": 2e-3})
    k = ForceCoefficients()
    phi = np.radians([-40.0, 0.0, 25.0, 120.0])  # the last on the trailing arc: no force
    slow, fast = Process(300, 4, 4), Process(300, 16, 4)
    b = np.sqrt(2 * 2e-3 * 4e-6)
    edge = cutting_force(phi, -0.25, slow, m, k, parts=("edge",))
    np.testing.assert_allclose(edge[:3, 2], k.edge_thrust * b)
    np.testing.assert_array_equal(edge[3], 0.0)
    np.testing.assert_allclose(cutting_force(phi, -0.25, fast, m, k, parts=("edge",)), edge)
    total = cutting_force(phi, -0.25, fast, m, k)
    np.testing.assert_allclose(total, edge + cutting_force(phi, -0.25, fast, m, k, parts=("area",)))


def test_forces_at_the_reference_cut_lie_in_the_literature_band():
    """Peak forces 0.1-1 N and specific cutting energy 1-5 GPa (diamond cutting of KDP)."""
    m = read_machine(MACHINE)
    p = Process(300, 15, 4)
    k = ForceCoefficients()
    f = cutting_force(np.linspace(-0.5, 0.5, 101), -0.25, p, m, k)
    peak = np.linalg.norm(f, axis=1).max()
    assert 0.1 <= peak <= 1.0
    assert 1e9 <= k.cutting <= 5e9
    # the whole [machine] force_scale band keeps the specific energy within 0.6-6 GPa
    assert 0.3 * k.cutting >= 0.5e9 and 3 * k.cutting <= 6e9


def test_reaction_on_the_workpiece_cancels_when_both_bodies_move_together():
    """Action on the tool and reaction on the workpiece: no net modal force in a common motion."""
    rng = np.random.default_rng(0)
    common = rng.normal(size=(3, 6))
    centre = np.array([0.0, 0.0, 0.1])
    # same rigid motion of one frame: shapes of both bodies at their own centres
    shifted = common.copy()
    shifted[:, :3] += np.cross(common[:, 3:], [0.0, 0.0, -0.3] - centre)
    basis = ModalBasis(
        omega=np.array([10.0, 20.0, 30.0]),
        modal_mass=np.ones(3),
        body_shapes={"head": common, "slider": shifted},
        body_centers={"head": centre, "slider": [0.0, 0.0, -0.3]},
    )
    geo = cut_geometry(basis, read_machine(MACHINE), n_phi=16, table_rows=4)
    # zero up to rounding of terms of size |shape| * K_t / M
    scale = np.abs(common).max() * ForceCoefficients().thrust
    assert np.abs(geo.w).max() < 1e-14 * scale
    assert np.abs(geo.c).max() < 1e-14 * np.abs(common).max()


def test_point_shapes_are_rigid_motions():
    basis = ModalBasis(
        omega=np.array([1.0]),
        modal_mass=np.array([1.0]),
        body_shapes={"b": np.array([[1e-3, 0, 0, 0, 0, 2e-3]])},
        body_centers={"b": [1.0, 0.0, 0.0]},
    )
    # rotation about z by 2e-3 rad: a point 0.5 m along +x from the centre moves +1e-3 in y
    np.testing.assert_allclose(basis.point_shapes("b", [1.5, 0.0, 0.0]), [[1e-3, 1e-3, 0.0]])
    assert basis.point_shapes("b", np.zeros((4, 3))).shape == (1, 4, 3)
    with pytest.raises(KeyError, match="unknown body"):
        basis.point_shapes("x", [0, 0, 0])


def test_peak_forces_are_the_full_engagement_force_at_phi_zero():
    """peak_forces = cutting_force at phi = 0 with the arc over the plate, component-wise."""
    from ufmt.machining.cutting import peak_forces

    m = read_machine(MACHINE)
    p = Process(300, 15, 4)
    k = ForceCoefficients()
    peaks = peak_forces(p, m, k, force_scale=1.3)
    f = cutting_force(np.array([0.0]), -0.25, p, m, k, force_scale=1.3)[0]
    # at phi = 0 ("cw") the cutting velocity is +x and the outward normal +y; both oppose
    assert peaks["cutting_n"] == pytest.approx(-f[0], rel=1e-12)
    assert peaks["feed_n"] == pytest.approx(-f[1], rel=1e-12)
    assert peaks["thrust_n"] == pytest.approx(f[2], rel=1e-12)
    area = p.depth_m * p.feed_per_rev_m
    assert peaks["specific_thrust_gpa"] == pytest.approx(f[2] / area * 1e-9, rel=1e-12)
