"""Power spectral density (PSD) of a machined surface and its band RMS, as optics shops compute it.

KDP optics for large lasers specify mid-spatial-frequency errors as band RMS of 1-D PSDs
(ISO 10110-8; the PSD practice of NIF/LLNL for large optics): PSD1 over spatial wavelengths
2.5-33 mm, PSD2 over 0.12-2.5 mm (:data:`BANDS`). Here, on the evenly spaced (core) grid of a
:class:`~ufmt.machining.surface.Surface` (:mod:`ufmt.machining.lines` the same on fine line
profiles over the whole plate, :func:`spectra_band_rms`):

0. Clear aperture: the bands read the plate less an edge margin (``aperture_margin``, the
   interferometer's, :mod:`ufmt.machining.instruments`), as a KDP specification holds over
   the optic's clear aperture: the cut's entry and exit strips stay out of the mean PSD.
1. Form removed: the least-squares Legendre fit up to 2nd order (piston, tilt, power,
   astigmatism, twist; :func:`~ufmt.machining.surface.legendre_fit`). A shop reports the
   2nd-order part as form (``form_pv_nm``), not as PSD1: with the line detrend alone, a bowl
   of PV 20 nm (u^2 + v^2) would read 0.08 nm in PSD1 on a 0.1 m plate (3 periods of 33 mm)
   through the window's leakage.
2. Each line profile (a column: along the feed, y; a row: across it, x) detrended (its own
   least-squares line), Hann-windowed, and its one-sided periodogram divided by the window's
   mean square (the power correction: a stationary profile keeps its mean square); PSD
   [m^2 m] at frequencies f_k = k / (n h) [1/m]. The PSDs of all lines are averaged.
3. Band RMS = sqrt(integral of the PSD over 1/lambda_max <= f <= 1/lambda_min), each bin a
   rectangle of width 1 / (n h) centred on f_k, the band edges cutting the partial bins
   (:func:`band_power`). Without a window the integral over every bin is the mean square of the
   detrended profile (Parseval); with the Hann window it is the mean square of the windowed
   profile divided by the window's.

A band is reported in a direction only where the profile resolves it (:func:`band_resolved`):
2 h <= lambda_min (Nyquist) and profile length (n - 1) h >= :data:`N_MIN_PERIODS` lambda_max;
otherwise NaN, never a partial number. Three periods: the Hann main lobe spans +-2 bins, so at
the band's longest wavelength (bin L / lambda_max) it must stay clear of bin 0, which the
piston, tilt and form removal empty. On 3 periods a sinusoid at lambda_max reads the same
(half its power, the edge bin split) whatever its phase to 0.1 % of its RMS; on 2 periods its
reading varies by 1.3 % with its phase (the detrend and the form removal take part of it), on
1.5 periods by 12 % (the 52.4 mm plate spans 1.6). The band edge
stays blurred by the main lobe over +-2 / L in frequency: on the 0.41 m plate a 30 mm
sinusoid reads 99.8 % of its RMS in PSD1 and a 40 mm one 1.7 %.

:func:`band_rms` reports each band along the feed, across it, and as ``psd1_rms_nm`` the
larger of the two (see there). :func:`psd_2d` and :func:`band_rms_2d` give the isotropic 2-D
PSD for comparison.
"""

from __future__ import annotations

import numpy as np
import scipy.fft
import scipy.signal

from ufmt.machining.surface import Surface, clear_aperture, legendre_fit

#: Spatial wavelength bands (shortest, longest) [m] of the KDP specifications.
BANDS = {"psd1": (2.5e-3, 33e-3), "psd2": (0.12e-3, 2.5e-3)}
#: Periods of a band's longest wavelength a profile must span for the band to be reported.
N_MIN_PERIODS = 3
#: Profile directions: along the feed (y, the grid's columns) and across it (x, its rows).
DIRECTIONS = ("along", "across")
_AXIS = {"along": 0, "across": 1}


