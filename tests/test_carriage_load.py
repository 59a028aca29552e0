"""The carriage's moving weight (``carriage_load``) against a hand-built model's closed form.

Model: a rigid bed on two z springs k at y = -a and +a (its centre of mass between them, the
springs at its height), a carriage (the workpiece body) bolted to it by a rigid hinge that
rides with the slide, and the head bolted rigidly to the ground. With the carriage at slide
position Y its weight W_c acts at y = -Y, so the bed tilts by theta_x = W_c Y / (2 k a^2)
(moment balance) and the workpiece point under the tip, at the tip's global y p_y(phi), rises
by theta_x p_y: the tool's height over it changes by

    z(phi, Y) = -W_c (Y - Y_ref) p_y(phi) / (2 k a^2)

against the tramming position Y_ref (the middle of the leading arc's cut).
"""

import numpy as np
import pytest
from frames import translated

from ufmt.machining.carriage_load import KNOTS, CarriageLoad, carriage_load
from ufmt.machining.cutting import tool_tip
from ufmt.machining.process import Process
from ufmt.machining.slide import cut_slide_position
from ufmt.machining.static import GRAVITY
from ufmt.model.load import load_model_text
from ufmt.simulate import simulate

A, K, CARRIAGE_MASS = 0.4, 2e7, 500.0

BED = f"""
name = "carriage on a bed on springs"

[[body]]
name = "bed"
kind = "rigid"
mass = 2000.0
center_of_mass = [0.0, 0.0, 0.5]
inertia = [[500.0, 0, 0], [0, 300.0, 0], [0, 0, 700.0]]

[[body]]
name = "table"
kind = "rigid"
mass = {CARRIAGE_MASS}
center_of_mass = [0.0, 0.0, 0.80]
inertia = [[12.0, 0, 0], [0, 15.0, 0], [0, 0, 22.0]]

[[body]]
name = "head"
kind = "rigid"
mass = 60.0
center_of_mass = [0.0, 0.0, 0.965]
inertia = [[0.51, 0, 0], [0, 0.51, 0], [0, 0, 0.97]]

[[hinge]]
name = "front_mount"
between = ["ground", "bed"]
at = [0.0, {-A}, 0.5]
stiffness = [{{kx}}, 1e9, {{k}}]
rotational_stiffness = [0.0, 1e8, 0.0]

[[hinge]]
name = "back_mount"
between = ["ground", "bed"]
at = [0.0, {A}, 0.5]
stiffness = [{{kx}}, 1e9, {{k}}]
rotational_stiffness = [0.0, 0.0, 0.0]

[[hinge]]
name = "table_bolts"
between = ["bed", "table"]
at = [0.0, 0.0, 0.75]
stiffness = [inf, inf, inf]
rotational_stiffness = [inf, inf, inf]

[[hinge]]
name = "head_bolts"
between = ["ground", "head"]
at = [0.0, 0.0, 1.0]
stiffness = [inf, inf, inf]
rotational_stiffness = [inf, inf, inf]

{{motor}}
[machine]
tool_body = "head"
workpiece_body = "table"
spindle_axis_xy = [0.0, 0.0]
cutting_plane_z = 0.93
tool_radius = 0.15
workpiece_size = [0.10, 0.10]
workpiece_center_xy = [0.0, 0.0]
rotation = "cw"
"""


MOTOR = """
[[hinge]]
name = "motor"
between = ["ground", "table"]
at = [0.0, 0.0, 0.75]
stiffness = [0.0, 0.0, 2e7]
rotational_stiffness = [0.0, 0.0, 0.0]
"""


def bed(k=K, kx=1e9, motor=""):
    """The bed model; ``motor``: MOTOR adds a z spring from the carriage to the ground that
    rides with it (a second load path, so the bed's share of the weight depends on Y)."""
    return load_model_text(BED.format(k=k, kx=kx, motor=motor))


def grid(machine, n=7):
    """Spindle angles over the plate and slide positions over the leading arc's cut."""
    phi = np.linspace(-0.3, 0.3, n)[:, None]
    y = np.linspace(machine.cut_span[0], machine.cutting_span[1], n)[None, :]
    return phi, y


def test_the_moving_weight_tilts_the_bed_as_the_closed_form_says():
    """The profile equals -W_c (Y - Y_ref) p_y / (2 k a^2) (to the spline's rounding: u(Y)
    is linear here)."""
    model = bed()
    machine = model.machine
    phi, y = grid(machine)
    got = carriage_load(model, machine)(phi, y)
    p_y = tool_tip(phi, machine)[..., 1]
    y_ref = cut_slide_position(machine)
    expected = -CARRIAGE_MASS * GRAVITY * (y - y_ref) * p_y / (2 * K * A**2)
    assert np.abs(expected).max() > 1e-7  # micrometres: the test can fail
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * np.abs(expected).max())


def test_a_rigid_translation_of_the_file_changes_nothing():
    model = bed()
    phi, y = grid(model.machine)
    reference = carriage_load(model, model.machine)(phi, y)
    moved = translated(model, (3.0, -2.0, 1.5))
    got = carriage_load(moved, moved.machine)(phi, y)
    np.testing.assert_allclose(got, reference, rtol=0, atol=1e-9 * np.abs(reference).max())


def test_infinitely_stiff_mounts_leave_no_gravity_effect():
    model = bed(k="inf", kx="inf")
    phi, y = grid(model.machine)
    assert np.abs(carriage_load(model, model.machine)(phi, y)).max() < 1e-15


def test_the_profile_is_converged_in_the_knots():
    """Halving the knot spacing changes the profile by < 1e-3 of its range, on the bed with
    a second load path (a rational function of Y, not a line: the test can fail, and does
    with 3 knots)."""
    model = bed(motor=MOTOR)
    machine = model.machine
    phi, y = grid(machine, n=41)
    coarse = CarriageLoad(model, machine, KNOTS)(phi, y)
    fine = CarriageLoad(model, machine, 2 * KNOTS - 1)(phi, y)
    span = np.ptp(fine)
    assert span > 0
    assert np.abs(fine - coarse).max() < 1e-3 * span
    line = CarriageLoad(model, machine, 2)(phi, y)
    assert np.abs(fine - line).max() > 1e-2 * span


def test_simulate_reports_the_carriage_load_alone():
    """`carriage_load` alone: the surface's PV is the closed form's PV over the cut points
    (on by default, no parameter), and it is named in pv_by_source_nm."""
    model = bed()
    result = simulate(model, Process(300, 15, 4), sources=("carriage_load",))
    assert result.pv_by_source_nm["carriage_load"] == result.metrics["pv_nm"] > 0
    default = simulate(model, Process(300, 15, 4))
    assert default.pv_by_source_nm["carriage_load"] > 0


def test_a_rigidly_held_bed_prints_nothing():
    """The simulation reads zero for it."""
    model = bed(k="inf", kx="inf")
    result = simulate(model, Process(300, 15, 4), sources=("carriage_load",))
    assert result.metrics["pv_nm"] == pytest.approx(0.0, abs=1e-9)
