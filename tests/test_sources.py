"""Error sources of the surface, each alone against its closed form; superposition, switches."""

import numpy as np
import pytest
from synthetic import MACHINE, SMALL, synthetic_basis

from ufmt.errors import ModelError
from ufmt.machining.carriage import reference_line
from ufmt.machining.process import Process
from ufmt.machining.sources import HEIGHT, REGISTRY, SOURCES
from ufmt.model.machine import OPTIONAL_FIELDS, PATH_FIELDS, read_machine
from ufmt.model.schema import Model
from ufmt.simulate import simulate

GEOMETRY = {
    "spindle_tilt_rad": 4e-6,
    "error_motion_m": 30e-9,
    "error_motion_phase_deg": 40.0,
    "straightness_m": 50e-9,
    "straightness_wavelength_m": 0.15,
    "pressure_ripple_m": 20e-9,
    "pressure_ripple_hz": 0.02,
    "workholding_power_m": 25e-9,
    "workholding_astigmatism_m": -10e-9,
}
P = Process(300, 13.7, 4)  # feed per revolution incommensurate with the grid


def run(machine_extra=None, sources=SOURCES, plate=MACHINE, **options):
    """The synthetic machine with GEOMETRY on ``plate`` (a [machine] table) cut at P."""
    machine = read_machine({**plate, **GEOMETRY, **(machine_extra or {})})
    model = Model("syn", (), (), machine=machine)
    return simulate(
        model, P, basis=synthetic_basis(n=6), sources=sources, static_correction=False, **options
    )


def lead_angle(surface):
    """Leading-arc angle phi_f(x) of each grid column (spindle over the plate's centre)."""
    return np.arcsin(surface.x / MACHINE["tool_radius"])


def test_spindle_tilt_alone_is_the_sag_beta_r_one_minus_cos():
    r = run(sources=("spindle_tilt",))
    phi = lead_angle(r.surface)
    sag = -GEOMETRY["spindle_tilt_rad"] * MACHINE["tool_radius"] * (1 - np.cos(phi))
    np.testing.assert_allclose(r.surface.z, np.broadcast_to(sag, r.surface.z.shape), atol=1e-18)
    edge = np.arcsin(0.205 / MACHINE["tool_radius"])
    expected = GEOMETRY["spindle_tilt_rad"] * MACHINE["tool_radius"] * (1 - np.cos(edge)) * 1e9
    # the grid has nodes on the plate edges; its middle node is within half a step of x = 0
    assert r.pv_by_source_nm["spindle_tilt"] == pytest.approx(expected, rel=1e-4)
    assert r.metrics["pv_nm"] == pytest.approx(np.ptp(sag) * 1e9, rel=1e-12)


def test_error_motion_alone_is_the_once_per_revolution_cosine():
    r = run(sources=("error_motion",))
    phi = lead_angle(r.surface)
    wave = GEOMETRY["error_motion_m"] * np.cos(phi - np.radians(40.0))
    np.testing.assert_allclose(r.surface.z, np.broadcast_to(wave, r.surface.z.shape), atol=1e-18)


def test_straightness_alone_follows_the_carriage_at_the_slide_position_of_the_pass():
    """Point pads S apart (length 0): the point cut rises h + theta (Y + R cos(phi_f)) with
    h, theta the two-point mean and slope of the guideway (the reference line over the
    travel removed), Y = y - R cos(phi_f); to within the slope in Y times one feed step (the
    deeper of the two bracketing passes is kept)."""
    pads = {"carriage_pad_length_m": 0.0, "carriage_pad_span_m": 0.4}
    r = run(pads, sources=("straightness",))
    machine = read_machine({**MACHINE, **GEOMETRY, **pads})
    mid, z_mid, beta = reference_line(machine)
    s, wavelength = GEOMETRY["straightness_m"], GEOMETRY["straightness_wavelength_m"]
    phi = lead_angle(r.surface)
    slide = r.surface.y[:, None] - MACHINE["tool_radius"] * np.cos(phi)[None, :]

    def guideway(g):
        line = z_mid + beta * (g - mid)
        return s * np.sin(2 * np.pi * g / wavelength) - line  # pads' centre at g = -Y

    heave = (guideway(-slide + 0.2) + guideway(-slide - 0.2)) / 2
    pitch = (guideway(-slide + 0.2) - guideway(-slide - 0.2)) / 0.4
    exact = -(heave + pitch * (slide + MACHINE["tool_radius"] * np.cos(phi)[None, :]))
    rate = np.abs(np.gradient(exact, r.surface.y, axis=0)).max()
    assert np.abs(r.surface.z - exact).max() <= rate * P.feed_per_rev_m
    assert np.ptp(r.surface.z) > 0.5 * s


