"""PSD of a machined surface and its band RMS (ufmt.machining.psd) against closed forms."""

import math

import numpy as np
import pytest
import scipy.signal
from synthetic import SMALL, synthetic_basis

import ufmt
from ufmt.machining.process import Process
from ufmt.machining.psd import (
    BANDS,
    N_MIN_PERIODS,
    band_power,
    band_resolved,
    band_rms,
    band_rms_2d,
    form_removed,
    profile_psd,
    psd_2d,
    surface_psd,
)
from ufmt.machining.surface import Surface
from ufmt.model.machine import read_machine
from ufmt.model.schema import Model

AMP = 3e-9  # sinusoid amplitude [m]
RMS_NM = AMP / np.sqrt(2) * 1e9
#: Hann window leakage: the main lobe (+-2 bins of 1 / L) and the side lobes of a sinusoid
#: spill past the band edge; 2 % of the RMS for one >= 1.3 bins inside the edge (30 mm on the
#: 0.41 m plate reads 99.8 %).
LEAKAGE = 0.02


def plate(size_x, spacing_x, size_y=None, spacing_y=None):
    """Grid axes x, y [m] with nodes on the plate's edges (as surface_grid), centred."""
    size_y = size_x if size_y is None else size_y
    spacing_y = spacing_x if spacing_y is None else spacing_y
    axes = []
    for size, h in ((size_x, spacing_x), (size_y, spacing_y)):
        axes.append(np.linspace(-size / 2, size / 2, int(np.ceil(size / h - 1e-9)) + 1))
    return axes


def sinusoid(x, y, wavelength, along_y, phase=0.3):
    coord = y[:, None] + 0 * x[None, :] if along_y else x[None, :] + 0 * y[:, None]
    return AMP * np.sin(2 * np.pi * coord / wavelength + phase)


@pytest.mark.parametrize(
    "size, spacing, wavelength, band",
    [
        (0.41, 1e-3, 30e-3, "psd1"),  # the review's 30 mm, on a plate that resolves PSD1
        (0.41, 1e-3, 10e-3, "psd1"),
        (0.41, 1e-3, 3e-3, "psd1"),
        (0.02, 5e-5, 1e-3, "psd2"),  # the PSD2 patch
        (0.02, 5e-5, 0.2e-3, "psd2"),
    ],
)
@pytest.mark.parametrize("along_y", [False, True])
@pytest.mark.parametrize("phase", [0.0, 0.3, np.pi / 2])
def test_a_sinusoid_in_the_band_reads_its_rms(size, spacing, wavelength, band, along_y, phase):
    """A sin(2 pi s / lambda + phase) reads A / sqrt(2) in its band, whatever the phase and the
    (non-integer) number of periods on the plate, within the window's leakage."""
    x, y = plate(size, spacing)
    metrics = band_rms(Surface(x, y, sinusoid(x, y, wavelength, along_y, phase)))
    direction = "along" if along_y else "across"
    assert metrics[f"{band}_rms_{direction}_nm"] == pytest.approx(RMS_NM, rel=LEAKAGE)
    assert metrics[f"{band}_rms_nm"] == metrics[f"{band}_rms_{direction}_nm"]
    other = "across" if along_y else "along"  # the crossing profiles are flat
    assert metrics[f"{band}_rms_{other}_nm"] < 1e-6 * RMS_NM


@pytest.mark.parametrize(
    "size, spacing, wavelength, band",
    [
        (0.41, 1e-3, 40e-3, "psd1"),  # the review's 40 mm, beyond the 33 mm edge
        (0.41, 1e-3, 0.1, "psd1"),
        (0.02, 5e-5, 5e-3, "psd2"),
        (0.02, 5e-5, 1e-3, "psd1"),  # PSD1 unresolved on the patch: NaN, not a number
    ],
)
@pytest.mark.parametrize("along_y", [False, True])
def test_a_sinusoid_outside_the_band_reads_under_5_percent(
    size, spacing, wavelength, band, along_y
):
    x, y = plate(size, spacing)
    metrics = band_rms(Surface(x, y, sinusoid(x, y, wavelength, along_y)))
    value = metrics[f"{band}_rms_nm"]
    assert np.isnan(value) if size < N_MIN_PERIODS * BANDS[band][1] else value < 0.05 * RMS_NM


