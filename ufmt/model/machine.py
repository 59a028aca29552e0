"""Machine geometry of a model: the ``[machine]`` table (tool, workpiece, spindle, cut).

Frames and the meaning of every quantity are described in :mod:`ufmt.machining.cutting`; the
tool geometry and the error sources in :mod:`ufmt.machining.sources` and docs/ufmt-model.md.
Every optional key has a documented default and a physical band (:data:`OPTIONAL_FIELDS`);
a value outside its band, a non-finite number or an unknown key is a :class:`ModelError`.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ufmt.errors import ModelError
from ufmt.model.guideway import GuidewayProfile, read_guideway_profile
from ufmt.model.orientation import DIRECTION_FIELDS, frame_matrix, read_directions
from ufmt.tables import Where


@dataclass(frozen=True)
class Machine:
    """Tool and workpiece geometry, read from the model's ``[machine]`` table.

    Attributes
    ----------
    tool_body, workpiece_body : body names carrying the tool and the workpiece.
    spindle_axis_xy : (x_m, y_m) of the spindle axis [m], machine frame.
    cutting_plane_z : z_m of the tool tip = workpiece top surface [m], machine frame.
    tool_radius : fly-cutting radius R [m].
    workpiece_size : (x, y) size of the workpiece [m].
    workpiece_center_xy : workpiece centre when the cut is halfway (under the spindle) [m].
    rotation : "cw" (eq. 4.1 as printed, clockwise seen from +z) or "ccw".
    force_scale : factor on the force coefficients [-] (default 1, band 0.3-3; fitted by
        ``ufmt calibrate``, :mod:`ufmt.calibration.response_fit`).
    nose_radius : tool nose radius r_n [m] (feed marks, edge length of the ploughing term).
    rake_angle_deg, clearance_angle_deg : tool rake and clearance angles [deg] (recorded and
        validated; the force coefficients are those of the default geometry).
    spindle_tilt_rad : tilt beta of the spindle axis against the feed [rad] (sag
        beta R (1 - cos phi)).
    error_motion_m, error_motion_phase_deg : amplitude [m] and phase [deg] of the
        once-per-revolution axial error motion of the fly-cutting head at the tool radius.
    error_motion_harmonics_m, error_motion_harmonics_phase_deg : amplitude [m] of the 2nd
        harmonic of the synchronous axial error motion (the 3rd-5th fall as 2/k) and the
        orientation [deg] of that profile against the tool.
    straightness_m, straightness_wavelength_m, straightness_phase_deg : amplitude [m],
        wavelength [m] and phase [deg] (at the pads' centre halfway through the cut) of the
        guideway's straightness in z along y, when no measured profile is given.
    straightness_profile : the guideway's measured height profile
        (:class:`~ufmt.model.guideway.GuidewayProfile`, the ``[machine]`` key holds the CSV's
        path, relative to the model file), or None.
    carriage_pad_span_m, carriage_pad_length_m, carriage_pad_offset_m : distance [m] between
        the carriage's front and rear vertical pad lines along y, each line's contact length
        [m], and the y [m] of their centre from the workpiece's centre
        (:mod:`ufmt.machining.carriage`).
    workholding_power_m, workholding_astigmatism_m : signed PV [m] over the plate of the
        workholding's bowl (centre high if > 0) and astigmatism (x edges high if > 0) left by
        the plate's spring-back off the vacuum chuck (:mod:`ufmt.machining.sources`).
    tool_compliance_m_per_N : z compliance of the tool and its holder between the tool body
        and the tip [m/N] (a cantilevered shank, 3 E I / L^3 its stiffness; 0: rigid).
    tool_mass_kg : mass of the tool carrier (holder, shank and tool) that the shank's spring
        carries [kg]: the tool is an oscillator on the head (:mod:`ufmt.machining.tool`);
        0: a massless spring, added quasi-statically with the static correction
        (:mod:`ufmt.machining.static`).
    tool_damping_ratio : damping ratio of the tool carrier on its shank [-].
    pressure_ripple_m, pressure_ripple_hz : amplitude [m] and frequency [Hz] of the axial
        motion of the head from the fluctuation of its bearings' air supply pressure (a
        non-synchronous source, :mod:`ufmt.machining.sources`).
    modal_damping_ratio : structural damping ratio of every mode [-] (the bodies' own
        damping; the hinge dampers act on top of it, :mod:`ufmt.machining.damping`).
    accelerometer_resonance_hz, accelerometer_damping_ratio : mounted resonance [Hz] and
        damping ratio [-] of the accelerometer; recorder_sampling_hz : the recorder's
        sampling rate [Hz] (:class:`ufmt.machining.instruments.AccelerometerChain`).
    table : the ``[machine]`` table as it was read (its keys in their order, their TOML
        types), which :func:`ufmt.model.write.model_to_toml` writes back.
    Defaults and bands: :data:`OPTIONAL_FIELDS`.
    """

    tool_body: str
    workpiece_body: str
    spindle_axis_xy: tuple[float, float]
    cutting_plane_z: float
    tool_radius: float
    workpiece_size: tuple[float, float]
    workpiece_center_xy: tuple[float, float]
    rotation: str
    force_scale: float = 1.0
    nose_radius: float = 5e-3
    rake_angle_deg: float = 0.0
    clearance_angle_deg: float = 6.0
    spindle_tilt_rad: float = 0.0
    error_motion_m: float = 0.0
    error_motion_phase_deg: float = 0.0
    straightness_m: float = 0.0
    straightness_wavelength_m: float = 0.1
    straightness_phase_deg: float = 0.0
    carriage_pad_span_m: float = 0.7
    carriage_pad_length_m: float = 0.2
    carriage_pad_offset_m: float = 0.0
    error_motion_harmonics_m: float = 0.0
    error_motion_harmonics_phase_deg: float = 0.0
    workholding_power_m: float = 0.0
    workholding_astigmatism_m: float = 0.0
    tool_compliance_m_per_N: float = 0.0
    tool_mass_kg: float = 0.015
    tool_damping_ratio: float = 0.03
    pressure_ripple_m: float = 0.0
    pressure_ripple_hz: float = 0.0096
    modal_damping_ratio: float = 0.01
    accelerometer_resonance_hz: float = 10e3
    accelerometer_damping_ratio: float = 0.03
    recorder_sampling_hz: float = 10e3
    straightness_profile: GuidewayProfile | None = None
    spindle_direction: tuple[float, float, float] = DIRECTION_FIELDS["spindle_direction"]
    feed_direction: tuple[float, float, float] = DIRECTION_FIELDS["feed_direction"]
    gravity_direction: tuple[float, float, float] = DIRECTION_FIELDS["gravity_direction"]
    table: Mapping = dataclasses.field(default_factory=dict, compare=False, repr=False)

    @property
    def frame(self) -> np.ndarray:
        """(3, 3) columns x_m, y_m, z_m of the machine frame, global frame
        (:func:`ufmt.model.orientation.frame_matrix`)."""
        return frame_matrix(self.spindle_direction, self.feed_direction)

    @property
    def upright(self) -> bool:
        """True when the machine frame is the global frame (the default directions)."""
        return (self.spindle_direction, self.feed_direction) == (
            DIRECTION_FIELDS["spindle_direction"],
            DIRECTION_FIELDS["feed_direction"],
        )

    @property
    def sense(self) -> float:
        """+1 for "cw" (x = R sin phi, eq. 4.1), -1 for "ccw"."""
        return 1.0 if self.rotation == "cw" else -1.0

    @property
    def offset_x(self) -> float:
        """s_x: spindle axis x relative to the workpiece centre [m]."""
        return self.spindle_axis_xy[0] - self.workpiece_center_xy[0]

    @property
    def cut_span(self) -> tuple[float, float]:
        """Slide positions Y [m]: first touch of the leading arc, exit of the trailing arc."""
        half = self.workpiece_size[1] / 2 + self.tool_radius
        return -half, half

    @property
    def guideway_span(self) -> tuple[float, float]:
        """Global y [m] of the guideway under the carriage's pads over the cut (the pads'
        centre at spindle y + ``carriage_pad_offset_m`` - Y, :mod:`ufmt.machining.carriage`)."""
        reach = self.carriage_pad_span_m / 2 + self.carriage_pad_length_m / 2
        centre = self.spindle_axis_xy[1] + self.carriage_pad_offset_m
        return centre - self.cut_span[1] - reach, centre - self.cut_span[0] + reach

    @property
    def cutting_span(self) -> tuple[float, float]:
        """Slide positions Y [m] over which the leading arc cuts (force is zero outside)."""
        far = self.workpiece_size[0] / 2 + abs(self.offset_x)
        end = self.workpiece_size[1] / 2 - math.sqrt(self.tool_radius**2 - far**2)
        return self.cut_span[0], end

    @property
    def cutting_angles(self) -> tuple[float, float]:
        """Angles (lo, hi) [rad], |.| < pi/2, where the leading arc is over the plate's x range."""
        ends = np.array([-1.0, 1.0]) * self.workpiece_size[0] / 2 - self.offset_x
        lo, hi = np.sort(np.arcsin(ends / (self.sense * self.tool_radius)))
        return float(lo), float(hi)

    @property
    def steady_span(self) -> tuple[float, float]:
        """Slide positions Y [m] over which the leading arc crosses the whole workpiece width.

        The chip pattern of every revolution is then the same (empty if the plate is too short).
        """
        lo, hi = self.cutting_angles
        cos_max = 1.0 if lo <= 0.0 <= hi else max(np.cos(lo), np.cos(hi))
        cos_min = min(np.cos(lo), np.cos(hi))
        ly = self.workpiece_size[1]
        return -ly / 2 - self.tool_radius * cos_min, ly / 2 - self.tool_radius * cos_max


