"""The time-domain response path, path (a) of :mod:`ufmt.machining.response`.

Every revolution of the whole cut, from the first touch of the leading arc (slide position
Y_start) until the trailing arc has left the workpiece, from zero initial conditions (paper
eqs. 3.11-3.13). Each modal equation is advanced by its exact recurrence
(:func:`~ufmt.machining.recurrence.real_recurrence`, run by ``scipy.signal.lfilter``) in blocks
of revolutions, the filter state carried from block to block; modal forces and z_re are matrix
products over the modes (w and c are trigonometric in phi). The z_re table holds one row per
revolution (:class:`~ufmt.machining.response.ZreTable`, drift v/f). The record window holds
``record_periods`` revolutions centred on :func:`~ufmt.machining.response.record_slide`; there
the modal velocities come from the exact complex-pole state recovered from q_{k-1}, q_k.
With hinge damping (:mod:`ufmt.machining.damping`) the recurrence runs on the complex modes
instead (first-order complex filters on the inputs L f, q = 2 Re(P z)), and the record window
keeps their state z.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter
from threadpoolctl import threadpool_limits

from ufmt.machining.basis import ModalBasis
from ufmt.machining.cut_geometry import CutGeometry
from ufmt.machining.cutting import chip_factor_cells, cutting_force, part_amplitude
from ufmt.machining.damping import damped_modes, serial_blas
from ufmt.machining.recurrence import (
    DEFAULT_ZETA,
    discretise,
    discretise_poles,
    modal_damping,
    real_recurrence,
)
from ufmt.machining.response import (
    Response,
    ZreTable,
    motion_shapes,
    projected_motion,
    record_slide,
    tool_and_workpiece_motion,
)

#: Modal state of the time path, relative to the largest modal coordinate so far, below which
#: a force-free block after the cut is taken as zero (1e-20 of the response: far below any
#: printed digit, and it stops the decay before it reaches subnormal numbers).
NEGLIGIBLE_STATE = 1e-20
#: Spindle periods in the time path's record window (paper Figs. 6-7 show 2 s = 10 periods).
DEFAULT_RECORD_PERIODS = 10


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
    the trailing arc has left the workpiece, in blocks of about ``block_samples`` samples (see
    the module docstring). The record window holds ``record_periods`` revolutions centred on
    :func:`~ufmt.machining.response.record_slide`. Memory: the z_re table takes 8 n_phi bytes
    per revolution.

    ``geo``: one :class:`~ufmt.machining.cut_geometry.CutGeometry` or a sequence of them, the
    force parts of one force on the same basis, machine and n_phi: their modal forces are
    summed before the recurrence, so the parts cost one pass.
    """
    parts = (geo,) if isinstance(geo, CutGeometry) else tuple(geo)
    geo = parts[0]
    zeta = modal_damping(zeta, geo.basis.n_modes)
    amps = [force_scale * part_amplitude(process, geo.machine, g.part) for g in parts]
    clock = _clock(geo, process, record_periods)
    rows, rec_q = _whole_cut(parts, amps, zeta, clock, block_samples)
    table = _zre_table(rows, clock)
    idx = np.arange(clock.rec0 * clock.n - 1, clock.rec1 * clock.n)  # one before the window
    j = idx % clock.n
    y = clock.y_start + clock.delta * idx / clock.n
    tip, acc, work, carrier = _record_motion(parts, amps, zeta, clock, rec_q, j, y)
    return Response(
        method="time",
        t=idx[1:] * clock.dt,
        slide_y=y[1:],
        force=cutting_force(
            geo.phases[j[1:]],
            y[1:],
            process,
            geo.machine,
            geo.coefficients,
            force_scale,
            2 * np.pi / clock.n,
            parts=tuple(g.part for g in parts),
        ),
        tip_disp=tip,
        tip_acc=acc,
        work_disp=work,
        z_re=tip[:, 2] - work[:, 2],
        carrier_acc=carrier,
        period=1.0 / clock.spindle_hz,
        periods=clock.rec1 - clock.rec0,
        table=table,
    )


@dataclass(frozen=True)
class _Clock:
    """Sampling of the whole cut: n samples per revolution at spindle_hz [Hz], step dt [s];
    delta [m] the feed per revolution, y_start [m] the slide position at the first touch
    (revolution 0, phi = 0), n_rev the revolutions of the cut; the record window holds the
    revolutions rec0 .. rec1 - 1 (global sample numbers k = revolution n + angle index)."""

    n: int
    spindle_hz: float
    dt: float
    delta: float
    y_start: float
    n_rev: int
    rec0: int
    rec1: int


