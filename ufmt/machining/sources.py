"""Error sources of the machined surface: each a switchable term with its closed form.

The surface height is the relative tool-workpiece z position of the pass that cuts deepest
(eq. 4.1 with tool interference, :mod:`ufmt.machining.surface`). Five sources move it; the
physics, literature magnitudes and defaults are in docs/ufmt-model.md ('Error sources'):

dynamic        cutting-force vibration z_re(phi, Y) (paper eqs. 3.9-3.13, the modal response
               plus its static correction).
feed_marks     tool-nose scallops: between two passes a normal distance d apart the round
               nose of radius r_n leaves d^2 / (8 r_n); d = (v/f) cos(phi) on the fly-cutting
               arc, so the scallop is (v/f)^2 cos^2(phi) / (8 r_n) (on by default).
spindle_tilt   spindle axis tilted by beta against the feed (about x): the tip circle is tilted
               and the tip height along the arc is beta R cos(phi), a sag
               -beta R (1 - cos phi) against the middle of the plate (beta > 0: middle high).
error_motion   once-per-revolution axial error motion of the head at the tool radius,
               e cos(phi - phi_0) (unbalance, air-film tilt synchronous with rotation: a
               synchronous tilt error gamma gives the same term with e = gamma R).
straightness   slide straightness in z along the feed: the workpiece rides s sin(2 pi Y / L)
               high, so the tool cuts -s sin(2 pi Y / L) relative to it (Y the slide position
               of the pass, 0 halfway).

Each geometric term (the last three) is a function of the spindle angle and the slide position
of the pass, added to z_re before the minimum over passes; all are linear in their amplitude.
"""

from __future__ import annotations

import numpy as np

from ufmt.errors import ModelError, closest_name
from ufmt.model.machine import Machine

SOURCES = ("dynamic", "feed_marks", "spindle_tilt", "error_motion", "straightness")
#: Sources that move the tool relative to the workpiece by a closed form in (phi, Y).
GEOMETRIC = ("spindle_tilt", "error_motion", "straightness")


def check_sources(sources) -> tuple[str, ...]:
    """The source names as a tuple in :data:`SOURCES` order; an unknown name is a ModelError."""
    if isinstance(sources, str):
        sources = (sources,)
    sources = tuple(sources)
    for name in sources:
        if name not in SOURCES:
            near = closest_name(name, SOURCES)
            hint = f" (did you mean '{near}'?)" if near else ""
            raise ModelError(
                f"sources: {name!r} is not an error source{hint}; choose from {', '.join(SOURCES)}"
            )
    return tuple(s for s in SOURCES if s in sources)


def spindle_tilt_z(phi, machine: Machine) -> np.ndarray:
    """Tool height from the spindle tilt, -beta R (1 - cos phi) [m]."""
    phi = np.asarray(phi, dtype=float)
    return -machine.spindle_tilt_rad * machine.tool_radius * (1.0 - np.cos(phi))


def error_motion_z(phi, machine: Machine) -> np.ndarray:
    """Tool height from the once-per-revolution axial error motion, e cos(phi - phi_0) [m]."""
    phi = np.asarray(phi, dtype=float)
    return machine.error_motion_m * np.cos(phi - np.radians(machine.error_motion_phase_deg))


def straightness_z(slide_y, machine: Machine) -> np.ndarray:
    """Tool height relative to the workpiece from the slide's straightness [m]."""
    y = np.asarray(slide_y, dtype=float)
    return -machine.straightness_m * np.sin(2 * np.pi * y / machine.straightness_wavelength_m)


def is_active(source: str, machine: Machine) -> bool:
    """False where a geometric source has zero amplitude on this machine (its term is 0)."""
    amplitude = {
        "spindle_tilt": machine.spindle_tilt_rad,
        "error_motion": machine.error_motion_m,
        "straightness": machine.straightness_m,
    }
    return amplitude.get(source, 1.0) != 0.0


def geometric_z(machine: Machine, sources):
    """z(phi, slide_y) [m] of the geometric sources among ``sources``, or None if none acts."""
    active = [s for s in sources if s in GEOMETRIC and is_active(s, machine)]
    if not active:
        return None

    def z(phi, slide_y):
        total = 0.0
        if "spindle_tilt" in active:
            total = total + spindle_tilt_z(phi, machine)
        if "error_motion" in active:
            total = total + error_motion_z(phi, machine)
        if "straightness" in active:
            total = total + straightness_z(slide_y, machine)
        return total

    return z
