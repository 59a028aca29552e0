"""The validity domain of the surface model: the cuts whose computed surface means something.

Outside it the numbers still come out (a PV of 14,000 nm at a 4 um cut, 4e21 nm at 1e-9
rpm) but describe no machined surface, so :func:`ufmt.simulate` refuses them with
:class:`OutsideDomainError` naming the limit and the values; a study records such a point as
``invalid`` (never ``ok``) and leaves it out of its optima and fits.

The limits and their physics (r_n nose radius, a_p depth of cut, s = v/f feed per revolution):

* **Nose engagement** a_p <= r_n: the chip-area force model (paper eq. 4.1 with the nose's
  circular arc) holds while only the round nose cuts; deeper, the straight flanks cut and
  the force grows without bound in the model (1e9 um gave 5.5e8 N).
* **Overlapping passes** s <= w(a_p) = 2 sqrt(2 r_n a_p - a_p^2): w is the width of the
  groove the nose cuts at depth a_p (the chord of the nose circle a_p below its lowest
  point). With s above it neighbouring passes do not overlap, the scallop (height
  s^2 / (8 r_n)) would be deeper than the cut and ridges of the original surface remain
  between the passes: the machined-surface model (the lower envelope of the passes) no longer
  describes the part.
* **Tool in contact** max |z_re| < a_p: the surface model has the tool remove material over
  its whole engagement, driven by the force of the nominal chip. A relative vibration z_re
  (tool minus workpiece along the depth) as large as the depth of cut would lift the tool out
  of the cut (no chip, no force) or double the chip, neither of which the linear response
  nor the lower envelope of the passes describes. Checked on the response's record window
  (mid-cut, every force part and the static correction included); either sign counts. Cheap
  (one max over the window), so it is checked after the response, before the surface.
* **Sampling** n_phi <= MAX_SAMPLES_PER_REV: the response is sampled at n_phi points per
  revolution so that the basis' highest mode is resolved
  (:func:`ufmt.machining.cut_geometry.samples_per_rev`); a spindle so slow that this needs
  more samples is outside the discretisation's range (its memory grows with n_phi).
* **Revolutions** of the whole cut (slide travel over the feed per revolution) at most
  MAX_CUT_REVOLUTIONS: the time of the record window (mid-cut) is n_rev / f, and with its
  sampling step 1 / (n_phi f) it must stay far inside a float64's resolution (a feed of
  1e-9 mm/min put 1e14 revolutions before the window and made the step 0); the time path's
  work grows with it too. Table 1's slowest feed per revolution (4 mm/min at 400 rpm) needs
  ~6.5e4 revolutions on the packaged machine.
* **Surface grid**: each workpiece side holds at least MIN_GRID_STEPS grid steps and the
  whole grid at most MAX_GRID_NODES nodes; the clear aperture (the plate less the margin at
  each edge) is not empty; a PSD2 patch fits on the plate.
* **Line profiles** of the PSD bands (:mod:`ufmt.machining.lines`): a step > 0 and at most
  MAX_LINE_POINTS points on the grid's columns and rows together (the 410 mm plate at
  0.03 mm needs ~1e7).
* **Bodies**: the tool and the workpiece are two different bodies, each with mode shapes
  (a real body, not a virtual one).

Positive finite process numbers are :class:`~ufmt.machining.process.Process`'s own check.
"""

from __future__ import annotations

import math

import numpy as np

from ufmt.errors import ProcessError
from ufmt.machining.process import Process
from ufmt.model.machine import Machine

MAX_SAMPLES_PER_REV = 2**16  # [-] response samples per revolution (the CLI's --samples-per-rev)
MAX_CUT_REVOLUTIONS = 2**24  # [-] revolutions of one cut (time resolution of the window)
MIN_GRID_STEPS = 2  # [-] grid steps along each workpiece side (three nodes)
MAX_GRID_NODES = 2**22  # [-] nodes of a surface grid (~4e6: 32 MB per float array)
MAX_LINE_POINTS = 2**25  # [-] points of the PSD line profiles (~3.4e7: 270 MB of heights)


class OutsideDomainError(ProcessError):
    """A cut outside the surface model's validity domain; the message names the limit and
    the values. :func:`ufmt.evaluate` raises it; a study records the point as invalid."""


def check_case(
    process: Process,
    machine: Machine,
    spacing,
    aperture_margin: float,
    psd2_patch=None,
    line_spacing=None,
) -> None:
    """Every limit that needs no modal basis (module doc): checked before any allocation."""
    check_cut(process, machine)
    check_revolutions(process, machine)
    check_bodies(machine)
    check_surface(machine, spacing, aperture_margin, psd2_patch)
    check_lines(machine, spacing, line_spacing)


def cut_width(nose_radius: float, depth: float) -> float:
    """Width [m] of the groove a nose of radius ``nose_radius`` [m] cuts at ``depth`` [m]:
    2 sqrt(2 r_n a_p - a_p^2) (for a_p <= r_n)."""
    return 2.0 * math.sqrt(max(2.0 * nose_radius * depth - depth**2, 0.0))


def check_cut(process: Process, machine: Machine) -> None:
    """Nose engagement and overlapping passes (module doc)."""
    r_n, a_p, s = machine.nose_radius, process.depth_m, process.feed_per_rev_m
    if a_p > r_n:
        raise OutsideDomainError(
            f"process: depth of cut {process.depth_um:g} um exceeds the nose radius"
            f" {r_n * 1e6:g} um (only the nose may cut: depth <= nose radius)"
        )
    width = cut_width(r_n, a_p)
    if s > width:
        raise OutsideDomainError(
            f"process: feed per revolution {s * 1e6:.4g} um ({process.feed_mm_min:g} mm/min at"
            f" {process.rpm:g} rpm) exceeds the width {width * 1e6:.4g} um the nose cuts at"
            f" {process.depth_um:g} um depth (scallop deeper than the cut; limit:"
            " feed/rev <= 2 sqrt(2 r_n a_p - a_p^2))"
        )