MACHINE_FIELDS = (
    "tool_body",
    "workpiece_body",
    "spindle_axis_xy",
    "cutting_plane_z",
    "tool_radius",
    "workpiece_size",
    "workpiece_center_xy",
    "rotation",
)
#: "cw": eq. 4.1 as printed, clockwise seen from +z; "ccw" the other sense.
ROTATIONS = ("cw", "ccw")

#: Optional ``[machine]`` keys: (default, low, high, unit); docs/ufmt-model.md gives the
#: physics and the source of each band.
OPTIONAL_FIELDS = {
    "force_scale": (1.0, 0.3, 3.0, "-"),
    "nose_radius": (5e-3, 0.1e-3, 50e-3, "m"),
    "rake_angle_deg": (0.0, -45.0, 10.0, "deg"),
    "clearance_angle_deg": (6.0, 2.0, 20.0, "deg"),
    "spindle_tilt_rad": (0.0, -50e-6, 50e-6, "rad"),
    "error_motion_m": (0.0, 0.0, 1e-6, "m"),
    "error_motion_phase_deg": (0.0, -360.0, 360.0, "deg"),
    "straightness_m": (0.0, 0.0, 2e-6, "m"),
    "straightness_wavelength_m": (0.1, 1e-3, 10.0, "m"),
    "straightness_phase_deg": (0.0, -360.0, 360.0, "deg"),
    "carriage_pad_span_m": (0.7, 1e-3, 20.0, "m"),
    "carriage_pad_length_m": (0.2, 0.0, 20.0, "m"),
    "carriage_pad_offset_m": (0.0, -20.0, 20.0, "m"),
    "error_motion_harmonics_m": (0.0, 0.0, 1e-6, "m"),
    "error_motion_harmonics_phase_deg": (0.0, -360.0, 360.0, "deg"),
    "workholding_power_m": (0.0, -2e-6, 2e-6, "m"),
    "workholding_astigmatism_m": (0.0, -2e-6, 2e-6, "m"),
    "tool_compliance_m_per_N": (0.0, 0.0, 2e-7, "m/N"),
    "tool_mass_kg": (0.015, 0.0, 0.05, "kg"),
    "tool_damping_ratio": (0.03, 0.005, 0.2, "-"),
    "pressure_ripple_m": (0.0, 0.0, 1e-7, "m"),
    "pressure_ripple_hz": (0.0096, 1e-4, 100.0, "Hz"),
    "modal_damping_ratio": (0.01, 1e-4, 0.2, "-"),
    "accelerometer_resonance_hz": (10e3, 3e3, 30e3, "Hz"),
    "accelerometer_damping_ratio": (0.03, 0.005, 0.1, "-"),
    "recorder_sampling_hz": (10e3, 5e3, 20e3, "Hz"),
}
#: Optional ``[machine]`` keys that name a file (relative to the model file): the guideway's
#: measured straightness profile (:mod:`ufmt.model.guideway`).
PATH_FIELDS = ("straightness_profile",)
#: Optional ``[machine]`` directions (:mod:`ufmt.model.orientation`).
DIRECTIONS = tuple(DIRECTION_FIELDS)


