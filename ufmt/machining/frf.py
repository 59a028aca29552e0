"""Frequency response functions of a model: tool-workpiece (the response behind z_re) and
point-to-point, in any pair of directions, as receptance, mobility or accelerance (paper eqs.
3.9-3.11).

An *end* of an FRF is a weighted set of points on rigid bodies: the tool-workpiece end is the
tool tip on the tool body (+1) and the same point on the workpiece body (-1), so its output is
the relative displacement and its input a force pair (+F on the tool, -F on the workpiece); a
point end is one point on one body. Along a unit direction d, the modal participation of an
end in mode s is ``c_s = sum_p w_p phi_s(body_p, point_p) . d``, and

    H(W) = sum_s c_out,s c_in,s / (M_s (w_s^2 - W^2 + 2 i zeta_s w_s W))  + residual

(modal superposition), or over the complex modes when the basis carries hinge damping
(:mod:`ufmt.machining.damping`): ``H = sum_j a_j / (i W - lambda_j) + conj``, ``a_j = (c_out^T
P)_j (L c_in / M)_j``. The residual is the static flexibility of the modes above the basis
(:func:`ufmt.machining.static.static_flexibility` minus the basis' own), so H(0) is the full
static compliance. Mobility is ``i W H``, accelerance ``-W^2 H``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ufmt import limits
from ufmt.defaults import DEFAULT_BASIS_CUTOFF_HZ
from ufmt.errors import UfmtError
from ufmt.kinds import kind_of
from ufmt.kinematics import point_motion
from ufmt.machining.basis import ModalBasis
from ufmt.machining.cutting import tool_tip
from ufmt.machining.damping import damped_modes
from ufmt.machining.machine_frame import in_machine_frame
from ufmt.machining.modal import modal_basis
from ufmt.machining.recurrence import DEFAULT_ZETA, modal_damping
from ufmt.machining.slide import model_at_slide
from ufmt.machining.static import ResidualFlexibility, static_flexibility
from ufmt.machining.tool import with_tool
from ufmt.model.load import as_model
from ufmt.model.machine import MAX_LENGTH_M, Machine, machine_of

AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}
#: kind -> (factor on the receptance as a function of i W, unit of the columns)
#: label of the tool-workpiece end (relative displacement, force pair)
TOOL_WORKPIECE = "tool-workpiece"
KINDS = {"receptance": "m_per_N", "mobility": "m_per_s_per_N", "accelerance": "m_per_s2_per_N"}


@dataclass(frozen=True)
class End:
    """One end of an FRF: ``terms`` of (body, point (3,) [m], weight)."""

    label: str
    terms: tuple[tuple[str, tuple[float, float, float], float], ...]


def tool_workpiece_end(machine: Machine, tool_angle: float = 0.0, slide_y: float = 0.0) -> End:
    """The tool tip at spindle angle ``tool_angle`` [rad] on the tool body (+1) and the
    material point under it on the workpiece body (-1) with the slide at ``slide_y`` [m]
    (file coordinates: tip + slide_y y_hat, :mod:`ufmt.machining.slide`): relative
    displacement, force pair."""
    tip = tool_tip(np.array([tool_angle]), machine)[0]
    work = tip + np.array([0.0, slide_y, 0.0])
    return End(
        TOOL_WORKPIECE,
        (
            (machine.tool_body, tuple(float(v) for v in tip), 1.0),
            (machine.workpiece_body, tuple(float(v) for v in work), -1.0),
        ),
    )


def point_end(body: str, point) -> End:
    """A point [m] (machine frame) on a rigid body."""
    p = tuple(float(v) for v in point)
    return End(f"{body}({','.join(f'{v:g}' for v in p)})", ((body, p, 1.0),))


def participation(basis: ModalBasis, end: End, direction) -> np.ndarray:
    """c (n,): the end's weighted point translations along ``direction`` in every mode (with
    the tool carrier in the basis, :mod:`ufmt.machining.tool`: the tool-workpiece end's tip
    on the carrier, any other point of the tool body on the head)."""
    d = np.asarray(direction, dtype=float)
    out = sum(w * basis.point_shapes(body, np.asarray(p)) @ d for body, p, w in end.terms)
    tool = basis.tool
    if tool is not None and end.label != TOOL_WORKPIECE:
        out = out - d[2] * tool.stretch * sum(w for b, _, w in end.terms if b == tool.body)
    return out


def modal_receptance(basis: ModalBasis, c_out, c_in, freq_hz, zeta=DEFAULT_ZETA) -> np.ndarray:
    """The basis' part of H (F,) [m/N] between participations ``c_out`` and ``c_in`` (module
    docstring), vectorised over the frequencies."""
    zeta = modal_damping(zeta, basis.n_modes)
    w = 2 * np.pi * np.asarray(freq_hz, dtype=float)[None, :]
    modes = damped_modes(basis, zeta)
    if modes is None:
        om = basis.omega[:, None]
        den = basis.modal_mass[:, None] * (om**2 - w**2 + 2j * zeta[:, None] * om * w)
        return np.sum((c_out * c_in)[:, None] / den, axis=0)
    a = ((c_out @ modes.outputs) * (modes.inputs @ (c_in / basis.modal_mass)))[:, None]
    lam = modes.poles[:, None]
    return np.sum(a / (1j * w - lam) + np.conj(a) / (1j * w - np.conj(lam)), axis=0)


def residual_receptance(
    model, basis: ModalBasis, out: End, d_out, inp: End, d_in, machine: Machine | None = None
) -> float:
    """Static flexibility of the modes above the basis between the two ends [m/N]: G_static
    of the ends' bodies (solved with the slide where the basis was, ``basis.slide_y``) minus
    the basis' sum of v v^T / (M w^2), projected on the points; between two tool-workpiece
    ends, plus the tool's own compliance along z (``tool_compliance_m_per_N``, a spring at the
    tip that no other point feels) unless the basis carries the tool as an oscillator
    (:mod:`ufmt.machining.tool`; its residual is then the head's alone)."""
    bodies = tuple(dict.fromkeys(b for b, _, _ in out.terms + inp.terms))
    for name in bodies:
        if not kind_of(model.body(name)).ONE_FRAME:
            raise UfmtError(f"{model.source}: FRF point on body {name!r}: a rigid body is needed")
    moved = model if machine is None else model_at_slide(model, machine, basis.slide_y)
    g = static_flexibility(moved, bodies)
    v = np.concatenate([basis.body_shapes[b] for b in bodies], axis=1)
    g = g - (v.T / (basis.modal_mass * basis.omega**2)) @ v
    tool = basis.tool
    if tool is not None and tool.body in bodies:  # the shank's compliance is in the basis
        i = 6 * bodies.index(tool.body) + 2
        g[i, i] += 1.0 / tool.stiffness
    h = float(_row(basis, bodies, out, d_out) @ g @ _row(basis, bodies, inp, d_in))
    if machine is not None and tool is None and out.label == inp.label == TOOL_WORKPIECE:
        h += machine.tool_compliance_m_per_N * float(d_out[2]) * float(d_in[2])
    return h


def _row(basis: ModalBasis, bodies, end: End, direction) -> np.ndarray:
    """(6B,) map from the bodies' centre-of-mass motions to the end's weighted translation."""
    row = np.zeros(6 * len(bodies))
    d = np.asarray(direction, dtype=float)
    for body, p, w in end.terms:
        i = bodies.index(body)
        t = point_motion(np.asarray(p) - basis.body_centers[body])[:3, :]
        row[6 * i : 6 * i + 6] += w * (d @ t)
    return row


def tool_workpiece_receptance(
    basis: ModalBasis,
    machine: Machine,
    freq_hz,
    zeta=None,
    tool_angle: float = 0.0,
    residual: ResidualFlexibility | None = None,
) -> np.ndarray:
    """Relative z displacement per unit force pair in z at the tool tip [m/N] (F,) complex.

    The z-z case of :func:`frf` on a given basis, with the residual of the tool and workpiece
    bodies (``residual``: :func:`ufmt.machining.static.residual_flexibility`, the tool's own
    compliance included; None: modal superposition alone). ``tool_angle``: spindle angle phi
    of the tip [rad] (0: along +y). The workpiece point is the material point under the tip
    with the slide where the basis was solved (``basis.slide_y``). ``zeta``: structural modal
    damping ratio (default the machine's ``modal_damping_ratio``).
    """
    zeta = machine.modal_damping_ratio if zeta is None else zeta
    end = tool_workpiece_end(machine, tool_angle, basis.slide_y)
    c = participation(basis, end, AXES["z"])
    h = modal_receptance(basis, c, c, freq_hz, zeta)
    if residual is not None:
        tool, work = residual.relative(end.terms[0][1], end.terms[1][1], [0.0, 0.0, 1.0])
        h = h + (tool[2] - work[2])
    return h


@dataclass(frozen=True, eq=False, repr=False)
class FrfResult:
    """One FRF of a model: ``values`` (F,) complex [unit of ``kind``] at ``frequencies_hz``
    (F,), between ``output`` and ``input`` (labels) along ``direction`` (output axis, input
    axis), as ``kind``; ``natural_hz`` the basis' natural frequencies [Hz]."""

    model_name: str
    frequencies_hz: np.ndarray
    values: np.ndarray
    kind: str
    output: str
    input: str
    direction: tuple[str, str]
    natural_hz: np.ndarray

    @property
    def unit(self) -> str:
        """Column-name unit of the values, e.g. ``m_per_N``."""
        return KINDS[self.kind]

    @property
    def name(self) -> str:
        """``frf`` for the tool-workpiece z receptance, else ``frf-<dirs>-<kind>``."""
        default = self.direction == ("z", "z") and self.kind == "receptance"
        tw = self.output == self.input == TOOL_WORKPIECE
        return "frf" if default and tw else f"frf-{''.join(self.direction)}-{self.kind}"

    def __repr__(self) -> str:
        peak = int(np.argmax(np.abs(self.values)))
        return (
            f"FrfResult({self.model_name!r}: {self.kind} {self.output} {self.direction[0]} / "
            f"{self.input} {self.direction[1]}, {self.frequencies_hz.size} frequencies "
            f"{self.frequencies_hz[0]:.4g}-{self.frequencies_hz[-1]:.4g} Hz, peak "
            f"{abs(self.values[peak]):.3e} {self.unit} at {self.frequencies_hz[peak]:.4g} Hz)"
        )

    def to_frame(self) -> pd.DataFrame:
        """frequency_hz, magnitude_<unit>, phase_deg, real_<unit>, imag_<unit>, model."""
        h = self.values
        return pd.DataFrame(
            {
                "frequency_hz": self.frequencies_hz,
                f"magnitude_{self.unit}": np.abs(h),
                "phase_deg": np.degrees(np.angle(h)),
                f"real_{self.unit}": h.real,
                f"imag_{self.unit}": h.imag,
                "model": self.model_name,
            }
        )

    def plot(self, ax=None):
        """Magnitude and phase against frequency (:func:`ufmt.plots.frf.plot_frf_result`)."""
        from ufmt.plots.frf import plot_frf_result

        return plot_frf_result(self, ax=ax)

    def save(self, directory) -> list[Path]:
        """Write ``<name>.csv`` (:meth:`to_frame`) and ``<name>.png`` to ``directory``, as one
        set (:class:`ufmt.files.FileSet`: both or neither)."""
        from ufmt import files
        from ufmt.plots import DPI

        table = self.to_frame()
        with files.FileSet(directory) as written:
            table.to_csv(written.staged(f"{self.name}.csv"), index=False, float_format="%.8g")
            csv = written.directory / f"{self.name}.csv"
            png = written.add(f"{self.name}.png", files.figure_png(self.plot(), DPI))
        return [csv, png]


def frf(
    model=None,
    direction: str = "z",
    kind: str = "receptance",
    *,
    output=None,
    input=None,
    fmin_hz: float = 1.0,
    fmax_hz: float = 1000.0,
    points: int = 4000,
    n_modes: int | None = None,
    basis_cutoff_hz: float = DEFAULT_BASIS_CUTOFF_HZ,
    zeta=None,
    static_correction: bool = True,
    tool_angle: float = 0.0,
) -> FrfResult:
    """An FRF of ``model`` (a path, a loaded model or None for the packaged UFMT).

    Parameters
    ----------
    direction : output axis then input axis, e.g. ``"xz"`` (x response to a z force); one
        letter means both (``"z"`` = ``"zz"``); axes of the machine frame (z along the
        spindle, :mod:`ufmt.model.orientation`), the global ones for an upright spindle.
    kind : ``"receptance"`` [m/N], ``"mobility"`` [m/(s N)] or ``"accelerance"`` [m/(s^2 N)].
    output, input : ``None`` for the tool-workpiece end (relative displacement at the tool
        tip, force pair; needs ``[machine]``), or ``(body, (x, y, z))`` a point [m] on a rigid
        body; ``input`` defaults to ``output`` (a driving point).
    fmin_hz, fmax_hz, points : log-spaced frequencies [Hz].
    n_modes, basis_cutoff_hz : the modal basis (first n modes, or every mode below the cutoff).
    zeta : structural modal damping ratio (the hinge damping adds to it); default the model's
        ``machine.modal_damping_ratio`` (:data:`DEFAULT_ZETA` without ``[machine]``).
    static_correction : add the residual flexibility of the modes above the basis.
    tool_angle : spindle angle of the tool tip [rad] (0: along +y).
    """
    model = as_model(model)
    frame = np.eye(3) if model.machine is None else model.machine.frame
    model = in_machine_frame(model)
    axes = _directions(direction)
    if kind not in KINDS:
        raise UfmtError(f"FRF kind {kind!r}: one of {', '.join(KINDS)}")
    fmin_hz = limits.number("fmin_hz", fmin_hz, 0.0, limits.MAX_FREQUENCY_HZ)
    fmax_hz = limits.number("fmax_hz", fmax_hz, 0.0, limits.MAX_FREQUENCY_HZ)
    points = limits.count("points", points, 2, limits.MAX_FRF_POINTS)
    if n_modes is not None:
        limits.count("n_modes", n_modes, 1, limits.MAX_MODE_COUNT)
    tool_angle = limits.number("tool_angle", tool_angle, -2 * np.pi, 2 * np.pi)
    if not 0 < fmin_hz < fmax_hz:
        raise UfmtError(f"FRF range: need 0 < fmin_hz {fmin_hz:g} < fmax_hz {fmax_hz:g} [Hz]")
    machine = machine_of(model) if model.machine is not None else None
    if zeta is None:
        zeta = DEFAULT_ZETA if machine is None else machine.modal_damping_ratio
    basis = modal_basis(model, n_modes, basis_cutoff_hz)
    if machine is not None:
        basis = with_tool(basis, machine)
    out = _end(model, output, tool_angle, basis.slide_y, frame)
    inp = out if input is None else _end(model, input, tool_angle, basis.slide_y, frame)
    freq = np.geomspace(fmin_hz, fmax_hz, int(points))
    d_out, d_in = (AXES[a] for a in axes)
    c_out, c_in = participation(basis, out, d_out), participation(basis, inp, d_in)
    h = modal_receptance(basis, c_out, c_in, freq, zeta)
    if static_correction:
        h = h + residual_receptance(model, basis, out, d_out, inp, d_in, machine)
    iw = 2j * np.pi * freq
    h = {"receptance": h, "mobility": iw * h, "accelerance": iw**2 * h}[kind]
    return FrfResult(
        model.name, freq, h, kind, out.label, inp.label, axes, basis.omega / (2 * np.pi)
    )


def _directions(direction: str) -> tuple[str, str]:
    text = str(direction).lower()
    axes = (text, text) if len(text) == 1 else tuple(text)
    if len(axes) != 2 or any(a not in AXES for a in axes):
        raise UfmtError(
            f"FRF direction {direction!r}: x, y or z, or two of them (output then input, e.g. 'xz')"
        )
    return axes


def _end(model, spec, tool_angle: float, slide_y: float, frame: np.ndarray) -> End:
    """The FRF end ``spec`` of ``model`` (in its machine frame); a point given in the file's
    global frame is carried to the machine frame by ``frame``."""
    if spec is None:
        return tool_workpiece_end(machine_of(model), tool_angle, slide_y)
    try:
        body, point = spec
        point = np.asarray(point, dtype=float).reshape(3) @ frame
    except (TypeError, ValueError):
        raise UfmtError(f"FRF point {spec!r}: expected (body name, (x, y, z) [m])") from None
    names = [b.name for b in model.bodies]
    if body not in names or not kind_of(model.body(body)).ONE_FRAME:
        rigid = [b.name for b in model.bodies if kind_of(b).ONE_FRAME]
        raise UfmtError(
            f"FRF point on {limits.shown(body)}: not a rigid body (rigid bodies: {rigid})"
        )
    offset = point - model.body(body).center_of_mass
    if not (np.all(np.isfinite(point)) and np.linalg.norm(offset) <= MAX_LENGTH_M):
        raise UfmtError(
            f"FRF point on {body!r}: {point.tolist()} [m] must be finite and within"
            f" {MAX_LENGTH_M:g} m of the body's centre of mass"
            f" {model.body(body).center_of_mass.tolist()} (lengths in metres)"
        )
    return point_end(body, point)