def test_a_bowl_is_form_not_psd1():
    """A shop removes form (the 2nd-order Legendre fit) before the PSD: a bowl of PV 20 nm on a
    0.1 m plate (3 periods of 33 mm) contributes < 1e-4 nm (round-off) to PSD1, where the line
    detrend alone would leave 0.08 nm of window leakage."""
    x, y = plate(0.1, 1e-3)
    u, v = 2 * x[None, :] / 0.1, 2 * y[:, None] / 0.1
    bowl = 10e-9 * (u**2 + v**2)
    assert np.ptp(bowl) == pytest.approx(20e-9)
    metrics = band_rms(Surface(x, y, bowl))
    for key in ("psd1_rms_nm", "psd1_rms_along_nm", "psd1_rms_across_nm"):
        assert metrics[key] < 1e-4
    freq, psd = profile_psd(bowl, 1e-3)  # line detrend only
    assert 0.05 < math.sqrt(band_power(freq, psd, BANDS["psd1"])) * 1e9 < 0.15
    # and a ripple on the bowl reads as if the bowl were not there
    ripple = sinusoid(x, y, 10e-3, along_y=False)
    with_bowl = band_rms(Surface(x, y, bowl + ripple))["psd1_rms_nm"]
    assert with_bowl == pytest.approx(band_rms(Surface(x, y, ripple))["psd1_rms_nm"], rel=1e-6)


@pytest.mark.parametrize("n", [256, 301])
def test_parseval(n):
    """The integral of the PSD over every bin is the detrended profile's mean square: exactly
    without a window, and the windowed one's divided by the window's mean square with it."""
    rng = np.random.default_rng(n)
    h = 1e-3
    z = rng.normal(size=(7, n)) + np.linspace(0, 5, n)  # with a trend to remove
    detrended = scipy.signal.detrend(z, axis=-1)
    for window in ("boxcar", "hann"):
        freq, psd = profile_psd(z, h, window=window)
        assert freq[1] - freq[0] == pytest.approx(1 / (n * h))
        w = scipy.signal.get_window(window, n)
        expected = np.mean(np.mean((detrended * w) ** 2, axis=-1) / np.mean(w**2))
        assert np.sum(psd) * (freq[1] - freq[0]) == pytest.approx(expected, rel=1e-12)
    # a band wider than the spectrum: every bin but half the DC bin, empty after the detrend
    freq, psd = profile_psd(z, h, window="boxcar")
    assert band_power(freq, psd, (h / 10, 1e9)) == pytest.approx(np.mean(detrended**2), rel=1e-12)


@pytest.mark.parametrize("axis", [0, 1])
@pytest.mark.parametrize("window", ["hann", "boxcar"])
def test_profile_psd_is_the_mean_periodogram_of_the_lines(axis, window):
    """The same as scipy's periodogram (linear detrend, density scaling) averaged over lines."""
    z = np.random.default_rng(axis).normal(size=(40, 51)) + np.linspace(0, 3, 51)
    freq, psd = profile_psd(z, 1e-3, axis, window)
    expected_freq, each = scipy.signal.periodogram(
        z, fs=1e3, window=window, detrend="linear", scaling="density", axis=axis
    )
    expected = np.moveaxis(each, axis, -1).reshape(-1, freq.size).mean(axis=0)
    np.testing.assert_array_equal(freq, expected_freq)
    np.testing.assert_allclose(psd, expected, rtol=1e-12, atol=1e-15 * expected.max())


def test_band_power_cuts_the_edge_bins():
    """A flat PSD integrates to its level times the band's width in frequency, edges
    falling inside bins."""
    freq = np.arange(0, 501) / 0.41
    psd = np.full(freq.size, 2.0)
    lam_min, lam_max = BANDS["psd1"]
    assert band_power(freq, psd, BANDS["psd1"]) == pytest.approx(
        2.0 * (1 / lam_min - 1 / lam_max), rel=1e-12
    )


def test_white_noise_reads_its_variance_share():
    """White noise of variance s^2 sampled at h has the flat one-sided PSD 2 s^2 h: PSD1 holds
    s^2 2 h (1/lambda_min - 1/lambda_max) of it (74 % at 1 mm); within 3 % (the scatter of
    about 50 000 averaged periodogram values)."""
    x, y = plate(0.41, 1e-3)
    sigma = 2e-9
    z = np.random.default_rng(5).normal(scale=sigma, size=(y.size, x.size))
    lam_min, lam_max = BANDS["psd1"]
    share = math.sqrt(2 * 1e-3 * (1 / lam_min - 1 / lam_max))
    metrics = band_rms(Surface(x, y, z))
    for direction in ("along", "across"):
        assert metrics[f"psd1_rms_{direction}_nm"] == pytest.approx(sigma * share * 1e9, rel=0.03)