def read_machine(machine: Mapping, source: str = "<memory>") -> Machine:
    """Validate a ``[machine]`` table and return the :class:`Machine`.

    Raises ModelError naming the file and field, e.g.
    ``ufmt.toml: machine: field 'tool_radius': -0.2 is not positive (allowed: > 0 [m])``.
    """
    where = Where(source, "machine", error=ModelError)
    where.keys(
        machine, (*MACHINE_FIELDS, *OPTIONAL_FIELDS, *PATH_FIELDS, *DIRECTIONS), MACHINE_FIELDS
    )
    rotation = where.choice("rotation", machine["rotation"], ROTATIONS, "rotation")
    m = Machine(
        tool_body=where.string("tool_body", machine["tool_body"]),
        workpiece_body=where.string("workpiece_body", machine["workpiece_body"]),
        spindle_axis_xy=_pair(where, machine, "spindle_axis_xy"),
        cutting_plane_z=where.number("cutting_plane_z", machine["cutting_plane_z"], unit="[m]"),
        tool_radius=where.number(
            "tool_radius", machine["tool_radius"], sign="positive", unit="[m]"
        ),
        workpiece_size=_pair(where, machine, "workpiece_size", sign="positive"),
        workpiece_center_xy=_pair(where, machine, "workpiece_center_xy"),
        rotation=rotation,
        **{field: _optional(where, machine, field) for field in OPTIONAL_FIELDS},
        straightness_profile=_profile(where, machine, source),
        **read_directions(where, machine),
        table=copy.deepcopy(dict(machine)),
    )
    _check_pads(where, m)
    if abs(m.workpiece_center_xy[1] - m.spindle_axis_xy[1]) > 1e-9:
        where.fail(
            "workpiece_center_xy",
            f"y = {m.workpiece_center_xy[1]!r} must equal spindle_axis_xy y = "
            f"{m.spindle_axis_xy[1]!r} (the workpiece centre is under the spindle halfway)",
        )
    for field in ("tool_radius", "workpiece_size", "spindle_axis_xy", "workpiece_center_xy"):
        _not_huge(where, field, getattr(m, field), MAX_LENGTH_M, "any fly-cutting machine")
    far = m.workpiece_size[0] / 2 + abs(m.offset_x)
    if far >= m.tool_radius:
        where.fail(
            "tool_radius",
            f"{m.tool_radius!r} must exceed workpiece_size x / 2 + |workpiece centre x - spindle "
            f"x| = {far!r} (the tool circle must cross the whole workpiece width)",
        )
    return m