def form_removed(
    surface: Surface, aperture_margin: float = 0.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The evenly spaced grid x (Nx,), y (Ny,) [m] of ``surface`` inside the clear aperture
    (``aperture_margin`` [m] off every edge, :func:`~ufmt.machining.surface.clear_aperture`)
    and its heights there (Ny, Nx) [m] less their Legendre fit up to 2nd order (piston, tilt
    and form)."""
    core = surface.core_rows
    x, y = surface.x, surface.y[core]
    in_x, in_y = clear_aperture(x, aperture_margin), clear_aperture(y, aperture_margin)
    x, y, z = x[in_x], y[in_y], surface.z[core][np.ix_(in_y, in_x)]
    fit, _ = legendre_fit(x, y, z)
    return x, y, z - fit


def profile_psd(
    z: np.ndarray, spacing: float, axis: int = -1, window: str = "hann"
) -> tuple[np.ndarray, np.ndarray]:
    """Mean one-sided PSD of the line profiles of ``z`` along ``axis``, ``spacing`` [m] apart.

    Each line is detrended (its least-squares line) and windowed (``window``, a
    :func:`scipy.signal.get_window` name; "boxcar" for none), its periodogram divided by the
    window's mean square: :func:`scipy.signal.periodogram` with ``detrend="linear"``,
    ``scaling="density"``. Returns frequency (n // 2 + 1,) [1/m] and PSD [z unit^2 m], the
    mean over the other axes.
    """
    lines = np.moveaxis(np.asarray(z, dtype=float), axis, -1)
    # the least-squares line of each profile in closed form (scipy's detrend solves lstsq)
    t = np.arange(lines.shape[-1]) - (lines.shape[-1] - 1) / 2
    slope = (lines @ t) / (t @ t)
    flat = lines - lines.mean(axis=-1, keepdims=True) - slope[..., None] * t
    frequency, psd = scipy.signal.periodogram(
        flat, fs=1.0 / spacing, window=window, detrend=False, scaling="density", axis=-1
    )
    return frequency, psd.reshape(-1, psd.shape[-1]).mean(axis=0)


def band_power(frequency: np.ndarray, psd: np.ndarray, band: tuple[float, float]) -> float:
    """Integral of ``psd`` over the band (lambda_min, lambda_max) [m] [psd unit / m].

    Each bin is a rectangle of width df = frequency[1] - frequency[0] centred on its frequency;
    a bin the band edge cuts counts with the part inside the band.
    """
    lam_min, lam_max = band
    df = frequency[1] - frequency[0]
    lo, hi = 1.0 / lam_max, 1.0 / lam_min
    inside = np.minimum(frequency + df / 2, hi) - np.maximum(frequency - df / 2, lo)
    return float(np.sum(psd * np.clip(inside, 0.0, None)))


def band_resolved(n: int, spacing: float, band: tuple[float, float]) -> bool:
    """True if a profile of ``n`` points ``spacing`` [m] apart resolves the band (lambda_min,
    lambda_max) [m]: 2 h <= lambda_min and (n - 1) h >= :data:`N_MIN_PERIODS` lambda_max."""
    lam_min, lam_max = band
    tol = 1 + 1e-9
    return 2 * spacing <= lam_min * tol and (n - 1) * spacing * tol >= N_MIN_PERIODS * lam_max


def surface_psd(
    surface: Surface, direction: str, window: str = "hann", aperture_margin: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Mean 1-D PSD of ``surface``'s line profiles in ``direction`` ("along" the feed: the
    columns, in y; "across" it: the rows, in x) over the clear aperture, form removed (module
    docstring).

    Returns frequency [1/m] and PSD [m^2 m] (:func:`profile_psd`).
    """
    axis = _axis(direction)
    _, _, flat = form_removed(surface, aperture_margin)
    return profile_psd(flat, surface.spacing[1 - axis], axis, window)


def band_rms(
    surface: Surface, bands=tuple(BANDS), aperture_margin: float = 0.0
) -> dict[str, float]:
    """Band RMS [nm] of the 1-D PSDs of ``surface`` in each of ``bands`` (names of
    :data:`BANDS`), NaN where a profile does not resolve the band (:func:`band_resolved`),
    over the clear aperture: the plate less ``aperture_margin`` [m] at every edge, profiles
    and form fit alike (module docstring).

    Keys per band, e.g. psd1: ``psd1_rms_along_nm`` (profiles along the feed, y),
    ``psd1_rms_across_nm`` (across it, x) and ``psd1_rms_nm``, the larger of the two (NaN
    unless both are resolved). The larger, because a fly-cut surface carries mid-spatial
    content in both directions (each arc's vibration across the feed; the slide's straightness
    and the cut's slow modulation along it) and a specification holds for a profile in any
    direction: the plate passes only if it passes in the worse one.
    """
    x, y, flat = form_removed(surface, aperture_margin)
    hx, hy = surface.spacing
    profiles = {
        "along": (y.size, hy, lambda: profile_psd(flat, hy, _axis("along"))),
        "across": (x.size, hx, lambda: profile_psd(flat, hx, _axis("across"))),
    }
    return spectra_band_rms(profiles, bands)


def spectra_band_rms(profiles: dict, bands=tuple(BANDS)) -> dict[str, float]:
    """Band RMS [nm] (keys as :func:`band_rms`) of ``profiles``: per direction of
    :data:`DIRECTIONS`, (n points per profile, spacing [m], a function returning the mean
    PSD (frequency [1/m], PSD [m^2 m])), each called at most once, where a band is resolved."""
    spectra = {}
    out = {}
    for name in bands:
        band = BANDS[name]
        per_direction = {}
        for direction in DIRECTIONS:
            n, h, spectrum = profiles[direction]
            if not band_resolved(n, h, band):
                per_direction[direction] = float("nan")
                continue
            if direction not in spectra:
                spectra[direction] = spectrum()
            power = band_power(*spectra[direction], band)
            per_direction[direction] = float(np.sqrt(power)) * 1e9
        out[f"{name}_rms_nm"] = float(np.maximum(per_direction["along"], per_direction["across"]))
        for direction in DIRECTIONS:
            out[f"{name}_rms_{direction}_nm"] = per_direction[direction]
    return out


def psd_2d(surface: Surface, window: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """2-D PSD of ``surface``'s evenly spaced grid, form removed.

    ``window``: a separable Hann window, with its power correction (else none). Returns fx
    (Nx,), fy (Ny,) [1/m] (FFT order) and PSD (Ny, Nx) [m^2 m^2], two-sided: its sum times
    df_x df_y is the mean square of the (windowed, corrected) surface.
    """
    x, y, flat = form_removed(surface)
    hx, hy = surface.spacing
    if window:
        win = np.outer(
            scipy.signal.get_window("hann", y.size), scipy.signal.get_window("hann", x.size)
        )
    else:
        win = np.ones_like(flat)
    spectrum = scipy.fft.fft2(flat * win)
    psd = hx * hy * np.abs(spectrum) ** 2 / np.sum(win**2)
    return scipy.fft.fftfreq(x.size, hx), scipy.fft.fftfreq(y.size, hy), psd


def band_rms_2d(surface: Surface, band: str) -> float:
    """RMS [nm] of the 2-D PSD (:func:`psd_2d`) over the annulus 1/lambda_max <= |f| <=
    1/lambda_min of ``band`` (whole bins); NaN unless both directions resolve it."""
    lam_min, lam_max = BANDS[band]
    ny, nx = int(surface.core_rows.sum()), surface.x.size
    hx, hy = surface.spacing
    if not (band_resolved(nx, hx, BANDS[band]) and band_resolved(ny, hy, BANDS[band])):
        return float("nan")
    fx, fy, psd = psd_2d(surface)
    radius = np.hypot(fy[:, None], fx[None, :])
    inside = (radius >= 1.0 / lam_max) & (radius <= 1.0 / lam_min)
    df = (fx[1] - fx[0]) * (fy[1] - fy[0])
    return float(np.sqrt(np.sum(psd[inside]) * df)) * 1e9


def _axis(direction: str) -> int:
    """Grid axis of the profiles in ``direction`` (:data:`DIRECTIONS`)."""
    if direction not in _AXIS:
        raise ValueError(f"direction must be one of {DIRECTIONS}, got {direction!r}")
    return _AXIS[direction]
