"""The carriage's heave and pitch on its guideway's straightness, carried by its air pads.

The carriage rides on two lines of vertical air pads (front and rear), ``carriage_pad_span_m``
S apart along y and each ``carriage_pad_length_m`` l long, centred ``carriage_pad_offset_m``
from the workpiece's centre. An air film of uniform stiffness per unit length puts the rigid
carriage where its elastic energy sum k (z_c(y) - z_g(y))^2 over the pads' contact is least:
the carriage's line z_c(y) = h + theta (y - c) is the least-squares line through the guideway
profile z_g over the two pads (c their centre):

    h = (M_+ + M_-) / 2,   theta = sum_j (d_j M_j + F_j) / (2 (S^2/4 + l^2/12)),

with M_j = (1/l) int z_g and F_j = (1/l) int u z_g over pad j (u from its centre, d_j = +-S/2).
Wavelengths shorter than a pad average out (sinc), and the two pad lines filter the rest: a
sine a sin(k s + psi) of wavelength L gives

    h = a sin(k c + psi) cos(pi S / L) sinc(l / L),

zero at S = (2 n + 1) L / 2 (and l = n L); with l = 0 (points) theta = (z_g(c + S/2) -
z_g(c - S/2)) / S, zero at S = n L. A straight but inclined profile z_g = g s moves the
carriage along that line: heave g c, pitch g.

Straightness is the deviation from a reference straight line (ISO 230-1): the least-squares
line of z_g over the guideway the pads touch during the cut (``Machine.guideway_span``) is
removed first. The spindle is aligned against the slide's actual travel (``spindle_tilt_rad``
is the tilt against it), so an inclined but straight guideway leaves no mark; without the
removal it would act as a spindle tilt of its slope (the plate tilts with the carriage while
the tool's circle does not).

Slide position Y (0 halfway, :mod:`ufmt.machining.cutting`): the carriage sits at -Y from the
file's position, so the pads' centre is at the machine-frame y c(Y) = y_s + offset - Y (y_s the
spindle axis's y, where the workpiece centre is halfway). The workpiece point cut at (phi, Y)
has the material y = Y + R cos(phi) on the plate; its lever arm from the pads' centre along y
is that y minus the offset (the Abbe offset), so the point sits h + theta (Y + R cos(phi) -
offset) high.

The guideway: a measured profile (``straightness_profile``, :mod:`ufmt.model.guideway`) or one
harmonic z_g(s) = a sin(2 pi (s - c(0)) / L + psi) (``straightness_m`` a,
``straightness_wavelength_m`` L, ``straightness_phase_deg`` psi: the phase at the pads' centre
halfway through the cut, so that a rigid translation of the model changes nothing).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ufmt.model.machine import Machine


def pad_centre(slide_y, machine: Machine) -> np.ndarray:
    """y [m] (machine frame) of the pads' centre c(Y) at slide positions ``slide_y`` [m]."""
    y = np.asarray(slide_y, dtype=float)
    return machine.spindle_axis_xy[1] + machine.carriage_pad_offset_m - y


def _harmonic_integrals(s, machine: Machine):
    """(int z_g, int (s - c(0)) z_g) of the harmonic guideway from c(0) to ``s`` [m]."""
    a, k = machine.straightness_m, 2 * np.pi / machine.straightness_wavelength_m
    psi = np.radians(machine.straightness_phase_deg)
    t = np.asarray(s, dtype=float) - pad_centre(0.0, machine)
    first = -a * np.cos(k * t + psi) / k + a * np.cos(psi) / k
    second = a * (-t * np.cos(k * t + psi) / k + np.sin(k * t + psi) / k**2 - np.sin(psi) / k**2)
    return first, second


@lru_cache(maxsize=64)
def reference_line(machine: Machine) -> tuple[float, float, float]:
    """(m, z_m, beta): the least-squares line z_m + beta (s - m) [m] of the guideway over
    ``Machine.guideway_span``, m its middle [m]."""
    lo, hi = machine.guideway_span
    mid, width = (lo + hi) / 2, hi - lo
    if machine.straightness_profile is not None:
        (a0, a1), (b0, b1) = (machine.straightness_profile.integrals(v) for v in (lo, hi))
        zero, first = b0 - a0, (b1 - a1) - mid * (b0 - a0)
    else:
        (a0, a1), (b0, b1) = (_harmonic_integrals(v, machine) for v in (lo, hi))
        shift = mid - pad_centre(0.0, machine)
        zero, first = b0 - a0, (b1 - a1) - shift * (b0 - a0)
    return mid, float(zero / width), float(first / (width**3 / 12))


def _harmonic_pads(centre, machine: Machine, d: float):
    """(M, F) of the harmonic guideway over the pad centred at ``centre`` + ``d`` [m]."""
    a, wavelength, l = (
        machine.straightness_m,
        machine.straightness_wavelength_m,
        machine.carriage_pad_length_m,
    )
    k = 2 * np.pi / wavelength
    angle = k * (centre + d - pad_centre(0.0, machine)) + np.radians(machine.straightness_phase_deg)
    mean = a * np.sin(angle) * np.sinc(l / wavelength)
    if l == 0.0:
        return mean, 0.0
    half = k * l / 2
    # (1/l) int_{-l/2}^{l/2} u sin(angle + k u) du = cos(angle) 2 (sin(h) - h cos(h)) / (k^2 l)
    first = a * np.cos(angle) * 2 * (np.sin(half) - half * np.cos(half)) / (k * k * l)
    return mean, first


def _profile_pads(centre, machine: Machine, d: float):
    """(M, F) of the measured profile over the pad centred at ``centre`` + ``d`` [m]."""
    profile, l = machine.straightness_profile, machine.carriage_pad_length_m
    mid = centre + d
    if l == 0.0:
        return profile.at(mid), 0.0
    lo0, lo1 = profile.integrals(mid - l / 2)
    hi0, hi1 = profile.integrals(mid + l / 2)
    zero, first = hi0 - lo0, hi1 - lo1  # int z_g, int s z_g over the pad
    return zero / l, (first - mid * zero) / l


def carriage_pose(slide_y, machine: Machine) -> tuple[np.ndarray, np.ndarray]:
    """Heave h [m] and pitch theta [rad] (z rising along +y) of the carriage at slide
    positions ``slide_y`` [m], from the guideway under its pads, against the reference line
    (:func:`reference_line`)."""
    centre = pad_centre(slide_y, machine)
    pads = _profile_pads if machine.straightness_profile is not None else _harmonic_pads
    span, l = machine.carriage_pad_span_m, machine.carriage_pad_length_m
    rear_m, rear_f = pads(centre, machine, -span / 2)
    front_m, front_f = pads(centre, machine, span / 2)
    heave = (front_m + rear_m) / 2
    pitch = (span / 2 * (front_m - rear_m) + front_f + rear_f) / (2 * (span**2 / 4 + l**2 / 12))
    mid, z_mid, slope = reference_line(machine)
    return heave - z_mid - slope * (centre - mid), pitch - slope


def workpiece_rise(phi, slide_y, machine: Machine) -> np.ndarray:
    """Height [m] of the workpiece point cut at (``phi`` [rad], ``slide_y`` [m]) above its
    place on a straight guideway: h + theta (Y + R cos(phi) - offset)."""
    heave, pitch = carriage_pose(slide_y, machine)
    arm = (
        np.asarray(slide_y, dtype=float)
        + machine.tool_radius * np.cos(phi)
        - machine.carriage_pad_offset_m
    )
    return heave + pitch * arm
