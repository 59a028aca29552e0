"""Which source explains which part of a measured spectrum: each error source's characteristic
spatial frequencies, and the share of each band's power found at them.

A fly-cut surface is written one arc per revolution: a point across the feed (x, near the arc's
middle x = R phi) is cut at the spindle angle phi, a point along the feed (y) once per
revolution, ``feed_per_rev`` f_r = v / f_s apart. A vibration at frequency f [Hz] therefore
prints (paper eq. 4.1 with z_re = a sin(2 pi f t)):

* across the feed: wavelength 2 pi R f_s / f (the arc's angle advances 2 pi f_s t);
* along the feed: the phase advances by 2 pi f / f_s per revolution, seen modulo 2 pi: spatial
  frequency |f / f_s - round(f / f_s)| / f_r (the beat with the nearest spindle harmonic;
  0 for a harmonic, which is the same on every arc).

Lines of each source (:func:`source_lines`): ``feed_marks`` k / f_r along (the scallops);
``spindle`` the harmonics k f_s across, k / (2 pi R) (tilt, error motion and the synchronous
part of the vibration); ``mode <i>`` each natural frequency f_i mapped both ways;
``pressure_ripple`` f_p / v along (f_p << f_s); ``straightness`` 1 / L along (the guideway's
profile, wavelength L).

Shares (:func:`band_shares`), of the spectra the band RMS read (the clear aperture, form
removed there): every bin of a 1-D PSD inside a band belongs to the source whose line lies
nearest within the Hann window's main lobe (+-2 bins); a source's share is the power of its
bins over the band's power (the partial-bin rule of :func:`ufmt.machining.psd.band_power`),
``unexplained`` the rest.
"""

from __future__ import annotations

import math

import numpy as np

from ufmt.machining.process import Process
from ufmt.machining.psd import BANDS
from ufmt.model.machine import Machine

#: Half-width of the Hann window's main lobe [bins]: a line's power spreads over +-2 bins.
MAIN_LOBE_BINS = 2.0
#: Harmonics of the spindle and of the feed marks listed per source.
HARMONICS = 40


def source_lines(
    machine: Machine,
    process: Process,
    mode_frequencies_hz=(),
    harmonics: int = HARMONICS,
) -> dict[str, dict[str, np.ndarray]]:
    """Characteristic spatial frequencies [1/m]: source -> {"along": (k,), "across": (k,)}
    (module docstring); ``mode_frequencies_hz`` the natural frequencies [Hz] to list."""
    f_s, v, f_r = process.spindle_hz, process.feed_m_s, process.feed_per_rev_m
    k = np.arange(1, harmonics + 1, dtype=float)
    radius = machine.tool_radius
    none = np.empty(0)
    lines = {
        "feed_marks": {"along": k / f_r, "across": none},
        "spindle": {"along": none, "across": k / (2 * math.pi * radius)},
    }
    if machine.pressure_ripple_hz > 0:
        lines["pressure_ripple"] = {
            "along": np.array([machine.pressure_ripple_hz / v]),
            "across": none,
        }
    if machine.straightness_wavelength_m > 0:
        lines["straightness"] = {
            "along": np.array([1.0 / machine.straightness_wavelength_m]),
            "across": none,
        }
    for i, f in enumerate(mode_frequencies_hz, start=1):
        ratio = f / f_s
        lines[f"mode {i}"] = {
            "along": np.array([abs(ratio - round(ratio)) / f_r]),
            "across": np.array([f / (2 * math.pi * radius * f_s)]),
        }
    return lines


def band_shares(
    frequency: np.ndarray,
    psd: np.ndarray,
    lines: dict[str, np.ndarray],
    band: tuple[float, float],
) -> dict[str, float]:
    """Share of the band's power (``band`` (lambda_min, lambda_max) [m]) of a 1-D PSD each
    source explains (``lines``: source -> its spatial frequencies [1/m] in this direction),
    and ``unexplained``; empty if the band holds no power (module docstring)."""
    df = frequency[1] - frequency[0]
    lo, hi = 1.0 / band[1], 1.0 / band[0]
    inside = np.clip(
        np.minimum(frequency + df / 2, hi) - np.maximum(frequency - df / 2, lo), 0, None
    )
    power = psd * inside
    total = float(power.sum())
    if not total > 0:
        return {}
    names = [name for name, f in lines.items() if np.size(f)]
    nearest = np.full(frequency.size, np.inf)
    owner = np.full(frequency.size, -1)
    for index, name in enumerate(names):
        distance = np.abs(frequency[:, None] - np.asarray(lines[name])[None, :]).min(axis=1)
        closer = (distance <= MAIN_LOBE_BINS * df * (1 + 1e-9)) & (distance < nearest)
        nearest[closer], owner[closer] = distance[closer], index
    shares = {name: float(power[owner == i].sum()) / total for i, name in enumerate(names)}
    shares = {name: share for name, share in shares.items() if share > 0}
    shares["unexplained"] = float(power[owner < 0].sum()) / total
    return shares


def attribute(
    spectra: dict[str, tuple[np.ndarray, np.ndarray]],
    lines: dict[str, dict[str, np.ndarray]],
    resolved: dict[str, dict[str, bool]],
) -> dict[str, dict[str, dict[str, float]]]:
    """Shares per band and direction: band -> direction -> source -> share, for the bands
    ``resolved[band][direction]``; ``spectra`` direction -> (frequency [1/m], PSD)."""
    out = {}
    for band_name, band in BANDS.items():
        out[band_name] = {}
        for direction, (frequency, psd) in spectra.items():
            if not resolved[band_name][direction] or frequency.size < 2:
                continue
            per_source = {name: f[direction] for name, f in lines.items()}
            out[band_name][direction] = band_shares(frequency, psd, per_source, band)
    return out


def attribute_map(
    height_map, lines: dict[str, dict[str, np.ndarray]], aperture_margin: float | None = None
):
    """Shares (:func:`attribute`) of the PSDs of a map whose feed runs along y over its clear
    aperture, form removed there (:func:`ufmt.measured.fits.map_psd`, the spectra of its band
    RMS), in the bands its profiles resolve; ``aperture_margin`` [m] (None:
    :func:`ufmt.measured.analysis.default_margin`)."""
    from ufmt.machining.psd import band_resolved
    from ufmt.measured.analysis import default_margin
    from ufmt.measured.fits import aperture, map_psd

    margin = default_margin(height_map) if aperture_margin is None else aperture_margin
    in_x, in_y = aperture(height_map, margin)
    hx, hy = height_map.spacing
    profile = {"along": (int(in_y.sum()), hy), "across": (int(in_x.sum()), hx)}
    spectra = {direction: map_psd(height_map, direction, margin) for direction in profile}
    resolved = {
        name: {d: band_resolved(*profile[d], band) for d in profile} for name, band in BANDS.items()
    }
    return attribute(spectra, lines, resolved)
