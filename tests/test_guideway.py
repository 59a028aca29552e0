"""The guideway's straightness carried to the workpiece by the carriage's pads, the
workholding form and the error motion's harmonics, against closed forms and invariances."""

import numpy as np
import pytest
from scipy.integrate import quad
from synthetic import MACHINE, synthetic_basis

from ufmt.calibration.settings import load_calibration
from ufmt.errors import ModelError
from ufmt.fingerprint import model_sha256
from ufmt.machining.carriage import carriage_pose, pad_centre, workpiece_rise
from ufmt.machining.process import Process
from ufmt.machining.sources import error_motion_z
from ufmt.model.load import packaged_path
from ufmt.model.machine import read_machine
from ufmt.model.schema import Model
from ufmt.simulate import simulate
from ufmt.studies.bands import CALIBRATION, documented_bands

P = Process(300, 13.7, 4)
PLATE = {**MACHINE, "workpiece_size": [0.1, 0.1]}  # a 0.1 m plate: R = 0.25 m over +-12 deg
HARMONIC = {
    "straightness_m": 80e-9,
    "straightness_wavelength_m": 0.3,
    "straightness_phase_deg": 35.0,
}


def machine(**extra):
    return read_machine({**PLATE, **extra})


def harmonic(s, m):
    """The guideway z_g(s) [m] of ``m``'s harmonic (phase at the pads' centre halfway)."""
    k = 2 * np.pi / m.straightness_wavelength_m
    return m.straightness_m * np.sin(
        k * (s - pad_centre(0.0, m)) + np.radians(m.straightness_phase_deg)
    )


def pads_line(m, c, span, length):
    """Least-squares line (intercept at c, slope) of the harmonic z_g over two pads of
    ``length`` centred at c -+ span / 2: the normal equations' moments by quadrature."""
    moments = np.zeros((2, 2))
    rhs = np.zeros(2)
    for d in (-span / 2, span / 2):
        lo, hi = c + d - length / 2, c + d + length / 2
        for i in range(2):
            rhs[i] += quad(lambda s, i=i: (s - c) ** i * harmonic(s, m), lo, hi, limit=200)[0]
            for j in range(2):
                moments[i, j] += quad(lambda s, n=i + j: (s - c) ** n, lo, hi)[0]
    return np.linalg.solve(moments, rhs)


def reference(m):
    """The guideway's least-squares line (intercept at s = 0, slope) over the travel window,
    from its moments by adaptive quadrature."""
    lo, hi = m.guideway_span
    mid = (lo + hi) / 2
    zero = quad(lambda s: harmonic(s, m), lo, hi, limit=500)[0]
    first = quad(lambda s: (s - mid) * harmonic(s, m), lo, hi, limit=500)[0]
    slope = first / ((hi - lo) ** 3 / 12)
    return zero / (hi - lo) - slope * mid, slope


def run(extra, sources=("straightness",), plate=PLATE):
    model = Model("syn", (), (), machine=read_machine({**plate, **extra}))
    return simulate(model, P, basis=synthetic_basis(n=6), sources=sources, static_correction=False)


def write_profile(path, s, z):
    rows = "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(s, z, strict=True))
    path.write_text("position_m,height_m\n" + rows)


@pytest.mark.parametrize("odd", [1, 3])
def test_point_pads_cancel_a_sine_in_heave_at_half_odd_wavelengths(odd):
    """Two point pads S apart: heave a sin(.) cos(pi S / L) vanishes at S = (2n+1) L / 2,
    pitch (z_+ - z_-) / S vanishes at S = n L (the reference line removed from both)."""
    wavelength = 0.2
    y = np.linspace(-0.2, 0.2, 9)
    heave_zero = machine(
        **{**HARMONIC, "straightness_wavelength_m": wavelength},
        carriage_pad_length_m=0.0,
        carriage_pad_span_m=odd * wavelength / 2,
    )
    z0, beta = reference(heave_zero)
    heave, pitch = carriage_pose(y, heave_zero)
    c = pad_centre(y, heave_zero)
    np.testing.assert_allclose(heave, -(z0 + beta * c), atol=1e-15)
    span = heave_zero.carriage_pad_span_m
    two_point = (harmonic(c + span / 2, heave_zero) - harmonic(c - span / 2, heave_zero)) / span
    np.testing.assert_allclose(pitch, two_point - beta, atol=1e-15)
    pitch_zero = machine(
        **{**HARMONIC, "straightness_wavelength_m": wavelength},
        carriage_pad_length_m=0.0,
        carriage_pad_span_m=odd * wavelength,
    )
    z0, beta = reference(pitch_zero)
    heave, pitch = carriage_pose(y, pitch_zero)
    np.testing.assert_allclose(pitch, -beta, atol=1e-15)
    c = pad_centre(y, pitch_zero)
    np.testing.assert_allclose(heave, -harmonic(c, pitch_zero) - z0 - beta * c, atol=1e-15)


