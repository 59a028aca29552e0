"""Modal response to the fly-cutting force (paper eqs. 3.9-3.13): what both paths share.

Each modal coordinate obeys q'' + 2 zeta w q' + w^2 q = f_s(t), f_s = <f, V^s> / M_s (eq. 3.11),
with zero initial conditions (eqs. 3.12-3.13); the modal force of the point force at the tool
tip and its reaction on the workpiece is tabulated by :mod:`ufmt.machining.cut_geometry`.

The force is sampled at ``n_phi`` equally spaced spindle angles per revolution (each sample
the mean of the chip factor over its cell, :func:`~ufmt.machining.cutting.chip_factor_cells`)
and taken as piecewise linear between samples (first-order hold). Both paths solve that forced
problem exactly (:mod:`ufmt.machining.recurrence`), so they differ only by the start-up
transient and by the quasi-static assumption of (b):

(a) time domain, :func:`~ufmt.machining.time_path.time_response`: every revolution of the whole
    cut, each modal equation advanced by the exact recurrence of its first-order-hold solution
    (run by ``scipy.signal.lfilter``), from zero initial conditions.
(b) periodic, :func:`~ufmt.machining.periodic_path.periodic_response`: for a fixed slide
    position Y the force is periodic in the spindle period; its periodic steady state is
    obtained per harmonic with the receptance of the same exact recurrence (FFT, receptance,
    inverse FFT), or at a few samples as a sum over the cutting angles with the recurrence's
    periodic impulse response (its inverse DFT). The slide moves only v/f = 10-80 um per
    revolution while the slowest mode settles in a few revolutions, so the steady state at each
    Y is taken as the response while the slide passes Y (quasi-static in Y), tabulated at
    ``table_rows`` slide positions. Where the leading arc crosses the whole plate width the
    chip pattern is the same every revolution and (a) converges to (b) exactly
    (tests/test_response.py). Where the arc's top enters and leaves the plate, the table's
    resolution in Y limits (b): the points along the plate's entry and exit edges are cut just
    as the tip crosses an edge, where z_re changes within a revolution or two, and they can set
    the whole-plate PV. Measured on the prior UFMT model (four processes of Table 1), the
    whole-plate PV of (b) is 0.6-5.6 % below (a) with 96 rows, 0.05-2.4 % with the default 192
    and 0.02-0.7 % with 384 (cost of (b) roughly linear in the rows). Use (a) for reference
    values, (b) for fast studies.

Both paths solve each force part (cutting "area" and ploughing "edge", see
:mod:`ufmt.machining.cutting`) with its own :class:`~ufmt.machining.cut_geometry.CutGeometry`;
the response is linear, so :func:`combine` adds the parts. With a
:class:`~ufmt.machining.static.ResidualFlexibility` the quasi-static response of the modes above
the basis (the static correction) is added to the displacements and to z_re (not to the
tool-tip acceleration: those modes respond quasi-statically, with accelerations of the order of
the force's own rate of change).

This module holds what the two paths share: the slide position of their record window
(:func:`record_slide`), the z_re table the surface reads (:class:`ZreTable`), the result
(:class:`Response`), the tool-tip and workpiece motion from modal coordinates
(:func:`tool_and_workpiece_motion`) and the sum of the force parts (:func:`combine`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ufmt.machining.cut_geometry import CutGeometry, cross
from ufmt.model.machine import Machine


def record_slide(machine: Machine) -> float:
    """Slide position Y [m] at the middle of the record window of both paths.

    The middle of the steady span, where the leading arc crosses the whole plate every
    revolution (the representative cutting state; the paper records "the middle 2 s in the
    cutting process"), or of the cutting span when the plate is too short for one.
    """
    a, b = machine.steady_span
    if a >= b:
        a, b = machine.cutting_span
    return 0.5 * (a + b)


@dataclass(frozen=True, eq=False)
class ZreTable:
    """Relative tool-workpiece z displacement over the cut, read by the surface (eq. 4.1).

    values (rows, N + 3) [m]: column c is spindle angle 2 pi (c - 1) / N, i.e. one revolution
    padded with the sample before and the two after (for cubic interpolation in phi);
    row_y (rows,) [m] the slide position of each row at phi = 0, ascending; drift [m] the slide
    travel during one row's revolution. Time path: one row per revolution, drift = v / f, the
    padding taken from the neighbouring revolutions. Periodic path: one row per tabulated slide
    position, drift = 0 (steady state at fixed Y), padded periodically. The slide position of
    (row, phi) is row_y + drift phi / (2 pi). row_knots (Y_0, dY, u (K,)): the fractional row
    of a slide position Y, linear between knots Y_0 + k dY holding u[k] (equal to the row index
    at each row's Y); beyond the first and last rows their values apply (they carry no cutting
    force).
    """

    values: np.ndarray
    row_y: np.ndarray
    drift: float
    row_knots: tuple[float, float, np.ndarray]

    def columns(self, phi: np.ndarray) -> np.ndarray:
        """Table columns at angles phi (arcs, Nx) [rad], 4-point Lagrange in phi [m]:
        (rows, arcs * Nx)."""
        samples, weights = cubic_weights(phi, self.values.shape[1] - 3)
        padded = np.mod(samples + 1, self.values.shape[1])  # column c holds sample c - 1
        return sum(self.values[:, padded[i]] * weights[i] for i in range(4))


def cubic_weights(phi: np.ndarray, n_phi: int) -> tuple[np.ndarray, np.ndarray]:
    """The four samples around each angle phi [rad] and their 4-point Lagrange weights.

    Returns samples (4, arcs * Nx) in -1..N + 1 (sample j at angle 2 pi j / N) and weights
    (4, arcs * Nx).
    """
    u = np.ravel(phi) * (n_phi / (2 * np.pi))
    j0 = np.minimum(u.astype(int), n_phi - 1)
    t = u - j0
    weights = np.stack(
        [
            -t * (t - 1) * (t - 2) / 6,
            (t + 1) * (t - 1) * (t - 2) / 2,
            -(t + 1) * t * (t - 2) / 2,
            (t + 1) * t * (t - 1) / 6,
        ]
    )
    return j0 + np.arange(-1, 3)[:, None], weights


@dataclass(frozen=True, eq=False)
class Response:
    """Response in a record window plus the z_re table of the whole cut.

    t (T,) time [s] (0 at the first touch of the cut); slide_y (T,) slide position Y [m]; force
    (T, 3) force on the tool [N]; tip_disp (T, 3) tool-tip displacement [m] (the tool carrier's
    in z, :mod:`ufmt.machining.tool`); tip_acc (T, 3) the head's acceleration at the tool point
    [m/s^2] (where the holder sits; the tool tip's with a rigid or massless tool); carrier_acc
    (T,) the tool carrier's z acceleration [m/s^2] (what a sensor "pasted under the tool
    carrier", paper section 4.2, sees; None in a hand-built response); work_disp (T, 3)
    workpiece displacement at the contact point [m]; z_re (T,) tool minus workpiece z
    displacement [m]; period [s] spindle period; periods: spindle periods in the window; table:
    the z_re of the whole cut, a :class:`ZreTable` (time path) or a
    :class:`~ufmt.machining.periodic_path.PeriodicZreTable` (periodic path: the same layout and
    reading methods, evaluated where it is read).
    """

    method: str
    t: np.ndarray
    slide_y: np.ndarray
    force: np.ndarray
    tip_disp: np.ndarray
    tip_acc: np.ndarray
    work_disp: np.ndarray
    z_re: np.ndarray
    period: float
    periods: int
    table: ZreTable  # or a PeriodicZreTable (see above)
    carrier_acc: np.ndarray | None = None


def tool_and_workpiece_motion(geo: CutGeometry, j, slide, q, qd, qdd, spindle_hz: float):
    """:func:`projected_motion` from modal coordinates.

    j (T,) phase indices; slide (T,) slide positions Y [m]; q, qd, qdd (n, T): their
    projections on :func:`motion_shapes` to :func:`projected_motion`.
    """
    on_q, on_qd, on_qdd = motion_shapes(geo)
    return projected_motion(geo, j, slide, q.T @ on_q, qd.T @ on_qd, qdd.T @ on_qdd, spindle_hz)


def motion_shapes(geo: CutGeometry) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The modal shapes (n, k) that :func:`projected_motion` reads, on q, q' and q'': the
    tool's and the workpiece's rigid-body motion [r; theta] at their centres of mass (n, 12),
    the tool's rotation (n, 3), and its motion (n, 6) with the tool carrier's stretch (n, 1)."""
    b, m = geo.basis, geo.machine
    tool, work = b.body_shapes[m.tool_body], b.body_shapes[m.workpiece_body]
    return np.concatenate([tool, work], axis=1), tool[:, 3:], np.column_stack([tool, stretch(b)])


def stretch(basis) -> np.ndarray:
    """The tool carrier's stretch on its shank per mode (n,) [m] (zeros without the tool in
    the basis, :mod:`ufmt.machining.tool`)."""
    return np.zeros(basis.n_modes) if basis.tool is None else basis.tool.stretch


def projected_motion(geo: CutGeometry, j, slide, moved, spin, accel, spindle_hz: float):
    """Tool-tip displacement, the head's acceleration at the tool point, workpiece
    displacement (T, 3) and the tool carrier's z acceleration (T,) from the bodies' motions
    (q, q', q'' on :func:`motion_shapes`): moved (T, 12) the tool's and the workpiece's
    [r; theta], spin (T, 3) the tool's angular velocity and accel (T, 7) the tool's
    acceleration and its carrier's stretch's (the head's acceleration is the carrier's less
    the stretch's).

    j (T,) phase indices; slide (T,) slide positions Y [m]. The tip is a material point of the
    spinning tool body, so its acceleration is d^2/dt^2 sum_s [r_s + theta_s x (p(t) - C)]
    q_s(t), including the terms from the motion of p. The workpiece point under the tool sits
    at p - C + Y y_hat from its centre of mass.
    """
    b, m = geo.basis, geo.machine
    arm_tool = geo.tip[j] - b.body_centers[m.tool_body]
    arm_work = geo.tip[j] - b.body_centers[m.workpiece_body]
    arm_work[:, 1] += slide
    om = 2 * np.pi * spindle_hz
    rot = np.stack([moved[:, 3:6], moved[:, 9:], accel[:, 3:6], spin, moved[:, 3:6]])
    arm = np.stack([arm_tool, arm_work, arm_tool, 2 * om * geo.dtip[j], om**2 * geo.ddtip[j]])
    turn = cross(rot, arm)  # (5, T, 3)
    acc = accel[:, :3] + turn[2] + turn[3] + turn[4]
    head = acc.copy()
    head[:, 2] -= accel[:, 6]
    return moved[:, :3] + turn[0], head, moved[:, 6:9] + turn[1], acc[:, 2]


def tip_acceleration_shapes(geo: CutGeometry) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The columns of :func:`motion_shapes` that the head's z acceleration at the tool point
    reads, on q, q' and q'': the tool's rotation about x and y (n, 2), the same (n, 2), and
    the head's z translation with its rotation about x and y (n, 3)."""
    tool = geo.basis.body_shapes[geo.machine.tool_body]
    accel = tool[:, 2:5].copy()
    accel[:, 0] -= stretch(geo.basis)  # the head's z, not the carrier's
    return tool[:, 3:5], tool[:, 3:5], accel


def projected_tip_acceleration(geo: CutGeometry, j, tilt, spin, accel, spindle_hz: float):
    """The z component of :func:`projected_motion`'s head acceleration (T,) [m/s^2] from
    the tool's motions on :func:`tip_acceleration_shapes`: tilt (T, 2) its rotation about x
    and y, spin (T, 2) their rates and accel (T, 3) the accelerations of its z translation and
    of the tilt; j (T,) phase indices. The same operations in the same order as there."""
    arm = geo.tip[j] - geo.basis.body_centers[geo.machine.tool_body]
    om = 2 * np.pi * spindle_hz

    def turn(rot, lever):  # z of rot x lever
        return rot[:, 0] * lever[:, 1] - rot[:, 1] * lever[:, 0]

    rate, curve = 2 * om * geo.dtip[j], om**2 * geo.ddtip[j]
    return accel[:, 0] + turn(accel[:, 1:], arm) + turn(spin, rate) + turn(tilt, curve)


def combine(responses) -> Response:
    """Sum of the responses of the force parts of one process (the response is linear).

    All must come from the same path, process and table rows (as :func:`ufmt.simulate.simulate`
    makes them); the first one's time axis and table layout are kept.
    """
    responses = list(responses)
    first = responses[0]
    if len(responses) == 1:
        return first

    def total(name):
        return sum(getattr(r, name) for r in responses)

    return Response(
        method=first.method,
        t=first.t,
        slide_y=first.slide_y,
        force=total("force"),
        tip_disp=total("tip_disp"),
        tip_acc=total("tip_acc"),
        work_disp=total("work_disp"),
        z_re=total("z_re"),
        carrier_acc=total("carrier_acc"),
        period=first.period,
        periods=first.periods,
        table=ZreTable(
            sum(r.table.values for r in responses),
            first.table.row_y,
            first.table.drift,
            first.table.row_knots,
        ),
    )
