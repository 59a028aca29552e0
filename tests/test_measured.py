"""Measured maps: reading (SurfaceTopography and ufmt's exports), the instrument pipeline, the
ISO 25178-2 parameters and the ISO 16610-21 filter, ``ufmt surface`` and ``ufmt compare``.

Oracles: maps built from a plane plus a cosine of known amplitude (Sq = A / sqrt 2, the
sampled PV, the band RMS of a sinusoid inside a band), invariance under an added plane, a
change of unit and a swap of the axes, the Gaussian filter's 50 % transmission at its cutoff,
an independent assembly of the periodogram, SurfaceTopography's own Sq, and the simulation's
own interferometer metrics of the surface it exported."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import scipy.fft
import scipy.signal
from SurfaceTopography import Topography
from synthetic import MACHINE, synthetic_basis

import ufmt
from ufmt.cli import main
from ufmt.errors import ModelError
from ufmt.exports import export_grid, read_sdf, write_sdf, write_x3p
from ufmt.machining.process import Process
from ufmt.machining.psd import profile_psd
from ufmt.machining.surface import DEFAULT_APERTURE_MARGIN, Surface
from ufmt.measured.analysis import analyse
from ufmt.measured.areal import gaussian_mean
from ufmt.measured.compare import compare
from ufmt.measured.read import HeightMap, read_map
from ufmt.model.machine import read_machine
from ufmt.model.schema import Model

A = 20e-9  # amplitude [m] of the test cosines


def symmetric_axis(n: int, h: float) -> np.ndarray:
    """n points h apart, symmetric about 0."""
    return (np.arange(n) - (n - 1) / 2) * h


def cosine_map(nx=200, ny=120, h=1e-4, wavelength=2e-3, plane=(0.0, 0.0, 0.0)) -> HeightMap:
    """A cos(2 pi x / wavelength) plus a plane c0 + c1 x + c2 y on a symmetric grid whose length
    n h holds whole periods (the cosine is orthogonal to 1, x and y)."""
    x, y = symmetric_axis(nx, h), symmetric_axis(ny, h)
    c0, c1, c2 = plane
    z = A * np.cos(2 * np.pi * x / wavelength)[None, :] + c0 + c1 * x[None, :] + c2 * y[:, None]
    return HeightMap(x, y, z, "cosine")


@pytest.fixture(scope="module")
def result():
    model = Model("syn", (), (), machine=read_machine(MACHINE), source="syn.toml")
    return ufmt.simulate(
        model, Process(300, 15, 4), basis=synthetic_basis(n=6), static_correction=False
    )


def test_cosine_sq_pv_and_rms_are_analytic():
    h, wavelength = 1e-4, 2e-3
    cosine = cosine_map(h=h, wavelength=wavelength)
    m = analyse(cosine, aperture_margin=0.0).metrics
    assert m["sq_nm"] == pytest.approx(A / math.sqrt(2) * 1e9, rel=1e-9)
    assert m["rms_measured_nm"] == pytest.approx(A / math.sqrt(2) * 1e9, rel=1e-9)
    # samples at half-integer steps from the crest: the largest is A cos(pi h / wavelength)
    assert m["pv_measured_nm"] == pytest.approx(2 * A * math.cos(math.pi * h / wavelength) * 1e9)
    assert m["sa_nm"] == pytest.approx(np.mean(np.abs(cosine.z)) * 1e9, rel=1e-9)  # mean |z|
    assert m["ssk"] == pytest.approx(0.0, abs=1e-9)
    assert m["sku"] == pytest.approx(1.5, rel=1e-9)  # mean cos^4 / (mean cos^2)^2


def test_piston_and_tilt_do_not_change_the_interferometer_reading():
    bare = analyse(cosine_map(), aperture_margin=2e-3).metrics
    tilted = analyse(cosine_map(plane=(3e-6, 2e-4, -5e-4)), aperture_margin=2e-3).metrics
    for key in ("pv_measured_nm", "rms_measured_nm", "waviness_rms_nm", "form_pv_nm"):
        assert tilted[key] == pytest.approx(bare[key], rel=1e-7, abs=1e-9)


def test_band_rms_of_a_sinusoid_inside_psd1():
    # 10 mm along the feed on a 120 mm profile at 1 mm: the whole RMS in PSD1 along, none across
    h, n = 1e-3, 121
    x, y = symmetric_axis(n, h), symmetric_axis(n, h)
    z = np.repeat((A * np.sin(2 * np.pi * y / 10e-3))[:, None], x.size, axis=1)
    m = analyse(HeightMap(x, y, z, "sine")).metrics
    # the detrend and the form removal take the sine's share on a line and a parabola:
    # the band keeps what they leave, to the Hann window's 0.2 % (ufmt.machining.psd)
    assert m["psd1_rms_along_nm"] == pytest.approx(A / math.sqrt(2) * 1e9, rel=5e-3)
    assert m["psd1_rms_across_nm"] == pytest.approx(0.0, abs=1e-6 * A * 1e9)
    assert m["psd1_rms_nm"] == m["psd1_rms_along_nm"]
    assert m["psd2_rms_nm"] is None or math.isnan(m["psd2_rms_nm"])  # 1 mm steps: unresolved


def test_feed_direction_x_is_the_map_turned():
    straight = cosine_map()
    turned = HeightMap(straight.y, straight.x, straight.z.T.copy(), "turned")
    a = analyse(cosine_map(), aperture_margin=0.0).metrics
    b = analyse(turned, feed_direction="x", aperture_margin=0.0).metrics
    for key, value in a.items():
        assert b[key] == pytest.approx(value, rel=1e-9, abs=1e-12, nan_ok=True), key


def test_periodogram_is_an_independent_assembly():
    rng = np.random.default_rng(3)
    z = rng.normal(size=(7, 64)) + np.linspace(0, 5, 64)
    f, psd = profile_psd(z, 2e-4)
    # by hand: least-squares line removed, Hann window, one-sided density
    t = np.arange(64.0)
    lines = np.array([r - np.polyval(np.polyfit(t, r, 1), t) for r in z])
    win = scipy.signal.get_window("hann", 64)
    power = np.abs(scipy.fft.rfft(lines * win, axis=1)) ** 2
    manual = power.mean(axis=0) * 2 * 2e-4 / np.sum(win**2)
    manual[0] /= 2
    manual[-1] /= 2
    np.testing.assert_allclose(f, scipy.fft.rfftfreq(64, 2e-4))
    np.testing.assert_allclose(psd, manual, rtol=1e-10, atol=1e-14)


def test_gaussian_filter_passes_half_at_its_cutoff():
    h, cutoff = 5e-5, 2e-3
    x, y = symmetric_axis(800, h), symmetric_axis(40, h)
    z = np.repeat((A * np.cos(2 * np.pi * x / cutoff))[None, :], y.size, axis=0)
    mean = gaussian_mean(z, (h, h), cutoff)
    inner = np.abs(x) < 10e-3  # a cutoff away from the ends
    np.testing.assert_allclose(mean[:, inner], 0.5 * z[:, inner], atol=2e-3 * A)
    # a wavelength 10 cutoffs long passes at exp(-pi alpha^2 / 100)
    long = np.repeat((A * np.cos(2 * np.pi * x / (10 * cutoff)))[None, :], y.size, axis=0)
    gain = math.exp(-math.log(2) / 100)
    np.testing.assert_allclose(
        gaussian_mean(long, (h, h), cutoff)[:, inner], gain * long[:, inner], atol=2e-3 * A
    )


def test_cutoff_adds_the_s_l_surface_parameters():
    # a plane plus a cosine 4 times below the cutoff (the mean passes exp(-16 pi alpha^2) of
    # it, 1.5e-5): the S-L surface is the cosine, but for the truncated kernel's share of it
    # within a cutoff of the ends (O(wavelength / length): 1.3e-4 here, 2.7e-4 at twice the
    # wavelength and cutoff)
    cosine = cosine_map(wavelength=0.5e-3, plane=(0, 1e-4, 2e-4))
    m = analyse(cosine, aperture_margin=0.0, cutoff=2e-3).metrics
    assert m["sq_lc_nm"] == pytest.approx(A / math.sqrt(2) * 1e9, rel=2e-4)
    assert m["sq_nm"] > 10 * m["sq_lc_nm"]  # unfiltered: the plane's RMS too


def test_x3p_units_and_missing_pixels_are_honoured(tmp_path):
    base = cosine_map(nx=80, ny=60)
    heights = np.ma.masked_array(base.z.T.copy(), mask=np.zeros(base.z.T.shape, bool))
    heights.mask[10:13, 20:22] = True
    h = base.spacing[0]
    for unit, scale in (("m", 1.0), ("um", 1e6)):
        t = Topography(heights * scale, physical_sizes=(80 * h * scale, 60 * h * scale), unit=unit)
        with open(tmp_path / f"{unit}.x3p", "wb") as f:
            t.to_x3p(f)
    a = ufmt.read_surface(tmp_path / "m.x3p", aperture_margin=0.0)
    b = ufmt.read_surface(tmp_path / "um.x3p", aperture_margin=0.0)
    assert np.isnan(a.map.z).sum() == 6 and a.to_dict()["missing_share"] == pytest.approx(6 / 4800)
    np.testing.assert_allclose(a.map.x, b.map.x, rtol=1e-12)
    np.testing.assert_allclose(a.map.z, b.map.z, rtol=1e-12, atol=1e-22)
    for key, value in a.metrics.items():
        assert b.metrics[key] == pytest.approx(value, rel=1e-9, nan_ok=True), key


@pytest.mark.filterwarnings("ignore::DeprecationWarning")  # inside SurfaceTopography
def test_sq_agrees_with_surfacetopography(tmp_path):
    rng = np.random.default_rng(5)
    z = rng.normal(scale=5e-9, size=(50, 70)) + 1e-6
    t = Topography(z.T, physical_sizes=(70e-3, 50e-3), unit="m")
    with open(tmp_path / "r.x3p", "wb") as f:
        t.to_x3p(f)
    ours = ufmt.read_surface(tmp_path / "r.x3p").metrics["sq_nm"]
    theirs = t.detrend("center").rms_height_from_area() * 1e9
    assert ours == pytest.approx(theirs, rel=1e-10)


def test_exports_read_back_alike_in_every_format(result, tmp_path):
    paths = result.save(tmp_path)
    x, y, z = export_grid(result.measured_surface())
    rx, ry, rz = read_sdf(tmp_path / "surface.sdf")
    # the SDF holds 1e-6 nm; SurfaceTopography's xyz reader rounds the step to 8 digits
    for name, step in (("sdf", 1e-12), ("xyz", 1e-6), ("x3p", 1e-12), ("npz", 1e-12)):
        m = read_map(tmp_path / f"surface.{name}")
        np.testing.assert_allclose(m.z, z, atol=1e-15)
        np.testing.assert_allclose(np.diff(m.x), np.diff(x), rtol=step)
        np.testing.assert_allclose(np.diff(m.y), np.diff(y), rtol=step)
    assert tmp_path / "surface.x3p" in paths
    np.testing.assert_allclose(rz, z, atol=1e-15)


def test_surface_cli_reproduces_the_simulated_interferometer(result, tmp_path, capsys):
    result.save(tmp_path)
    assert main(["surface", str(tmp_path / "surface.sdf"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for key in ("sq_nm", "pv_measured_nm", "rms_measured_nm", "psd1_rms_nm", "psd2_rms_nm"):
        assert key in out
    assert out["pv_measured_nm"] == pytest.approx(result.metrics["pv_measured_nm"], rel=0.02)


def test_bands_of_an_exported_surface_are_the_simulations(tmp_path):
    # an evenly spaced surface (no refined rows): the map read back is the simulated grid
    x, y = symmetric_axis(131, 1e-3), symmetric_axis(121, 1e-3)
    z = A * np.sin(2 * np.pi * x / 7e-3)[None, :] + A * np.cos(2 * np.pi * y / 12e-3)[:, None]
    surface = Surface(x, y, z)
    from ufmt.machining.psd import band_rms

    write_sdf(surface, tmp_path / "s.sdf")
    write_x3p(surface, tmp_path / "s.x3p")
    for margin in (0.0, DEFAULT_APERTURE_MARGIN):  # whole map and the default clear aperture
        expected = band_rms(surface, aperture_margin=margin)
        for name, rel in (("s.sdf", 1e-6), ("s.x3p", 1e-9)):  # the SDF: 1e-6 nm of ~20 nm
            m = ufmt.read_surface(tmp_path / name, aperture_margin=margin).metrics
            for key, value in expected.items():
                assert m[key] == pytest.approx(value, rel=rel, nan_ok=True), (name, key)


def test_compare_a_surface_with_its_own_simulation(result, tmp_path):
    result.save(tmp_path)
    comparison = compare(ufmt.read_surface(tmp_path / "surface.sdf"), result)
    frame = comparison.to_frame().set_index("metric")
    np.testing.assert_allclose(frame["ratio"].dropna(), 1.0, rtol=1e-6)
    names = {p.name for p in comparison.save(tmp_path / "cmp")}
    assert names == {"comparison.json", "comparison.csv", "comparison.png"}


@pytest.mark.parametrize(
    "content, reason",
    [(b"aISO-1.0\r\nNumPoints = 3\r\n*\r\n1 2\r\n*\r\n*\r\n", ""), (b"\x00\x01garbage", "")],
)
def test_malformed_map_exits_2_with_one_line(tmp_path, capsys, content, reason):
    path = tmp_path / "bad.sdf"
    path.write_bytes(content)
    assert main(["surface", str(path), "--json"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(path) in err


def test_bad_options_name_the_field(tmp_path):
    m = cosine_map()
    with pytest.raises(ModelError, match="feed_direction"):
        analyse(m, feed_direction="z")
    with pytest.raises(ModelError, match="aperture_margin"):
        analyse(m, aperture_margin=1.0)
    with pytest.raises(ModelError, match="no such file"):
        read_map(tmp_path / "missing.x3p")
    with pytest.raises(ModelError, match="unit"):
        read_map(tmp_path / "missing.x3p", unit="furlong")


def test_attribution_recovers_each_sources_share():
    import dataclasses

    from ufmt.measured.attribution import attribute_map, source_lines

    process = Process(300, 15, 4)  # f_s = 5 Hz, v = 0.25 mm/s, f_r = 50 um
    machine = dataclasses.replace(
        read_machine(MACHINE),
        pressure_ripple_hz=0.25e-3 / 7e-3,  # v / f_p = 7 mm along the feed
        straightness_wavelength_m=20e-3,
    )
    mode_hz = 5.0 * (100 + 0.05 / 12)  # beats with the 100th harmonic: 12 mm along the feed
    lines = source_lines(machine, process, [mode_hz])
    assert lines["mode 1"]["along"][0] == pytest.approx(1 / 12e-3)
    h = 0.5e-3
    x, y = symmetric_axis(41, h), symmetric_axis(401, h)
    amplitudes = {"straightness": (10e-9, 20e-3), "pressure_ripple": (5e-9, 7e-3),
                  "mode 1": (3e-9, 12e-3)}  # fmt: skip
    rng = np.random.default_rng(11)
    profile = sum(a * np.sin(2 * np.pi * y / lam + rng.uniform(0, 2 * np.pi))
                  for a, lam in amplitudes.values())  # fmt: skip
    noise = 1e-9
    z = profile[:, None] + rng.normal(scale=noise, size=(y.size, x.size))
    shares = attribute_map(HeightMap(x, y, z, "synthetic"), lines)["psd1"]["along"]
    # expected: each sine's mean square over the band's (the sines plus the white noise's
    # share of the band, (1/2.5 - 1/33) mm^-1 of the 1 mm^-1 up to Nyquist)
    noise_power = noise**2 * (1 / 2.5e-3 - 1 / 33e-3) * 2 * h
    total = sum(a**2 / 2 for a, _ in amplitudes.values()) + noise_power
    for name, (a, _) in amplitudes.items():
        assert shares[name] == pytest.approx(a**2 / 2 / total, rel=0.10), name
    # the noise less its part in the sources' bins (5 of ~370 per line)
    assert shares["unexplained"] == pytest.approx(noise_power / total, rel=0.2)
    assert sum(shares.values()) == pytest.approx(1.0, rel=1e-12)


def test_cli_simulate_save_surface_and_compare(tmp_path, capsys):
    # the outside contract on the packaged model: the saved surface.sdf reads the simulation's
    # interferometer PV within 2 %, and compare of it against the same cut finds ratio 1
    assert main(["simulate", "--json", "--save", str(tmp_path / "sim")]) == 0
    simulated = json.loads(capsys.readouterr().out)
    sdf = str(tmp_path / "sim" / "surface.sdf")
    assert main(["surface", sdf, "--json", "--plot", str(tmp_path / "plots")]) == 0
    read = json.loads(capsys.readouterr().out)
    assert read["pv_measured_nm"] == pytest.approx(simulated["pv_measured_nm"], rel=0.02)
    assert (tmp_path / "plots" / "psd.png").is_file()
    assert main(["compare", sdf, "--json", "--fmax", "200"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["metrics"]["pv_measured_nm"]["ratio"] == pytest.approx(1.0, rel=1e-6)
    assert out["rpm"] == simulated["rpm"]


def test_attribution_of_a_simulated_surface_read_back(tmp_path):
    # straightness (10 nm, 20 mm) and pressure ripple (5 nm, v / f_p = 7 mm) alone on a
    # 120 mm plate: along the feed the surface is the two sines, 100 : 25 in mean square (the
    # carriage's pads 20 mm apart and 1 mm long carry the guideway's 20 mm wave whole: heave
    # cos(pi S / L) sinc(l / L) = -1.00, no pitch)
    from ufmt.measured.attribution import attribute_map, source_lines

    table = {**MACHINE, "workpiece_size": [0.12, 0.12], "straightness_m": 10e-9,
             "straightness_wavelength_m": 20e-3, "carriage_pad_span_m": 20e-3,
             "carriage_pad_length_m": 1e-3, "pressure_ripple_m": 5e-9,
             "pressure_ripple_hz": 0.25e-3 / 7e-3}  # fmt: skip
    machine = read_machine(table)
    result = ufmt.simulate(
        Model("syn", (), (), machine=machine, source="syn.toml"),
        Process(300, 15, 4),
        basis=synthetic_basis(n=6),
        static_correction=False,
        sources=("straightness", "pressure_ripple"),
    )
    result.save(tmp_path)
    read = ufmt.read_surface(tmp_path / "surface.sdf")
    shares = attribute_map(read.map, source_lines(machine, result.process))["psd1"]["along"]
    assert shares["straightness"] == pytest.approx(0.8, rel=0.10)
    assert shares["pressure_ripple"] == pytest.approx(0.2, rel=0.10)
    assert shares["unexplained"] < 0.02
