"""Fly-cutting kinematics and cutting force (paper section 2.1, Fig. 3, eq. 4.1).

Frames and conventions
----------------------
Machine frame (:mod:`ufmt.model.orientation`; the model's global frame for the default upright
spindle): z along the spindle axis, opposite to the depth of cut, y opposite to the feed. The
tool tip
sits at radius R on the fly-cutting head; the spindle angle is phi = 2 pi f t, with phi = 0 when
the tip points along +y. Seen from +z, eq. 4.1 (x = R sin phi, y = R cos phi) turns clockwise:
``rotation = "cw"`` follows eq. 4.1 literally, ``"ccw"`` mirrors x (x = -R sin phi).

The workpiece frame has its origin at the workpiece centre and moves with the slide. ``Y`` is the
y coordinate of the spindle axis in that frame: Y = Y_start + v t grows with time (the workpiece
moves along -y), so the tool path on the workpiece is eq. 4.1, x = s_x + sigma R sin phi,
y = Y + R cos phi, with s_x the spindle axis x relative to the workpiece centre. The cut is
halfway at Y = 0 (workpiece centre under the spindle).

Cutting only happens on the leading half of the tool circle (cos phi > 0, where the circle
advances into uncut material) while the tip is over the workpiece; the trailing half passes over
the surface already cut and carries no force (whether it re-cuts is a surface option, see
:mod:`ufmt.machining.surface`). The uncut chip is the material between two successive passes:
thickness (in-plane, normal to the path) h = (v / f) cos phi and width a_p, area A = a_p h.

Force on the tool: a cutting (shearing) term proportional to the uncut chip area A = a_p h and
an edge (ploughing) term proportional to the engaged edge length b, per component
(F = K_e b + K_c A):
cutting  -(K_c A + K_ec b) t  (t: unit cutting velocity, tangent to the circle; the feed's
                               v/(R 2 pi f) ~ 3e-5 share of the relative velocity is neglected),
feed     -(K_f A + K_ef b) n  (n: outward normal of the circle; the material ahead pushes back),
thrust   +(K_t A + K_et b) z  (the workpiece pushes the tool up, away from the cut).
b = sqrt(2 r_n a_p) is the contact arc of a round-nose tool of nose radius r_n at depth a_p
(feed per revolution << b); it acts wherever the tool engages the plate. The reaction -F acts
on the workpiece body at the same point. The two terms are the two force *parts* ("area",
"edge") of the response: each has its own pattern over (phi, Y) (:func:`chip_factor_cells`)
and its own direction vector (:func:`force_vector`); the response is their sum.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ufmt.model.machine import Machine

#: The two parts of the force: per unit chip area (cutting) and per unit edge length (ploughing).
FORCE_PARTS = ("area", "edge")


@dataclass(frozen=True)
class ForceCoefficients:
    """Specific cutting forces [N/m^2] and edge (ploughing) forces per unit edge length [N/m].

    Cutting: K_c = 2 GPa, with thrust K_t = 1.5 K_c (a few-micrometre chip under a rounded
    edge: thrust exceeds the cutting force in diamond cutting of KDP) and feed 0.3 K_c.
    Band of the specific forces of diamond on KDP, cutting and thrust alike: 1-5 GPa
    (docs/ufmt-model.md, 'Cutting force': of the order of KDP's Vickers hardness, 1.5-2 GPa,
    Fang and Lambropoulos, J. Am. Ceram. Soc. 85 (2002) 174, rising with the size effect at
    micrometre chips). ``force_scale`` ([machine]) scales both parts; its calibration band
    [1 GPa / K_c, 5 GPa / K_t] = [0.5, 5/3] keeps the specific cutting force >= 1 GPa and the
    specific thrust <= 5 GPa (``ufmt/data/calibration.toml``). At the reference process (300
    rpm, 15 mm/min, 4 um: chip 4 um x 50 um) force_scale 1 gives peak forces of 0.41 N
    cutting and 0.64 N thrust, the order of the 0.15-0.19 N measured in diamond turning of KDP
    (Wang et al., Key Eng. Mater. 339, doi:10.4028/www.scientific.net/kem.339.78).
    Edge: the pressure under the rounded edge is about the hardness of KDP (H ~ 1.5-2 GPa) over
    a contact width of about the edge radius (~0.1 um for a sharp diamond tool): K_et = 200
    N/m in thrust, K_ec = mu K_et = 60 N/m with mu ~ 0.3 (diamond on KDP), no feed component.
    """

    cutting: float = 2.0e9
    thrust: float = 3.0e9
    feed: float = 0.6e9
    edge_cutting: float = 60.0
    edge_thrust: float = 200.0
    edge_feed: float = 0.0

    def vector(self, part: str) -> tuple[float, float, float]:
        """(cutting, feed, thrust) coefficients of one force part ("area" or "edge")."""
        if part == "area":
            return self.cutting, self.feed, self.thrust
        if part == "edge":
            return self.edge_cutting, self.edge_feed, self.edge_thrust
        raise ValueError(f"force part must be one of {FORCE_PARTS}, got {part!r}")


#: The force coefficients of the default tool geometry (:class:`ForceCoefficients`).
DEFAULT_COEFFICIENTS = ForceCoefficients()


def edge_length(process, machine: Machine) -> float:
    """Engaged edge length b = sqrt(2 r_n a_p) of a round-nose tool [m]."""
    return float(np.sqrt(2.0 * machine.nose_radius * process.depth_m))


def part_amplitude(process, machine: Machine, part: str) -> float:
    """Scale of a force part's pattern: a_p v/f [m^2] ("area") or b [m] ("edge")."""
    if part == "area":
        return process.depth_m * process.feed_per_rev_m
    return edge_length(process, machine)


