"""Error sources of the machined surface: each a switchable term with its closed form.

The surface height is the relative tool-workpiece z position of the pass that cuts deepest
(eq. 4.1 with tool interference, :mod:`ufmt.machining.surface`). These sources move it; the
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
pressure_ripple  fluctuation of the air supply pressure of the head's bearings: the head (and
               the tool) moves axially by a sin(2 pi f_p t), t the time of the pass since the
               first touch of the cut; not synchronous with the spindle or the slide, it prints
               waviness along the feed of wavelength v / f_p.
carriage_load  the carriage's own weight as it moves: the tool-workpiece deflection under
               gravity at the pass's slide position less that at the tramming position, from a
               static solve of the model (:mod:`ufmt.machining.carriage_load`; no parameter,
               always on; its profile is built once per model and passed to
               :meth:`ErrorSource.heights`).

Each geometric term (spindle_tilt to pressure_ripple) is a height function
z(phi, Y, machine, process) of the spindle angle and the slide position of the pass (the
process gives the feed speed, hence the time of the pass, t = (Y - Y_first_touch) / v),
added to z_re before the minimum over passes; all are linear in their amplitude, and a
source whose amplitude is zero on a machine is inactive there.

:data:`REGISTRY` holds one :class:`ErrorSource` per source, in the order of :data:`SOURCES`
(the order of every per-source output). Adding a geometric source is one registry entry and its
height function, plus its ``[machine]`` fields and bands in :mod:`ufmt.model.machine`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ufmt.errors import ModelError, closest_name
from ufmt.machining.carriage_load import carriage_load
from ufmt.machining.process import Process
from ufmt.model.machine import Machine

#: How a source enters the surface: the vibration response's z_re table, the tool nose's
#: scallop between passes, a height function z(phi, Y, machine) at each pass, or a height
#: z(phi, Y) the simulation builds once from the model (a profile, cached per model).
VIBRATION = "vibration"
SCALLOP = "scallop"
HEIGHT = "height"
MODEL = "model"


@dataclass(frozen=True)
class ErrorSource:
    """One error source of the surface.

    name: the source's name (``sources`` option, ``pv_by_source_nm`` key); enters: how it
    enters the surface (:data:`VIBRATION`, :data:`SCALLOP` or :data:`HEIGHT`); amplitude: the
    ``[machine]`` field of its amplitude (the source is inactive where it is zero; None: always
    active); parameters: the other ``[machine]`` fields it reads; height: for :data:`HEIGHT`,
    its tool height relative to the workpiece z(phi [rad], slide_y [m], machine, process) [m]
    (``process`` a :class:`~ufmt.machining.process.Process`: the feed speed and spindle speed
    that give the time of the pass); profile: for :data:`MODEL`, profile(model, machine) the
    height z(phi [rad], slide_y [m]) [m] (the simulation builds it once per model and passes
    it to :meth:`heights`).
    """

    name: str
    enters: str = HEIGHT
    amplitude: str | None = None
    parameters: tuple[str, ...] = ()
    height: Callable[[np.ndarray, np.ndarray, Machine, Process], np.ndarray] | None = None
    profile: Callable[[object, Machine], Callable] | None = None

    @property
    def fields(self) -> tuple[str, ...]:
        """The ``[machine]`` fields the source reads (amplitude first)."""
        return ((self.amplitude,) if self.amplitude else ()) + self.parameters

    def is_active(self, machine: Machine) -> bool:
        """False where the source's amplitude is zero on ``machine`` (its term is 0)."""
        return self.amplitude is None or getattr(machine, self.amplitude) != 0.0

    def heights(
        self, passes, table, machine: Machine, process: Process, profiles=None
    ) -> np.ndarray:
        """Heights [m] of the source at both passes over every grid point of ``passes`` (a
        :class:`~ufmt.machining.surface.Passes`); ``table`` the response's z_re table;
        ``profiles`` name -> the built profile of each :data:`MODEL` source."""
        if self.enters == MODEL:
            return passes.geometric(profiles[self.name])
        if self.enters == VIBRATION:
            return passes.dynamic(table, machine)
        if self.enters == SCALLOP:
            return passes.feed_marks(machine.nose_radius)
        return passes.geometric(geometric_z(machine, (self.name,), process))