def test_finite_pads_are_the_least_squares_line_through_the_guideway_under_them():
    """Pads of length l: the carriage's (h, theta) is the least-squares line through z_g over
    both pads (dense sampling, np.polyfit), and its heave a sin(.) cos(pi S/L) sinc(l/L)."""
    m = machine(**HARMONIC, carriage_pad_span_m=0.5, carriage_pad_length_m=0.13)
    z0, beta = reference(m)
    y = np.array([-0.17, -0.05, 0.0, 0.11])
    heave, pitch = carriage_pose(y, m)
    for i, c in enumerate(pad_centre(y, m)):
        intercept, slope = pads_line(m, c, 0.5, 0.13)
        assert heave[i] + z0 + beta * c == pytest.approx(intercept, abs=1e-14)
        assert pitch[i] + beta == pytest.approx(slope, abs=1e-13)
        k = 2 * np.pi / 0.3
        closed = 80e-9 * np.sin(k * (c - pad_centre(0.0, m)) + np.radians(35.0))
        closed *= np.cos(np.pi * 0.5 / 0.3) * np.sinc(0.13 / 0.3)
        assert heave[i] + z0 + beta * c == pytest.approx(closed, abs=1e-15)


def test_the_pitch_reaches_the_cut_point_through_its_abbe_arm():
    """The point cut at (phi, Y) rises h + theta (Y + R cos(phi) - offset)."""
    m = machine(**HARMONIC, carriage_pad_offset_m=0.04)
    phi = np.array([-0.2, 0.0, 0.3])[:, None]
    y = np.array([-0.3, -0.25, -0.2])[None, :]
    heave, pitch = carriage_pose(y, m)
    arm = y + 0.25 * np.cos(phi) - 0.04
    np.testing.assert_allclose(workpiece_rise(phi, y, m), heave + pitch * arm, atol=1e-18)


def test_a_straight_inclined_guideway_leaves_no_mark(tmp_path):
    """Straightness is the deviation from the reference line: a linear profile gives zero."""
    m = machine()
    s = np.linspace(m.guideway_span[0] - 0.01, m.guideway_span[1] + 0.01, 50)
    write_profile(tmp_path / "line.csv", s, 3e-7 + 2e-6 * s)
    r = run({"straightness_profile": str(tmp_path / "line.csv")})
    assert r.metrics["pv_nm"] < 1e-6


def test_a_profile_sampled_from_the_harmonic_gives_the_harmonic(tmp_path):
    m = machine(**HARMONIC)
    s = np.linspace(m.guideway_span[0] - 0.01, m.guideway_span[1] + 0.01, 20001)
    write_profile(tmp_path / "g.csv", s, harmonic(s, m))
    sampled = run({"straightness_profile": str(tmp_path / "g.csv")})
    closed = run(HARMONIC)
    scale = np.ptp(closed.surface.z)
    assert scale > 1e-9
    np.testing.assert_allclose(sampled.surface.z, closed.surface.z, atol=1e-4 * scale)


def test_a_rigid_translation_of_the_whole_model_changes_no_metric(tmp_path):
    """Every point shifted by d (the spindle axis, the workpiece centre, the profile's
    positions): the same surface, the same metrics."""
    d = np.array([0.37, -1.9])
    m = machine()
    s = np.linspace(m.guideway_span[0] - 0.02, m.guideway_span[1] + 0.02, 3001)
    z = 40e-9 * np.sin(2 * np.pi * s / 0.23) + 25e-9 * np.cos(2 * np.pi * s / 0.61)
    write_profile(tmp_path / "a.csv", s, z)
    write_profile(tmp_path / "b.csv", s + d[1], z)
    extra = {"workholding_power_m": 30e-9, "error_motion_harmonics_m": 20e-9}
    sources = ("straightness", "workholding", "error_motion")
    here = run({**extra, "straightness_profile": str(tmp_path / "a.csv")}, sources)
    moved = {
        **PLATE,
        "spindle_axis_xy": list(d),
        "workpiece_center_xy": [d[0], d[1]],
    }
    there = run({**extra, "straightness_profile": str(tmp_path / "b.csv")}, sources, moved)
    np.testing.assert_allclose(there.surface.z, here.surface.z, atol=1e-13)
    for key in ("pv_nm", "pv_measured_nm", "rms_nm"):
        assert there.metrics[key] == pytest.approx(here.metrics[key], rel=1e-9, abs=1e-9)
    harmonic_here = run(HARMONIC)
    harmonic_there = run(HARMONIC, plate=moved)
    np.testing.assert_allclose(harmonic_there.surface.z, harmonic_here.surface.z, atol=1e-15)


