"""Process-independent geometry of the cut: what the response needs besides the process.

For the point force F at the tool tip p on the tool body and its reaction on the workpiece body
at the same point, the modal force is f_s = (V_tool,s(p) - V_work,s(p)) . F / M_s (paper
eq. 3.11), where V_b,s(p) is the translation of point p of body b in mode s. :func:`cut_geometry`
tabulates, for one force part (cutting "area" or ploughing "edge", see
:mod:`ufmt.machining.cutting`), the modal force per unit pattern and the relative z translation
at ``n_phi`` spindle angles, their Fourier coefficients (they are trigonometric polynomials in
phi), the static correction's displacements (:mod:`ufmt.machining.static`), and the slide
positions of the periodic path's table with the chip pattern there.

Mode shapes are those of the nominal configuration, taken as the halfway point of the cut (see
:mod:`ufmt.machining.basis`). The workpiece is loaded at the material point under the tool: its
arm from the workpiece body's centre of mass is p - C + Y y_hat, so the workpiece terms of the
modal force and of z_re are linear in the slide position Y (``*_y`` in :class:`CutGeometry`).

Everything that depends on the machine alone (the maps of the bodies' motions, the chip
pattern's tables) is cached per machine, so every design of a sweep shares it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property, lru_cache, partial

import numpy as np

from ufmt.assembled import point_motion
from ufmt.defaults import (
    MIN_SAMPLES_PER_REV,
    SAMPLES_PER_GRID_STEP,
    SAMPLES_PER_MODE_PERIOD,
    SAMPLES_PER_TOOL_PERIOD,
)
from ufmt.machining.basis import ModalBasis
from ufmt.machining.cutting import (
    DEFAULT_COEFFICIENTS,
    ForceCoefficients,
    arc_y_bounds,
    chip_factor_cells,
    force_vector,
    tool_tip,
    tool_tip_rates,
)
from ufmt.machining.static import ResidualFlexibility
from ufmt.machining.validity import MAX_SAMPLES_PER_REV
from ufmt.model.machine import Machine

#: Force samples per spindle revolution of a basis of the paper's size (30 modes, ~700 Hz);
#: the default of a basis is :func:`samples_per_rev`.
DEFAULT_N_PHI = MIN_SAMPLES_PER_REV
#: Slide positions of the periodic path's table (see :func:`cut_geometry` and the accuracy
#: note in :mod:`ufmt.machining.response`).
DEFAULT_TABLE_ROWS = 192
#: Share of the table rows spread evenly in slide travel; the rest follow the chip pattern.
UNIFORM_SHARE = 0.1
#: Harmonics of the modal-force shape w_s(phi) (a trigonometric polynomial of degree 2).
FORCE_HARMONICS = np.arange(-2, 3)
#: Harmonics of the output shape c_s(phi) (degree 1).
OUTPUT_HARMONICS = np.arange(-1, 2)


def samples_per_rev(
    highest_hz: float,
    spindle_hz: float,
    tool_radius: float = 0.0,
    grid_step: float = math.inf,
    tool_hz: float = 0.0,
) -> int:
    """Default samples per spindle revolution [-], a power of two, never below
    MIN_SAMPLES_PER_REV (:mod:`ufmt.defaults`): at least SAMPLES_PER_MODE_PERIOD per period
    of the basis' highest mode ``highest_hz`` [Hz] at ``spindle_hz`` [rev/s], and at least
    SAMPLES_PER_GRID_STEP per surface grid step ``grid_step`` [m] across the feed along the
    tip's circle of radius ``tool_radius`` [m]. The second holds the engagement: the force
    enters z_re directly through the static correction and the tool's compliance, and the
    sampled force places its step at the plate's edges to one sample, which the whole-plate
    PV reads (4096 samples at 300 rpm: PV 0.51 % from 4x the sampling; 8192: 0.19 %). The
    surface metrics, z_re and the accelerometer's peak then lie within 0.5 % of four times the
    sampling (tests/test_convergence.py). The tool carrier's mode ``tool_hz`` [Hz] (0: none,
    :mod:`ufmt.machining.tool`) asks for SAMPLES_PER_TOOL_PERIOD per period, as far as
    MAX_SAMPLES_PER_REV allows: the force's entry step is sampled as a ramp over about one
    sample, which excites the carrier's ringing by sinc(w_t dt / 2) of the step's, an error
    of second order in dt (at 4 samples per period a tenth of the ringing)."""
    need = max(
        SAMPLES_PER_MODE_PERIOD * highest_hz / spindle_hz,
        SAMPLES_PER_GRID_STEP * 2 * math.pi * tool_radius / grid_step,
        min(SAMPLES_PER_TOOL_PERIOD * tool_hz / spindle_hz, MAX_SAMPLES_PER_REV),
    )
    return max(MIN_SAMPLES_PER_REV, 1 << max(0, math.ceil(math.log2(max(need, 1.0)))))


@dataclass(frozen=True, eq=False)
class CutGeometry:
    """Process-independent data of one (basis, machine, force coefficients, n_phi, table_rows,
    force part, static correction).

    part: "area" or "edge" (:data:`~ufmt.machining.cutting.FORCE_PARTS`): the pattern and the
    force vector below are that part's. residual: the static correction (or None);
    static_tool, static_work (3, N, 3) or None: the residual-flexibility displacement of the
    tool tip and of the workpiece point per unit pattern, as a quadratic in Y (coefficients of
    Y^0, Y^1, Y^2); static_hat (3, 7) the complex Fourier coefficients (harmonics -3..3) of
    their z difference per power of Y, which the periodic path adds to its kernels (exact:
    force, arms and so the displacement of the residual flexibility are trigonometric
    polynomials of degree <= 3 in phi).

    phases (N,) [rad]; tip (N, 3) tool-tip position [m] and dtip, ddtip (N, 3) its first and
    second derivatives in phi [m]; w (n, N) modal force per unit chip area,
    (V_tool - V_work)(p) . k / M_s with k from :func:`force_vector` [N/(kg m^2)];
    c (n, N) relative z translation (V_tool - V_work)_z(p) [m], both at slide position Y = 0;
    w_y (n, N) [N/(kg m^3)] and c_y (n,) [m/m] their rates of change with Y (the workpiece's
    rotation times the moving arm). w, w_y and c are trigonometric polynomials in phi (degree
    2, 1 and 1): w_hat, w_y_hat (n, 5) and c_hat (n, 3) hold their complex Fourier coefficients
    (harmonics -2..2, -1..1), w_trig, w_y_trig (n, 5) and c_trig (3, n) the real ones on
    ``trig`` (5, N) = [1, cos, sin, cos 2phi, sin 2phi]. table_y (M,) slide positions [m] of
    the periodic table and row_knots their row coordinate (see
    :class:`~ufmt.machining.response.ZreTable`); active (N,) the angles that cut at some slide
    position.

    shapes (n, 12) the tool and workpiece bodies' motions, maps and static_maps their
    :class:`_PartMaps` (centres of the basis and of the residual): w, w_y, c and the static
    terms are products of them, formed at all N angles on first use (read-only); w, w_y and c
    at a few samples by :meth:`modal_at` (the periodic path reads only those).
    """

    basis: ModalBasis
    machine: Machine
    coefficients: ForceCoefficients
    n_phi: int
    table_rows: int
    phases: np.ndarray
    tip: np.ndarray
    dtip: np.ndarray
    ddtip: np.ndarray
    c_y: np.ndarray
    w_hat: np.ndarray
    w_y_hat: np.ndarray
    c_hat: np.ndarray
    w_trig: np.ndarray
    w_y_trig: np.ndarray
    c_trig: np.ndarray
    trig: np.ndarray
    table_y: np.ndarray
    row_knots: tuple[float, float, np.ndarray]
    active: np.ndarray
    shapes: np.ndarray
    maps: _PartMaps
    part: str = "area"
    residual: ResidualFlexibility | None = None
    static_maps: _PartMaps | None = None

    def modal_at(self, samples) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """w, w_y and c (n, S) at the sample indices ``samples`` (S,) (a slice: all of them)."""
        n = self.n_phi
        samples = np.arange(n)[samples]
        maps = self.maps.modal[:, (np.arange(3)[:, None] * n + samples).ravel()]  # no copy of all
        out = self.shapes @ maps
        size = out.shape[1] // 3
        mass = self.basis.modal_mass[:, None]
        return out[:, :size] / mass, out[:, size : 2 * size] / mass, out[:, 2 * size :]

    @cached_property
    def _modal(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        out = self.modal_at(slice(None))
        for a in out:  # cached: shared by every later read
            a.setflags(write=False)
        return out

    @property
    def w(self) -> np.ndarray:
        """Modal force per unit pattern at Y = 0, (n, N) (class docstring)."""
        return self._modal[0]

    @property
    def w_y(self) -> np.ndarray:
        """Rate of w in Y, (n, N) (class docstring)."""
        return self._modal[1]

    @property
    def c(self) -> np.ndarray:
        """Relative z translation at Y = 0, (n, N) [m] (class docstring)."""
        return self._modal[2]

    @cached_property
    def _static(self) -> tuple[np.ndarray, np.ndarray, np.ndarray] | tuple[None, None, None]:
        if self.residual is None:
            return None, None, None
        tool, work = self.static_maps.static(self.residual.matrix)
        rel = np.fft.fft(tool[..., 2] - work[..., 2], axis=1) / self.n_phi
        out = (tool, work, rel[:, np.arange(-3, 4) % self.n_phi])
        for a in out:  # cached: shared by every later read
            a.setflags(write=False)
        return out

    @property
    def static_tool(self) -> np.ndarray | None:
        """Static correction of the tool tip per unit pattern, (3, N, 3) [m], or None."""
        return self._static[0]

    @property
    def static_work(self) -> np.ndarray | None:
        """Static correction of the workpiece point per unit pattern, (3, N, 3) [m], or None."""
        return self._static[1]

    @property
    def static_hat(self) -> np.ndarray | None:
        """Harmonics -3..3 of the static z difference per power of Y, (3, 7) [m], or None."""
        return self._static[2]

    def static_at(self, j, slide_y) -> tuple[np.ndarray, np.ndarray]:
        """Static-correction displacement of tool tip and workpiece point per unit pattern.

        ``j`` phase indices and ``slide_y`` [m] broadcast; returns two (..., 3) arrays [m].
        """
        y = np.asarray(slide_y, dtype=float)[..., None]
        tool = self.static_tool[0][j] + y * (self.static_tool[1][j] + y * self.static_tool[2][j])
        work = self.static_work[0][j] + y * (self.static_work[1][j] + y * self.static_work[2][j])
        return tool, work


@lru_cache(maxsize=8)
def cut_geometry(
    basis: ModalBasis,
    machine: Machine,
    coefficients: ForceCoefficients = DEFAULT_COEFFICIENTS,
    n_phi: int = DEFAULT_N_PHI,
    table_rows: int = DEFAULT_TABLE_ROWS,
    part: str = "area",
    residual: ResidualFlexibility | None = None,
) -> CutGeometry:
    """Precompute what does not depend on the process (cached per arguments).

    ``part``: the force part ("area" cutting, "edge" ploughing); ``residual``: the static
    correction of the basis (none: modal superposition alone).

    ``n_phi`` force samples per revolution (even, >= 8). ``table_rows`` slide positions of the
    periodic table over the cutting span: half of them evenly spaced, half where the chip
    pattern changes fastest (where the leading arc's top enters and leaves the workpiece edges
    the engaged arc grows like the square root of the slide travel), plus the two ends of the
    steady span.
    """
    for body in (machine.tool_body, machine.workpiece_body):
        if body not in basis.body_shapes:
            raise KeyError(f"machine body {body!r} has no mode shapes in the basis")
    if n_phi < 8 or n_phi % 2:
        raise ValueError(f"n_phi must be even and >= 8, got {n_phi}")
    if table_rows < 3:
        raise ValueError(f"table_rows must be >= 3, got {table_rows}")
    bodies = (machine.tool_body, machine.workpiece_body)
    maps = _part_maps(machine, _centers(basis, bodies), coefficients, n_phi, part)
    shapes = np.concatenate([basis.body_shapes[b] for b in bodies], axis=1)  # (n, 12)
    shapes.setflags(write=False)
    mass = basis.modal_mass[:, None]
    hats = shapes @ maps.harmonics
    w_hat, w_y_hat, c_hat = hats[:, :5] / mass, hats[:, 5:10] / mass, hats[:, 10:]

    def real_form(hat):  # coefficients of [1, cos, sin, cos 2phi, sin 2phi]
        return np.stack(
            [hat[:, 2].real, 2 * hat[:, 3].real, -2 * hat[:, 3].imag]
            + [2 * hat[:, 4].real, -2 * hat[:, 4].imag],
            axis=1,
        )

    c_trig = np.stack([c_hat[:, 1].real, 2 * c_hat[:, 2].real, -2 * c_hat[:, 2].imag])
    table_y, row_knots, active, _ = pattern_tables(machine, n_phi, table_rows, part)
    static_maps = None
    if residual is not None:
        centers = tuple(residual.centers.ravel().tolist())
        static_maps = _part_maps(machine, centers, coefficients, n_phi, part)
    return CutGeometry(
        basis=basis,
        machine=machine,
        coefficients=coefficients,
        n_phi=n_phi,
        table_rows=table_rows,
        phases=maps.phases,
        tip=maps.tip,
        dtip=maps.dtip,
        ddtip=maps.ddtip,
        c_y=shapes @ maps.modal[:, 3 * n_phi],
        w_hat=w_hat,
        w_y_hat=w_y_hat,
        c_hat=c_hat,
        w_trig=real_form(w_hat),
        w_y_trig=real_form(w_y_hat),
        c_trig=c_trig,
        trig=maps.trig,
        table_y=table_y,
        row_knots=row_knots,
        active=active,
        shapes=shapes,
        maps=maps,
        part=part,
        residual=residual,
        static_maps=static_maps,
    )


def _centers(basis: ModalBasis, bodies: tuple[str, ...]) -> tuple[float, ...]:
    """The bodies' centres of mass [m], flattened (a cache key of :func:`_part_maps`)."""
    return tuple(np.concatenate([basis.body_centers[b] for b in bodies]).tolist())