def tool_tip(phi, machine: Machine) -> np.ndarray:
    """Tool-tip position at spindle angle ``phi`` [rad], machine frame (eq. 4.1): (..., 3) [m]."""
    phi = np.asarray(phi, dtype=float)
    x0, y0 = machine.spindle_axis_xy
    r = machine.tool_radius
    return np.stack(
        [
            x0 + machine.sense * r * np.sin(phi),
            y0 + r * np.cos(phi),
            np.full(phi.shape, machine.cutting_plane_z),
        ],
        axis=-1,
    )


def tool_tip_rates(phi, machine: Machine, spindle_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Tool-tip velocity [m/s] and acceleration [m/s^2] at ``phi`` for spindle frequency f [Hz]."""
    phi = np.asarray(phi, dtype=float)
    w = 2 * np.pi * spindle_hz
    r = machine.tool_radius
    zero = np.zeros(phi.shape)
    vel = np.stack([machine.sense * r * w * np.cos(phi), -r * w * np.sin(phi), zero], axis=-1)
    acc = np.stack([-machine.sense * r * w**2 * np.sin(phi), -r * w**2 * np.cos(phi), zero], -1)
    return vel, acc


def tool_over_workpiece(phi, slide_y, machine: Machine) -> np.ndarray:
    """True where the tool tip at angle ``phi`` is over the workpiece at slide position ``slide_y``.

    ``phi`` [rad] and ``slide_y`` [m] broadcast against each other.
    """
    phi = np.asarray(phi, dtype=float)
    x = machine.offset_x + machine.sense * machine.tool_radius * np.sin(phi)
    y = np.asarray(slide_y, dtype=float) + machine.tool_radius * np.cos(phi)
    lx, ly = machine.workpiece_size
    return (np.abs(x) <= lx / 2) & (np.abs(y) <= ly / 2)


def chip_factor(phi, slide_y, machine: Machine, part: str = "area") -> np.ndarray:
    """Pattern of a force part where the leading arc cuts the workpiece, else 0.

    "area": cos(phi), the uncut chip thickness h = (v / f) cos(phi) over v / f;
    "edge": 1 (the edge engages).
    """
    c = np.cos(np.asarray(phi, dtype=float))
    value = c if part == "area" else np.ones_like(c)
    return np.where((c > 0) & tool_over_workpiece(phi, slide_y, machine), value, 0.0)


def arc_y_bounds(slide_y, machine: Machine) -> tuple[np.ndarray, np.ndarray]:
    """|phi| range [p1, p2] [rad] where the leading arc is within the plate's y extent at Y.

    -ly/2 <= Y + R cos(phi) <= ly/2 with cos(phi) >= 0; empty where p1 > p2.
    """
    slide_y = np.asarray(slide_y, dtype=float)
    r, ly = machine.tool_radius, machine.workpiece_size[1]
    p1 = np.arccos(np.clip((ly / 2 - slide_y) / r, -1.0, 1.0))
    p2 = np.arccos(np.clip((-ly / 2 - slide_y) / r, 0.0, 1.0))
    return p1, p2


def chip_factor_cells(
    phi, slide_y, machine: Machine, width: float, part: str = "area"
) -> np.ndarray:
    """Mean of :func:`chip_factor` (of force part ``part``) over each sample's cell.

    The cell of a sample is [phi - width/2, phi + width/2].

    The force is sampled at n_phi angles and taken linear between samples; sampling the cell
    means instead of point values keeps the mean force exact and lets the edges of the cut
    (where the tip crosses a workpiece edge) move continuously with the slide instead of
    jumping from sample to sample. ``phi`` [rad] and ``slide_y`` [m] broadcast; ``width``
    [rad] is the sample spacing 2 pi / n_phi.
    """
    phi = np.asarray(phi, dtype=float)
    slide_y = np.asarray(slide_y, dtype=float)
    centred = np.mod(phi + np.pi, 2 * np.pi) - np.pi
    lo_cell, hi_cell = centred - width / 2, centred + width / 2
    lo_x, hi_x = machine.cutting_angles  # leading arc over the workpiece's x range
    p1, p2 = arc_y_bounds(slide_y, machine)
    total = 0.0
    for a, b in (
        (np.maximum(p1, lo_x), np.minimum(p2, hi_x)),
        (np.maximum(-p2, lo_x), np.minimum(-p1, hi_x)),
    ):
        lo, hi = np.maximum(lo_cell, a), np.minimum(hi_cell, b)
        if part == "area":
            total = total + np.where(hi > lo, np.sin(hi) - np.sin(lo), 0.0)
        else:
            total = total + np.where(hi > lo, hi - lo, 0.0)
    return total / width


def force_vector(
    phi, machine: Machine, coefficients: ForceCoefficients, part: str = "area"
) -> np.ndarray:
    """Force on the tool per unit pattern of a part, -K_c t - K_f n + K_t z: (..., 3).

    [N/m^2] per unit chip area ("area") or [N/m] per unit edge length ("edge").
    """
    phi = np.asarray(phi, dtype=float)
    kc, kf, kt = coefficients.vector(part)
    s, c, sense = np.sin(phi), np.cos(phi), machine.sense
    t = np.stack([sense * c, -s, np.zeros(phi.shape)], axis=-1)
    n = np.stack([sense * s, c, np.zeros(phi.shape)], axis=-1)
    z = np.array([0.0, 0.0, 1.0])
    return -kc * t - kf * n + kt * z


def cutting_force(
    phi,
    slide_y,
    process,
    machine: Machine,
    coefficients: ForceCoefficients = ForceCoefficients(),
    force_scale: float = 1.0,
    cell: float | None = None,
    parts=FORCE_PARTS,
) -> np.ndarray:
    """Force of the workpiece on the tool [N], (..., 3); the workpiece gets the reaction.

    F = force_scale * sum over parts of amplitude * pattern(phi, Y) * :func:`force_vector`:
    a_p (v / f) :func:`chip_factor` for the cutting part, b times the engagement for the edge
    part; ``phi`` [rad] and ``slide_y`` [m] broadcast. With ``cell`` [rad] each pattern is
    the mean over each sample's cell (:func:`chip_factor_cells`), as the response samples it.
    """
    total = 0.0
    for part in parts:
        if cell is None:
            pattern = chip_factor(phi, slide_y, machine, part)
        else:
            pattern = chip_factor_cells(phi, slide_y, machine, cell, part)
        amp = part_amplitude(process, machine, part) * pattern
        total = total + amp[..., None] * force_vector(phi, machine, coefficients, part)
    return force_scale * total


def peak_forces(
    process,
    machine: Machine,
    coefficients: ForceCoefficients = ForceCoefficients(),
    force_scale: float = 1.0,
) -> dict[str, float]:
    """Peak force components [N] and effective specific forces [GPa] of a process.

    At phi = 0 with the leading arc fully engaged (largest chip, h = v/f): cutting, feed and
    thrust force [N] of both parts, and the same per chip area a_p v/f [GPa] (the specific
    forces a calibration implies; compare with the 1-5 GPa band of docs/ufmt-model.md).
    """
    area = process.depth_m * process.feed_per_rev_m
    edge = edge_length(process, machine)
    kc, kf, kt = coefficients.vector("area")
    ec, ef, et = coefficients.vector("edge")
    out = {}
    for name, k, e in (("cutting", kc, ec), ("feed", kf, ef), ("thrust", kt, et)):
        force = force_scale * (k * area + e * edge)
        out[f"{name}_n"] = force
        out[f"specific_{name}_gpa"] = force / area * 1e-9
    return out
