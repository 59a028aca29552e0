"""Modal response to the fly-cutting force (paper eqs. 3.9-3.13), two paths.

Each modal coordinate obeys q'' + 2 zeta w q' + w^2 q = f_s(t), f_s = <f, V^s> / M_s (eq. 3.11),
with zero initial conditions (eqs. 3.12-3.13). For the point force F at the tool tip p on the
tool body and its reaction on the workpiece body at the same point, f_s = (V_tool,s(p) -
V_work,s(p)) . F / M_s, where V_b,s(p) is the translation of point p of body b in mode s.

The force is sampled at ``n_phi`` equally spaced spindle angles per revolution (each sample
the mean of the chip factor over its cell, :func:`~ufmt.machining.cutting.chip_factor_cells`)
and taken as piecewise linear between samples (first-order hold). Both paths solve that forced
problem exactly, so they differ only by the start-up transient and by the quasi-static
assumption of (b):

(a) time domain, :func:`time_response`: every revolution of the whole cut, each modal equation
    advanced by the exact recurrence of its first-order-hold solution (:func:`discretise`,
    :func:`real_recurrence`, run by ``scipy.signal.lfilter``), from zero initial conditions.
(b) periodic, :func:`periodic_response`: for a fixed slide position Y the force is periodic in the
    spindle period; its periodic steady state is obtained per harmonic with the receptance of the
    same exact recurrence (FFT, receptance, inverse FFT), or at a few samples as a sum over the
    cutting angles with the recurrence's periodic impulse response (its inverse DFT). The slide
    moves only v/f = 10-80 um per revolution while the slowest mode settles in a few revolutions, so
    the steady state at each Y is taken as the response while the slide passes Y (quasi-static in
    Y), tabulated at ``table_rows`` slide positions. Where the leading arc crosses the whole plate
    width the chip pattern is the same every revolution and (a) converges to (b) exactly
    (tests/test_response.py). Where the arc's top enters and leaves the plate, the table's
    resolution in Y limits (b): the points along the plate's entry and exit edges are cut just as
    the tip crosses an edge, where z_re changes within a revolution or two, and they can set the
    whole-plate PV. Measured on the prior UFMT model (four processes of Table 1), the whole-plate PV
    of (b) is 0.6-5.6 % below (a) with 96 rows, 0.05-2.4 % with the default 192 and 0.02-0.7 % with
    384 (cost of (b) roughly linear in the rows). Use (a) for reference values, (b) for fast
    studies.

Both paths solve each force part (cutting "area" and ploughing "edge", see
:mod:`ufmt.machining.cutting`) with its own :class:`CutGeometry`; the response is linear, so
:func:`combine` adds the parts. With a :class:`~ufmt.machining.static.ResidualFlexibility`
the quasi-static response of the modes above the basis (the static correction) is added to
the displacements and to z_re (not to the tool-tip acceleration: those modes respond
quasi-statically, with accelerations of the order of the force's own rate of change).

Mode shapes are those of the nominal configuration, taken as the halfway point of the cut (see
:mod:`ufmt.machining.basis`). The workpiece is loaded at the material point under the tool: its
arm from the workpiece body's centre of mass is p - C + Y y_hat, so the workpiece terms of the
modal force and of z_re are linear in the slide position Y (``*_y`` in :class:`CutGeometry`).

Modal damping (not part of the basis): ``DEFAULT_ZETA`` = 0.03 for every mode. Modal damping
ratios measured on precision machine structures with bolted and aerostatic joints lie around
0.01-0.05; aerostatic films add little damping, granite beds and bolted joints most of it, so
the middle of that band is taken. A per-mode array overrides it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np
from scipy.signal import lfilter
from threadpoolctl import threadpool_limits

from ufmt.assembled import point_motion
from ufmt.machining.basis import ModalBasis
from ufmt.machining.cutting import (
    ForceCoefficients,
    arc_y_bounds,
    chip_factor_cells,
    cutting_force,
    force_vector,
    part_amplitude,
    tool_tip,
    tool_tip_rates,
)
from ufmt.machining.static import ResidualFlexibility
from ufmt.model.machine import Machine

DEFAULT_ZETA = 0.03
#: Force samples per spindle revolution (both paths): the PV converges as 1/n_phi^2 and is
#: within 0.1 % of its limit at 512 (tests/test_response.py).
DEFAULT_N_PHI = 512
#: Slide positions of the periodic path's table (see :func:`cut_geometry` and the accuracy
#: note above).
DEFAULT_TABLE_ROWS = 192
#: Share of the table rows spread evenly in slide travel; the rest follow the chip pattern.
UNIFORM_SHARE = 0.1
DEFAULT_COEFFICIENTS = ForceCoefficients()
#: Modal state of the time path, relative to the largest modal coordinate so far, below which
#: a force-free block after the cut is taken as zero (1e-20 of the response: far below any
#: printed digit, and it stops the decay before it reaches subnormal numbers).
NEGLIGIBLE_STATE = 1e-20
#: Spindle periods in the time path's record window (paper Figs. 6-7 show 2 s = 10 periods).
DEFAULT_RECORD_PERIODS = 10

_HARM_W = np.arange(-2, 3)  # harmonics of the modal-force shape w_s(phi)
_HARM_C = np.arange(-1, 2)  # harmonics of the output shape c_s(phi)


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


def modal_damping(zeta, n_modes: int) -> np.ndarray:
    """Per-mode damping ratios (n,) from a scalar or an (n,) array; each must be in (0, 1)."""
    z = np.broadcast_to(np.asarray(zeta, dtype=float), (n_modes,)).copy()
    if not np.all((z > 0) & (z < 1)):
        raise ValueError(f"modal damping ratios must lie in (0, 1), got {zeta!r}")
    return z


def _phi1_phi2(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """phi1 = (e^x - 1)/x and phi2 = (e^x - 1 - x)/x^2 for complex x, stable at small |x|."""
    small = np.abs(x) < 0.1
    xs = np.where(small, 1.0, x)
    p1 = np.expm1(xs) / xs
    p2 = (p1 - 1.0) / xs
    if not small.any():
        return p1, p2
    t = np.where(small, x, 0.0)
    s1 = 1 + t / 2 + t**2 / 6 + t**3 / 24 + t**4 / 120 + t**5 / 720
    s2 = 0.5 + t / 6 + t**2 / 24 + t**3 / 120 + t**4 / 720 + t**5 / 5040
    return np.where(small, s1, p1), np.where(small, s2, p2)


def discretise(omega, zeta, dt: float):
    """Exact first-order-hold discretisation of q'' + 2 zeta w q' + w^2 q = f (eq. 3.11).

    With the pole lambda = -zeta w + i w_d and z' = lambda z + f / (2 i w_d), q = 2 Re z and
    q' = 2 Re(lambda z). For f linear between samples the exact recurrence is
    z_k = E z_{k-1} + b0 f_k + b1 f_{k-1}.

    Returns
    -------
    lam, E, b0, b1 : (n,) complex pole [1/s], e^(lambda dt), and input weights [s^2].
    """
    omega = np.asarray(omega, dtype=float)
    zeta = np.asarray(zeta, dtype=float)
    wd = omega * np.sqrt(1.0 - zeta**2)
    lam = -zeta * omega + 1j * wd
    r = 1.0 / (2j * wd)
    x = lam * dt
    p1, p2 = _phi1_phi2(x)
    return lam, np.exp(x), r * dt * p2, r * dt * (p1 - p2)


def discrete_receptance(omega, zeta, dt: float, theta) -> tuple[np.ndarray, np.ndarray]:
    """Periodic steady-state transfer of the exact recurrence at angles theta = 2 pi k / N.

    Returns (H_q, H_v), each (n, K) complex [s^2, s]: the DFT of q (of q') over one period is
    H times the DFT of the sampled modal force. As dt -> 0 at fixed frequency, H_q tends to the
    modal receptance 1 / (w^2 - W^2 + 2 i zeta w W).
    """
    lam, e, b0, b1 = (a[:, None] for a in discretise(omega, zeta, dt))
    zp = np.exp(-1j * np.asarray(theta, dtype=float))[None, :]
    zm = np.conj(zp)
    tf_p = (b0 + b1 * zp) / (1.0 - e * zp)
    tf_m = (b0 + b1 * zm) / (1.0 - e * zm)
    return tf_p + np.conj(tf_m), lam * tf_p + np.conj(lam * tf_m)


@dataclass(frozen=True, eq=False)
class PeriodicRecurrence:
    """The exact recurrence (:func:`discretise`) over a period of N samples.

    lam, e, b0, b1 (n,) as :func:`discretise` returns them; powers (n, N) E^l for
    l = 0..N - 1, the product of E^(B a) and E^b for l = B a + b (B ~ sqrt(N): two short
    tables of exponentials); period (n,) E^N.
    """

    lam: np.ndarray
    e: np.ndarray
    b0: np.ndarray
    b1: np.ndarray
    powers: np.ndarray
    period: np.ndarray

    def impulse(self, lags) -> np.ndarray:
        """Complex state z_l (n, ...) at integer ``lags`` in 0..N - 1 of the periodic steady
        state under one unit force sample per period, at sample 0.

        z_l = (b0 E^l + b1 E^((l - 1) mod N)) / (1 - E^N); q = 2 Re z [s^2] and
        q' = 2 Re(lambda z) [s], whose DFTs over the period are :func:`discrete_receptance`'s
        H_q and H_v.
        """
        lags = np.asarray(lags)
        flat = lags.ravel()
        previous = self.powers[:, flat - 1]  # index -1 is E^(N - 1)
        z = (self.b0[:, None] * self.powers[:, flat] + self.b1[:, None] * previous) / (
            1.0 - self.period[:, None]
        )
        return z.reshape(-1, *lags.shape)


def periodic_recurrence(omega, zeta, dt: float, n_samples: int) -> PeriodicRecurrence:
    """:class:`PeriodicRecurrence` of modes ``omega`` [rad/s], ``zeta``, step ``dt`` [s] over
    ``n_samples`` samples."""
    lam, e, b0, b1 = discretise(omega, zeta, dt)
    step = math.isqrt(n_samples - 1) + 1
    fine = np.exp(np.outer(lam, dt * np.arange(step)))
    coarse = np.exp(np.outer(lam, dt * step * np.arange(-(-n_samples // step))))
    powers = (coarse[:, :, None] * fine[:, None, :]).reshape(lam.size, -1)[:, :n_samples]
    return PeriodicRecurrence(lam, e, b0, b1, powers, np.exp(lam * (dt * n_samples)))


def real_recurrence(omega, zeta, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """The recurrence of :func:`discretise` for q itself, as real filter coefficients.

    q_k = b[0] f_k + b[1] f_{k-1} + b[2] f_{k-2} - a[1] q_{k-1} - a[2] q_{k-2}
    (``scipy.signal.lfilter(b, a, f)`` form). Returns (b, a), each (n, 3).
    """
    _, e, b0, b1 = discretise(omega, zeta, dt)
    ec = np.conj(e)
    num = np.stack([2 * b0.real, 2 * (b1 - b0 * ec).real, -2 * (b1 * ec).real], axis=1)
    den = np.stack([np.ones_like(e.real), -2 * e.real, np.abs(e) ** 2], axis=1)
    return num, den


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
    the periodic table and row_knots their row coordinate (see :class:`ZreTable`); active (N,)
    the angles that cut at some slide position.

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
        maps = self.maps.modal[:, : 3 * n].reshape(12, 3, n)[:, :, samples].reshape(12, -1)
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
    table_y, row_knots, _, active, _ = _pattern_tables(machine, n_phi, table_rows, part)
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
    in :class:`CutGeometry`. The static correction's: arms (N, 2, 3) [m] of the tip from the
    tool's and the workpiece's centre of mass at Y = 0, wrench (2, N, 12) the bodies' load per
    unit pattern at Y = 0 and its rate in Y [N, N m per unit].
    """

    phases: np.ndarray
    tip: np.ndarray
    dtip: np.ndarray
    ddtip: np.ndarray
    trig: np.ndarray
    modal: np.ndarray
    harmonics: np.ndarray
    arms: np.ndarray
    wrench: np.ndarray

    def static(self, matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Residual-flexibility displacement of tool tip and workpiece point per unit pattern
        as a quadratic in Y, each (3, N, 3) [m] (:class:`CutGeometry` static_tool,
        static_work), from the residual flexibility ``matrix`` (12, 12)."""
        u = (self.wrench @ matrix.T).reshape(2, -1, 4, 3)  # (Y^0, Y^1; N; r, theta per body)
        # a point at arm x moves r + theta x x; the workpiece arm grows by Y y_hat
        moved = u[:, :, ::2] + _cross(u[:, :, 1::2], self.arms)  # (2, N, 2, 3)
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
    hats = [harmonics(coarse[:, 0], _HARM_W), harmonics(coarse[:, 1], _HARM_W)]
    hats = np.concatenate([*hats, harmonics(coarse[:, 2], _HARM_C)], axis=1)
    phases = 2 * np.pi * np.arange(n_phi) / n_phi
    tip = tool_tip(phases, machine)
    dtip, ddtip = tool_tip_rates(phases, machine, 1 / (2 * np.pi))  # d/dphi, d^2/dphi^2
    trig = np.stack(
        [np.ones(n_phi), np.cos(phases), np.sin(phases), np.cos(2 * phases), np.sin(2 * phases)]
    )
    k = force_vector(phases, machine, coefficients, part)
    arms = np.stack([tip - c_tool, tip - c_work], axis=1)  # (N, 2, 3)
    t_y = _translation(y_hat) - _translation(np.zeros(3))
    wrench = np.zeros((2, n_phi, 12))  # the workpiece takes the reaction -k
    wrench[0, :, :6] = np.einsum("jci,jc->ji", _translation(arms[:, 0]), k)
    wrench[0, :, 6:] = -np.einsum("jci,jc->ji", _translation(arms[:, 1]), k)
    wrench[1, :, 6:] = -k @ t_y
    arrays = (phases, tip, dtip, ddtip, trig, modal, hats, arms, wrench)
    for a in arrays:  # cached: shared by every design's geometry
        a.setflags(write=False)
    return _PartMaps(*arrays)


@lru_cache(maxsize=4)  # ~1.6 MiB each: both force parts of two machines
def _pattern_tables(machine: Machine, n_phi: int, table_rows: int, part: str):
    """Machine-only tables of :func:`cut_geometry` (cached per machine, not per design).

    Returns table_y, row_knots, the extended half spectra (N/2 + 7, M) of the chip pattern of
    ``part`` at the table rows, the active angles (N,) and the pattern on them (M, active); all
    read-only.
    """
    phases = 2 * np.pi * np.arange(n_phi) / n_phi
    cell = 2 * np.pi / n_phi
    table_y, row_knots = _table_rows(machine, table_rows)
    centred = np.mod(phases + np.pi, 2 * np.pi) - np.pi
    lo, hi = machine.cutting_angles
    active = (centred + cell / 2 > lo) & (centred - cell / 2 < hi) & (np.abs(centred) < np.pi / 2)
    pattern = np.zeros((table_y.size, n_phi))
    pattern[:, active] = chip_factor_cells(phases[active], table_y[:, None], machine, cell, part)
    spectra = np.ascontiguousarray(_extend(np.fft.rfft(pattern, axis=1)).T)  # (N/2 + 7, M)
    cutting = pattern[:, active]
    for a in (table_y, spectra, active, cutting):
        a.setflags(write=False)
    return table_y, row_knots, spectra, active, cutting


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
        samples, weights = _cubic_weights(phi, self.values.shape[1] - 3)
        padded = np.mod(samples + 1, self.values.shape[1])  # column c holds sample c - 1
        return sum(self.values[:, padded[i]] * weights[i] for i in range(4))


def _cubic_weights(phi: np.ndarray, n_phi: int) -> tuple[np.ndarray, np.ndarray]:
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
class PeriodicZreTable:
    """The periodic path's z_re table (:class:`ZreTable` layout, drift 0), evaluated where it
    is read.

    The chip pattern is zero except on the few ``active`` angles of the cut, so z_re at a
    sample j is a short sum over them: z_re[i, j] = sum_(part, p) amp Y_i^p
    sum_m T_(part, p)[j, m] A_part[i, m] with the periodic impulse response of the exact
    recurrence (:meth:`PeriodicRecurrence.impulse`) in the kernels T, the static correction on
    their diagonal. :meth:`columns` evaluates the samples the surface reads (a few tens);
    ``values``, the whole table by the harmonics (:func:`periodic_response`), is computed on
    first use. parts: the force parts' geometries; amps [m^2 or m] their amplitudes times the
    force scale; spindle_hz [Hz]; zeta (n,) modal damping.
    """

    parts: tuple[CutGeometry, ...]
    amps: np.ndarray
    spindle_hz: float
    zeta: tuple[float, ...]
    row_y: np.ndarray
    row_knots: tuple[float, float, np.ndarray]
    drift: float = 0.0

    @cached_property
    def values(self) -> np.ndarray:
        """The whole table (rows, N + 3) [m], padded periodically (see :class:`ZreTable`)."""
        geo = self.parts[0]
        n = geo.n_phi
        half = n // 2
        kern = _periodic_kernels(self.parts, self.spindle_hz, self.zeta)
        # z_re[k, i] = sum_(d, part, p) amp K[k, (d, part, p)] Y_i^p A_part[k - d, i]: one
        # small product per harmonic over a strided view of the stacked spectra (no copy)
        stacked = _stacked_spectra(geo.machine, n, geo.table_rows, self.part_names)
        rows = stacked.shape[3]
        view = np.lib.stride_tricks.as_strided(
            stacked,
            shape=(half + 1, 7 * stacked.shape[1] * 3, rows),
            strides=(stacked.strides[0], stacked.strides[2], stacked.strides[3]),
            writeable=False,
        )
        zk = np.matmul(kern * np.repeat(np.tile(self.amps, 7), 3), view)[:, 0]  # (N/2 + 1, M)
        values = np.empty((rows, n + 3))
        table = values[:, 1 : n + 1]
        np.fft.irfft(zk.T, n=n, axis=1, out=table)
        values[:, 0], values[:, n + 1 :] = table[:, -1], table[:, :2]
        values.setflags(write=False)
        return values

    @property
    def part_names(self) -> tuple[str, ...]:
        """The force parts ("area", "edge") of ``parts``."""
        return tuple(g.part for g in self.parts)

    def columns(self, phi: np.ndarray) -> np.ndarray:
        """Table columns at angles phi (arcs, Nx) [rad], 4-point Lagrange in phi [m]:
        (rows, arcs * Nx), from the samples the stencils touch only."""
        geo = self.parts[0]
        n = geo.n_phi
        plan = _column_plan(self.parts, tuple(np.ravel(phi).tolist()))
        z = _recurrence(geo.basis, n, self.spindle_hz, self.zeta).impulse(plan.lags)
        h = 2 * z.real.T  # q of the impulse response at the lags (L, n)
        # kernels of c^(a) and w^(b) (a, b = 0: at Y = 0, 1: rate in Y) for each angle m
        # and sample k: sum_s c^(a)_s[k] h_s[k - m] w^(b)_s[m]
        active, samples = plan.lag_index.shape
        ch = h[plan.lag_index][:, :, None, :] * plan.c  # (A, K, 2, n)
        kern = np.matmul(ch.reshape(active, 2 * samples, -1), plan.w)
        kern = kern.reshape(active, samples, 2, len(self.parts), 2)
        powers = np.stack(  # of Y: p = a + b
            [kern[..., 0, :, 0], kern[..., 0, :, 1] + kern[..., 1, :, 0], kern[..., 1, :, 1]],
            axis=-1,
        )  # (A, K, P, 3)
        powers += plan.static
        powers *= self.amps[:, None]
        at_samples = powers.transpose(0, 2, 3, 1).reshape(-1, samples) @ plan.stencil
        return plan.patterns @ at_samples


@dataclass(frozen=True)
class _ColumnPlan:
    """Process-independent data of :meth:`PeriodicZreTable.columns` at C angles, which read
    K samples.

    lags (L,) the distinct lags (sample - active angle) mod N and lag_index (A, K) each pair's;
    c (K, 2, n) the relative z translation at the samples at Y = 0 and its rate in Y [m, m/m];
    w (A, n, 2 P) each part's modal force at the active angles at Y = 0 and its rate in Y;
    static (A, K, P, 3) the static correction's z per power of Y where sample = angle;
    stencil (K, C) the Lagrange weights of the samples at each angle;
    patterns (M, A P 3) of :func:`_stacked_patterns`.
    """

    lags: np.ndarray
    lag_index: np.ndarray
    c: np.ndarray
    w: np.ndarray
    static: np.ndarray
    stencil: np.ndarray
    patterns: np.ndarray


@lru_cache(maxsize=4)
def _column_plan(parts: tuple[CutGeometry, ...], phi: tuple[float, ...]) -> _ColumnPlan:
    """The :class:`_ColumnPlan` of angles ``phi`` [rad] (cached per geometry and angles)."""
    geo = parts[0]
    j, stencil, active, lags, lag_index, hits = _column_samples(
        geo.n_phi, geo.active.tobytes(), phi
    )
    c = geo.modal_at(j)[2]
    c = np.stack([c.T, np.broadcast_to(geo.c_y, (j.size, geo.c_y.size))], axis=1)
    w = np.stack([a.T for g in parts for a in g.modal_at(active)[:2]], axis=2)
    static = np.zeros((active.size, j.size, len(parts), 3))
    hit_a, hit_k = hits
    for i, g in enumerate(parts):
        if g.static_tool is not None:  # the static correction acts at the sample itself
            rel = g.static_tool[:, j[hit_k], 2] - g.static_work[:, j[hit_k], 2]
            static[hit_a, hit_k, i] = rel.T
    names = tuple(g.part for g in parts)
    arrays = (np.ascontiguousarray(c), np.ascontiguousarray(w), static)
    for a in arrays:  # cached: shared by every later call
        a.setflags(write=False)
    return _ColumnPlan(
        lags,
        lag_index,
        *arrays,
        stencil,
        _stacked_patterns(geo.machine, geo.n_phi, geo.table_rows, names),
    )


@lru_cache(maxsize=4)  # per angle grid and cut mask, not per design
def _column_samples(n_phi: int, active: bytes, phi: tuple[float, ...]):
    """The sample indices of :func:`_column_plan` (cached per angles, not per design).

    ``active`` (N bools as bytes) the cut's angles. Returns the samples j (K,) the stencils
    of ``phi`` [rad] read, the stencil (K, C), the active angles (A,), the lags (L,), their
    lag_index (A, K) and the (angle, sample) index pairs where sample = angle; read-only.
    """
    samples, weights = _cubic_weights(np.array(phi), n_phi)
    j, where = np.unique(np.mod(samples, n_phi), return_inverse=True)
    stencil = np.zeros((j.size, len(phi)))
    for i in range(4):  # the four samples of a stencil are distinct
        stencil[where.reshape(samples.shape)[i], np.arange(len(phi))] = weights[i]
    active = np.flatnonzero(np.frombuffer(active, dtype=bool))
    lags, lag_index = np.unique(np.mod(j - active[:, None], n_phi), return_inverse=True)
    lag_index = lag_index.reshape(active.size, j.size)
    hits = np.nonzero(active[:, None] == j)
    for a in (j, stencil, active, lags, lag_index, *hits):
        a.setflags(write=False)
    return j, stencil, active, lags, lag_index, hits


@dataclass(frozen=True, eq=False)
class Response:
    """Response in a record window plus the z_re table of the whole cut.

    t (T,) time [s] (0 at the first touch of the cut); slide_y (T,) slide position Y [m];
    force (T, 3) force on the tool [N]; tip_disp, tip_acc (T, 3) tool-tip displacement [m]
    and acceleration [m/s^2]; work_disp (T, 3) workpiece displacement at the contact point
    [m]; z_re (T,) tool minus workpiece z displacement [m]; period [s] spindle period;
    periods: spindle periods in the window.
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
    table: ZreTable | PeriodicZreTable


def _outputs(geo: CutGeometry, j, slide, q, qd, qdd, spindle_hz: float):
    """Tool-tip displacement and acceleration, workpiece displacement, from modal coordinates.

    j (T,) phase indices; slide (T,) slide positions Y [m]; q, qd, qdd (n, T). The tip is a
    material point of the spinning tool body, so its acceleration is
    d^2/dt^2 sum_s [r_s + theta_s x (p(t) - C)] q_s(t), including the terms from the motion of
    p. The workpiece point under the tool sits at p - C + Y y_hat from its centre of mass.
    """
    b, m = geo.basis, geo.machine
    tool, work = b.body_shapes[m.tool_body], b.body_shapes[m.workpiece_body]
    arm_tool = geo.tip[j] - b.body_centers[m.tool_body]
    arm_work = geo.tip[j] - b.body_centers[m.workpiece_body]
    arm_work[:, 1] += slide
    moved = q.T @ np.concatenate([tool, work], axis=1)  # (T, 12) both bodies' motions
    om = 2 * np.pi * spindle_hz
    accel = qdd.T @ tool  # (T, 6)
    rot = np.stack([moved[:, 3:6], moved[:, 9:], accel[:, 3:], qd.T @ tool[:, 3:], moved[:, 3:6]])
    arm = np.stack([arm_tool, arm_work, arm_tool, 2 * om * geo.dtip[j], om**2 * geo.ddtip[j]])
    turn = _cross(rot, arm)  # (5, T, 3)
    acc = accel[:, :3] + turn[2] + turn[3] + turn[4]
    return moved[:, :3] + turn[0], acc, moved[:, 6:9] + turn[1]


def _translation(arm: np.ndarray) -> np.ndarray:
    """(..., 3, 6) maps [r; θ] -> r + θ × arm of points at ``arm`` (..., 3) [m] from a body's
    reference point: the translation rows of :func:`ufmt.assembled.point_motion`."""
    return point_motion(arm)[..., :3, :]


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b for (..., 3) arrays (np.cross without its axis handling)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def periodic_response(geo, process, zeta=DEFAULT_ZETA, force_scale: float = 1.0) -> Response:
    """Periodic steady state at each tabulated slide position (path b).

    The table (:class:`PeriodicZreTable`) is evaluated where it is read: at the few samples
    of the cut the surface reads, by the periodic impulse response over the active angles; the
    whole table by the harmonics on first use of its ``values``: per harmonic k,
    z_re[k] = sum_s sum_l c_hat[s,l] H_s[k-l] sum_m w_hat[s,m] A[k-l-m] = sum_d K_d[k] A[k-d],
    with A the spectrum of the chip factor (:func:`_stacked_spectra`) and H_s the receptance of
    :func:`discrete_receptance`; with the workpiece arm's Y terms the kernels are a quadratic
    in Y, sum_p Y^p K_pd. The record window is one spindle period at the slide position of
    :func:`record_slide`: the modal force there summed over the cut's angles with the periodic
    impulse response, free decay after them (:class:`PeriodicRecurrence`, cached per spindle
    speed and damping; the force per unit amplitude cached per geometry).

    ``geo``: one :class:`CutGeometry` or a sequence of them, the force parts of one force on
    the same basis, machine, n_phi and table rows: their responses are summed (each times its
    part's amplitude) before any transform, so the parts cost one.
    """
    parts = (geo,) if isinstance(geo, CutGeometry) else tuple(geo)
    geo = parts[0]
    zeta = modal_damping(zeta, geo.basis.n_modes)
    f = process.spindle_hz
    n = geo.n_phi
    amps = np.array([force_scale * part_amplitude(process, geo.machine, g.part) for g in parts])
    units = [_record_unit(g) for g in parts]
    fs = sum(amp * u.fs for amp, u in zip(amps, units, strict=True))
    q, qd = _periodic_state(_recurrence(geo.basis, n, f, tuple(zeta.tolist())), fs, geo.active)
    b = geo.basis
    qdd = fs - (2 * zeta * b.omega)[:, None] * qd - (b.omega**2)[:, None] * q
    y_rec = record_slide(geo.machine)
    tip, acc, work = _outputs(geo, np.arange(n), np.full(n, y_rec), q, qd, qdd, f)
    for amp, u in zip(amps, units, strict=True):
        if u.static_tip is not None:
            tip, work = tip + amp * u.static_tip, work + amp * u.static_work
    j = np.arange(n)
    return Response(
        method="periodic",
        t=(j + (y_rec - geo.machine.cut_span[0]) / process.feed_per_rev_m * n) / (f * n),
        slide_y=np.full(n, y_rec),
        force=sum(amp * u.force for amp, u in zip(amps, units, strict=True)),
        tip_disp=tip,
        tip_acc=acc,
        work_disp=work,
        z_re=tip[:, 2] - work[:, 2],
        period=1.0 / f,
        periods=1,
        table=PeriodicZreTable(parts, amps, f, tuple(zeta.tolist()), geo.table_y, geo.row_knots),
    )


@lru_cache(maxsize=4)  # ~0.3 MiB each
def _recurrence(basis: ModalBasis, n_phi: int, spindle_hz: float, zeta: tuple):
    """:func:`periodic_recurrence` of the basis at the spindle frequency [Hz] (cached per
    spindle speed and damping; its arrays read-only)."""
    out = periodic_recurrence(basis.omega, np.array(zeta), 1 / (spindle_hz * n_phi), n_phi)
    for a in (out.lam, out.e, out.b0, out.b1, out.powers, out.period):
        a.setflags(write=False)
    return out


@lru_cache(maxsize=8)
def _cut_run(active: bytes):
    """The circular run of the ``active`` samples (N bools as bytes): its first sample, its
    samples in order (A,), the distinct lags (L,) between them mod N and each pair's (A, A)."""
    active = np.frombuffer(active, dtype=bool)
    n = active.size
    first = int(np.flatnonzero(active & ~np.roll(active, 1))[0])
    a = int(np.count_nonzero(active))
    lags, pairs = np.unique(
        np.mod(np.subtract.outer(np.arange(a), np.arange(a)), n), return_inverse=True
    )
    pairs = pairs.reshape(a, a)
    run = (first + np.arange(a)) % n
    for arr in (run, lags, pairs):  # cached: shared by every later call
        arr.setflags(write=False)
    return first, run, lags, pairs


def _periodic_state(recurrence: PeriodicRecurrence, force: np.ndarray, active: np.ndarray):
    """Periodic steady state (q, q') (n, N) [m, m/s per unit modal force] of the recurrence
    under the modal force (n, N), zero outside the circular run of ``active`` (N,) samples.

    Within the run: its sum with the periodic impulse response; after it, the free decay E^l
    of the state after the run's last sample.
    """
    first, run, lags, pairs = _cut_run(active.tobytes())
    n, a = active.size, run.size
    f = force[:, run]
    inside = np.einsum("sjm,sm->sj", recurrence.impulse(lags)[:, pairs], f)
    after = recurrence.e * inside[:, -1] + recurrence.b1 * f[:, -1]  # no force there
    x = np.empty(force.shape, complex)  # from the run's first sample on
    x[:, :a] = inside
    np.multiply(recurrence.powers[:, : n - a], after[:, None], out=x[:, a:])
    x = np.roll(x, first, axis=1)
    return 2 * x.real, 2 * (recurrence.lam[:, None] * x).real


@lru_cache(maxsize=2)  # ~4.7 MiB each (two parts, 192 rows); machine-only
def _stacked_spectra(machine: Machine, n_phi: int, table_rows: int, parts: tuple[str, ...]):
    """The parts' extended spectra times Y^p at each row, (N/2 + 7, P, 3, M) (cached per
    machine: every design of a sweep shares it)."""
    tables = [_pattern_tables(machine, n_phi, table_rows, part) for part in parts]
    powers = tables[0][0] ** np.arange(3)[:, None]  # (3, M)
    out = np.stack([t[2] for t in tables], axis=1)[:, :, None, :] * powers
    out.setflags(write=False)
    return out


@lru_cache(maxsize=2)  # machine-only
def _stacked_patterns(machine: Machine, n_phi: int, table_rows: int, parts: tuple[str, ...]):
    """The parts' chip patterns on the active angles times Y^p at each row, (M, A P 3) in the
    order (angle, part, power p) (cached per machine: every design of a sweep shares it)."""
    tables = [_pattern_tables(machine, n_phi, table_rows, part) for part in parts]
    powers = tables[0][0][:, None, None, None] ** np.arange(3)  # (M, 1, 1, 3)
    out = (np.stack([t[4] for t in tables], axis=2)[..., None] * powers).reshape(
        powers.shape[0], -1
    )
    out.setflags(write=False)
    return out


@lru_cache(maxsize=16)
def _periodic_kernels(parts: tuple[CutGeometry, ...], spindle_hz: float, zeta: tuple):
    """Kernels of :attr:`PeriodicZreTable.values` (cached per spindle speed).

    Returns kern (N/2 + 1, 1, 21 P): for harmonic k and (shift, part, power p of Y) the kernel
    K_pd[k] of that part with d = 3 - shift (the order of the strided spectra view), the
    static correction's coefficients included (:class:`CutGeometry` ``static_hat``).
    """
    geo = parts[0]
    n = geo.n_phi
    half = n // 2
    k = np.arange(-1, half + 2)
    hq, _ = discrete_receptance(
        geo.basis.omega, np.array(zeta), 1 / (spindle_hz * n), 2 * np.pi * k / n
    )
    # one product of the receptances, shifted by each output harmonic l, with the coefficients
    coef, static = _kernel_coefficients(parts)
    shifted = np.concatenate([hq.T[1 - l : half + 2 - l] for l in _HARM_C], axis=1)  # (K, 3n)
    kern = (shifted @ coef + static).reshape(half + 1, 1, -1)
    kern.setflags(write=False)
    return kern


@lru_cache(maxsize=8)
def _kernel_coefficients(parts: tuple[CutGeometry, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients of the kernels of :func:`_periodic_kernels` (cached per geometry).

    K_pd[k] = sum_l sum_s coef[(l, s), (d, part, p)] H_s[k - l] + static[(d, part, p)]: the
    kernels of Y^0, Y^1, Y^2 from c = c_hat + Y c_y (harmonic 0 only) and
    w = w_hat + Y w_y_hat (output harmonic l, force harmonic m = d - l), and the static
    correction's Fourier coefficients. Columns in the order of the strided spectra view
    (shift 6 - d index, part, power). Returns coef (3 n, 21 P) and static (21 P,).
    """
    n_modes = parts[0].basis.n_modes
    coef = np.zeros((3, n_modes, 7, len(parts), 3), dtype=complex)  # (l, s, d, part, p)
    static = np.zeros((7, len(parts), 3), dtype=complex)
    for pi_, g in enumerate(parts):
        c_y = np.zeros_like(g.c_hat)
        c_y[:, 1] = g.c_y
        for pc, ch in enumerate((g.c_hat, c_y)):
            for pw, wh in enumerate((g.w_hat, g.w_y_hat)):
                for li in range(3):
                    coef[li, :, li : li + 5, pi_, pc + pw] += ch[:, li : li + 1] * wh
        if g.static_hat is not None:
            static[:, pi_, :] = g.static_hat.T
    coef = np.ascontiguousarray(coef[:, :, ::-1]).reshape(3 * n_modes, -1)
    static = np.ascontiguousarray(static[::-1]).reshape(-1)
    for a in (coef, static):
        a.setflags(write=False)
    return coef, static


@dataclass(frozen=True)
class _RecordUnit:
    """Record-window quantities of one force part per unit amplitude (process-independent).

    fs (n, N) the modal force; force (N, 3) the force on the tool [N per unit]; static_tip,
    static_work (N, 3) or None the static correction's displacements.
    """

    fs: np.ndarray
    force: np.ndarray
    static_tip: np.ndarray | None
    static_work: np.ndarray | None


@lru_cache(maxsize=8)
def _record_unit(geo: CutGeometry) -> _RecordUnit:
    """The record window of :func:`periodic_response` per unit amplitude (cached per geometry;
    the modal force formed on the cutting samples only)."""
    y_rec, chip, force, cut = _record_pattern(geo.machine, geo.coefficients, geo.n_phi, geo.part)
    w, w_y, _ = geo.modal_at(cut)
    fs = np.zeros((geo.basis.n_modes, geo.n_phi))
    fs[:, cut] = (w + y_rec * w_y) * chip[cut]
    static_tip = static_work = None
    if geo.static_tool is not None:
        s_tool, s_work = geo.static_at(slice(None), y_rec)
        static_tip, static_work = chip[:, None] * s_tool, chip[:, None] * s_work
    for a in (fs, static_tip, static_work):
        if a is not None:
            a.setflags(write=False)
    return _RecordUnit(fs, force, static_tip, static_work)


@lru_cache(maxsize=4)  # machine-only
def _record_pattern(machine: Machine, coefficients: ForceCoefficients, n_phi: int, part: str):
    """The record window's slide position [m], chip pattern (N,), force on the tool per unit
    amplitude (N, 3) [N] and the samples where the pattern is not zero (cached per machine;
    arrays read-only)."""
    phases = 2 * np.pi * np.arange(n_phi) / n_phi
    y_rec = record_slide(machine)
    chip = chip_factor_cells(phases, y_rec, machine, 2 * np.pi / n_phi, part)
    force = chip[:, None] * force_vector(phases, machine, coefficients, part)
    cut = np.flatnonzero(chip)
    for a in (chip, force, cut):
        a.setflags(write=False)
    return y_rec, chip, force, cut


def time_response(
    geo,
    process,
    zeta=DEFAULT_ZETA,
    force_scale: float = 1.0,
    record_periods: int = DEFAULT_RECORD_PERIODS,
    block_samples: int = 1 << 15,
) -> Response:
    """Whole-workpiece response from zero initial conditions (path a; eqs. 3.11-3.13).

    Every revolution from the first touch of the leading arc (slide position Y_start) until
    the trailing arc has left the workpiece. Each modal equation is advanced by its exact
    recurrence (:func:`real_recurrence`, ``scipy.signal.lfilter``) in blocks of about
    ``block_samples`` samples, the filter state carried from block to block; modal forces and
    z_re are matrix products over the modes (w and c are trigonometric in phi). The record
    window holds ``record_periods`` revolutions centred on :func:`record_slide`; there the
    modal velocities come from the exact complex-pole state recovered from q_{k-1}, q_k.
    Memory: the z_re table takes 8 n_phi bytes per revolution.

    ``geo``: one :class:`CutGeometry` or a sequence of them, the force parts of one force on
    the same basis, machine and n_phi: their modal forces are summed before the recurrence,
    so the parts cost one pass.
    """
    parts = (geo,) if isinstance(geo, CutGeometry) else tuple(geo)
    geo = parts[0]
    b, mach = geo.basis, geo.machine
    n, nm = geo.n_phi, b.n_modes
    zeta = modal_damping(zeta, nm)
    f = process.spindle_hz
    dt = 1.0 / (f * n)
    delta = process.feed_per_rev_m
    amps = [force_scale * part_amplitude(process, mach, g.part) for g in parts]
    y_start, y_end = mach.cut_span
    n_rev = int(np.ceil((y_end - y_start) / delta)) + 1
    record_periods = max(1, min(record_periods, n_rev))
    middle = round((record_slide(mach) - y_start) / delta)
    rec0 = int(np.clip(middle - record_periods // 2, 0, n_rev - record_periods))
    rec1 = rec0 + record_periods
    num, den = real_recurrence(b.omega, zeta, dt)
    state = np.zeros((nm, 2))
    rows = np.empty((n_rev + 1, n + 3))  # padded as ZreTable wants: sample -1 and N, N + 1
    rec_q = np.zeros((nm, record_periods * n + 1))  # one sample before the window first
    step = max(1, block_samples // n)
    # the force is zero outside the angles that can cut: work on those runs of columns only
    edges = np.flatnonzero(np.diff(np.concatenate([[0], geo.active.astype(int), [0]])))
    runs = [slice(lo, hi) for lo, hi in zip(edges[::2], edges[1::2], strict=True)]
    forces = np.zeros((nm, step, n))
    peak = 0.0  # largest |q| so far
    static = np.zeros((step, n))  # static-correction z_re of a block
    w_both = [np.concatenate([g.w_trig, g.w_y_trig], axis=1) for g in parts]
    # skinny products over the modes: BLAS threads only add synchronisation here
    with threadpool_limits(limits=1, user_api="blas"):
        for r0 in range(0, n_rev + 1, step):
            r1 = min(r0 + step, n_rev + 1)
            c = r1 - r0
            for run in runs:
                y = y_start + delta * (np.arange(r0, r1)[:, None] + np.arange(n)[run] / n)
                forces[:, :c, run] = 0.0
                static[:c, run] = 0.0
                for g, amp, w in zip(parts, amps, w_both, strict=True):
                    a = chip_factor_cells(g.phases[run], y, mach, 2 * np.pi / n, g.part) * amp
                    basis_a = g.trig[:, None, run] * a
                    inputs = np.concatenate([basis_a, basis_a * y]).reshape(10, -1)
                    forces[:, :c, run] += (w @ inputs).reshape(nm, c, -1)
                    if g.static_tool is not None:
                        s_tool, s_work = g.static_at(np.arange(n)[run], y)
                        static[:c, run] += a * (s_tool[..., 2] - s_work[..., 2])
            if not forces[:, :c].any() and np.abs(state).max() <= NEGLIGIBLE_STATE * peak:
                # free decay after the cut below any visible level: lfilter would only grind
                # through subnormal numbers (issue 9: 20 of 21 s); the response is zero
                q = np.zeros((nm, c * n))
                state[:] = 0.0
            else:
                q = np.empty((nm, c * n))
                for s in range(nm):
                    q[s], state[s] = lfilter(num[s], den[s], forces[s, :c].ravel(), zi=state[s])
                peak = max(peak, float(np.abs(q).max()))
            zc = (np.vstack([geo.c_trig, geo.c_y]) @ q).reshape(4, c, n)
            y = y_start + delta * (np.arange(r0, r1)[:, None] + np.arange(n) / n)
            rows[r0:r1, 1 : n + 1] = np.einsum("irj,ij->rj", zc[:3], geo.trig[:3]) + y * zc[3]
            rows[r0:r1, 1 : n + 1] += static[:c]
            lo, hi = max(r0 * n, rec0 * n - 1), min(r1 * n, rec1 * n)
            if lo < hi:
                rec_q[:, lo - (rec0 * n - 1) : hi - (rec0 * n - 1)] = q[
                    :, lo - r0 * n : hi - r0 * n
                ]
    rows[0, 0] = 0.0  # zero before the cut (eq. 3.13)
    rows[1:, 0] = rows[:-1, n]
    rows[:-1, n + 1 :] = rows[1:, 1:3]
    row_y = y_start + delta * np.arange(n_rev)
    table = ZreTable(rows[:-1], row_y, delta, (y_start, delta, np.arange(n_rev, dtype=float)))

    idx = np.arange(rec0 * n - 1, rec1 * n)  # global sample numbers, one before the window
    j = idx % n
    y = y_start + delta * idx / n
    chips = [
        chip_factor_cells(g.phases[j], y, mach, 2 * np.pi / n, g.part) * amp
        for g, amp in zip(parts, amps, strict=True)
    ]
    fs = sum((g.w[:, j] + y * g.w_y[:, j]) * a for g, a in zip(parts, chips, strict=True))
    lam, e, b0, b1 = (v[:, None] for v in discretise(b.omega, zeta, dt))
    # z_{k-1} = u + i v from q_{k-1} = 2 Re z_{k-1} and q_k = 2 Re(E z_{k-1} + g_k)
    g = b0 * fs[:, 1:] + b1 * fs[:, :-1]
    u = rec_q[:, :-1] / 2
    v = (e.real * u + g.real - rec_q[:, 1:] / 2) / e.imag
    z = e * (u + 1j * v) + g
    q = rec_q[:, 1:]
    qd = 2 * (lam * z).real
    qdd = fs[:, 1:] - (2 * zeta * b.omega)[:, None] * qd - (b.omega**2)[:, None] * q
    tip, acc, work = _outputs(geo, j[1:], y[1:], q, qd, qdd, f)
    for g, a in zip(parts, chips, strict=True):
        if g.static_tool is not None:
            s_tool, s_work = g.static_at(j[1:], y[1:])
            tip, work = tip + a[1:, None] * s_tool, work + a[1:, None] * s_work
    return Response(
        method="time",
        t=idx[1:] * dt,
        slide_y=y[1:],
        force=cutting_force(
            geo.phases[j[1:]],
            y[1:],
            process,
            mach,
            geo.coefficients,
            force_scale,
            2 * np.pi / n,
            parts=tuple(g.part for g in parts),
        ),
        tip_disp=tip,
        tip_acc=acc,
        work_disp=work,
        z_re=tip[:, 2] - work[:, 2],
        period=1.0 / f,
        periods=record_periods,
        table=table,
    )


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
        period=first.period,
        periods=first.periods,
        table=ZreTable(
            sum(r.table.values for r in responses),
            first.table.row_y,
            first.table.drift,
            first.table.row_knots,
        ),
    )