def check_revolutions(process: Process, machine: Machine) -> None:
    """At most MAX_CUT_REVOLUTIONS revolutions in the cut (module doc)."""
    y0, y1 = machine.cut_span
    revolutions = (y1 - y0) / process.feed_per_rev_m
    if not revolutions <= MAX_CUT_REVOLUTIONS:
        raise OutsideDomainError(
            f"process: {process.feed_mm_min:g} mm/min at {process.rpm:g} rpm needs"
            f" {revolutions:.3g} revolutions to cross the {(y1 - y0) * 1e3:g} mm cut; at most"
            f" {MAX_CUT_REVOLUTIONS:,} (feed per revolution >="
            f" {(y1 - y0) / MAX_CUT_REVOLUTIONS * 1e9:.3g} nm)"
        )


def check_contact(z_re: np.ndarray, process: Process) -> None:
    """Tool in contact (module doc): the largest |z_re| [m] of the record window stays below
    the depth of cut."""
    peak = float(np.max(np.abs(z_re)))
    if peak >= process.depth_m:
        raise OutsideDomainError(
            f"process: the relative vibration z_re reaches {peak * 1e9:.4g} nm, not less than"
            f" the depth of cut {process.depth_m * 1e9:.4g} nm: the tool would leave the cut"
            " (limit: max |z_re| < depth of cut)"
        )


def check_bodies(machine: Machine, bodies_with_shapes=None) -> None:
    """The tool and the workpiece are two bodies and, once the basis is known (the names of
    ``bodies_with_shapes``), each has mode shapes (module doc)."""
    if machine.tool_body == machine.workpiece_body:
        raise OutsideDomainError(
            f"machine: tool_body and workpiece_body are the same body {machine.tool_body!r};"
            " the tool must cut another body"
        )
    fields = (("tool_body", machine.tool_body), ("workpiece_body", machine.workpiece_body))
    for field, body in fields if bodies_with_shapes is not None else ():
        if body not in bodies_with_shapes:
            raise OutsideDomainError(
                f"machine: field {field!r}: body {body!r} has no mode shapes (a virtual body"
                " or not in the model); name a rigid or beam body"
            )


def check_sampling(n_phi: int, process: Process, highest_hz: float) -> None:
    """At most MAX_SAMPLES_PER_REV samples per revolution (module doc)."""
    if n_phi > MAX_SAMPLES_PER_REV:
        raise OutsideDomainError(
            f"process: {process.rpm:g} rpm needs {n_phi} samples per revolution to resolve the"
            f" basis' highest mode ({highest_hz:.4g} Hz); at most {MAX_SAMPLES_PER_REV}: raise"
            " the spindle speed or lower the basis cutoff"
        )


def check_surface(
    machine: Machine, spacing, aperture_margin: float, psd2_patch: float | None = None
) -> None:
    """The surface grid, the clear aperture and the PSD2 patch (module doc)."""
    hx, hy = np.broadcast_to(np.asarray(spacing, dtype=float), (2,))
    lx, ly = machine.workpiece_size
    for side, length, step in (("x", lx, hx), ("y", ly, hy)):
        if not length >= MIN_GRID_STEPS * step:
            raise OutsideDomainError(
                f"machine: workpiece_size {side} = {length:g} m holds fewer than"
                f" {MIN_GRID_STEPS} grid steps of {step:g} m"
            )
    nodes = (lx / hx + 1) * (ly / hy + 1)
    if nodes > MAX_GRID_NODES:
        raise OutsideDomainError(
            f"machine: workpiece_size [{lx:g}, {ly:g}] m at a grid step of [{hx:g}, {hy:g}] m"
            f" needs {nodes:.3g} surface nodes; at most {MAX_GRID_NODES:,}"
        )
    if not 2 * aperture_margin < min(lx, ly):
        raise OutsideDomainError(
            f"aperture margin {aperture_margin * 1e3:g} mm at each edge leaves no clear aperture"
            f" on the {lx * 1e3:g} x {ly * 1e3:g} mm workpiece (below {min(lx, ly) * 500:g} mm)"
        )
    if psd2_patch is not None and not psd2_patch <= min(lx, ly):
        raise OutsideDomainError(
            f"PSD2 patch {psd2_patch * 1e3:g} mm does not fit on the {lx * 1e3:g} x"
            f" {ly * 1e3:g} mm workpiece (at most {min(lx, ly) * 1e3:g} mm)"
        )


def check_lines(machine: Machine, spacing, line_spacing: float | None) -> None:
    """The PSD line profiles' step and size (module doc); None: no line profiles."""
    if line_spacing is None:
        return
    if not (math.isfinite(line_spacing) and line_spacing > 0):
        raise OutsideDomainError(
            f"line_spacing: {line_spacing!r} m is not a step > 0 (e.g. 3e-05, the default)"
        )
    hx, hy = np.broadcast_to(np.asarray(spacing, dtype=float), (2,))
    lx, ly = machine.workpiece_size
    points = (lx / hx + 1) * (ly / line_spacing + 1) + (ly / hy + 1) * (lx / line_spacing + 1)
    if points > MAX_LINE_POINTS:
        raise OutsideDomainError(
            f"machine: workpiece_size [{lx:g}, {ly:g}] m at a line spacing of {line_spacing:g} m"
            f" needs {points:.3g} line-profile points; at most {MAX_LINE_POINTS:,} (a coarser"
            " line spacing)"
        )
