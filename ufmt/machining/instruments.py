"""Instruments as models: the numbers a shop's instruments report of the machined surface.

The paper's Table 4 PV is a flatness measured by a full-aperture laser interferometer, not the
maximum minus the minimum of the cut's every point. Two instruments are modelled here.

Interferometer (:class:`Interferometer`, :func:`interferometer_metrics`): a Fizeau
interferometer images the plate's clear aperture on a camera; every pixel averages the surface
over its footprint, and the flatness is reported with piston and tilt removed (they are the
alignment of the plate against the reference flat, not a property of the surface).

* Lateral resolution ``pixel`` [m], default 0.5 mm: a 600 mm aperture (the size used for large
  KDP plates) on a 1k-2k camera resolves 0.3-0.6 mm per pixel (e.g. Zygo's large-aperture
  Fizeau systems; ISO 10110-5 flatness with piston and tilt removed). The surface grid of
  :mod:`ufmt.machining.surface` is 1-1.25 mm, so every feature the grid holds is resolved.
* Tool-nose scallops: their spacing is the feed per revolution times cos(phi) (50 um at the
  reference cut). Where it lies below half a pixel the instrument sees only their local
  mean, h(phi) / 3 above the cusps for the parabolic scallop of height
  h = (v/f)^2 cos^2(phi) / (8 r_n) (mean of min(s, 1 - s)^2 over the spacing, times
  4 h); where it does not (very coarse feeds), the scallops are measured in full.
* Clear aperture: the plate less ``aperture_margin`` [m] at every edge (default 5 mm, the
  same as the aperture metrics of :func:`ufmt.machining.surface.surface_metrics`).

Accelerometer (:class:`Accelerometer`, :func:`accelerometer_peak`): the paper's Fig. 12 signal
comes from a 1 V/g accelerometer under the tool carrier and a recorder rotating with the head
(section 4.2). High-sensitivity (1 V/g) IEPE accelerometers are specified to about 2 kHz
(e.g. PCB 393A03: 0.5-2,000 Hz within 5 %), and the recorder's anti-alias filter sits near
there for the sample rates used in machining tests. The model: a 2nd-order Butterworth
low-pass at ``bandwidth_hz`` (default 2 kHz) applied to the simulated tool-tip z acceleration
over the record window (taken as periodic: the periodic path's record is; the time path's is
the mid-cut steady state), then the same statistic as the raw metric (the mean over the
spindle periods of the largest |a| in each). The raw peak holds the response to the force
step at engagement up to the highest mode of the basis, which no accelerometer passes.

Roughness (:func:`scallop_roughness`): a stylus or white-light profiler across the feed marks
reports their PV and Rq. For the parabolic scallop of height h, PV = h and
Rq = 2 h / (3 sqrt 5) (the RMS about the mean of h (2 s)^2, |s| <= 1/2); both are reported at
the largest h inside the clear aperture (the arc's point nearest phi = 0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ufmt.machining.surface import DEFAULT_APERTURE_MARGIN, Surface
from ufmt.model.machine import Machine

#: Bandwidth [Hz] of the modelled accelerometer and recorder (module docstring).
DEFAULT_ACCELEROMETER_BANDWIDTH = 2000.0
#: Lateral resolution [m] of the modelled interferometer (module docstring).
DEFAULT_PIXEL = 0.5e-3
#: Scallops are seen as their mean where their spacing is below this share of a pixel.
SCALLOP_UNRESOLVED_SHARE = 0.5


@dataclass(frozen=True)
class Interferometer:
    """A full-aperture flatness interferometer: lateral resolution ``pixel`` [m] and clear
    aperture edge exclusion ``aperture_margin`` [m]; piston and tilt are always removed."""

    pixel: float = DEFAULT_PIXEL
    aperture_margin: float = DEFAULT_APERTURE_MARGIN

    def __post_init__(self):
        for name in ("pixel", "aperture_margin"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0 and (name != "pixel" or value > 0)):
                raise ValueError(f"interferometer {name} must be a finite length [m], got {value}")

    def resolves_scallops(self, feed_per_rev: float) -> bool:
        """True if scallops ``feed_per_rev`` [m] apart are resolved (spacing >= half a pixel)."""
        return feed_per_rev >= SCALLOP_UNRESOLVED_SHARE * self.pixel


def scallop_height(x: np.ndarray, machine: Machine, feed_per_rev: float) -> np.ndarray:
    """Scallop height h(x) = (v/f)^2 cos^2(phi) / (8 r_n) [m] along the plate's x [m], phi the
    leading arc's angle over x (eq. 4.1)."""
    s = machine.sense * (np.asarray(x, dtype=float) - machine.offset_x) / machine.tool_radius
    cos2 = 1.0 - np.clip(s, -1.0, 1.0) ** 2
    return feed_per_rev**2 * cos2 / (8.0 * machine.nose_radius)


