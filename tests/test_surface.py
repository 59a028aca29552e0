"""Machined surface (paper eq. 4.1, tool interference) and its metrics."""

import numpy as np
import pytest
from synthetic import MACHINE, dynamic_surface

from ufmt.machining.basis import ModalBasis
from ufmt.machining.cut_geometry import cut_geometry
from ufmt.machining.periodic_path import periodic_response
from ufmt.machining.process import Process
from ufmt.machining.response import ZreTable
from ufmt.machining.surface import DEFAULT_SPACING, Surface, surface_metrics, surface_passes
from ufmt.model.machine import read_machine

N_PHI = 512


def synthetic_basis(n=30, seed=1):
    rng = np.random.default_rng(seed)
    shapes = {}
    for body in ("head", "slider"):
        s = rng.normal(size=(n, 6))
        s[:, 3:] *= 2.0
        shapes[body] = s
    return ModalBasis(
        omega=2 * np.pi * np.geomspace(7.0, 700.0, n),
        modal_mass=np.full(n, 2000.0),
        body_shapes=shapes,
        body_centers={"head": [0, 0, 0.15], "slider": [0, 0, -0.15]},
    )


ROWS = np.linspace(-0.46, 0.46, 93)  # evenly spaced: knots at the rows


def table_of(function, row_y=ROWS, drift=0.0):
    """A ZreTable holding function(phi, Y) on N_PHI angles (padded as the response pads)."""
    phi = 2 * np.pi * (np.arange(-1, N_PHI + 2)) / N_PHI
    knots = (row_y[0], row_y[1] - row_y[0], np.arange(row_y.size, dtype=float))
    return ZreTable(function(phi[None, :], row_y[:, None]), row_y, drift, knots)


def lead_angle(x, machine):
    return np.arcsin(machine.sense * (x - machine.offset_x) / machine.tool_radius)


@pytest.mark.parametrize("rotation, offset", [("cw", 0.0), ("ccw", 0.0), ("cw", 0.02)])
def test_surface_reads_z_re_at_the_leading_arc_angle(rotation, offset):
    """z_re(phi) only: z(x, y) = z_re(asin((x - s_x) / (sigma R))) (eq. 4.1), every y."""
    m = read_machine({**MACHINE, "rotation": rotation, "spindle_axis_xy": [offset, 0.0]})
    table = table_of(lambda phi, y: 1e-7 * np.cos(3 * phi) + 2e-8 * np.sin(phi) + 0 * y)
    s = dynamic_surface(table, m, feed_per_rev=5e-5)
    phi = lead_angle(s.x, m)
    expect = 1e-7 * np.cos(3 * phi) + 2e-8 * np.sin(phi)
    # 4-point interpolation in phi: error ~ (3 dphi)^4 / 24 of the amplitude
    np.testing.assert_allclose(s.z, np.broadcast_to(expect, s.z.shape), rtol=0, atol=1e-13)


def test_surface_reads_z_re_at_the_slide_position_of_the_pass():
    """z_re(Y) only, increasing: the lower of the two revolutions bracketing the point.

    Eq. 4.1: y = R cos(phi) + Y, the slide at Y_start + (k + phi / 2 pi) v/f in revolution k;
    the point is passed at Y = y - R cos(phi_f(x)) and the revolution before it is the lower.
    """
    m = read_machine(MACHINE)
    delta = 5e-5
    table = table_of(lambda phi, y: 3e-7 * y + 0 * phi)
    s = dynamic_surface(table, m, feed_per_rev=delta)
    phi = lead_angle(s.x, m)
    turn = np.mod(phi, 2 * np.pi)[None, :] / (2 * np.pi)
    slide = s.y[:, None] - 0.25 * np.cos(phi)[None, :]
    below = m.cut_span[0] + delta * (np.floor((slide - m.cut_span[0]) / delta - turn) + turn)
    assert np.all((below <= slide) & (slide - below < delta))
    np.testing.assert_allclose(s.z, 3e-7 * below, rtol=1e-9, atol=1e-20)


def test_time_tables_drift_with_the_slide_within_a_revolution():
    """A time table (one row per revolution, drift = v/f) holding z_re = c Y reads back c Y."""
    m = read_machine(MACHINE)
    delta = 5e-5
    rows = m.cut_span[0] + delta * np.arange(int(0.92 / delta))
    table = table_of(lambda phi, y: 2e-7 * (y + delta * phi / (2 * np.pi)), rows, delta)
    s = dynamic_surface(table, m, feed_per_rev=delta)
    phi = lead_angle(s.x, m)
    turn = np.mod(phi, 2 * np.pi)[None, :] / (2 * np.pi)
    slide = s.y[:, None] - 0.25 * np.cos(phi)[None, :]
    # the lower of the two bracketing revolutions (the first touch has none before it)
    k = np.maximum(np.floor((slide - m.cut_span[0]) / delta - turn), 0)
    expect = 2e-7 * (m.cut_span[0] + delta * (k + turn))
    np.testing.assert_allclose(s.z, expect, rtol=0, atol=1e-10 * np.abs(expect).max())


