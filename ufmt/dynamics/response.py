"""Modal response to the fly-cutting force (paper eqs. 3.9-3.13), two paths.

Each modal coordinate obeys q'' + 2 zeta w q' + w^2 q = f_s(t), f_s = <f, V^s> / M_s (eq. 3.11),
with zero initial conditions (eqs. 3.12-3.13). For the point force F at the tool tip p on the
tool body and its reaction on the workpiece body at the same point, f_s = (V_tool,s(p) -
V_work,s(p)) . F / M_s, where V_b,s(p) is the translation of point p of body b in mode s.

The force is sampled at ``n_phi`` equally spaced spindle angles per revolution and taken as
piecewise linear between samples (first-order hold). Both paths solve that forced problem
exactly, so they differ only by the start-up transient and by the quasi-static assumption below:

(a) time domain, :func:`time_response`: every revolution of the whole cut, each modal equation
    discretised exactly (complex-pole recurrence of the first-order-hold solution, run by
    ``scipy.signal.lfilter``), from zero initial conditions.
(b) periodic, :func:`periodic_response`: the force is periodic in the spindle period for a fixed
    slide position Y; its periodic steady state is obtained per harmonic with the receptance of
    the same exact recurrence (FFT, receptance, inverse FFT). The slide moves only v/f = 10-80 um
    per revolution while the slowest mode settles in a few revolutions, so the steady state at
    each Y is used as the response while the slide passes Y (quasi-static in Y), tabulated on a
    grid of slide positions.

Mode shapes are those of the nominal configuration (see :mod:`ufmt.dynamics.basis`).

Modal damping (not part of the basis): ``DEFAULT_ZETA`` = 0.03 for every mode. Modal damping
ratios measured on precision machine structures with bolted and aerostatic joints lie around
0.01-0.05; aerostatic films add little damping, granite beds and bolted joints most of it, so
the middle of that band is taken. A per-mode array overrides it.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.signal import lfilter

from ufmt.dynamics.basis import ModalBasis
from ufmt.dynamics.cutting import (
    ForceCoefficients,
    Machine,
    chip_factor,
    force_per_area,
    tool_tip,
)

DEFAULT_ZETA = 0.03
#: Force samples per spindle revolution (both paths). See docs of :func:`cut_geometry`.
DEFAULT_N_PHI = 1024
#: Largest slide-position step [m] of the periodic path's table.
DEFAULT_TABLE_STEP = 5e-3
#: Spindle periods recorded around the halfway point (time path; paper Figs. 6-7 show 2 s).
DEFAULT_RECORD_PERIODS = 10

_HARM_W = np.arange(-2, 3)  # harmonics of the modal-force shape w_s(phi)
_HARM_C = np.arange(-1, 2)  # harmonics of the output shape c_s(phi)


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
    """Process-independent data of one (basis, machine, force coefficients, n_phi, table_rows).

    phases (N,) [rad]; tip (N, 3) tool-tip position [m] and dtip, ddtip (N, 3) its first and
    second derivatives in phi [m]; w (n, N) modal force per unit chip area,
    (V_tool - V_work)(p) . k / M_s with k from :func:`force_per_area` [N/(kg m^2)];
    c (n, N) relative z translation (V_tool - V_work)_z(p) [m]. Both are trigonometric
    polynomials in phi (degree 2 and 1): w_hat (n, 5) and c_hat (n, 3) hold their complex
    Fourier coefficients (harmonics -2..2, -1..1), w_trig (n, 5) and c_trig (3, n) the real ones
    on ``trig`` (5, N) = [1, cos, sin, cos 2phi, sin 2phi]. table_y (M,) slide positions [m] of
    the periodic table; table_a (M, N/2 + 7) the half spectrum of the chip factor at each,
    extended by 3 bins on both sides.
    """

    basis: ModalBasis
    machine: Machine
    coefficients: ForceCoefficients
    n_phi: int
    phases: np.ndarray
    tip: np.ndarray
    dtip: np.ndarray
    ddtip: np.ndarray
    w: np.ndarray
    c: np.ndarray
    w_hat: np.ndarray
    c_hat: np.ndarray
    w_trig: np.ndarray
    c_trig: np.ndarray
    trig: np.ndarray
    table_y: np.ndarray
    table_a: np.ndarray


@lru_cache(maxsize=16)
def cut_geometry(
    basis: ModalBasis,
    machine: Machine,
    coefficients: ForceCoefficients = DEFAULT_COEFFICIENTS,
    n_phi: int = DEFAULT_N_PHI,
    table_rows: int = DEFAULT_TABLE_ROWS,
) -> CutGeometry:
    """Precompute what does not depend on the process (cached per arguments).

    ``n_phi`` force samples per revolution (even, >= 8). ``table_rows`` slide positions of the
    periodic table over the cutting span: half of them evenly spaced, half where the chip
    pattern changes fastest (where the leading arc's top enters and leaves the workpiece edges
    the engaged arc grows like the square root of the slide travel).
    """
    for body in (machine.tool_body, machine.workpiece_body):
        if body not in basis.body_shapes:
            raise KeyError(f"machine body {body!r} has no mode shapes in the basis")
    if n_phi < 8 or n_phi % 2:
        raise ValueError(f"n_phi must be even and >= 8, got {n_phi}")
    if table_rows < 3:
        raise ValueError(f"table_rows must be >= 3, got {table_rows}")
    phases = 2 * np.pi * np.arange(n_phi) / n_phi

    def shapes(ph):
        tip = tool_tip(ph, machine)
        rel = basis.point_shapes(machine.tool_body, tip)
        rel = rel - basis.point_shapes(machine.workpiece_body, tip)
        w = np.einsum("sjc,jc->sj", rel, force_per_area(ph, machine, coefficients))
        return tip, w / basis.modal_mass[:, None], rel[:, :, 2]

    tip, w, c = shapes(phases)
    _, w8, c8 = shapes(2 * np.pi * np.arange(8) / 8)  # 8 samples resolve degree 2 exactly
    w_hat = np.fft.fft(w8, axis=1)[:, _HARM_W % 8] / 8
    c_hat = np.fft.fft(c8, axis=1)[:, _HARM_C % 8] / 8
    w_trig = np.stack(
        [w_hat[:, 2].real, 2 * w_hat[:, 3].real, -2 * w_hat[:, 3].imag]
        + [2 * w_hat[:, 4].real, -2 * w_hat[:, 4].imag],
        axis=1,
    )
    c_trig = np.stack([c_hat[:, 1].real, 2 * c_hat[:, 2].real, -2 * c_hat[:, 2].imag])
    trig = np.stack(
        [np.ones(n_phi), np.cos(phases), np.sin(phases), np.cos(2 * phases), np.sin(2 * phases)]
    )
    table_y = _table_rows(machine, phases[:: max(1, n_phi // 256)], table_rows)
    table_a = _extend(np.fft.rfft(chip_factor(phases, table_y[:, None], machine), axis=1))
    r, s = machine.tool_radius, machine.sense
    dtip = np.stack([s * r * np.cos(phases), -r * np.sin(phases), 0 * phases], axis=1)
    ddtip = np.stack([-s * r * np.sin(phases), -r * np.cos(phases), 0 * phases], axis=1)
    return CutGeometry(
        basis=basis,
        machine=machine,
        coefficients=coefficients,
        n_phi=n_phi,
        phases=phases,
        tip=tip,
        dtip=dtip,
        ddtip=ddtip,
        w=w,
        c=c,
        w_hat=w_hat,
        c_hat=c_hat,
        w_trig=w_trig,
        c_trig=c_trig,
        trig=trig,
        table_y=table_y,
        table_a=table_a,
    )


def _table_rows(machine: Machine, phases: np.ndarray, rows: int) -> np.ndarray:
    """Slide positions [m] at equal steps of (uniform measure + chip-pattern change) / 2."""
    y0, y1 = machine.cutting_span
    fine = np.linspace(y0, y1, 40 * rows)
    change = np.abs(np.diff(chip_factor(phases, fine[:, None], machine), axis=0)).sum(axis=1)
    moved = np.concatenate([[0.0], np.cumsum(change)])
    measure = np.linspace(0.0, 0.5, fine.size) + 0.5 * moved / max(moved[-1], 1e-300)
    return np.interp(np.linspace(0.0, 1.0, rows), measure, fine)


def _extend(half: np.ndarray, pad: int = 3) -> np.ndarray:
    """Half spectrum (..., N/2 + 1) of a real signal, extended by ``pad`` bins at both ends."""
    left = np.conj(half[..., pad:0:-1])
    right = np.conj(half[..., -2 : -2 - pad : -1])
    return np.concatenate([left, half, right], axis=-1)


@dataclass(frozen=True, eq=False)
class ZreTable:
    """Relative tool-workpiece z displacement over the cut, read by the surface (eq. 4.1).

    values (rows, N + 1) [m]: column j is spindle angle 2 pi j / N (column N closes the period);
    row_y (rows,) [m] the slide position of each row at phi = 0, ascending; drift [m] the slide
    travel during one row's revolution. Time path: one row per revolution, drift = v / f.
    Periodic path: one row per tabulated slide position, drift = 0 (steady state at fixed Y).
    The slide position of (row, phi) is row_y + drift phi / (2 pi); beyond the first and last
    rows their values apply (they carry no cutting force).
    """

    values: np.ndarray
    row_y: np.ndarray
    drift: float


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
    table: ZreTable


def _outputs(geo: CutGeometry, j, q, qd, qdd, spindle_hz: float):
    """Tool-tip displacement and acceleration, workpiece displacement, from modal coordinates.

    j (T,) phase indices; q, qd, qdd (n, T). The tip is a material point of the spinning tool
    body, so its acceleration is d^2/dt^2 sum_s [r_s + theta_s x (p(t) - C)] q_s(t), including
    the terms from the motion of p.
    """
    b, m = geo.basis, geo.machine
    disp = []
    for body in (m.tool_body, m.workpiece_body):
        s, arm = b.body_shapes[body], geo.tip[j] - b.body_centers[body]
        disp.append(q.T @ s[:, :3] + np.cross(q.T @ s[:, 3:], arm))
    s = b.body_shapes[m.tool_body]
    om = 2 * np.pi * spindle_hz
    arm = geo.tip[j] - b.body_centers[m.tool_body]
    acc = (
        qdd.T @ s[:, :3]
        + np.cross(qdd.T @ s[:, 3:], arm)
        + 2 * np.cross(qd.T @ s[:, 3:], om * geo.dtip[j])
        + np.cross(q.T @ s[:, 3:], om**2 * geo.ddtip[j])
    )
    return disp[0], acc, disp[1]


def periodic_response(
    geo: CutGeometry, process, zeta=DEFAULT_ZETA, force_scale: float = 1.0
) -> Response:
    """Periodic steady state at each tabulated slide position (path b).

    Per harmonic k: z_re[k] = sum_s sum_l c_hat[s,l] H_s[k-l] sum_m w_hat[s,m] A[k-l-m]
    = sum_d K_d[k] A[k-d], with A the spectrum of the chip factor (cached in ``geo``) and H_s
    the receptance of :func:`discrete_receptance`. The record window is one spindle period at
    the halfway slide position Y = 0.
    """
    b = geo.basis
    n = geo.n_phi
    half = n // 2
    zeta = modal_damping(zeta, b.n_modes)
    f = process.spindle_hz
    dt = 1.0 / (f * n)
    amp = force_scale * process.depth_m * process.feed_per_rev_m
    k = np.arange(-1, half + 2)
    hq, hv = discrete_receptance(b.omega, zeta, dt, 2 * np.pi * k / n)
    kern = np.zeros((7, half + 1), dtype=complex)
    for li, l in enumerate(_HARM_C):
        kern[li : li + 5] += (geo.c_hat[:, li : li + 1] * geo.w_hat).T @ hq[:, 1 - l : half + 2 - l]
    a = geo.table_a
    zk = kern[0] * a[:, 6 : 6 + half + 1]
    for d in range(1, 7):
        zk += kern[d] * a[:, 6 - d : 6 - d + half + 1]
    rows = np.fft.irfft(zk, n=n, axis=1)
    rows *= amp
    table = ZreTable(np.concatenate([rows, rows[:, :1]], axis=1), geo.table_y, 0.0)

    a0 = chip_factor(geo.phases, 0.0, geo.machine) * amp
    a0_ext = _extend(np.fft.rfft(a0))
    fk = geo.w_hat[:, :1] * a0_ext[None, 5 : 5 + half + 1]
    for mi in range(1, 5):
        fk += geo.w_hat[:, mi : mi + 1] * a0_ext[None, 5 - mi : 5 - mi + half + 1]
    q = np.fft.irfft(hq[:, 1 : half + 2] * fk, n=n, axis=1)
    qd = np.fft.irfft(hv[:, 1 : half + 2] * fk, n=n, axis=1)
    qdd = geo.w * a0 - (2 * zeta * b.omega)[:, None] * qd - (b.omega**2)[:, None] * q
    j = np.arange(n)
    tip, acc, work = _outputs(geo, j, q, qd, qdd, f)
    return Response(
        method="periodic",
        t=(j - geo.machine.cut_span[0] / process.feed_per_rev_m * n) * dt,
        slide_y=np.zeros(n),
        force=a0[:, None] * force_per_area(geo.phases, geo.machine, geo.coefficients),
        tip_disp=tip,
        tip_acc=acc,
        work_disp=work,
        z_re=tip[:, 2] - work[:, 2],
        period=1.0 / f,
        periods=1,
        table=table,
    )


def time_response(
    geo: CutGeometry,
    process,
    zeta=DEFAULT_ZETA,
    force_scale: float = 1.0,
    record_periods: int = DEFAULT_RECORD_PERIODS,
    block_samples: int = 1 << 18,
) -> Response:
    """Whole-workpiece response from zero initial conditions (path a; eqs. 3.11-3.13).

    Every revolution from the first touch of the leading arc (slide position Y_start) until
    the trailing arc has left the workpiece. Each modal equation is advanced by its exact
    recurrence (:func:`real_recurrence`, ``scipy.signal.lfilter``) in blocks of about
    ``block_samples`` samples, the filter state carried from block to block; modal forces and
    z_re are matrix products over the modes (w and c are trigonometric in phi). The record
    window holds ``record_periods`` revolutions centred on the halfway point (Y = 0); there the
    modal velocities come from the exact complex-pole state recovered from q_{k-1}, q_k.
    Memory: the z_re table takes 8 n_phi bytes per revolution.
    """
    b, mach = geo.basis, geo.machine
    n, nm = geo.n_phi, b.n_modes
    zeta = modal_damping(zeta, nm)
    f = process.spindle_hz
    dt = 1.0 / (f * n)
    delta = process.feed_per_rev_m
    amp = force_scale * process.depth_m * delta
    y_start, y_end = mach.cut_span
    n_rev = int(np.ceil((y_end - y_start) / delta)) + 1
    record_periods = max(1, min(record_periods, n_rev))
    rec0 = int(np.clip(round(-y_start / delta) - record_periods // 2, 0, n_rev - record_periods))
    rec1 = rec0 + record_periods
    num, den = real_recurrence(b.omega, zeta, dt)
    state = np.zeros((nm, 2))
    rows = np.empty((n_rev + 1, n))
    rec_q = np.empty((nm, record_periods * n + 1))  # one sample before the window first
    step = max(1, block_samples // n)
    frac = np.arange(n) / n
    trig_c = geo.trig[:3]
    for r0 in range(0, n_rev + 1, step):
        r1 = min(r0 + step, n_rev + 1)
        y = y_start + delta * (np.arange(r0, r1)[:, None] + frac)
        a = chip_factor(geo.phases, y, mach) * amp
        forces = geo.w_trig @ (geo.trig[:, None, :] * a).reshape(5, -1)
        q = np.empty_like(forces)
        for s in range(nm):
            q[s], state[s] = lfilter(num[s], den[s], forces[s], zi=state[s])
        zc = (geo.c_trig @ q).reshape(3, r1 - r0, n)
        rows[r0:r1] = np.einsum("irj,ij->rj", zc, trig_c)
        lo, hi = max(r0 * n, rec0 * n - 1), min(r1 * n, rec1 * n)
        if lo < hi:
            rec_q[:, lo - (rec0 * n - 1) : hi - (rec0 * n - 1)] = q[:, lo - r0 * n : hi - r0 * n]
    table = ZreTable(
        np.concatenate([rows[:-1], rows[1:, :1]], axis=1),
        y_start + delta * np.arange(n_rev),
        delta,
    )

    idx = np.arange(rec0 * n - 1, rec1 * n)  # global sample numbers, one before the window
    j = idx % n
    y = y_start + delta * idx / n
    a = chip_factor(geo.phases[j], y, mach) * amp
    fs = geo.w[:, j] * a
    lam, e, b0, b1 = (v[:, None] for v in discretise(b.omega, zeta, dt))
    # z_{k-1} = u + i v from q_{k-1} = 2 Re z_{k-1} and q_k = 2 Re(E z_{k-1} + g_k)
    g = b0 * fs[:, 1:] + b1 * fs[:, :-1]
    u = rec_q[:, :-1] / 2
    v = (e.real * u + g.real - rec_q[:, 1:] / 2) / e.imag
    z = e * (u + 1j * v) + g
    q = rec_q[:, 1:]
    qd = 2 * (lam * z).real
    qdd = fs[:, 1:] - (2 * zeta * b.omega)[:, None] * qd - (b.omega**2)[:, None] * q
    tip, acc, work = _outputs(geo, j[1:], q, qd, qdd, f)
    return Response(
        method="time",
        t=idx[1:] * dt,
        slide_y=y[1:],
        force=a[1:, None] * force_per_area(geo.phases[j[1:]], mach, geo.coefficients),
        tip_disp=tip,
        tip_acc=acc,
        work_disp=work,
        z_re=tip[:, 2] - work[:, 2],
        period=1.0 / f,
        periods=record_periods,
        table=table,
    )