def spindle_tilt_z(phi, slide_y, machine: Machine, process: Process) -> np.ndarray:
    """Tool height from the spindle tilt, -beta R (1 - cos phi) [m] (independent of Y)."""
    phi = np.asarray(phi, dtype=float)
    return -machine.spindle_tilt_rad * machine.tool_radius * (1.0 - np.cos(phi))


def error_motion_z(phi, slide_y, machine: Machine, process: Process) -> np.ndarray:
    """Tool height from the once-per-revolution axial error motion, e cos(phi - phi_0) [m]
    (independent of Y)."""
    phi = np.asarray(phi, dtype=float)
    return machine.error_motion_m * np.cos(phi - np.radians(machine.error_motion_phase_deg))


def straightness_z(phi, slide_y, machine: Machine, process: Process) -> np.ndarray:
    """Tool height relative to the workpiece from the slide's straightness [m] (independent
    of phi)."""
    y = np.asarray(slide_y, dtype=float)
    return -machine.straightness_m * np.sin(2 * np.pi * y / machine.straightness_wavelength_m)


def pass_time(slide_y, machine: Machine, process: Process) -> np.ndarray:
    """Time [s] of the pass at slide position ``slide_y`` [m] since the leading arc's first
    touch (``Machine.cut_span``): the slide moves at the feed speed v."""
    v = process.feed_mm_min / 60e3  # [m/s]
    return (np.asarray(slide_y, dtype=float) - machine.cut_span[0]) / v


def pressure_ripple_z(phi, slide_y, machine: Machine, process: Process) -> np.ndarray:
    """Tool height from the supply-pressure ripple of the head's bearings,
    a sin(2 pi f_p t) [m] at the time t of the pass (:func:`pass_time`; independent of phi
    but through the pass's slide position)."""
    t = pass_time(slide_y, machine, process)
    return machine.pressure_ripple_m * np.sin(2 * np.pi * machine.pressure_ripple_hz * t)


REGISTRY = (
    ErrorSource("dynamic", enters=VIBRATION),
    ErrorSource("feed_marks", enters=SCALLOP, parameters=("nose_radius",)),
    ErrorSource("spindle_tilt", amplitude="spindle_tilt_rad", height=spindle_tilt_z),
    ErrorSource(
        "error_motion",
        amplitude="error_motion_m",
        parameters=("error_motion_phase_deg",),
        height=error_motion_z,
    ),
    ErrorSource(
        "straightness",
        amplitude="straightness_m",
        parameters=("straightness_wavelength_m",),
        height=straightness_z,
    ),
    ErrorSource(
        "pressure_ripple",
        amplitude="pressure_ripple_m",
        parameters=("pressure_ripple_hz",),
        height=pressure_ripple_z,
    ),
    ErrorSource("carriage_load", enters=MODEL, profile=carriage_load),
)
SOURCES = tuple(source.name for source in REGISTRY)


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


def acting_sources(sources, machine: Machine) -> tuple[ErrorSource, ...]:
    """The registry entries of the names ``sources`` that act on ``machine``, in registry
    order."""
    return tuple(s for s in REGISTRY if s.name in sources and s.is_active(machine))


def geometric_z(machine: Machine, sources, process: Process):
    """z(phi, slide_y) [m] of the height sources among ``sources`` (names) in ``process``, or
    None if none acts on ``machine``."""
    active = [s for s in acting_sources(sources, machine) if s.enters == HEIGHT]
    if not active:
        return None

    def z(phi, slide_y):
        total = 0.0
        for source in active:
            total = total + source.height(phi, slide_y, machine, process)
        return total

    return z
