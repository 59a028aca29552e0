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
error_motion   synchronous axial error motion of the head at the tool radius: the once-per-
               revolution e cos(phi - phi_0) (unbalance, air-film tilt synchronous with
               rotation: a synchronous tilt gamma gives e = gamma R) plus the 2nd-5th
               harmonics of the air bearing's thrust faces, e_2 (2/k) cos(k (phi - psi)).
straightness   the guideway's straightness carried to the workpiece by the carriage's air pads
               (heave and pitch, :mod:`ufmt.machining.carriage`): the cut point rides
               h + theta (Y + R cos(phi) - offset) high, so the tool cuts that much low.
pressure_ripple  fluctuation of the air supply pressure of the head's bearings: the head (and
               the tool) moves axially by a sin(2 pi f_p t), t the time of the pass since the
               first touch of the cut; not synchronous with the spindle or the slide, it prints
               waviness along the feed of wavelength v / f_p.
workholding    the plate's spring-back off the vacuum chuck: a bowl c_p (1 - (u^2 + v^2) / 2)
               and an astigmatism c_a (u^2 - v^2) / 2 of the plate's material coordinates
               u = 2 x / l_x, v = 2 y / l_y (each of PV |c| on the plate; power and
               astigmatism are not tilt, the interferometer keeps them).
carriage_load  the carriage's own weight as it moves: the tool-workpiece deflection under
               gravity at the pass's slide position less that at the tramming position, from a
               static solve of the model (:mod:`ufmt.machining.carriage_load`; no parameter,
               always on; its profile is built once per model and passed to
               :meth:`ErrorSource.heights`).

Each geometric term (spindle_tilt to workholding) is a height function
z(phi, Y, machine, process) of the spindle angle and the slide position of the pass (the
process gives the feed speed, hence the time of the pass, t = (Y - Y_first_touch) / v), added
to z_re before the minimum over passes; all are linear in their amplitudes, and a source whose
amplitudes are all zero on a machine is inactive there.

:data:`REGISTRY` holds one :class:`ErrorSource` per source, in the order of :data:`SOURCES`
(the order of every per-source output). Adding a geometric source is one registry entry and its
height function, plus its ``[machine]`` fields and bands in :mod:`ufmt.model.machine`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ufmt.errors import ModelError, closest_name
from ufmt.machining.carriage import workpiece_rise
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
    enters the surface (:data:`VIBRATION`, :data:`SCALLOP` or :data:`HEIGHT`); amplitudes: the
    ``[machine]`` fields of its amplitudes (the source is inactive where all are zero or unset;
    none: always active); parameters: the other ``[machine]`` fields it reads; height: for
    :data:`HEIGHT`, its tool height relative to the workpiece z(phi [rad], slide_y [m],
    machine, process) [m] (``process`` a :class:`~ufmt.machining.process.Process`: the feed
    speed and spindle speed that give the time of the pass); profile: for :data:`MODEL`,
    profile(model, machine) the height z(phi [rad], slide_y [m]) [m] (the simulation builds it
    once per model and passes it to :meth:`heights`).
    """

    name: str
    enters: str = HEIGHT
    amplitudes: tuple[str, ...] = ()
    parameters: tuple[str, ...] = ()
    height: Callable[[np.ndarray, np.ndarray, Machine, Process], np.ndarray] | None = None
    profile: Callable[[object, Machine], Callable] | None = None

    @property
    def fields(self) -> tuple[str, ...]:
        """The ``[machine]`` fields the source reads (amplitudes first)."""
        return self.amplitudes + self.parameters

    def is_active(self, machine: Machine) -> bool:
        """False where every amplitude of the source is zero or unset on ``machine`` (its term
        is 0)."""
        if not self.amplitudes:
            return True
        return any(getattr(machine, a) not in (0.0, None) for a in self.amplitudes)

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


#: Harmonics (per revolution) of the synchronous error motion above the first.
ERROR_MOTION_HARMONICS = (2, 3, 4, 5)


def error_motion_z(phi, slide_y, machine: Machine, process: Process) -> np.ndarray:
    """Tool height from the synchronous axial error motion [m]: e cos(phi - phi_0) plus
    e_2 (2/k) cos(k (phi - psi)) for k = 2-5 (independent of Y)."""
    phi = np.asarray(phi, dtype=float)
    z = machine.error_motion_m * np.cos(phi - np.radians(machine.error_motion_phase_deg))
    if machine.error_motion_harmonics_m:
        psi = np.radians(machine.error_motion_harmonics_phase_deg)
        for k in ERROR_MOTION_HARMONICS:
            z = z + machine.error_motion_harmonics_m * (2 / k) * np.cos(k * (phi - psi))
    return z


def straightness_z(phi, slide_y, machine: Machine, process: Process) -> np.ndarray:
    """Tool height relative to the workpiece from the guideway's straightness [m]: minus the
    rise of the point cut (:func:`ufmt.machining.carriage.workpiece_rise`)."""
    return -workpiece_rise(phi, slide_y, machine)


def material_uv(phi, slide_y, machine: Machine) -> tuple[np.ndarray, np.ndarray]:
    """Material coordinates (u, v) in [-1, 1] of the plate point cut at (phi, Y): the point
    (s_x + sigma R sin(phi), Y + R cos(phi)) [m] over the half sides (eq. 4.1)."""
    phi = np.asarray(phi, dtype=float)
    x = machine.offset_x + machine.sense * machine.tool_radius * np.sin(phi)
    y = np.asarray(slide_y, dtype=float) + machine.tool_radius * np.cos(phi)
    lx, ly = machine.workpiece_size
    return 2 * x / lx, 2 * y / ly


def workholding_z(phi, slide_y, machine: Machine, process: Process) -> np.ndarray:
    """Height [m] of the plate's spring-back form at the point cut:
    c_p (1 - (u^2 + v^2) / 2) + c_a (u^2 - v^2) / 2."""
    u, v = material_uv(phi, slide_y, machine)
    power = machine.workholding_power_m * (1 - (u * u + v * v) / 2)
    return power + machine.workholding_astigmatism_m * (u * u - v * v) / 2


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
    ErrorSource("spindle_tilt", amplitudes=("spindle_tilt_rad",), height=spindle_tilt_z),
    ErrorSource(
        "error_motion",
        amplitudes=("error_motion_m", "error_motion_harmonics_m"),
        parameters=("error_motion_phase_deg", "error_motion_harmonics_phase_deg"),
        height=error_motion_z,
    ),
    ErrorSource(
        "straightness",
        amplitudes=("straightness_m", "straightness_profile"),
        parameters=(
            "straightness_wavelength_m",
            "straightness_phase_deg",
            "carriage_pad_span_m",
            "carriage_pad_length_m",
            "carriage_pad_offset_m",
        ),
        height=straightness_z,
    ),
    ErrorSource(
        "pressure_ripple",
        amplitudes=("pressure_ripple_m",),
        parameters=("pressure_ripple_hz",),
        height=pressure_ripple_z,
    ),
    ErrorSource(
        "workholding",
        amplitudes=("workholding_power_m", "workholding_astigmatism_m"),
        height=workholding_z,
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