def test_feed_marks_alone_are_the_nose_scallop():
    """PV = (v/f)^2 / (8 r_n) (the scallop at the plate's middle, cos(phi) = 1)."""
    nose = 2e-3
    r = run({"nose_radius": nose}, sources=("feed_marks",))
    bound = (P.feed_per_rev_m * np.cos(lead_angle(r.surface))) ** 2 / (8 * nose)
    assert np.all(r.surface.z <= bound[None, :] * (1 + 1e-9))
    scallop = P.feed_per_rev_m**2 / (8 * nose) * 1e9
    assert r.pv_by_source_nm["feed_marks"] == pytest.approx(scallop, rel=0.03)


def test_sources_that_depend_on_the_angle_only_superpose_exactly():
    """Tilt and error motion are the same on both bracketing passes: the surface is the
    dynamic surface plus their closed forms, exactly; all sources scale linearly. (On the
    small plate: superposition and linearity hold on any plate.)"""
    alone = run(sources=("dynamic",), plate=SMALL).surface.z
    both = run(sources=("dynamic", "spindle_tilt", "error_motion"), plate=SMALL)
    geo = run(sources=("spindle_tilt", "error_motion"), plate=SMALL).surface.z
    np.testing.assert_allclose(both.surface.z, alone + geo, atol=1e-12 * np.abs(geo).max())
    doubled = {
        k: 2 * v if k != "error_motion_phase_deg" and not k.endswith("_wavelength_m") else v
        for k, v in GEOMETRY.items()
    }
    three = ("spindle_tilt", "error_motion", "straightness")
    twice = run(doubled, sources=three, plate=SMALL).surface.z
    once = run(sources=three, plate=SMALL).surface.z
    np.testing.assert_allclose(twice, 2 * once, atol=1e-12 * np.abs(once).max())


def test_pressure_ripple_alone_is_a_sine_in_the_time_of_the_pass():
    """z = a sin(2 pi f_p t), t = (Y - Y_first_touch) / v the time of the pass at slide
    Y = y - R cos(phi_f), to within the slope times one feed step; its wavelength along the
    feed is v / f_p, not tied to the spindle or the slide's position."""
    r = run(sources=("pressure_ripple",))
    a, f_p = GEOMETRY["pressure_ripple_m"], GEOMETRY["pressure_ripple_hz"]
    machine = read_machine({**MACHINE, **GEOMETRY})
    v = P.feed_mm_min / 60e3
    phi = lead_angle(r.surface)
    slide = r.surface.y[:, None] - MACHINE["tool_radius"] * np.cos(phi)[None, :]
    exact = a * np.sin(2 * np.pi * f_p * (slide - machine.cut_span[0]) / v)
    step = 2 * np.pi * a * f_p / v * P.feed_per_rev_m
    assert np.abs(r.surface.z - exact).max() <= step
    assert r.surface.z.max() - r.surface.z.min() > 1.9 * a  # both crests lie on the plate
    # a slower feed prints a shorter wavelength: the same ripple is not the same surface
    slower = simulate(
        Model("syn", (), (), machine=machine),
        Process(300, P.feed_mm_min / 2, 4),
        basis=synthetic_basis(n=6),
        sources=("pressure_ripple",),
        static_correction=False,
    )
    assert np.abs(slower.surface.z - r.surface.z).max() > a


def test_total_pv_is_bounded_by_the_sum_of_the_sources():
    """Superposition of the sources before the minimum over passes: PV(total) <= sum of PVs."""
    r = run()
    assert set(r.pv_by_source_nm) == set(SOURCES)
    # the synthetic model has no bodies, so no static solve: its carriage load does not act
    assert r.pv_by_source_nm["carriage_load"] == 0.0
    parts = [v for name, v in r.pv_by_source_nm.items() if name != "carriage_load"]
    assert all(v > 0 for v in parts)
    assert r.metrics["pv_nm"] <= sum(parts) * (1 + 1e-9)
    assert r.metrics["pv_nm"] >= max(parts) * 0.5


def test_switched_off_sources_report_none_and_unknown_names_fail():
    r = run(sources=("dynamic", "feed_marks"), plate=SMALL)
    assert r.pv_by_source_nm["spindle_tilt"] is None
    assert r.pv_by_source_nm["dynamic"] > 0
    off = run({"spindle_tilt_rad": 0.0}, sources=SOURCES, plate=SMALL)
    assert off.pv_by_source_nm["spindle_tilt"] == 0.0
    with pytest.raises(ModelError, match="did you mean 'straightness'"):
        run(sources=("straightnes",))


def test_registry_names_declared_machine_fields_in_the_output_order():
    """One record per source, in the order of every per-source output; each names only
    declared [machine] fields (with their bands), and exactly the height sources have a
    height function."""
    assert SOURCES == (
        "dynamic",
        "feed_marks",
        "spindle_tilt",
        "error_motion",
        "straightness",
        "pressure_ripple",
        "workholding",
        "carriage_load",
    )
    assert tuple(s.name for s in REGISTRY) == SOURCES
    for source in REGISTRY:
        known = (*OPTIONAL_FIELDS, *PATH_FIELDS)
        assert all(field in known for field in source.fields), source.name
        assert (source.height is not None) == (source.enters == HEIGHT), source.name