def test_the_workholding_form_keeps_its_analytical_pv_through_the_tilt_removal():
    """Bowl and astigmatism of signed PV c on the plate: whole-plate PV |c|; inside the
    aperture (plate less 5 mm per edge; its outermost nodes at u_a, v_a of the half sides)
    |c| (u_a^2 + v_a^2) / 2 (power is not tilt)."""
    for key in ("workholding_power_m", "workholding_astigmatism_m"):
        r = run({key: -60e-9}, sources=("workholding",))
        assert r.pv_by_source_nm["workholding"] == pytest.approx(60.0, rel=1e-3)
        assert r.metrics["pv_nm"] == pytest.approx(60.0, rel=1e-3)
        x, y = r.surface.x, r.surface.y
        u = np.abs(x)[np.abs(x) <= 0.045 + 1e-12].max() / 0.05
        v = np.abs(y)[np.abs(y) <= 0.045 + 1e-12].max() / 0.05
        aperture = 60.0 * (u * u + v * v) / 2
        assert r.metrics["pv_aperture_nm"] == pytest.approx(aperture, rel=5e-3)
        assert r.metrics["pv_measured_nm"] == pytest.approx(aperture, rel=2e-2)


def test_the_error_motion_harmonics_are_the_closed_form():
    m = machine(error_motion_harmonics_m=20e-9, error_motion_harmonics_phase_deg=25.0)
    phi = np.linspace(-1, 1, 7)
    psi = np.radians(25.0)
    expected = sum(20e-9 * 2 / k * np.cos(k * (phi - psi)) for k in (2, 3, 4, 5))
    np.testing.assert_allclose(error_motion_z(phi, 0.0, m, P), expected, atol=1e-20)


@pytest.mark.parametrize(
    "rows, problem",
    [
        ("position_m,height_m\n0,0\n0,1e-9\n", "increase strictly"),
        ("position_m,height_m\n-2,0\n2,nan\n", "not finite"),
        ("pos,height\n-2,0\n2,0\n", "first line"),
        ("position_m,height_m\n-0.1,0\n0.1,0\n", "do not cover"),
    ],
)
def test_a_bad_profile_is_one_line_naming_the_file_and_field(tmp_path, rows, problem):
    (tmp_path / "bad.csv").write_text(rows)
    with pytest.raises(ModelError, match=f"straightness_profile.*bad.csv.*{problem}"):
        machine(straightness_profile=str(tmp_path / "bad.csv"))


def test_pads_longer_than_their_span_and_a_profile_with_a_harmonic_are_refused(tmp_path):
    with pytest.raises(ModelError, match="carriage_pad_length_m"):
        machine(carriage_pad_span_m=0.3, carriage_pad_length_m=0.4)
    s = np.linspace(-3, 3, 10)
    write_profile(tmp_path / "g.csv", s, 0 * s)
    with pytest.raises(ModelError, match="straightness_m.*one of them"):
        machine(straightness_profile=str(tmp_path / "g.csv"), straightness_m=1e-8)


def test_the_model_key_of_the_evaluation_cache_follows_the_profile_content(tmp_path):
    """Two models of the same text whose profile files differ have different content keys;
    the same profile content under another name has the same key."""
    m = machine()
    s = np.linspace(m.guideway_span[0] - 0.01, m.guideway_span[1] + 0.01, 11)
    keys = []
    for name, height in (("a", 0 * s), ("b", 1e-8 + 0 * s), ("c", 0 * s)):
        folder = tmp_path / name
        folder.mkdir()
        write_profile(folder / "g.csv", s, height)
        machine_ = read_machine({**PLATE, "straightness_profile": "g.csv"}, str(folder / "m.toml"))
        keys.append(model_sha256(Model("syn", (), (), machine=machine_)))
    assert keys[0] != keys[1]
    assert keys[0] == keys[2]


GEOMETRIC_KEYS = (
    "straightness_m",
    "straightness_wavelength_m",
    "straightness_phase_deg",
    "error_motion_m",
    "error_motion_phase_deg",
    "error_motion_harmonics_m",
    "error_motion_harmonics_phase_deg",
    "workholding_power_m",
    "workholding_astigmatism_m",
)


def test_geometric_errors_are_held_uncertain_inputs_never_fitted():
    """Every geometric key has a documented band in the calibration file, is held there
    (fit = false) at a start inside its band, and is an input of the uncertainty study
    (ufmt.studies.bands)."""
    settings, _, _ = load_calibration(packaged_path(CALIBRATION))
    entries = {p.key: p for p in settings.response.parameters}
    bands = documented_bands()
    for key in GEOMETRIC_KEYS:
        entry = entries[key]
        assert not entry.fit, key
        assert entry.band[0] <= entry.start <= entry.band[1], key
        assert f"machine.{key}" in bands, key
