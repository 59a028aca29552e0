"""The instrument models (oracles: closed forms of planes, bowls and parabolic scallops, and an
independent fine sampling of the scallop profile)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import ufmt
from ufmt.machining.instruments import (
    Interferometer,
    interferometer_metrics,
    scallop_height,
    scallop_roughness,
)
from ufmt.machining.surface import Surface
from ufmt.model.machine import machine_of

MARGIN = 5e-3


@pytest.fixture(scope="module")
def machine(packaged):
    """The packaged machine with the spindle axis over the plate centre (offset 0)."""
    m = machine_of(packaged)
    return dataclasses.replace(m, workpiece_center_xy=m.spindle_axis_xy)


def plate(machine, z_of_xy):
    """A surface on a 1 mm grid over the plate, z = z_of_xy(x, y) [m]."""
    lx, ly = machine.workpiece_size
    x = np.linspace(-lx / 2, lx / 2, 411)
    y = np.linspace(-ly / 2, ly / 2, 301)
    return Surface(x, y, z_of_xy(x[None, :], y[:, None]) + 0 * x[None, :] + 0 * y[:, None])


def aperture(surface):
    half_x = (surface.x[-1] - surface.x[0]) / 2 - MARGIN
    half_y = (surface.y[-1] - surface.y[0]) / 2 - MARGIN
    return np.abs(surface.x) <= half_x + 1e-12, np.abs(surface.y) <= half_y + 1e-12


def test_piston_and_tilt_are_not_measured(machine):
    s = plate(machine, lambda x, y: 3e-7 + 2e-6 * x - 5e-7 * y)
    m = interferometer_metrics(s, machine, 50e-6)
    assert m["pv_measured_nm"] < 1e-6 and m["rms_measured_nm"] < 1e-6


def test_a_bowl_is_measured_over_the_clear_aperture(machine):
    c = 1e-6  # [1/m]: z = c (x^2 + y^2), symmetric, so the fitted plane is a piston alone
    s = plate(machine, lambda x, y: c * (x**2 + y**2) - 4e-6 * x)
    in_x, in_y = aperture(s)
    x, y = s.x[in_x], s.y[in_y]
    expected = c * ((x**2).max() + (y**2).max() - (x**2).min() - (y**2).min())
    m = interferometer_metrics(s, machine, 50e-6)
    assert m["pv_measured_nm"] == pytest.approx(expected * 1e9, rel=1e-9)


def test_unresolved_scallops_are_seen_as_their_mean(machine):
    feed = 50e-6  # 50 um per revolution, far below half a 0.5 mm pixel
    flat = plate(machine, lambda x, y: 0.0 * x * y)
    rough = plate(machine, lambda x, y: 1e-6 * np.cos(1e5 * x) + 0 * y)  # must be ignored
    m = interferometer_metrics(flat, machine, feed, scallops=rough)
    in_x, _ = aperture(flat)
    mean = scallop_height(flat.x[in_x], machine, feed) / 3  # symmetric in x: no tilt to remove
    assert m["pv_measured_nm"] == pytest.approx((mean.max() - mean.min()) * 1e9, rel=1e-9)


def test_resolved_scallops_are_measured_in_full(machine):
    flat = plate(machine, lambda x, y: 0.0 * x * y)
    ridges = plate(machine, lambda x, y: 2e-8 * np.cos(2 * np.pi * y / 0.01) + 0 * x)
    instrument = Interferometer(pixel=0.5e-3)
    assert instrument.resolves_scallops(0.3e-3)
    m = interferometer_metrics(flat, machine, 0.3e-3, scallops=ridges, instrument=instrument)
    assert m["pv_measured_nm"] == pytest.approx(40.0, rel=1e-3)


def test_roughness_of_the_parabolic_scallop(machine):
    feed = 50e-6
    r = scallop_roughness(machine, feed, MARGIN)
    h = feed**2 / (8 * machine.nose_radius)  # phi = 0 lies over the aperture (offset 0)
    assert r["roughness_pv_nm"] == pytest.approx(h * 1e9, rel=1e-12)
    # independent oracle: the profile min(s, 1 - s)^2 p^2 / (2 r_n) sampled finely
    s = (np.arange(200_000) + 0.5) / 200_000
    profile = np.minimum(s, 1 - s) ** 2 * feed**2 / (2 * machine.nose_radius)
    assert r["roughness_rq_nm"] == pytest.approx(np.std(profile) * 1e9, rel=1e-6)
    assert r["roughness_rq_nm"] == pytest.approx(h * 1e9 * 2 / (3 * math.sqrt(5)), rel=1e-12)


def test_roughness_off_axis_uses_the_aperture_point_nearest_the_axis(machine):
    lx = machine.workpiece_size[0]
    off = dataclasses.replace(machine, workpiece_center_xy=(machine.spindle_axis_xy[0] - lx, 0.0))
    x_near = lx / 2 - MARGIN  # the spindle axis lies beyond +x: this aperture edge is nearest
    expected = scallop_height(np.array([x_near]), off, 50e-6)[0]
    assert scallop_roughness(off, 50e-6, MARGIN)["roughness_pv_nm"] == pytest.approx(
        expected * 1e9, rel=1e-12
    )


@pytest.mark.parametrize(
    "field, value", [("pixel", 0.0), ("pixel", math.nan), ("aperture_margin", -1e-3)]
)
def test_bad_instrument_settings_are_refused(field, value):
    with pytest.raises(ValueError, match=field):
        Interferometer(**{field: value})


def test_simulate_reports_the_instruments_and_its_basis(packaged):
    result = ufmt.simulate(packaged, ufmt.Process(300, 15, 4), n_modes=30, n_phi=256)
    d = result.to_dict()
    assert d["samples_per_rev"] == 256 and d["n_modes"] == 30
    assert d["basis_cutoff_hz"] == d["basis_highest_hz"] > 0  # a basis chosen by count
    assert d["roughness_pv_nm"] == pytest.approx(d["pv_by_source_nm"]["feed_marks"], rel=0.02)
    assert d["pv_measured_nm"] < d["pv_aperture_nm"]
