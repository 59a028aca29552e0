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

Accelerometer chain (:class:`AccelerometerChain`, :func:`accelerometer_peak`): the paper's
Fig. 12 signal comes from a 1.000 V/g accelerometer "pasted under the tool carrier" and a Dong
Hua DH5916 dynamic signal recorder rotating with the head; it reports "the average peak value in
a period" (section 4.2). The chain, each stage a documented device model:

* Sensor: a seismic piezoelectric (IEPE) accelerometer is a 2nd-order mass-spring system; its
  output follows the acceleration times H_s(f) = 1 / (1 - r^2 + 2 i zeta r), r = f / f_n, f_n
  the mounted resonance ``resonance_hz`` (default 10 kHz, band 3-30 kHz) and zeta its damping
  ``damping_ratio`` (default 0.03, band 0.005-0.1). 1 V/g seismic sensors (e.g. PCB 393A03
  datasheet: 1000 mV/g, 0.5-2,000 Hz within 5 %, mounted resonance >= 10 kHz on a stud) are
  specified to a fifth of their resonance, where |H_s| = 1.04; adhesive mounting lowers the
  resonance (a few kHz for a thick glue layer, Serridge and Licht, Brüel & Kjær's
  "Piezoelectric accelerometers and vibration preamplifiers", mounting chapter). Piezoelectric
  sensors are lightly damped (resonance gains of 20-40 dB, same source: zeta 0.005-0.05). The
  IEPE high-pass (0.5 Hz) is left out: the record's mean acceleration is zero and the spindle
  runs at >= 1.7 Hz.
* Recorder anti-alias filter: the DH5916's filter is not documented in any source available
  here; the chain takes the generic anti-alias filter of dynamic signal analysers, an
  ``ANTI_ALIAS_ORDER`` (8th) order Butterworth low-pass at the sampling rate over 2.56 (the
  2.56 ratio of analysis bandwidth to sampling rate of FFT analysers and recorders), applied
  to the continuous signal before sampling.
* Recorder sampling at ``sampling_hz`` (default 10 kHz, band 5-20 kHz: the per-channel rates
  set for machining vibration on such recorders; the paper gives none). The recorder's clock
  runs free of the spindle, so each period is sampled at its own phase: the reported statistic
  is the mean over the record's spindle periods of the largest |a| among each period's
  samples, averaged over ``SAMPLING_PHASES`` evenly spaced sampling phases (the expectation
  over a free-running clock). Sampling lowers a peak: a sine sampled m times per cycle reports
  on average sin(pi / m) / (pi / m) of its amplitude (m even).