def test_three_periods_make_the_reading_independent_of_the_phase():
    """The reason for N_MIN_PERIODS = 3: a sinusoid at lambda_max (33 mm) reads half its power
    (the edge bin split) whatever its phase to 0.5 % on a profile of 3 periods; on 2 periods
    the detrend and form removal take a phase-dependent part (> 1 %)."""
    lam = BANDS["psd1"][1]
    spread = {}
    for periods in (2, N_MIN_PERIODS):
        x, y = plate(periods * lam, 0.5e-3, 0.01, 0.5e-3)
        readings = []
        for phase in np.linspace(0, np.pi, 7):
            surface = Surface(x, y, sinusoid(x, y, lam, along_y=False, phase=phase))
            power = band_power(*surface_psd(surface, "across"), BANDS["psd1"])
            readings.append(math.sqrt(power) * 1e9 / RMS_NM)
        spread[periods] = np.ptp(readings)
        assert np.mean(readings) == pytest.approx(np.sqrt(0.5), rel=0.05)
    assert spread[N_MIN_PERIODS] < 0.005 < 0.01 < spread[2]


@pytest.mark.parametrize(
    "size_x, size_y, spacing, resolved",
    [
        (0.0524, 0.0524, 1e-3, set()),  # the packaged plate: 1.6 periods of 33 mm
        (0.099, 0.099, 1e-3, {"psd1"}),  # exactly 3 periods
        (0.098, 0.098, 1e-3, set()),
        (0.41, 0.41, 1.25e-3, {"psd1"}),  # 2 h = 2.5 mm, PSD1's shortest wavelength
        (0.41, 0.41, 1.3e-3, set()),
        (0.02, 0.02, 5e-5, {"psd2"}),
        (0.0075, 0.0075, 5e-5, {"psd2"}),  # 3 periods of 2.5 mm
        (0.007, 0.007, 5e-5, set()),
        (0.02, 0.02, 7e-5, set()),
    ],
)
def test_a_band_the_profiles_do_not_resolve_is_nan(size_x, size_y, spacing, resolved):
    """NaN (never a partial number) unless 2 h <= lambda_min and (n - 1) h >= 3 lambda_max."""
    x, y = plate(size_x, spacing, size_y)
    z = 1e-9 * np.cos(2 * np.pi * x[None, :] / 3e-3) + 0 * y[:, None]
    metrics = band_rms(Surface(x, y, z))
    for band in BANDS:
        for key in (f"{band}_rms_nm", f"{band}_rms_along_nm", f"{band}_rms_across_nm"):
            assert np.isnan(metrics[key]) == (band not in resolved)


def test_each_direction_needs_its_own_length():
    """A plate long across the feed and short along it resolves PSD1 across only; the reported
    value (the larger of both) is then NaN."""
    x, y = plate(0.41, 1e-3, 0.05, 1e-3)
    metrics = band_rms(Surface(x, y, sinusoid(x, y, 10e-3, along_y=False)))
    assert metrics["psd1_rms_across_nm"] == pytest.approx(RMS_NM, rel=LEAKAGE)
    assert np.isnan(metrics["psd1_rms_along_nm"]) and np.isnan(metrics["psd1_rms_nm"])
    assert band_resolved(x.size, 1e-3, BANDS["psd1"])
    assert not band_resolved(y.size, 1e-3, BANDS["psd1"])
    # a 0.1 m profile at 0.06 mm resolves both bands
    assert all(band_resolved(1668, 6e-5, band) for band in BANDS.values())


def test_the_reported_band_is_the_larger_direction():
    x, y = plate(0.41, 1e-3, 0.41, 1.25e-3)
    z = sinusoid(x, y, 10e-3, along_y=False) + 0.5 * sinusoid(x, y, 20e-3, along_y=True)
    metrics = band_rms(Surface(x, y, z))
    assert metrics["psd1_rms_nm"] == metrics["psd1_rms_across_nm"]
    assert metrics["psd1_rms_along_nm"] == pytest.approx(0.5 * RMS_NM, rel=LEAKAGE)


