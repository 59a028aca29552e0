"""The carriage's own weight as it moves: the tool-workpiece deflection under gravity along the
cut (a parameter-free error source, ``carriage_load`` in :mod:`ufmt.machining.sources`).

As the slide travels, the weight of the carriage (the slider, the chuck, the plate and what
rides with them, :func:`ufmt.machining.slide.carriage`) moves over the bed: the bed and the
foundation tilt on their supports, the columns and the bridge follow, and the tool's height
over the workpiece changes. With the carriage at slide position Y (:func:`model_at_slide`)
the static solve of the assembled model under the weight of every mass (g along -z,
:func:`ufmt.machining.static.gravity_deflection`, the model's own stiffnesses: nothing to set)
gives the tool body's and the workpiece body's rigid motions u_t(Y), u_w(Y), and the tool's
height over the material point under the tip p(phi) (eq. 4.1) is

    delta(phi, Y) = [T(p - C_t) u_t(Y)]_z - [T(p + Y y - C_w) u_w(Y)]_z

(T(a) = [I, -[a]x], C the bodies' centres as the file draws them). The machine is trammed
under its own weight with the slide half way through the leading arc's cut (Y_ref,
:func:`~ufmt.machining.slide.cut_slide_position`): what prints is the change
z(phi, Y) = delta(phi, Y) - delta(phi, Y_ref).

u(Y) is solved at KNOTS evenly spaced slide positions over each arc's span (the leading arc
from first touch to its exit, the trailing arc's mirror image when back-cutting asks for it)
and interpolated by a cubic spline (tests/test_carriage_load.py halves the spacing).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from scipy.interpolate import CubicSpline

from ufmt.machining.cutting import tool_tip
from ufmt.machining.machine_frame import in_machine_frame
from ufmt.machining.slide import cut_slide_position, model_at_slide
from ufmt.machining.static import gravity_deflection
from ufmt.model.machine import Machine
from ufmt.recent import Recent

#: Slide positions per arc's span at which the static solve runs.
KNOTS = 5
#: Profiles of the last few (model, machine, knots): the designs of a study and each source
#: alone reuse them.
_PROFILES = Recent(8)


@dataclass(frozen=True, eq=False)
class CarriageLoad:
    """z(phi, Y) [m] of the carriage's moving weight: call it with spindle angles ``phi``
    [rad] and slide positions ``slide_y`` [m] (broadcast). ``model``, ``machine``: the model
    and machine it solves; ``knots``: solves per arc's span."""

    model: object
    machine: Machine
    knots: int = KNOTS
    _spans: dict = field(default_factory=dict, repr=False)

    @cached_property
    def reference(self) -> np.ndarray:
        """:func:`_height_terms` (5,) of the deflections at the tramming position Y_ref."""
        return _height_terms(self._deflection(cut_slide_position(self.machine)))

    def _deflection(self, slide_y: float) -> np.ndarray:
        """[u_tool, u_work] (12,) [m, rad] under gravity with the carriage at ``slide_y``."""
        machine = self.machine
        moved = model_at_slide(self.model, machine, slide_y)
        return gravity_deflection(moved, (machine.tool_body, machine.workpiece_body))

    def _spline(self, arc: int) -> CubicSpline:
        """:func:`_height_terms` (5,) of u(Y) over arc ``arc``'s span (0 leading, 1 trailing)
        (a spline of a linear combination is that combination of the splines)."""
        if arc not in self._spans:
            start, end = self.machine.cut_span[0], self.machine.cutting_span[1]
            ends = (start, end) if arc == 0 else (-end, -start)
            y = np.linspace(*ends, self.knots)
            u = np.array([self._deflection(float(v)) for v in y])
            self._spans[arc] = CubicSpline(y, _height_terms(u), axis=0)
        return self._spans[arc]

    def __call__(self, phi, slide_y) -> np.ndarray:
        phi = np.asarray(phi, dtype=float)
        slide = np.asarray(slide_y, dtype=float)
        trailing = slide > 0.0  # the arcs' spans are mirror images about Y = 0
        u = self._spline(0)(slide)
        if trailing.any():
            u = np.where(trailing[..., None], self._spline(1)(slide), u)
        tip = tool_tip(phi, self.machine)
        y_ref = cut_slide_position(self.machine)
        return self._height(tip, slide, u) - self._height(tip, y_ref, self.reference)

    def _height(self, tip, slide, v) -> np.ndarray:
        """Tool height over the workpiece [m] for the bodies' motions' :func:`_height_terms`
        ``v`` (..., 5): [T(p - C_t) u_t]_z - [T(p + Y y - C_w) u_w]_z."""
        c_tool = self.model.body(self.machine.tool_body).center_of_mass
        c_work = self.model.body(self.machine.workpiece_body).center_of_mass
        arm_t, arm_w = tip - c_tool, tip - c_work
        return (
            v[..., 0]
            + v[..., 1] * arm_t[..., 1]
            - v[..., 2] * arm_t[..., 0]
            - v[..., 3] * (arm_w[..., 1] + slide)
            + v[..., 4] * arm_w[..., 0]
        )


def _height_terms(u: np.ndarray) -> np.ndarray:
    """The terms (..., 5) of the tool's height over the workpiece that the bodies' motions
    u = [u_tool, u_work] (..., 12) [m, rad] enter: u_t,z - u_w,z, theta_t,x, theta_t,y,
    theta_w,x, theta_w,y (z of theta x arm: theta_x arm_y - theta_y arm_x)."""
    return np.stack([u[..., 2] - u[..., 8], u[..., 3], u[..., 4], u[..., 9], u[..., 10]], axis=-1)


def carriage_load(model, machine: Machine, knots: int = KNOTS) -> CarriageLoad:
    """The :class:`CarriageLoad` profile of ``model`` and ``machine`` (cached per model,
    machine and knots: one per design of a study); the model in its machine frame
    (:mod:`ufmt.machining.machine_frame`)."""
    model = in_machine_frame(model)
    return _PROFILES.get((model, machine, knots), lambda: CarriageLoad(model, machine, knots))
