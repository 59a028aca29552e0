"""The periodic (frequency-domain) response path, path (b) of :mod:`ufmt.machining.response`.

For a fixed slide position Y the cutting force is periodic in the spindle period; its periodic
steady state is the response while the slide passes Y (quasi-static in Y). The z_re of the whole
cut is a table over the slide positions of :func:`~ufmt.machining.cut_geometry.cut_geometry`
(:class:`PeriodicZreTable`), evaluated where it is read: at the few samples the surface reads, as
a sum over the cut's active angles with the periodic impulse response of the exact recurrence
(:class:`~ufmt.machining.recurrence.PeriodicRecurrence`); the whole table on first use of its
``values``, per harmonic with the recurrence's receptance (kernels of the modal force and output
shapes, :func:`~ufmt.machining.recurrence.discrete_receptance`) times the spectra of the chip
pattern. The record window is one spindle period at :func:`~ufmt.machining.response.record_slide`.

Process-independent parts are cached per geometry or per machine (the chip pattern), the
recurrence and the kernels per spindle speed and damping, so a sweep over designs or processes
repeats only what changes.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np

from ufmt.machining.basis import ModalBasis
from ufmt.machining.cut_geometry import (
    OUTPUT_HARMONICS,
    CutGeometry,
    pattern_spectra,
    pattern_tables,
)
from ufmt.machining.cutting import (
    ForceCoefficients,
    chip_factor_cells,
    force_vector,
    part_amplitude,
)
from ufmt.machining.damping import DampedModes, damped_modes, serial_blas
from ufmt.machining.recurrence import (
    DEFAULT_ZETA,
    MODE_BLOCK_BYTES,
    PeriodicRecurrence,
    discrete_receptance,
    modal_damping,
    periodic_recurrence,
    pole_recurrence,
    pole_transfer,
    real_part_product,
)
from ufmt.machining.response import (
    Response,
    ZreTable,
    cubic_weights,
    motion_shapes,
    projected_motion,
    projected_tip_acceleration,
    record_slide,
    tip_acceleration_shapes,
)
from ufmt.model.machine import Machine

#: Bytes [B] of one block of :attr:`PeriodicZreTable.values`' stacked spectra (a few rows) or
#: of its kernels' shifted receptances (a block of harmonics).
SPECTRA_BLOCK_BYTES = 2**25


@dataclass(frozen=True, eq=False)
class PeriodicZreTable:
    """The periodic path's z_re table (:class:`~ufmt.machining.response.ZreTable` layout,
    drift 0), evaluated where it is read.

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
        """The whole table (rows, N + 3) [m], padded periodically (see
        :class:`~ufmt.machining.response.ZreTable`)."""
        geo = self.parts[0]
        n = geo.n_phi
        half = n // 2
        kern = _periodic_kernels(self.parts, self.spindle_hz, self.zeta)
        coef = (kern * np.repeat(np.tile(self.amps, 7), 3))[:, 0]
        tables = [pattern_tables(geo.machine, n, geo.table_rows, p) for p in self.part_names]
        rows = self.row_y.size
        values = np.empty((rows, n + 3))
        table = values[:, 1 : n + 1]
        step = max(1, SPECTRA_BLOCK_BYTES // ((half + 7) * 3 * len(tables) * 16))
        for i in range(0, rows, step):  # a block of rows at a time: memory bounded
            block = slice(i, i + step)
            # z_re[k, i] = sum_(d, part, p) amp K[k, (d, part, p)] Y_i^p A_part[k - d, i]: one
            # small product per harmonic over a strided view of the stacked spectra (no copy)
            stacked = _stacked_spectra(tables, block)
            view = np.lib.stride_tricks.as_strided(
                stacked,
                shape=(half + 1, 7 * stacked.shape[1] * 3, stacked.shape[3]),
                strides=(stacked.strides[0], stacked.strides[2], stacked.strides[3]),
                writeable=False,
            )
            # einsum: matmul over the overlapping strided view is an order of magnitude slower
            zk = np.einsum("kj,kjm->km", coef, view)
            np.fft.irfft(zk.T, n=n, axis=1, out=table[block])
        values[:, 0], values[:, n + 1 :] = table[:, -1], table[:, :2]
        values.setflags(write=False)
        return values

    @property
    def part_names(self) -> tuple[str, ...]:
        """The force parts ("area", "edge") of ``parts``."""
        return tuple(g.part for g in self.parts)

    def columns(self, phi: np.ndarray) -> np.ndarray:
        """Table columns at angles phi (arcs, Nx) [rad], 4-point Lagrange in phi [m]:
        (rows, arcs * Nx): :meth:`columns_from_samples` or, where the table is known or the
        samples' sum over the active angles costs more than the whole table by the harmonics
        (many angles: a large plate, the fine line profiles), the whole table read there."""
        geo = self.parts[0]
        n = geo.n_phi
        by_samples = int(geo.active.sum()) * min(4 * np.size(phi), n) * geo.basis.n_modes
        by_harmonics = (n // 2) * 21 * len(self.parts) * self.row_y.size
        if "values" in self.__dict__ or by_samples > by_harmonics:
            return ZreTable(self.values, self.row_y, self.drift, self.row_knots).columns(phi)
        return self.columns_from_samples(phi)

    def columns_from_samples(self, phi: np.ndarray) -> np.ndarray:
        """:meth:`columns` from the samples the stencils touch only."""
        geo = self.parts[0]
        n = geo.n_phi
        plan = _column_plan(self.parts, tuple(np.ravel(phi).tolist()))
        active, samples = plan.lag_index.shape
        modes = damped_modes(geo.basis, self.zeta)
        # kernels of c^(a) and w^(b) (a, b = 0: at Y = 0, 1: rate in Y) for each angle m and
        # sample k: sum_s c^(a)_s[k] h_s[k - m] w^(b)_s[m] (A, 2 K, 2 P)
        if modes is None:
            z = _recurrence(geo.basis, n, self.spindle_hz, self.zeta).impulse(plan.lags)
            h = 2 * z.real.T  # q of the impulse response at the lags (L, n)
            kern = _lag_products(h, plan.lag_index, plan.c, plan.w)
        else:  # complex modes: 2 Re sum_j (c^(a) P)_j[k] z_j[k - m] (L w^(b))_j[m]
            z = _pole_recurrence(modes, n, self.spindle_hz).impulse(plan.lags).T  # (L, m)
            with serial_blas():
                w = modes.inputs @ plan.w
                kern = 2 * _lag_products(z, plan.lag_index, plan.c @ modes.outputs, w)
        kern = kern.reshape(active, samples, 2, len(self.parts), 2)
        powers = np.stack(  # of Y: p = a + b
            [kern[..., 0, :, 0], kern[..., 0, :, 1] + kern[..., 1, :, 0], kern[..., 1, :, 1]],
            axis=-1,
        )  # (A, K, P, 3)
        powers += plan.static
        powers *= self.amps[:, None]
        at_samples = powers.transpose(0, 2, 3, 1).reshape(-1, samples) @ plan.stencil
        return plan.patterns @ at_samples


def _lag_products(h, lag_index, c, w, chunk_bytes: int = 2**21) -> np.ndarray:
    """Re sum_s c[k, i, s] h[lag_index[a, k], s] w[a, s, p] (A, K I, P): the state per lag
    h (L, n) between the output shapes c (K, I, n) and the inputs w (A, n, P), real or
    complex. A few angles a at a time, so that their (K I, n) products stay in cache
    (``chunk_bytes``); complex factors as one real product of x's real and imaginary parts
    as they lie in memory (interleaved) with the rows of Re w and -Im w interleaved."""
    active, samples = lag_index.shape
    rows, width = samples * c.shape[1], c.shape[2]
    split = np.iscomplexobj(h) or np.iscomplexobj(c) or np.iscomplexobj(w)
    if split:  # Re(x w) = sum_s Re x_s Re w_s - Im x_s Im w_s
        stacked = np.empty((active, 2 * width, w.shape[2]))
        stacked[:, 0::2], stacked[:, 1::2] = w.real, -w.imag
        w = stacked
    out = np.empty((active, rows, w.shape[2]))
    step = max(1, chunk_bytes // (rows * width * 16))
    for a in range(0, active, step):
        x = (h[lag_index[a : a + step]][:, :, None, :] * c).reshape(-1, rows, width)
        if split:
            x = x.astype(complex, copy=False).view(float)
        np.matmul(x, w[a : a + step], out=out[a : a + step])
    return out


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
    samples, weights = cubic_weights(np.array(phi), n_phi)
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


def periodic_response(geo, process, zeta=DEFAULT_ZETA, force_scale: float = 1.0) -> Response:
    """Periodic steady state at each tabulated slide position (path b).

    The table (:class:`PeriodicZreTable`) is evaluated where it is read: at the few samples
    of the cut the surface reads, by the periodic impulse response over the active angles; the
    whole table by the harmonics on first use of its ``values``: per harmonic k,
    z_re[k] = sum_s sum_l c_hat[s,l] H_s[k-l] sum_m w_hat[s,m] A[k-l-m] = sum_d K_d[k] A[k-d],
    with A the spectrum of the chip factor (:func:`_stacked_spectra`) and H_s the receptance of
    :func:`discrete_receptance`; with the workpiece arm's Y terms the kernels are a quadratic
    in Y, sum_p Y^p K_pd. The record window is one spindle period at the slide position of
    :func:`record_slide`: the periodic state of the recurrence under the modal force there
    (the state over the cut's run, free decay after it; :class:`PeriodicRecurrence` cached
    per spindle speed and damping, the force per unit amplitude per geometry), projected on
    the tool's and workpiece's motion (:func:`_record_motion`; with complex modes
    :func:`periodic_projection`, which never forms the state over the free decay).

    ``geo``: one :class:`CutGeometry` or a sequence of them, the force parts of one force on
    the same basis, machine, n_phi and table rows: their responses are summed (each times its
    part's amplitude) before any transform, so the parts cost one.
    """
    parts = (geo,) if isinstance(geo, CutGeometry) else tuple(geo)
    geo = parts[0]
    zeta = modal_damping(zeta, geo.basis.n_modes)
    f = process.spindle_hz
    n = geo.n_phi
    amps = _amplitudes(parts, process, force_scale)
    units = [_record_unit(g) for g in parts]
    fs = sum(amp * _record_force(g) for amp, g in zip(amps, parts, strict=True))
    y_rec = record_slide(geo.machine)
    j = np.arange(n)
    motion = _record_motion(geo, zeta, f, fs, motion_shapes(geo))
    tip, acc, work, carrier = projected_motion(geo, j, np.full(n, y_rec), *motion, f)
    for amp, u in zip(amps, units, strict=True):
        if u.static_tip is not None:
            tip, work = tip + amp * u.static_tip, work + amp * u.static_work
    return Response(
        method="periodic",
        t=_record_times(geo, process),
        slide_y=np.full(n, y_rec),
        force=sum(amp * u.force for amp, u in zip(amps, units, strict=True)),
        tip_disp=tip,
        tip_acc=acc,
        work_disp=work,
        z_re=tip[:, 2] - work[:, 2],
        carrier_acc=carrier,
        period=1.0 / f,
        periods=1,
        table=PeriodicZreTable(parts, amps, f, tuple(zeta.tolist()), geo.table_y, geo.row_knots),
    )


def record_tip_acceleration(
    geo, process, zeta=DEFAULT_ZETA, force_scale: float = 1.0
) -> tuple[np.ndarray, np.ndarray]:
    """The record window of :func:`periodic_response` reduced to what an accelerometer on the
    head reads: its times t (N,) [s] and the head's z acceleration at the tool point (N,)
    [m/s^2], equal to that response's ``t`` and ``tip_acc[:, 2]`` to rounding.

    The same periodic state under the same modal force, projected on the 7 modal shapes the
    acceleration reads (:func:`~ufmt.machining.response.tip_acceleration_shapes`) instead of
    21; the static correction (which does not reach the acceleration, see
    :mod:`ufmt.machining.response`), the workpiece's motion, the force and the z_re table are
    not formed, so the geometries' table rows and residual are not read. ``geo``, ``zeta``
    and ``force_scale`` as in :func:`periodic_response`.
    """
    parts = (geo,) if isinstance(geo, CutGeometry) else tuple(geo)
    geo = parts[0]
    zeta = modal_damping(zeta, geo.basis.n_modes)
    f = process.spindle_hz
    amps = _amplitudes(parts, process, force_scale)
    fs = sum(amp * _record_force(g) for amp, g in zip(amps, parts, strict=True))
    motion = _record_motion(geo, zeta, f, fs, tip_acceleration_shapes(geo))
    acc = projected_tip_acceleration(geo, np.arange(geo.n_phi), *motion, f)
    return _record_times(geo, process), acc


def _amplitudes(parts: tuple[CutGeometry, ...], process, force_scale: float) -> np.ndarray:
    """The force parts' amplitudes [m^2 or m] times the force scale."""
    return np.array([force_scale * part_amplitude(process, g.machine, g.part) for g in parts])


def _record_times(geo: CutGeometry, process) -> np.ndarray:
    """Times [s] of the record window's samples (0 at the first touch of the cut)."""
    n, f = geo.n_phi, process.spindle_hz
    y_rec = record_slide(geo.machine)
    return (np.arange(n) + (y_rec - geo.machine.cut_span[0]) / process.feed_per_rev_m * n) / (f * n)


def _record_motion(geo: CutGeometry, zeta: np.ndarray, spindle_hz: float, fs: np.ndarray, shapes):
    """The periodic steady state under the modal force fs (n, A) on the cut's run (zero
    outside it, :func:`_record_force`) projected on the modal ``shapes`` (n, k) on q, q' and
    q'' (those of :func:`~ufmt.machining.response.motion_shapes` give
    :func:`~ufmt.machining.response.projected_motion`'s moved, spin and accel): (N, k) each."""
    b, n = geo.basis, geo.n_phi
    run = _cut_run(geo.active.tobytes())[1]
    modes = damped_modes(b, zeta)
    if modes is None:
        rec = _recurrence(b, n, spindle_hz, tuple(zeta.tolist()))
        force = np.zeros((b.n_modes, n))
        force[:, run] = fs
        q, qd = periodic_state(rec, force, geo.active)
        qdd = force - (2 * zeta * b.omega)[:, None] * qd - (b.omega**2)[:, None] * q
        return q.T @ shapes[0], qd.T @ shapes[1], qdd.T @ shapes[2]
    with serial_blas():
        rec = _pole_recurrence(modes, n, spindle_hz)
        out = periodic_projection(rec, modes.inputs @ fs, geo.active, modes.state_weights(*shapes))
        q, qd, qdd = np.split(out, np.cumsum([shapes[0].shape[1], shapes[1].shape[1]]), axis=1)
        qdd[run] += fs.T @ shapes[2]
        return q, qd, qdd


@lru_cache(maxsize=4)  # n N complex each once its powers are formed
def _recurrence(basis: ModalBasis, n_phi: int, spindle_hz: float, zeta: tuple):
    """:func:`periodic_recurrence` of the basis at the spindle frequency [Hz] (cached per
    spindle speed and damping; its arrays read-only)."""
    return periodic_recurrence(basis.omega, np.array(zeta), 1 / (spindle_hz * n_phi), n_phi)


@lru_cache(maxsize=4)
def _pole_recurrence(modes: DampedModes, n_phi: int, spindle_hz: float) -> PeriodicRecurrence:
    """:func:`pole_recurrence` of the complex modes at the spindle frequency [Hz] (cached per
    modes and spindle speed; its arrays read-only)."""
    return pole_recurrence(modes.poles, 1 / (spindle_hz * n_phi), n_phi)


@lru_cache(maxsize=8)
def _cut_run(active: bytes) -> tuple[int, np.ndarray]:
    """The circular run of the ``active`` samples (N bools as bytes, not all): its first
    sample and its samples in order (A,) (read-only)."""
    active = np.frombuffer(active, dtype=bool)
    first = int(np.flatnonzero(active & ~np.roll(active, 1))[0])
    run = (first + np.arange(np.count_nonzero(active))) % active.size
    run.setflags(write=False)  # cached: shared by every later call
    return first, run


def periodic_state(recurrence: PeriodicRecurrence, force: np.ndarray, active: np.ndarray):
    """Periodic steady state (q, q') (n, N) [m, m/s per unit modal force] of the recurrence
    under the modal force (n, N), zero outside the circular run of ``active`` (N,) samples
    (:func:`periodic_coordinates`)."""
    x = periodic_coordinates(recurrence, force, active)
    return 2 * x.real, 2 * (recurrence.lam[:, None] * x).real


def periodic_coordinates(recurrence: PeriodicRecurrence, force: np.ndarray, active: np.ndarray):
    """Complex state z (n, N) of the periodic steady state of the recurrence under the input
    (n, N) (real or complex), zero outside the circular run of ``active`` (N,) samples; only
    the run's A samples of ``force`` are read.

    Over the run, the state from rest w (:meth:`PeriodicRecurrence.from_rest`) plus the free
    decay E^(k + 1) z_b of the periodic state z_b at the sample before the run; after the run,
    the free decay E^l of the state after its last sample, w_A + E^(A + 1) z_b. Periodicity
    closes it: z_b = E^(N - 1 - A) w_A / (1 - E^N), w_A = E w_(A - 1) + b1 f_(A - 1). Equal to
    the sum of the force with the periodic impulse response (:meth:`PeriodicRecurrence.impulse`)
    without its (n, A, A) tensor: O(n A sqrt(A)) over the run, O(n N) for the decay.
    """
    run = _cut_run(active.tobytes())[1]
    inside, after, start, head = _periodic_run(recurrence, force[:, run], active)
    n, a, powers = active.size, run.size, recurrence.powers
    x = np.empty(force.shape, complex)
    x[:, run] = inside
    np.multiply(powers[:, :head], after[:, None], out=x[:, start : start + head])
    np.multiply(powers[:, head : n - a], after[:, None], out=x[:, : n - a - head])
    return x


def _periodic_run(recurrence: PeriodicRecurrence, force: np.ndarray, active: np.ndarray):
    """The periodic state over the circular run of ``active`` (N,) under the input ``force``
    (n, A) there (:func:`periodic_coordinates`): (the state over the run (n, A), the state
    after its last sample (n,), where the free decay starts, how many of its N - A samples
    come before the period wraps)."""
    first, run = _cut_run(active.tobytes())
    n, a = active.size, run.size
    e = recurrence.e
    w = recurrence.from_rest(force)
    left = e * w[:, -1] + recurrence.b1 * force[:, -1]  # w_A: no force after the run
    before = recurrence.power(n - 1 - a) * left / (1.0 - recurrence.period)  # z_b
    inside = w  # w + E^(k + 1) z_b in place, a block of modes at a time: (n, A) complex each
    step = max(1, MODE_BLOCK_BYTES // (16 * a))
    for i in range(0, w.shape[0], step):
        m = slice(i, i + step)
        inside[m] += recurrence.subset(m).power(np.arange(1, a + 1)) * before[m, None]
    after = left + e * recurrence.power(a) * before  # the state after the run's last sample
    start = (first + a) % n  # the free decay: n - a samples from here, circularly
    return inside, after, start, min(n - a, n - start)


def periodic_projection(
    recurrence: PeriodicRecurrence, force: np.ndarray, active: np.ndarray, weights: np.ndarray
) -> np.ndarray:
    """2 Re(z^T W) (N, k) of the complex state z of :func:`periodic_coordinates` under the
    input ``force`` (n, A) on the circular run of ``active`` (N,) (its A samples in order),
    for complex weights W (n, k), without forming z.

    Over the run, from its A states; over the free decay after it, where z = E^l z_a, as
    :meth:`~ufmt.machining.recurrence.PeriodicRecurrence.projected_powers` of the weights
    times z_a: neither the (n, N) state nor the table of E^l is formed.
    """
    run = _cut_run(active.tobytes())[1]
    inside, after, start, head = _periodic_run(recurrence, force, active)
    n, a = active.size, run.size
    out = np.empty((n, weights.shape[1]))
    out[run] = real_part_product(inside.T, weights)
    decay = recurrence.projected_powers(after[:, None] * weights, n - a)
    out[start : start + head], out[: n - a - head] = decay[:head], decay[head:]
    return out


def _stacked_spectra(tables: list, block: slice) -> np.ndarray:
    """The parts' extended spectra (:func:`~ufmt.machining.cut_geometry.pattern_spectra`)
    times Y^p at the ``block`` of rows of their :func:`pattern_tables`, (N/2 + 7, P, 3, m)."""
    powers = tables[0][0][block] ** np.arange(3)[:, None]  # (3, m)
    spectra = [pattern_spectra(t[2], t[3][block]) for t in tables]
    return np.stack(spectra, axis=1)[:, :, None, :] * powers


@lru_cache(maxsize=2)  # machine-only
def _stacked_patterns(machine: Machine, n_phi: int, table_rows: int, parts: tuple[str, ...]):
    """The parts' chip patterns on the active angles times Y^p at each row, (M, A P 3) in the
    order (angle, part, power p) (cached per machine: every design of a sweep shares it)."""
    tables = [pattern_tables(machine, n_phi, table_rows, part) for part in parts]
    powers = tables[0][0][:, None, None, None] ** np.arange(3)  # (M, 1, 1, 3)
    out = (np.stack([t[3] for t in tables], axis=2)[..., None] * powers).reshape(
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
    modes = damped_modes(geo.basis, zeta)
    if modes is None:
        hq, _ = discrete_receptance(
            geo.basis.omega, np.array(zeta), 1 / (spindle_hz * n), 2 * np.pi * k / n
        )
        coef, static = _kernel_coefficients(parts)
    else:  # each complex mode and its conjugate: a term of its own
        hq = np.concatenate(pole_transfer(modes.poles, 1 / (spindle_hz * n), 2 * np.pi * k / n))
        with serial_blas():
            coef, static = _complex_kernel_coefficients(parts, modes)
    # one product of the receptances, shifted by each output harmonic l, with the coefficients,
    # a block of harmonics at a time (the (K, 3n) receptances would be N n complex)
    kern = np.empty((half + 1, coef.shape[1]), complex)
    step = max(1, SPECTRA_BLOCK_BYTES // (16 * coef.shape[0]))
    for i in range(0, half + 1, step):
        end = min(i + step, half + 1)
        shifted = np.concatenate(
            [hq.T[i + 1 - l : end + 1 - l] for l in OUTPUT_HARMONICS], axis=1
        )  # (block, 3n)
        kern[i:end] = shifted @ coef + static
    kern = kern.reshape(half + 1, 1, -1)
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
    shapes = [(g.c_hat, g.c_y, g.w_hat, g.w_y_hat) for g in parts]
    return _coefficients(shapes, [g.static_hat for g in parts])


@lru_cache(maxsize=8)
def _complex_kernel_coefficients(parts: tuple[CutGeometry, ...], modes: DampedModes):
    """:func:`_kernel_coefficients` of the complex modes (cached per geometry and modes): the
    Fourier coefficients of the output shapes c P and the inputs L w of each complex mode z_j,
    then of its conjugate (conj(P), conj(L)), rows 2 m in the order of
    :func:`~ufmt.machining.recurrence.pole_transfer`'s two halves."""
    out, inp = modes.outputs, modes.inputs
    shapes = [
        tuple(
            np.concatenate([a, b])
            for a, b in zip(
                (out.T @ g.c_hat, out.T @ g.c_y, inp @ g.w_hat, inp @ g.w_y_hat),
                (
                    out.T.conj() @ g.c_hat,
                    out.T.conj() @ g.c_y,
                    inp.conj() @ g.w_hat,
                    inp.conj() @ g.w_y_hat,
                ),
                strict=True,
            )
        )
        for g in parts
    ]
    return _coefficients(shapes, [g.static_hat for g in parts])


def _coefficients(shapes, static_hats) -> tuple[np.ndarray, np.ndarray]:
    """coef (3 n, 21 P) and static (21 P,) of :func:`_kernel_coefficients` from each part's
    (c_hat (n, 3), c_y (n,), w_hat (n, 5), w_y_hat (n, 5)) and static_hat (or None)."""
    n_modes = shapes[0][0].shape[0]
    coef = np.zeros((3, n_modes, 7, len(shapes), 3), dtype=complex)  # (l, s, d, part, p)
    static = np.zeros((7, len(shapes), 3), dtype=complex)
    for pi_, (c_hat, c_y_hat, w_hat, w_y_hat) in enumerate(shapes):
        c_y = np.zeros_like(c_hat)
        c_y[:, 1] = c_y_hat
        for pc, ch in enumerate((c_hat, c_y)):
            for pw, wh in enumerate((w_hat, w_y_hat)):
                for li in range(3):
                    coef[li, :, li : li + 5, pi_, pc + pw] += ch[:, li : li + 1] * wh
        if static_hats[pi_] is not None:
            static[:, pi_, :] = static_hats[pi_].T
    coef = np.ascontiguousarray(coef[:, :, ::-1]).reshape(3 * n_modes, -1)
    static = np.ascontiguousarray(static[::-1]).reshape(-1)
    for a in (coef, static):
        a.setflags(write=False)
    return coef, static


@dataclass(frozen=True)
class _RecordUnit:
    """Record-window quantities of one force part per unit amplitude (process-independent).

    force (N, 3) the force on the tool [N per unit]; static_tip, static_work (N, 3) or None
    the static correction's displacements (the modal force: :func:`_record_force`).
    """

    force: np.ndarray
    static_tip: np.ndarray | None
    static_work: np.ndarray | None


@lru_cache(maxsize=8)
def _record_unit(geo: CutGeometry) -> _RecordUnit:
    """The record window of :func:`periodic_response` per unit amplitude (cached per
    geometry)."""
    y_rec, chip, force, _ = _record_pattern(geo.machine, geo.coefficients, geo.n_phi, geo.part)
    static_tip = static_work = None
    if geo.static_tool is not None:
        s_tool, s_work = geo.static_at(slice(None), y_rec)
        static_tip, static_work = chip[:, None] * s_tool, chip[:, None] * s_work
        for a in (static_tip, static_work):
            a.setflags(write=False)
    return _RecordUnit(force, static_tip, static_work)


@lru_cache(maxsize=8)
def _record_force(geo: CutGeometry) -> np.ndarray:
    """The record window's modal force per unit amplitude on the cut's run (n, A) (the
    samples of :func:`_cut_run`; zero outside it), cached per geometry, read-only."""
    y_rec, chip, _, cut = _record_pattern(geo.machine, geo.coefficients, geo.n_phi, geo.part)
    first, run = _cut_run(geo.active.tobytes())
    at = (cut - first) % geo.n_phi  # the cutting samples' places in the run
    if np.any(at >= run.size):
        raise ValueError("the record window cuts outside the cut's active angles")
    w, w_y, _ = geo.modal_at(cut)
    fs = np.zeros((geo.basis.n_modes, run.size))
    fs[:, at] = (w + y_rec * w_y) * chip[cut]
    fs.setflags(write=False)
    return fs


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