#: Longest plausible length [m] of a fly-cutting machine's geometry (the largest reported
#: machines are a few metres): a length beyond it was typed in mm or cm.
MAX_LENGTH_M = 20.0


def unit_hint(value: float, fits) -> str:
    """``did you mean ...?`` for a length typed in mm or cm: ``value`` / 1000 or / 100 when
    ``fits(candidate)`` accepts it, else a request to give metres."""
    guesses = [
        f"{value / factor:.6g} m ({value:g} {unit})"
        for factor, unit in ((1000.0, "mm"), (100.0, "cm"))
        if fits(value / factor)
    ]
    if guesses:
        return f"did you mean {' or '.join(guesses)}?"
    return "lengths are in metres [m], in the model's global frame"


def _not_huge(where: Where, field: str, value, limit: float, what: str) -> None:
    """Fail if the largest |component| of ``value`` [m] exceeds ``limit`` [m]."""
    largest = float(np.max(np.abs(value)))
    if largest > limit:
        hint = unit_hint(largest, lambda x: x <= limit)
        where.fail(field, f"{largest:g} m is larger than {what} ({limit:g} m): {hint}")


def body_points(body) -> np.ndarray:
    """(P, 3) points [m] that place a body: a rigid body's centre of mass, a beam's two ends
    (a virtual body has none)."""
    if hasattr(body, "center_of_mass"):
        return np.atleast_2d(np.asarray(body.center_of_mass, dtype=float))
    if hasattr(body, "start"):
        return np.array([body.start, body.end], dtype=float)
    return np.zeros((0, 3))