def _clock(geo: CutGeometry, process, record_periods: int) -> _Clock:
    """The :class:`_Clock` of ``process`` on ``geo``'s machine, with a record window of
    ``record_periods`` revolutions (at most the cut's) centred on the record slide position."""
    mach = geo.machine
    n = geo.n_phi
    f = process.spindle_hz
    dt = 1.0 / (f * n)
    delta = process.feed_per_rev_m
    y_start, y_end = mach.cut_span
    n_rev = int(np.ceil((y_end - y_start) / delta)) + 1
    record_periods = max(1, min(record_periods, n_rev))
    middle = round((record_slide(mach) - y_start) / delta)
    rec0 = int(np.clip(middle - record_periods // 2, 0, n_rev - record_periods))
    return _Clock(n, f, dt, delta, y_start, n_rev, rec0, rec0 + record_periods)


def _whole_cut(parts, amps, zeta, clock: _Clock, block_samples: int):
    """Every revolution of the cut, block by block.

    Returns rows (n_rev + 1, N + 3) [m], the z_re of each revolution in columns 1..N (the
    padding columns are filled by :func:`_zre_table`), and rec_q (n, record samples + 1), the
    modal coordinates in the record window from one sample before it. With hinge damping the
    recurrence runs on the complex modes: their inputs L w and outputs 2 c P replace the
    modal force and output shapes, and rec_q holds their state z (m, record samples + 1).
    """
    geo = parts[0]
    nm, n = geo.basis.n_modes, clock.n
    w_both = [np.concatenate([g.w_trig, g.w_y_trig], axis=1) for g in parts]
    c_both = np.vstack([geo.c_trig, geo.c_y])
    modes = damped_modes(geo.basis, zeta)
    if modes is None:
        num, den = real_recurrence(geo.basis.omega, zeta, clock.dt)
        state = np.zeros((nm, 2))
    else:
        num, den = _pole_filters(modes.poles, clock.dt)
        state = np.zeros((modes.poles.size, 1), complex)
        w_both = [modes.inputs @ w for w in w_both]
        c_both = 2 * (c_both @ modes.outputs)  # z_re terms: Re(c_both z)
    rows = np.empty((clock.n_rev + 1, n + 3))  # padded as ZreTable wants: sample -1 and N, N + 1
    # the record window from one sample before it: q, or the complex modes' state
    rec_q = np.zeros((state.shape[0], (clock.rec1 - clock.rec0) * n + 1), state.dtype)
    step = max(1, block_samples // n)
    runs = _cutting_runs(geo.active)
    forces = np.zeros((state.shape[0], step, n), state.dtype)
    peak = 0.0  # largest |q| so far
    static = np.zeros((step, n))  # static-correction z_re of a block
    # skinny products over the modes: BLAS threads only add synchronisation here
    with threadpool_limits(limits=1, user_api="blas"):
        for r0 in range(0, clock.n_rev + 1, step):
            r1 = min(r0 + step, clock.n_rev + 1)
            c = r1 - r0
            _block_forces(parts, amps, w_both, runs, clock, r0, r1, forces[:, :c], static[:c])
            q, peak = _recur_block(num, den, forces[:, :c], state, peak)
            zc = (c_both @ q).real.reshape(4, c, n)
            y = clock.y_start + clock.delta * (np.arange(r0, r1)[:, None] + np.arange(n) / n)
            rows[r0:r1, 1 : n + 1] = np.einsum("irj,ij->rj", zc[:3], geo.trig[:3]) + y * zc[3]
            rows[r0:r1, 1 : n + 1] += static[:c]
            _keep_record(rec_q, q, clock, r0, r1)
    return rows, rec_q


def _pole_filters(poles, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """``lfilter`` coefficients (m, 2) of the complex modes' recurrence z_k = E z_{k-1} +
    b0 u_k + b1 u_{k-1} (:func:`~ufmt.machining.recurrence.discretise_poles`)."""
    _, e, b0, b1 = discretise_poles(poles, dt)
    return np.stack([b0, b1], axis=1), np.stack([np.ones_like(e), -e], axis=1)


def _cutting_runs(active: np.ndarray) -> list[slice]:
    """The runs of consecutive angles that can cut (``active`` (N,)): the force is zero
    outside them, so the time path works on those columns only."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], active.astype(int), [0]])))
    return [slice(lo, hi) for lo, hi in zip(edges[::2], edges[1::2], strict=True)]


def _block_forces(parts, amps, w_both, runs, clock: _Clock, r0: int, r1: int, forces, static):
    """Write the modal forces ``forces`` (n, c, N) and the static correction's z_re ``static``
    (c, N) [m] of revolutions r0 .. r1 - 1 on the cutting ``runs`` (the other columns stay
    zero). ``w_both`` (n, 10) per part: its w and w_y on the trigonometric basis."""
    mach, n, c = parts[0].machine, clock.n, r1 - r0
    nm = forces.shape[0]
    for run in runs:
        y = clock.y_start + clock.delta * (np.arange(r0, r1)[:, None] + np.arange(n)[run] / n)
        forces[:, :, run] = 0.0
        static[:, run] = 0.0
        for g, amp, w in zip(parts, amps, w_both, strict=True):
            a = chip_factor_cells(g.phases[run], y, mach, 2 * np.pi / n, g.part) * amp
            basis_a = g.trig[:, None, run] * a
            inputs = np.concatenate([basis_a, basis_a * y]).reshape(10, -1)
            forces[:, :, run] += (w @ inputs).reshape(nm, c, -1)
            if g.static_tool is not None:
                s_tool, s_work = g.static_at(np.arange(n)[run], y)
                static[:, run] += a * (s_tool[..., 2] - s_work[..., 2])


def _recur_block(num, den, forces, state, peak: float):
    """Modal coordinates (n, c N) of one block under ``forces`` (n, c, N) by the recurrence
    (``lfilter`` coefficients ``num``, ``den``), the filter ``state`` (n, 2) carried in place
    (complex modes: their state z under their inputs, the filter state (m, 1) complex).

    Returns them and the largest |q| so far (``peak`` before the block).
    """
    nm, c, n = forces.shape
    if not forces.any() and np.abs(state).max() <= NEGLIGIBLE_STATE * peak:
        # free decay after the cut below any visible level: lfilter would only grind through
        # subnormal numbers (most of the run time of a long cut); the response is zero
        q = np.zeros((nm, c * n), state.dtype)
        state[:] = 0.0
    else:
        q = np.empty((nm, c * n), state.dtype)
        for s in range(nm):
            q[s], state[s] = lfilter(num[s], den[s], forces[s].ravel(), zi=state[s])
        peak = max(peak, float(np.abs(q).max()))
    return q, peak


def _keep_record(rec_q, q, clock: _Clock, r0: int, r1: int) -> None:
    """Copy the samples of block r0 .. r1 - 1 (``q`` (n, c N)) that fall in the record window
    (from one sample before it) into ``rec_q``."""
    n = clock.n
    start = clock.rec0 * n - 1
    lo, hi = max(r0 * n, start), min(r1 * n, clock.rec1 * n)
    if lo < hi:
        rec_q[:, lo - start : hi - start] = q[:, lo - r0 * n : hi - r0 * n]


def _zre_table(rows, clock: _Clock) -> ZreTable:
    """The :class:`~ufmt.machining.response.ZreTable` of the revolutions' z_re ``rows``, their
    padding taken from the neighbouring revolutions (zero before the cut, eq. 3.13)."""
    n, n_rev = clock.n, clock.n_rev
    rows[0, 0] = 0.0  # zero before the cut (eq. 3.13)
    rows[1:, 0] = rows[:-1, n]
    rows[:-1, n + 1 :] = rows[1:, 1:3]
    row_y = clock.y_start + clock.delta * np.arange(n_rev)
    knots = (clock.y_start, clock.delta, np.arange(n_rev, dtype=float))
    return ZreTable(rows[:-1], row_y, clock.delta, knots)


def _record_motion(parts, amps, zeta, clock: _Clock, rec_q, j, y):
    """Tool-tip displacement, the head's acceleration at the tool point and workpiece
    displacement (T, 3), the tool carrier's z acceleration (T,), in the record window, from its
    modal coordinates ``rec_q`` (or the complex modes' state, see :func:`_whole_cut`) at angle
    indices ``j`` and slide positions ``y`` [m] (T + 1,) (from one sample before the window),
    static correction included."""
    geo = parts[0]
    n = clock.n
    chips = [
        chip_factor_cells(g.phases[j], y, geo.machine, 2 * np.pi / n, g.part) * amp
        for g, amp in zip(parts, amps, strict=True)
    ]
    fs = sum((g.w[:, j] + y * g.w_y[:, j]) * a for g, a in zip(parts, chips, strict=True))
    modes = damped_modes(geo.basis, zeta)
    if modes is None:
        q, qd, qdd = _modal_rates(geo.basis, zeta, clock.dt, fs, rec_q)
        motion = tool_and_workpiece_motion(geo, j[1:], y[1:], q, qd, qdd, clock.spindle_hz)
    else:  # the complex modes' state itself, projected without forming q, q', q''
        with serial_blas():
            motion = modes.projected(rec_q[:, 1:], fs[:, 1:], *motion_shapes(geo))
        motion = projected_motion(geo, j[1:], y[1:], *motion, clock.spindle_hz)
    tip, acc, work, carrier = motion
    for g, a in zip(parts, chips, strict=True):
        if g.static_tool is not None:
            s_tool, s_work = g.static_at(j[1:], y[1:])
            tip, work = tip + a[1:, None] * s_tool, work + a[1:, None] * s_work
    return tip, acc, work, carrier


def _modal_rates(basis: ModalBasis, zeta, dt: float, fs, rec_q):
    """q, q' and q'' (n, T) from the modal coordinates ``rec_q`` (n, T + 1) and the modal
    force ``fs`` (n, T + 1): the exact complex-pole state recovered from q_{k-1}, q_k."""
    lam, e, b0, b1 = (v[:, None] for v in discretise(basis.omega, zeta, dt))
    # z_{k-1} = u + i v from q_{k-1} = 2 Re z_{k-1} and q_k = 2 Re(E z_{k-1} + g_k)
    g = b0 * fs[:, 1:] + b1 * fs[:, :-1]
    u = rec_q[:, :-1] / 2
    v = (e.real * u + g.real - rec_q[:, 1:] / 2) / e.imag
    z = e * (u + 1j * v) + g
    q = rec_q[:, 1:]
    qd = 2 * (lam * z).real
    qdd = fs[:, 1:] - (2 * zeta * basis.omega)[:, None] * qd - (basis.omega**2)[:, None] * q
    return q, qd, qdd