The record (the simulated acceleration, sampled every dt) is taken as periodic over its window
(the periodic path's record is; the time path's is the mid-cut steady state); the chain's
output is evaluated at the recorder's instants by trigonometric interpolation of the filtered
record (exact for the record's own harmonics), so the reported value converges with the
simulation's sampling like the record itself. Components above 8 times the sampling rate are
dropped where the recorder's instants are coarser than the record's (the filter has taken them
below 1e-10 of their size).

Roughness (:func:`scallop_roughness`): a stylus or white-light profiler across the feed marks
reports their PV and Rq. For the parabolic scallop of height h, PV = h and
Rq = 2 h / (3 sqrt 5) (the RMS about the mean of h (2 s)^2, |s| <= 1/2); both are reported at
the largest h inside the clear aperture (the arc's point nearest phi = 0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ufmt.machining.surface import DEFAULT_APERTURE_MARGIN, Surface, clear_aperture
from ufmt.model.machine import Machine

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
    """Column (Nx,) and row (Ny,) masks of the clear aperture (:func:`clear_aperture`)."""
    return clear_aperture(surface.x, margin), clear_aperture(surface.y, margin)


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


#: Anti-alias filter of the recorder: Butterworth order and cut-off as a share of the
#: sampling rate (module docstring).
ANTI_ALIAS_ORDER = 8
ANTI_ALIAS_SHARE = 1.0 / 2.56
#: Sampling phases of the free-running recorder clock averaged by :func:`accelerometer_peak`.
SAMPLING_PHASES = 16


@dataclass(frozen=True)
class AccelerometerChain:
    """The paper's accelerometer chain (module docstring): a seismic sensor of mounted
    resonance ``resonance_hz`` [Hz] and damping ratio ``damping_ratio`` [-], the recorder's
    anti-alias filter and its sampling at ``sampling_hz`` [Hz]."""

    resonance_hz: float = 10e3
    damping_ratio: float = 0.03
    sampling_hz: float = 10e3

    def __post_init__(self):
        for name in ("resonance_hz", "damping_ratio", "sampling_hz"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"accelerometer chain {name} must be > 0, got {value!r}")

    @classmethod
    def of(cls, machine: Machine) -> AccelerometerChain:
        """The chain of a machine's ``accelerometer_*`` and ``recorder_*`` keys."""
        return cls(
            machine.accelerometer_resonance_hz,
            machine.accelerometer_damping_ratio,
            machine.recorder_sampling_hz,
        )

    @property
    def cutoff_hz(self) -> float:
        """Cut-off [Hz] of the anti-alias filter (-3 dB)."""
        return self.sampling_hz * ANTI_ALIAS_SHARE

    def sensor_gain(self, frequency_hz) -> np.ndarray:
        """Sensor H_s(f) = 1 / (1 - r^2 + 2 i zeta r), r = f / f_n (SDOF base excitation)."""
        r = np.asarray(frequency_hz, dtype=float) / self.resonance_hz
        return 1.0 / (1.0 - r * r + 2j * self.damping_ratio * r)

    def anti_alias_gain(self, frequency_hz) -> np.ndarray:
        """Butterworth low-pass prod_k -p_k / (i f / f_c - p_k), p_k its poles on the unit
        circle's left half (order ANTI_ALIAS_ORDER)."""
        n = ANTI_ALIAS_ORDER
        poles = np.exp(1j * np.pi * (2 * np.arange(1, n + 1) + n - 1) / (2 * n))
        s = 1j * np.asarray(frequency_hz, dtype=float)[..., None] / self.cutoff_hz
        return np.prod(-poles / (s - poles), axis=-1)

    def gain(self, frequency_hz) -> np.ndarray:
        """Complex response of the analogue chain (sensor, then anti-alias filter)."""
        return self.sensor_gain(frequency_hz) * self.anti_alias_gain(frequency_hz)


def accelerometer_peak(
    t: np.ndarray, acc: np.ndarray, periods: int, chain: AccelerometerChain = AccelerometerChain()
) -> float:
    """The average peak per period [unit of ``acc``] the recorder reports of the acceleration
    ``acc`` (T,) at the even times ``t`` (T,) [s] over ``periods`` spindle periods (record taken
    as periodic; module docstring).

    The recorder's rate is rounded to a whole number S of samples per period (a change of at
    most 1 / (2 S) of it); each period's largest |a| over its S samples is averaged over the
    periods and over SAMPLING_PHASES sampling phases.
    """
    acc = np.asarray(acc, dtype=float)
    dt = float(t[1] - t[0])
    period = acc.size * dt / periods
    per_period = max(1, round(chain.sampling_hz * period))
    size = periods * per_period * SAMPLING_PHASES
    spectrum = np.fft.rfft(acc) * chain.gain(np.fft.rfftfreq(acc.size, dt))
    kept = min(spectrum.size, size // 2 + 1)
    resampled = np.zeros(size // 2 + 1, complex)
    resampled[:kept] = spectrum[:kept]
    if kept == size // 2 + 1 and size % 2 == 0:
        resampled[-1] = resampled[-1].real  # the new Nyquist bin of a real signal
    elif kept < size // 2 + 1 and acc.size % 2 == 0:
        resampled[kept - 1] /= 2  # the record's Nyquist bin splits into +- that frequency
    at_instants = np.fft.irfft(resampled, size) * (size / acc.size)
    peaks = np.abs(at_instants).reshape(periods, per_period, SAMPLING_PHASES).max(axis=1)
    return float(peaks.mean())