@dataclass(frozen=True, eq=False)
class _PartMaps:
    """Design-independent maps of :func:`cut_geometry` for one force part (all read-only).

    The mode shapes enter the geometry only through the tool and workpiece bodies' motions
    v (n, 12) = [r_tool, theta_tool, r_work, theta_work] (paper eq. 3.11 with a point force):
    modal (12, 3 N + 1) maps them to [w M_s, w_y M_s, c, c_y] at the N angles and harmonics
    (12, 13) to [w_hat M_s (5), w_y_hat M_s (5), c_hat (3)]. phases, tip, dtip, ddtip, trig as
    in :class:`CutGeometry`. The static correction's, formed on first use (a geometry without
    the static correction never reads them): arms (N, 2, 3) [m] of the tip from the tool's and
    the workpiece's centre of mass ``centers`` (2, 3) [m] at Y = 0, wrench (2, N, 12) the
    bodies' load per unit pattern at Y = 0 and its rate in Y [N, N m per unit].
    """

    phases: np.ndarray
    tip: np.ndarray
    dtip: np.ndarray
    ddtip: np.ndarray
    trig: np.ndarray
    modal: np.ndarray
    harmonics: np.ndarray
    centers: np.ndarray
    force: Callable[[np.ndarray], np.ndarray]

    @cached_property
    def arms(self) -> np.ndarray:
        arms = self.tip[:, None, :] - self.centers  # (N, 2, 3)
        arms.setflags(write=False)
        return arms

    @cached_property
    def wrench(self) -> np.ndarray:
        k = self.force(self.phases)
        t_y = _translation(np.array([0.0, 1.0, 0.0])) - _translation(np.zeros(3))
        wrench = np.zeros((2, self.phases.size, 12))  # the workpiece takes the reaction -k
        wrench[0, :, :6] = np.einsum("jci,jc->ji", _translation(self.arms[:, 0]), k)
        wrench[0, :, 6:] = -np.einsum("jci,jc->ji", _translation(self.arms[:, 1]), k)
        wrench[1, :, 6:] = -k @ t_y
        wrench.setflags(write=False)
        return wrench

    def static(self, matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Residual-flexibility displacement of tool tip and workpiece point per unit pattern
        as a quadratic in Y, each (3, N, 3) [m] (:class:`CutGeometry` static_tool,
        static_work), from the residual flexibility ``matrix`` (12, 12)."""
        u = (self.wrench @ matrix.T).reshape(2, -1, 4, 3)  # (Y^0, Y^1; N; r, theta per body)
        # a point at arm x moves r + theta x x; the workpiece arm grows by Y y_hat
        moved = u[:, :, ::2] + cross(u[:, :, 1::2], self.arms)  # (2, N, 2, 3)
        theta = u[:, :, 3]
        turn = np.stack([-theta[..., 2], np.zeros(theta.shape[:-1]), theta[..., 0]], axis=-1)
        tool = np.concatenate([moved[:, :, 0], np.zeros((1, *turn.shape[1:]))])
        return tool, np.stack([moved[0, :, 1], moved[1, :, 1] + turn[0], turn[1]])


@lru_cache(maxsize=4)  # ~0.6 MiB each: both force parts of two machines
def _part_maps(
    machine: Machine,
    centers: tuple[float, ...],
    coefficients: ForceCoefficients,
    n_phi: int,
    part: str,
) -> _PartMaps:
    """The :class:`_PartMaps` of ``machine`` with tool and workpiece centres of mass
    ``centers`` (6,) [m] (cached per machine, not per design)."""
    c_tool, c_work = np.reshape(centers, (2, 3))
    y_hat = np.array([0.0, 1.0, 0.0])

    def modal_maps(samples):  # (12, 3, samples): w M_s, w_y M_s and c per unit body motion
        phi = 2 * np.pi * np.arange(samples) / samples
        tip = tool_tip(phi, machine)
        k = force_vector(phi, machine, coefficients, part)
        rel = np.concatenate([_translation(tip - c_tool), -_translation(tip - c_work)], axis=2)
        lever = np.zeros((samples, 12))  # rel(Y) = rel(0) + Y y_hat x theta_work
        lever[:, 9:] = np.cross(k, y_hat)  # (y_hat x theta) . k = theta . (k x y_hat)
        return np.stack([np.einsum("jci,jc->ij", rel, k), lever.T, rel[:, 2].T], axis=1)

    def harmonics(values, orders):  # complex Fourier coefficients from 8 exact samples
        return np.fft.fft(values, axis=-1)[:, orders % 8] / 8

    fine, coarse = modal_maps(n_phi), modal_maps(8)  # 8 samples resolve degree 2
    c_y = np.zeros((12, 1))
    c_y[9] = -1.0  # (y_hat x theta_work)_z
    modal = np.concatenate([fine.reshape(12, -1), c_y], axis=1)
    hats = [harmonics(coarse[:, 0], FORCE_HARMONICS), harmonics(coarse[:, 1], FORCE_HARMONICS)]
    hats = np.concatenate([*hats, harmonics(coarse[:, 2], OUTPUT_HARMONICS)], axis=1)
    phases = 2 * np.pi * np.arange(n_phi) / n_phi
    tip = tool_tip(phases, machine)
    dtip, ddtip = tool_tip_rates(phases, machine, 1 / (2 * np.pi))  # d/dphi, d^2/dphi^2
    trig = np.stack(
        [np.ones(n_phi), np.cos(phases), np.sin(phases), np.cos(2 * phases), np.sin(2 * phases)]
    )
    centres = np.stack([c_tool, c_work])
    arrays = (phases, tip, dtip, ddtip, trig, modal, hats, centres)
    for a in arrays:  # cached: shared by every design's geometry
        a.setflags(write=False)
    return _PartMaps(
        *arrays, partial(force_vector, machine=machine, coefficients=coefficients, part=part)
    )


@lru_cache(maxsize=4)  # ~1.6 MiB each: both force parts of two machines
def pattern_tables(machine: Machine, n_phi: int, table_rows: int, part: str):
    """Machine-only tables of :func:`cut_geometry` (cached per machine, not per design).

    Returns table_y, row_knots, the active angles (N,) and the chip pattern of ``part`` on
    them at the table rows (M, active); all read-only.
    """
    phases = 2 * np.pi * np.arange(n_phi) / n_phi
    cell = 2 * np.pi / n_phi
    table_y, row_knots = _table_rows(machine, table_rows)
    centred = np.mod(phases + np.pi, 2 * np.pi) - np.pi
    lo, hi = machine.cutting_angles
    active = (centred + cell / 2 > lo) & (centred - cell / 2 < hi) & (np.abs(centred) < np.pi / 2)
    cutting = chip_factor_cells(phases[active], table_y[:, None], machine, cell, part)
    for a in (table_y, active, cutting):
        a.setflags(write=False)
    return table_y, row_knots, active, cutting


def pattern_spectra(active: np.ndarray, cutting: np.ndarray) -> np.ndarray:
    """The extended half spectra (N/2 + 7, m) of the chip patterns ``cutting`` (m, active)
    on the ``active`` angles (N,) of :func:`pattern_tables` (a few rows at a time: not
    cached, the whole table's would be N M complex)."""
    pattern = np.zeros((cutting.shape[0], active.size))
    pattern[:, active] = cutting
    return np.ascontiguousarray(_extend(np.fft.rfft(pattern, axis=1)).T)


def _table_rows(machine: Machine, rows: int, uniform: float = UNIFORM_SHARE):
    """Slide positions [m] of the periodic table and the knots of its row coordinate.

    Rows sit at equal steps of a measure that is ``uniform`` slide travel and 1 - ``uniform``
    chip-pattern change (the travel of sin(phi) at the edges of the cut: the chip area between
    them is their difference), plus the ends of the steady span (kinks of the pattern). A slide
    position between two rows is placed by that measure too (knots (Y, fractional row)): where
    an edge of the cut moves like the square root of the travel, the table then interpolates
    in the pattern's change rather than in Y.
    """
    y0, y1 = machine.cutting_span
    fine = np.linspace(y0, y1, 64 * rows)
    lo, hi = machine.cutting_angles
    p1, p2 = arc_y_bounds(fine, machine)
    edges = np.sin(np.clip(np.stack([p1, p2, -p1, -p2]), lo, hi))
    moved = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(edges, axis=1)).sum(axis=0))])
    measure = np.linspace(0.0, uniform, fine.size) + (1 - uniform) * moved / max(moved[-1], 1e-300)
    ys = np.interp(np.linspace(0.0, 1.0, rows), measure, fine)
    kinks = [y for y in machine.steady_span if y0 < y < y1]
    table_y = np.unique(np.concatenate([ys, kinks]))
    at_rows = np.interp(table_y, fine, measure)
    u = np.interp(measure, at_rows, np.arange(table_y.size, dtype=float))
    return table_y, (y0, fine[1] - fine[0], u)


def _extend(half: np.ndarray, pad: int = 3) -> np.ndarray:
    """Half spectrum (..., N/2 + 1) of a real signal, extended by ``pad`` bins at both ends."""
    left = np.conj(half[..., pad:0:-1])
    right = np.conj(half[..., -2 : -2 - pad : -1])
    return np.concatenate([left, half, right], axis=-1)


def _translation(arm: np.ndarray) -> np.ndarray:
    """(..., 3, 6) maps [r; θ] -> r + θ × arm of points at ``arm`` (..., 3) [m] from a body's
    reference point: the translation rows of :func:`ufmt.assembled.point_motion`."""
    return point_motion(arm)[..., :3, :]


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b for (..., 3) arrays (np.cross without its axis handling)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)