def test_only_the_evenly_spaced_rows_enter():
    """Refined edge rows (core False) are left out of the profiles."""
    x, y = plate(0.41, 1e-3)
    z = sinusoid(x, y, 10e-3, along_y=True)
    extra = np.array([-0.2049, 0.2049])
    y_all = np.concatenate([y, extra])
    order = np.argsort(y_all)
    z_all = np.concatenate([z, np.full((2, x.size), 1e-6)])[order]
    core = (np.arange(y_all.size) < y.size)[order]
    refined = band_rms(Surface(x, y_all[order], z_all, core))
    np.testing.assert_equal(refined, band_rms(Surface(x, y, z)))


def test_surface_psd_peaks_at_the_wavelength():
    x, y = plate(0.41, 1e-3)
    for direction, along_y in (("along", True), ("across", False)):
        freq, psd = surface_psd(Surface(x, y, sinusoid(x, y, 10e-3, along_y)), direction)
        assert freq[np.argmax(psd)] == pytest.approx(100.0, abs=freq[1])  # 1 / 10 mm
    with pytest.raises(ValueError, match="direction"):
        surface_psd(Surface(x, y, 0 * x[None, :] + 0 * y[:, None]), "diagonal")


def test_psd_2d_parseval_and_band():
    """2-D PSD: without a window its integral is the form-removed surface's mean square; an
    isotropic band over it reads a sinusoid's RMS within the leakage."""
    x, y = plate(0.41, 1e-3, 0.41, 1.25e-3)
    z = sinusoid(x, y, 10e-3, along_y=False) + np.random.default_rng(2).normal(
        scale=1e-10, size=(y.size, x.size)
    )
    surface = Surface(x, y, z)
    fx, fy, psd = psd_2d(surface, window=False)
    mean_square = np.mean(form_removed(surface)[2] ** 2)
    assert np.sum(psd) * (fx[1] - fx[0]) * (fy[1] - fy[0]) == pytest.approx(mean_square, rel=1e-12)
    assert band_rms_2d(Surface(x, y, sinusoid(x, y, 10e-3, False)), "psd1") == pytest.approx(
        RMS_NM, rel=LEAKAGE
    )
    assert np.isnan(band_rms_2d(surface, "psd2"))


def test_simulate_reports_both_directions_and_the_psd2_patch():
    """On the grid's own columns and rows (``line_spacing=None``) the bands are the grid's
    band_rms and PSD2 is unresolved (1 mm steps); PSD1 is resolved on the whole plate (the
    small 0.1 m x 0.2 m one: three periods of its longest wavelength, 33 mm, so the whole
    plate is the clear aperture here). By default the line profiles resolve PSD2 over the
    whole plate; the PSD2 patch replaces the psd2 keys."""
    model = Model("syn", (), (), machine=read_machine(SMALL), source="syn.toml")
    basis = synthetic_basis(n=6)
    process = Process(300, 15, 4)
    options = dict(basis=basis, static_correction=False, aperture_margin=0.0)
    r = ufmt.simulate(model, process, line_spacing=None, **options)
    m = r.metrics
    assert m["psd1_rms_nm"] == max(m["psd1_rms_along_nm"], m["psd1_rms_across_nm"]) > 0
    bands = band_rms(r.smooth_surface)  # of the surface without the feed marks' scallops
    np.testing.assert_equal({key: m[key] for key in bands}, bands)
    assert all(np.isnan(m[k]) for k in ("psd2_rms_nm", "psd2_rms_along_nm", "psd2_rms_across_nm"))
    lines = ufmt.simulate(model, process, **options).metrics
    assert lines["psd_line_spacing_mm"] == pytest.approx(0.03)
    psd2 = [lines[k] for k in ("psd2_rms_nm", "psd2_rms_along_nm", "psd2_rms_across_nm")]
    assert all(np.isfinite(psd2)) and psd2[0] == max(psd2[1:]) > 0
    patched = ufmt.simulate(model, process, psd2_patch=20e-3, **options).metrics
    psd2 = [patched[k] for k in ("psd2_rms_nm", "psd2_rms_along_nm", "psd2_rms_across_nm")]
    assert all(np.isfinite(psd2)) and psd2[0] == max(psd2[1:])
    assert patched["psd1_rms_nm"] == lines["psd1_rms_nm"]