def _aperture_masks(surface: Surface, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """Column (Nx,) and row (Ny,) masks of the clear aperture."""
    x, y = surface.x, surface.y
    half_x = (x[-1] - x[0]) / 2 - margin
    half_y = (y[-1] - y[0]) / 2 - margin
    if half_x <= 0 or half_y <= 0:
        raise ValueError(f"aperture_margin {margin!r} m leaves no clear aperture")
    cx, cy = (x[-1] + x[0]) / 2, (y[-1] + y[0]) / 2
    return np.abs(x - cx) <= half_x + 1e-12, np.abs(y - cy) <= half_y + 1e-12


def plane_removed(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """z (Ny, Nx) [m] less its least-squares plane, each row weighted by the length of plate
    it stands for (half the gaps to its neighbours): the camera's pixels are equal, and the
    refined rows along the entry and exit edges (finer than the evenly spaced ones) count
    for their own strip, not for a whole grid step."""
    edges = np.concatenate([y[:1], (y[1:] + y[:-1]) / 2, y[-1:]])
    root = np.sqrt(np.diff(edges))[:, None]
    yy, xx = np.meshgrid(y, x, indexing="ij")
    design = np.stack([np.ones_like(xx), xx, yy], axis=-1) * root[..., None]
    coef, *_ = np.linalg.lstsq(design.reshape(-1, 3), (z * root).ravel(), rcond=None)
    return z - (coef[0] + coef[1] * x[None, :] + coef[2] * y[:, None])


def interferometer_surface(
    smooth: Surface,
    machine: Machine,
    feed_per_rev: float,
    *,
    scallops: Surface | None = None,
    instrument: Interferometer = Interferometer(),
) -> Surface:
    """The surface as the interferometer sees it: ``smooth`` (every switched-on source but the
    feed marks) with the feed marks' mean h(x) / 3 where it does not resolve them, else
    ``scallops`` (the surface with the feed marks); ``smooth`` where the feed marks are off
    (``scallops`` None). feed_per_rev [m]."""
    if scallops is None:
        return smooth
    if instrument.resolves_scallops(feed_per_rev):
        return scallops
    mean = scallop_height(smooth.x, machine, feed_per_rev)[None, :] / 3.0
    return Surface(smooth.x, smooth.y, smooth.z + mean, smooth.core)


def interferometer_metrics(
    smooth: Surface,
    machine: Machine,
    feed_per_rev: float,
    *,
    scallops: Surface | None = None,
    instrument: Interferometer = Interferometer(),
) -> dict[str, float]:
    """Flatness as the interferometer reports it [nm]: ``pv_measured_nm``, ``rms_measured_nm``.

    smooth: the surface of every switched-on source but the feed marks; scallops: the surface
    with the feed marks too (None where the feed marks are switched off). feed_per_rev [m].
    """
    in_x, in_y = _aperture_masks(smooth, instrument.aperture_margin)
    seen = interferometer_surface(
        smooth, machine, feed_per_rev, scallops=scallops, instrument=instrument
    )
    x, y = smooth.x[in_x], smooth.y[in_y]
    flat = plane_removed(x, y, seen.z[np.ix_(in_y, in_x)])
    core = flat[smooth.core_rows[in_y]]
    return {
        "pv_measured_nm": float(flat.max() - flat.min()) * 1e9,
        "rms_measured_nm": float(np.sqrt(np.mean(core**2))) * 1e9,
    }


def scallop_roughness(
    machine: Machine, feed_per_rev: float, aperture_margin: float = DEFAULT_APERTURE_MARGIN
) -> dict[str, float]:
    """Feed-mark roughness [nm] at the largest scallop inside the clear aperture:
    ``roughness_pv_nm`` (h) and ``roughness_rq_nm`` (2 h / (3 sqrt 5))."""
    half = machine.workpiece_size[0] / 2 - aperture_margin
    if half <= 0:
        raise ValueError(f"aperture_margin {aperture_margin!r} m leaves no clear aperture")
    # |x - s_x| is smallest at the spindle axis if it lies over the aperture, else at its edge
    x = float(np.clip(machine.offset_x, -half, half))
    h = float(scallop_height(np.array([x]), machine, feed_per_rev)[0])
    return {"roughness_pv_nm": h * 1e9, "roughness_rq_nm": 2.0 * h / (3.0 * math.sqrt(5.0)) * 1e9}


@dataclass(frozen=True)
class Accelerometer:
    """An accelerometer with recorder: a 2nd-order Butterworth low-pass at ``bandwidth_hz``."""

    bandwidth_hz: float = DEFAULT_ACCELEROMETER_BANDWIDTH

    def __post_init__(self):
        if not (math.isfinite(self.bandwidth_hz) and self.bandwidth_hz > 0):
            raise ValueError(f"accelerometer bandwidth_hz must be > 0, got {self.bandwidth_hz}")

    def gain(self, frequency_hz: np.ndarray) -> np.ndarray:
        """Complex frequency response H(f) = 1 / (s^2 + sqrt(2) s + 1), s = i f / f_c."""
        s = 1j * np.asarray(frequency_hz, dtype=float) / self.bandwidth_hz
        return 1.0 / (s * s + math.sqrt(2.0) * s + 1.0)


def accelerometer_peak(
    signal: np.ndarray, dt: float, periods: int, instrument: Accelerometer = Accelerometer()
) -> float:
    """Mean over the ``periods`` spindle periods of the largest |a| of ``signal`` (T,) [its
    unit], sampled every ``dt`` [s], as the accelerometer reports it (record taken as
    periodic)."""
    spectrum = np.fft.rfft(signal)
    filtered = np.fft.irfft(
        spectrum * instrument.gain(np.fft.rfftfreq(signal.size, dt)), signal.size
    )
    return float(np.abs(filtered).reshape(periods, -1).max(axis=1).mean())