def body_size(body) -> float:
    """Largest extent [m] of a body: a beam's length, a rigid body's largest edge of the box
    with its mass and principal moments (``I_x = m (b^2 + c^2) / 12``), 0 for a point."""
    if hasattr(body, "inertia"):
        ix, iy, iz = np.diag(np.asarray(body.inertia, dtype=float))
        squares = 6.0 * np.array([iy + iz - ix, ix + iz - iy, ix + iy - iz]) / body.mass
        return float(np.sqrt(np.clip(squares, 0.0, None)).max())
    points = body_points(body)
    return float(np.linalg.norm(points[-1] - points[0])) if len(points) else 0.0


def check_machine_geometry(machine: Machine, bodies, source: str) -> None:
    """Plausibility of the ``[machine]`` lengths against the machine the bodies describe, so
    that a length typed in mm or cm is caught with its field and the likely unit:

    * ``tool_radius`` <= the larger of the machine's extent E (the largest span, along x, y or
      z of the machine frame, of the bodies' centres of mass and beam ends) and the tool body's
      size;
    * ``cutting_plane_z`` within the tool body's size + ``tool_radius`` + E / 4 of the tool
      body (its centre of mass, or its beam) along the spindle axis: the tip is on the tool
      body;
    * the workpiece (``workpiece_size`` and its centre) within E of the workpiece body.
    """
    where = Where(source, "machine", error=ModelError)
    bodies = list(bodies)
    points = np.concatenate([body_points(b) for b in bodies] + [np.zeros((0, 3))])
    points = points @ machine.frame  # machine frame: z along the spindle
    extent = float(np.max(np.ptp(points, axis=0))) if len(points) else 0.0
    tool = next(b for b in bodies if b.name == machine.tool_body)
    limit = max(extent, body_size(tool))
    if limit > 0 and machine.tool_radius > limit:
        where.fail(
            "tool_radius",
            f"{machine.tool_radius:g} m is larger than the machine (its bodies span {limit:.3g}"
            f" m): {unit_hint(machine.tool_radius, lambda r: r <= limit)}",
        )
    _plane_near_tool(where, machine, tool, extent)
    work = next(b for b in bodies if b.name == machine.workpiece_body)
    anchor = body_points(work)
    if len(anchor) and extent > 0:
        half = max(machine.workpiece_size) / 2
        reach = max(extent, body_size(work))
        if half > reach:
            where.fail(
                "workpiece_size",
                f"{max(machine.workpiece_size):g} m is larger than the machine (its bodies span "
                f"{reach:.3g} m): {unit_hint(half * 2, lambda w: w / 2 <= reach)}",
            )