def test_trailing_arc_passes_lower_the_surface_where_the_tool_sits_lower():
    """Tool interference: with back-cutting on, each point keeps the lower of its two passes."""
    m = read_machine(MACHINE)
    table = table_of(lambda phi, y: 1e-7 * np.cos(phi) + 0 * y)  # trailing arc (cos < 0) lower
    lead = dynamic_surface(table, m, feed_per_rev=5e-5)
    both = dynamic_surface(table, m, feed_per_rev=5e-5, trailing_arc=True)
    cos = np.cos(lead_angle(lead.x, m))
    np.testing.assert_allclose(lead.z, np.broadcast_to(1e-7 * cos, lead.z.shape), atol=1e-14)
    np.testing.assert_allclose(both.z, np.broadcast_to(-1e-7 * cos, lead.z.shape), atol=1e-14)


def test_kinematic_marks_are_scallops_of_the_nose_radius():
    """Flat z_re: marks between passes (v/f) cos(phi) apart, height d^2 / (8 r_n) at most."""
    m = read_machine(MACHINE)
    delta, nose = 4.37e-5, 2e-3  # feed per revolution incommensurate with the grid
    passes = surface_passes(m, delta)
    flat = table_of(lambda phi, y: 0 * phi + 0 * y)
    s = passes.lower([passes.dynamic(flat, m), passes.feed_marks(nose)])
    bound = (delta * np.cos(lead_angle(s.x, m))) ** 2 / (8 * nose)
    assert s.z.min() >= 0
    assert np.all(s.z <= bound * (1 + 1e-9))
    # 205 rows sample the scallop densely: its crest is reached to within a few per cent
    assert np.all(s.z.max(axis=0) >= 0.95 * bound)
    with pytest.raises(ValueError, match="nose_radius must be > 0"):
        passes.feed_marks(-1.0)


def test_grid_convergence_of_the_pv():
    """PV on the default grid (1 mm in x, 1.25 mm in y, refined edge bands) within 1 % of a grid
    four times finer, for a fast-ringing basis at the slowest spindle speed."""
    m = read_machine({**MACHINE, "tool_radius": 0.3, "rotation": "ccw"})
    p = Process(200, 16, 8)
    table = periodic_response(cut_geometry(synthetic_basis(), m), p).table
    pv = {
        h: surface_metrics(dynamic_surface(table, m, p.feed_per_rev_m, (h, 1.25 * h)))["pv_nm"]
        for h in (4e-3, 2e-3, 1e-3, 2.5e-4)
    }
    err = {h: abs(v / pv[2.5e-4] - 1) for h, v in pv.items() if h != 2.5e-4}
    assert DEFAULT_SPACING == (1e-3, 1.25e-3)
    assert err[4e-3] > err[1e-3]
    assert err[1e-3] < 0.01


def grid(size, spacing):
    n = int(round(size / spacing))
    c = (np.arange(n) + 0.5) * spacing - size / 2
    return c, c


def test_pv_tilt_and_rms():
    x, y = grid(0.4, 2e-3)
    plane = 1e-7 * x[None, :] - 2e-7 * y[:, None] + 5e-8
    bowl = 4e-7 * (x[None, :] ** 2 + y[:, None] ** 2)  # even: orthogonal to the tilt
    metrics = surface_metrics(Surface(x, y, plane + bowl))
    assert metrics["pv_nm"] == pytest.approx(np.ptp(plane + bowl) * 1e9, rel=1e-12)
    assert metrics["pv_tilt_removed_nm"] == pytest.approx(np.ptp(bowl) * 1e9, rel=1e-9)
    assert metrics["rms_nm"] == pytest.approx(np.std(bowl) * 1e9, rel=1e-9)
    flat = surface_metrics(Surface(x, y, plane))
    assert flat["pv_tilt_removed_nm"] < 1e-9 * flat["pv_nm"]


def test_form_is_the_quadratic_part_and_waviness_the_rest():
    """Legendre fit up to 2nd order: a bowl is all form; a short ripple is all waviness."""
    x, y = grid(0.4, 2e-3)
    u, v = x[None, :] / 0.2, y[:, None] / 0.2
    bowl = 50e-9 * (u**2 + v**2) + 10e-9 * u * v
    ripple = 3e-9 * np.cos(2 * np.pi * x[None, :] / 0.01) + 0 * v
    metrics = surface_metrics(Surface(x, y, bowl + 7e-9 * u + ripple))
    assert metrics["form_pv_nm"] == pytest.approx(np.ptp(bowl) * 1e9, rel=0.01)
    assert metrics["waviness_rms_nm"] == pytest.approx(3 / np.sqrt(2), rel=0.01)
    assert metrics["waviness_pv_nm"] == pytest.approx(np.ptp(ripple) * 1e9, rel=0.02)


def test_clear_aperture_excludes_the_edge_band():
    """A step 3 mm from an edge counts in the whole-plate PV, not in a 5 mm clear aperture."""
    x, y = grid(0.4, 1e-3)
    z = np.zeros((y.size, x.size))
    z[:, x > 0.2 - 3e-3] = 40e-9
    z[y < -0.2 + 20e-3, :] += 5e-9  # a step inside the aperture
    metrics = surface_metrics(Surface(x, y, z))
    assert metrics["pv_nm"] == pytest.approx(45.0, rel=1e-9)
    assert metrics["pv_aperture_nm"] == pytest.approx(5.0, rel=1e-9)
    with pytest.raises(ValueError, match="leaves no clear aperture"):
        surface_metrics(Surface(x, y, z), aperture_margin=0.3)