def _plane_near_tool(where: Where, machine: Machine, tool, extent: float) -> None:
    """``cutting_plane_z`` near the tool body in z (see :func:`check_machine_geometry`)."""
    points = body_points(tool) @ machine.frame
    if not len(points):
        return
    low, high = points[:, 2].min(), points[:, 2].max()
    z = machine.cutting_plane_z
    gap = max(low - z, z - high, 0.0)
    allowed = body_size(tool) + machine.tool_radius + extent / 4
    if gap > allowed:
        hint = unit_hint(z, lambda c: max(low - c, c - high, 0.0) <= allowed)
        where.fail(
            "cutting_plane_z",
            f"{z:g} m is {gap:.3g} m from the tool body {tool.name!r} (z {low:.4g}"
            + ("" if high == low else f" to {high:.4g}")
            + f" m; allowed within {allowed:.3g} m: its size, the tool radius and a quarter of "
            f"the machine): {hint}",
        )


def _profile(where: Where, machine: Mapping, source: str) -> GuidewayProfile | None:
    """The guideway profile of ``straightness_profile`` (a path relative to the model file
    ``source``), or None."""
    if "straightness_profile" not in machine:
        return None
    base = Path.cwd() if source.startswith("<") else Path(source).parent  # "<memory>": no file
    return read_guideway_profile(
        machine["straightness_profile"], where, "straightness_profile", base
    )


def _check_pads(where: Where, m: Machine) -> None:
    """The pads must not overlap, and a measured profile must cover the guideway under them
    over the whole cut (:mod:`ufmt.machining.carriage`)."""
    if m.carriage_pad_length_m > m.carriage_pad_span_m:
        where.fail(
            "carriage_pad_length_m",
            f"{m.carriage_pad_length_m!r} exceeds carriage_pad_span_m = "
            f"{m.carriage_pad_span_m!r} (allowed: 0 to the span [m]: the two pad lines must not "
            "overlap)",
        )
    profile = m.straightness_profile
    if profile is None:
        return
    if m.straightness_m != 0.0:
        where.fail(
            "straightness_m",
            f"{m.straightness_m!r} is given with straightness_profile (allowed: one of them; the "
            "measured profile replaces the harmonic)",
        )
    need = m.guideway_span
    have = (float(profile.position[0]), float(profile.position[-1]))
    if have[0] > need[0] + 1e-12 or have[1] < need[1] - 1e-12:
        where.fail(
            "straightness_profile",
            f"{profile.path}: positions {have[0]:.6g} to {have[1]:.6g} m do not cover the "
            f"guideway under the pads over the cut, {need[0]:.6g} to {need[1]:.6g} m (allowed: "
            "a profile covering the slide's travel over the cut plus the pad span, global y)",
        )


def _pair(where: Where, machine: Mapping, field: str, sign: str | None = None):
    """Two numbers [m] (x, y)."""
    x, y = where.numbers(field, machine[field], 2, sign=sign, unit="[m]")
    return x, y


def _optional(where: Where, machine: Mapping, field: str) -> float:
    """An optional number: its default when absent, else checked against its band."""
    default, low, high, unit = OPTIONAL_FIELDS[field]
    if field not in machine:
        return default
    unit = "" if unit == "-" else f"[{unit}]"
    return where.within(field, where.number(field, machine[field], unit=unit), low, high, unit)


def check_machine_bodies(machine: Machine, body_names, source: str) -> None:
    """The tool and workpiece bodies must be bodies of the model (checked when it has bodies)."""
    names = list(body_names)
    for field in ("tool_body", "workpiece_body"):
        if names and getattr(machine, field) not in names:
            Where(source, "machine", error=ModelError).fail(
                field,
                f"{getattr(machine, field)!r} is not a body of the model (bodies: "
                f"{', '.join(names)})",
            )


def machine_of(model) -> Machine:
    """The validated :class:`Machine` of a :class:`ufmt.model.schema.Model`.

    Raises ModelError when the model has no ``[machine]`` table, or when its tool or workpiece
    body is not a body of the model.
    """
    if model.machine is None:
        raise ModelError(
            f"{model.source}: no [machine] table: add one with {', '.join(MACHINE_FIELDS)} "
            "(see docs/ufmt-model.md, 'Machine table')"
        )
    check_machine_bodies(model.machine, (b.name for b in model.bodies), model.source)
    return model.machine
