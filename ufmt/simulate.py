"""Simulate fly-cutting on a machine model: cutting force, modal response, machined surface.

``simulate(model, process)`` is the Python API of ``ufmt simulate``: it takes the modal basis
of the model (or the one given) with its static correction, runs the periodic or the
time-domain response for each force part, builds the machined surface from every switched-on
error source (:mod:`ufmt.machining.sources`) and returns a :class:`SimulationResult` with the
arrays, the metrics and the PV of each source alone. Process-independent work is cached per
(basis, machine, options), so a new process on a known basis costs only the response and the
surfaces.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from ufmt import limits
from ufmt.arguments import simulate_inputs
from ufmt.defaults import DEFAULT_BASIS_CUTOFF_HZ, DEFAULT_SPACING
from ufmt.errors import ProcessError
from ufmt.machining import validity
from ufmt.machining.basis import ModalBasis
from ufmt.machining.cut_geometry import DEFAULT_TABLE_ROWS, cut_geometry, samples_per_rev
from ufmt.machining.cutting import DEFAULT_COEFFICIENTS, FORCE_PARTS, ForceCoefficients
from ufmt.machining.instruments import (
    AccelerometerChain,
    Interferometer,
    accelerometer_peak,
    interferometer_metrics,
    scallop_roughness,
)
from ufmt.machining.lines import DEFAULT_LINE_SPACING, line_band_rms, line_spectra
from ufmt.machining.machine_frame import in_machine_frame
from ufmt.machining.periodic_path import periodic_response, record_tip_acceleration
from ufmt.machining.process import Process
from ufmt.machining.psd import band_rms
from ufmt.machining.recurrence import modal_damping
from ufmt.machining.response import Response
from ufmt.machining.sources import (
    MODEL,
    SCALLOP,
    SOURCES,
    ErrorSource,
    acting_sources,
    check_sources,
)
from ufmt.machining.static import ResidualFlexibility, residual_flexibility
from ufmt.machining.surface import (
    DEFAULT_APERTURE_MARGIN,
    DYNAMIC_METRICS,
    PSD2_PATCH_SPACING,
    Passes,
    Surface,
    dynamic_metrics,
    surface_metrics,
    surface_passes,
)
from ufmt.machining.time_path import DEFAULT_RECORD_PERIODS, time_response
from ufmt.machining.tool import with_tool
from ufmt.model.machine import Machine, machine_of
from ufmt.simulation_result import SimulationResult

#: Slide positions of the geometries that refine the accelerometer's peak: only their record
#: window is read, which does not depend on the rows (:func:`_periodic_acceleration`).
ACCELEROMETER_TABLE_ROWS = 8

METHODS = ("periodic", "time")
#: The source of the cutting-force vibration (:mod:`ufmt.machining.sources`).
DYNAMIC = "dynamic"


def simulate(
    model,
    process: Process,
    *,
    n_modes: int | None = None,
    basis_cutoff_hz: float = DEFAULT_BASIS_CUTOFF_HZ,
    zeta=None,
    method: str = "periodic",
    basis: ModalBasis | None = None,
    force_scale: float | None = None,
    coefficients: ForceCoefficients = DEFAULT_COEFFICIENTS,
    n_phi: int | None = None,
    table_rows: int = DEFAULT_TABLE_ROWS,
    spacing: float | tuple[float, float] = DEFAULT_SPACING,
    trailing_arc: bool = False,
    record_periods: int = DEFAULT_RECORD_PERIODS,
    sources=SOURCES,
    static_correction: bool = True,
    aperture_margin: float = DEFAULT_APERTURE_MARGIN,
    psd2_patch: float | None = None,
    line_spacing: float | None = DEFAULT_LINE_SPACING,
) -> SimulationResult:
    """Machined surface and response of ``model`` under ``process``.

    Parameters
    ----------
    model, process : a path, a loaded model (with ``[machine]``) or None (packaged); a
        :class:`Process` or a mapping as :func:`ufmt.evaluate` takes (:mod:`ufmt.arguments`).
    n_modes, basis_cutoff_hz : the modal basis: every mode below ``basis_cutoff_hz`` [Hz]
        (default 5 kHz, :mod:`ufmt.defaults`), or the first ``n_modes`` when given (the
        paper's choice is 30); the static residual stands for the modes above.
    zeta : structural modal damping ratio, scalar or (n_modes,) array; default the model's
        ``machine.modal_damping_ratio`` (0.01 unless the file says otherwise); the model's
        hinge dampers act on top of it (:mod:`ufmt.machining.damping`, carried by the basis).
    method : "periodic" (frequency domain, milliseconds; quasi-static in the slide position)
        or "time" (every revolution, exact recurrence, seconds); :mod:`ufmt.machining.response`.
    basis : modal basis instead of the model's (cut to ``n_modes`` or to the modes below
        ``basis_cutoff_hz``; its ``hinge_damping``, or none, is the hinge damping used).
    force_scale : factor on the force coefficients (default ``machine.force_scale``, else 1).
    coefficients, n_phi, table_rows : force model and discretisation (:func:`~ufmt.machining.
        cut_geometry.cut_geometry`); ``n_phi`` samples per spindle revolution, by default from
        the basis' highest mode (:func:`~ufmt.machining.cut_geometry.samples_per_rev`).
    spacing, trailing_arc : surface grid step [m] (one value or (x, y)) and back-cutting (off),
        see :func:`ufmt.machining.surface.surface_passes`.
    record_periods : spindle periods in the time path's record window.
    sources : error sources switched on (default all of :mod:`ufmt.machining.sources`).
    static_correction : add the residual flexibility of the modes above the basis
        (:mod:`ufmt.machining.static`; needs the model's assembled static solve).
    aperture_margin : clear-aperture edge exclusion [m] (5 mm) of the PV and the PSD bands.
    psd2_patch, line_spacing : the PSD bands read line profiles along and across the feed
        over the clear aperture at ``line_spacing`` [m] (0.03 mm, :mod:`ufmt.machining.lines`;
        None: the grid's columns and rows, PSD2 unresolved); ``psd2_patch`` [m] (superseded)
        recomputes the psd2 keys on a centred square patch at 0.05 mm.

    Raises OutsideDomainError (:mod:`ufmt.machining.validity`), ProcessError (:mod:`ufmt.limits`).
    """
    model, process = simulate_inputs(model, process)
    model = in_machine_frame(_loaded(model, n_modes, n_phi, table_rows, sources))
    machine = _machine(model)
    validity.check_case(process, machine, spacing, aperture_margin, psd2_patch, line_spacing)
    basis = _basis(model, machine, basis, n_modes, basis_cutoff_hz)
    n_phi = _sampling(machine, basis, process, n_phi, spacing)
    residual = _residual(model, basis, machine) if static_correction else None
    options = SimulationOptions(
        zeta=machine.modal_damping_ratio if zeta is None else zeta,
        method=method,
        force_scale=machine.force_scale if force_scale is None else force_scale,
        coefficients=coefficients,
        n_phi=n_phi,
        table_rows=table_rows,
        spacing=spacing,
        trailing_arc=trailing_arc,
        record_periods=record_periods,
        sources=sources,
        aperture_margin=aperture_margin,
        psd2_patch=psd2_patch,
        line_spacing=line_spacing,
        basis_cutoff_hz=basis_cutoff_hz if n_modes is None else None,
    )
    return _run(basis, machine, process, residual, options, _profiles(model, machine, sources))


def _loaded(model, n_modes, n_phi, table_rows, sources):
    """``model``, loaded if it is a path (None: the packaged UFMT), once the sizes asked for
    are inside their budgets (:func:`_check_sizes`)."""
    from ufmt.model.load import as_model

    _check_sizes(n_modes, n_phi, table_rows, sources)
    return as_model(model)


def _check_sizes(n_modes, n_phi, table_rows, sources) -> None:
    """The discretisation's sizes inside their budgets (:mod:`ufmt.limits`) and at least one
    error source, before anything is allocated."""
    if n_modes is not None:
        limits.count("n_modes", n_modes, 1, limits.MAX_MODE_COUNT, ProcessError)
    if n_phi is not None:
        top = validity.MAX_SAMPLES_PER_REV
        limits.count("n_phi", n_phi, 8, top, ProcessError)
        if n_phi % 2:
            raise ProcessError(f"n_phi: {n_phi} must be even (8-{top})")
    limits.count("table_rows", table_rows, 2, limits.MAX_TABLE_ROWS, ProcessError)
    if isinstance(sources, str):
        sources = (sources,)
    if not isinstance(sources, Iterable) or not tuple(sources):
        raise ProcessError(f"sources: {sources!r} names no error source (at least one)")


def _sampling(
    machine: Machine, basis: ModalBasis, process: Process, n_phi: int | None, spacing
) -> int:
    """Samples per revolution: ``n_phi`` or, if None, the default from the basis' highest
    mode, the tool carrier's mode and the surface grid's step across the feed
    (:func:`~ufmt.machining.cut_geometry.samples_per_rev`), inside the validity domain (with
    the tool and workpiece bodies in the basis)."""
    validity.check_bodies(machine, basis.body_shapes)
    highest_hz = float(basis.omega[-1]) / (2 * np.pi)
    if n_phi is None:  # 0 stays an error of the discretisation, not the default
        x_step = float(np.atleast_1d(spacing)[0])
        n_phi = samples_per_rev(
            _machine_highest_hz(basis),
            process.rpm / 60.0,
            machine.tool_radius,
            x_step,
            _tool_mode_hz(basis) or 0.0,
        )
    validity.check_sampling(n_phi, process, highest_hz)
    return n_phi


@dataclass(frozen=True, eq=False)
class SimulationOptions:
    """The options of one :func:`simulate` call that the run reads, as :func:`simulate` takes
    them (its parameters hold their meaning and defaults); ``force_scale`` resolved (the
    machine's where the call gave none)."""

    zeta: float | np.ndarray
    method: str
    force_scale: float
    coefficients: ForceCoefficients
    n_phi: int
    table_rows: int
    spacing: float | tuple[float, float]
    trailing_arc: bool
    record_periods: int
    sources: str | Iterable[str]
    aperture_margin: float
    psd2_patch: float | None
    basis_cutoff_hz: float | None  # None: the basis was chosen by count
    line_spacing: float | None = DEFAULT_LINE_SPACING


@lru_cache(maxsize=8)
def _machine(model) -> Machine:
    """The model's validated machine (cached per model object; models are immutable)."""
    return machine_of(model)


def _residual(model, basis: ModalBasis, machine: Machine) -> ResidualFlexibility:
    """The static correction of ``basis`` (cached per model, basis and machine)."""
    return residual_flexibility(model, basis, machine)


def _profiles(model, machine: Machine, sources) -> dict:
    """The model-built height of each acting :data:`~ufmt.machining.sources.MODEL` source
    among ``sources`` (built lazily, cached per model and machine by its module); none for a
    model without bodies (a basis given directly stands for its structure)."""
    if not model.bodies:
        return {}
    return {
        source.name: source.profile(model, machine)
        for source in acting_sources(check_sources(sources), machine)
        if source.enters == MODEL
    }


def _basis(
    model, machine: Machine, basis: ModalBasis | None, n_modes: int | None, cutoff_hz: float
) -> ModalBasis:
    """The basis of the run: ``basis`` (the model's when None) cut to ``n_modes`` or to the
    modes below ``cutoff_hz`` [Hz], its tool and workpiece bodies checked, with the machine's
    tool carrier (:func:`~ufmt.machining.tool.with_tool`)."""
    if basis is None:
        from ufmt.machining.modal import modal_basis

        basis = modal_basis(model, n_modes, cutoff_hz)
    basis = _truncated(basis, _basis_size(basis, n_modes, cutoff_hz))
    validity.check_bodies(machine, basis.body_shapes)
    return with_tool(basis, machine)


def _machine_highest_hz(basis: ModalBasis) -> float:
    """The highest natural frequency [Hz] of the machine's modes in ``basis`` (the tool
    carrier's mode left out, :mod:`ufmt.machining.tool`)."""
    omega = basis.omega if basis.tool is None else basis.tool.structure_omega
    return float(omega[-1]) / (2 * np.pi)


def _tool_mode_hz(basis: ModalBasis) -> float | None:
    """The tool carrier's natural frequency [Hz] in ``basis``, or None (no carrier)."""
    tool = basis.tool
    return None if tool is None else float(basis.omega[tool.mode]) / (2 * np.pi)


def _basis_size(basis: ModalBasis, n_modes: int | None, cutoff_hz: float) -> int:
    """Modes of ``basis`` kept: ``n_modes`` if given, else those below ``cutoff_hz`` [Hz]."""
    if n_modes is not None:
        return n_modes
    if not (math.isfinite(cutoff_hz) and cutoff_hz > 0):
        raise ValueError(f"basis_cutoff_hz must be a finite number > 0 [Hz], got {cutoff_hz!r}")
    kept = int(np.count_nonzero(basis.omega <= 2 * np.pi * cutoff_hz))
    if kept == 0:
        raise ValueError(
            f"no mode below basis_cutoff_hz = {cutoff_hz:g} Hz (lowest "
            f"{basis.omega[0] / (2 * np.pi):.4g} Hz)"
        )
    return kept


@lru_cache(maxsize=16)
def _truncated(basis: ModalBasis, n_modes: int) -> ModalBasis:
    """The first ``n_modes`` of ``basis``, one object per (basis, n) so caches keep hitting."""
    return basis.truncated(n_modes)


def _run(
    basis: ModalBasis,
    machine: Machine,
    process: Process,
    residual: ResidualFlexibility | None,
    options: SimulationOptions,
    profiles: dict,
) -> SimulationResult:
    """One simulation on a truncated ``basis``: the response, the surfaces and the metrics;
    ``profiles`` the model-built heights (:func:`_profiles`)."""
    if options.method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {options.method!r}")
    force_scale = options.force_scale
    if not (np.isfinite(force_scale) and force_scale > 0):
        raise ValueError(f"force_scale must be a finite number > 0, got {force_scale!r}")
    sources = check_sources(options.sources)
    zeta = modal_damping(options.zeta, basis.n_modes)
    response = _response(basis, machine, process, residual, zeta, options)
    validity.check_contact(response.z_re, process)

    # every surface reported (the total, the band surface, each source alone) is the lower
    # pass of a sum of per-source heights on one set of passes: each height is computed once
    acting = tuple(
        s for s in acting_sources(sources, machine) if s.enters != MODEL or s.name in profiles
    )
    passes = surface_passes(machine, process.feed_per_rev_m, options.spacing, options.trailing_arc)
    terms = {
        source.name: source.heights(passes, response.table, machine, process, profiles)
        for source in acting
    }
    total = passes.lower(terms.values())
    # the scallop's wavelength (v/f) cos(phi) <= 80 um lies below PSD2 (>= 120 um) for every
    # Table 1 process; on grids coarser than it, it would only alias into the bands
    smooth = [terms[source.name] for source in acting if source.enters != SCALLOP]
    scallops = any(source.enters == SCALLOP for source in acting)
    band_surface = passes.lower(smooth) if scallops else total
    metrics = surface_metrics(total, options.aperture_margin)
    smooth_acting = tuple(source for source in acting if source.enters != SCALLOP)
    bands, spectra = _band_rms(
        band_surface, response, machine, process, smooth_acting, options, profiles
    )
    metrics.update(bands)
    if options.psd2_patch is not None:
        metrics.update(_psd2_band_rms(response, machine, process, acting, options, profiles))
    pv_by_source = _pv_by_source(sources, passes, terms, metrics["pv_nm"])
    metrics.update(_dynamic_metrics(passes, terms, machine))
    metrics.update(_record_metrics(response, machine, force_scale))
    metrics["tip_acc_measured_mm_s2"] = _extrapolated_acceleration(
        metrics["tip_acc_measured_mm_s2"], basis, machine, process, zeta, options
    )
    metrics.update(_instrument_metrics(machine, process, band_surface, scallops, total, options))
    highest = _machine_highest_hz(basis)
    return SimulationResult(
        process=process,
        method=options.method,
        machine=machine,
        zeta=zeta,
        force_scale=float(force_scale),
        response=response,
        surface=total,
        smooth_surface=band_surface,
        metrics=metrics,
        pv_by_source_nm=pv_by_source,
        sources=sources,
        n_modes=basis.n_modes - (basis.tool is not None),
        basis_cutoff_hz=float(options.basis_cutoff_hz or highest),
        basis_highest_hz=highest,
        samples_per_rev=options.n_phi,
        tool_mode_hz=_tool_mode_hz(basis),
        psd_spectra=spectra,
    )


def _instrument_metrics(
    machine: Machine,
    process: Process,
    smooth: Surface,
    scallops: bool,
    total: Surface,
    options: SimulationOptions,
) -> dict[str, float]:
    """The flatness the interferometer reports and the feed marks' roughness [nm]
    (:mod:`ufmt.machining.instruments`; roughness 0 where the feed marks are off)."""
    feed = process.feed_per_rev_m
    instrument = Interferometer(aperture_margin=options.aperture_margin)
    out = interferometer_metrics(
        smooth, machine, feed, scallops=total if scallops else None, instrument=instrument
    )
    if scallops:
        out.update(scallop_roughness(machine, feed, options.aperture_margin))
    else:
        out.update(roughness_pv_nm=0.0, roughness_rq_nm=0.0)
    return out


def _response(
    basis: ModalBasis,
    machine: Machine,
    process: Process,
    residual: ResidualFlexibility | None,
    zeta: np.ndarray,
    options: SimulationOptions,
) -> Response:
    """The response of every force part with a non-zero coefficient, by ``options.method``:
    the parts share one inverse FFT (periodic) or one recurrence (time)."""
    geos = _geometries(basis, machine, residual, options)
    if options.method == "periodic":
        return periodic_response(geos, process, zeta, options.force_scale)
    return time_response(geos, process, zeta, options.force_scale, options.record_periods)


def _geometries(
    basis: ModalBasis,
    machine: Machine,
    residual: ResidualFlexibility | None,
    options: SimulationOptions,
) -> list:
    """The cut geometry of every force part with a non-zero coefficient."""
    coefficients = options.coefficients
    return [
        cut_geometry(
            basis, machine, coefficients, options.n_phi, options.table_rows, part, residual
        )
        for part in FORCE_PARTS
        if any(coefficients.vector(part))
    ]


def _band_rms(
    band_surface: Surface,
    response: Response,
    machine: Machine,
    process: Process,
    smooth: tuple[ErrorSource, ...],
    options: SimulationOptions,
    profiles: dict,
) -> tuple[dict[str, float], dict | None]:
    """The PSD bands [nm] of the surface without the scallops (the ``smooth`` sources) with
    psd_line_spacing_mm, the profiles' step, and the line profiles' spectra: on the line
    profiles at ``options.line_spacing`` (:func:`~ufmt.machining.lines.line_spectra`), or on
    ``band_surface``'s grid if None (no spectra)."""
    if options.line_spacing is None:
        step = max(band_surface.spacing) * 1e3
        bands = band_rms(band_surface, aperture_margin=options.aperture_margin)
        return {**bands, "psd_line_spacing_mm": step}, None

    def heights(passes):
        return [s.heights(passes, response.table, machine, process, profiles) for s in smooth]

    spectra = line_spectra(
        machine,
        process.feed_per_rev_m,
        band_surface,
        heights,
        options.line_spacing,
        options.trailing_arc,
        options.aperture_margin,
    )
    return {**line_band_rms(spectra), "psd_line_spacing_mm": options.line_spacing * 1e3}, spectra


def _psd2_band_rms(
    response: Response,
    machine: Machine,
    process: Process,
    acting: tuple[ErrorSource, ...],
    options: SimulationOptions,
    profiles: dict,
) -> dict[str, float]:
    """The PSD2 band RMS [nm] (psd2_rms_nm, psd2_rms_along_nm, psd2_rms_across_nm) of the
    square patch of side ``options.psd2_patch`` [m] at the plate centre
    (:data:`~ufmt.machining.surface.PSD2_PATCH_SPACING`), without the scallops."""
    half = options.psd2_patch / 2
    window = ((-half, half), (-half, half))
    patch_passes = surface_passes(
        machine, process.feed_per_rev_m, PSD2_PATCH_SPACING, options.trailing_arc, window
    )
    patch = patch_passes.lower(
        source.heights(patch_passes, response.table, machine, process, profiles)
        for source in acting
        if source.enters != SCALLOP
    )
    return band_rms(patch, bands=("psd2",))


def _pv_by_source(
    sources: tuple[str, ...], passes: Passes, terms: dict, pv_nm: float
) -> dict[str, float | None]:
    """PV [nm] of the surface of each source alone, in :data:`SOURCES` order: None where
    switched off, 0 where it does not act, the total ``pv_nm`` where it is the only source."""
    alone = dict(zip(terms, passes.pv_each(terms.values()), strict=True)) if terms else {}
    pv_by_source = {}
    for name in SOURCES:
        if name not in sources:
            pv_by_source[name] = None
        elif name not in terms:
            pv_by_source[name] = 0.0
        elif len(sources) == 1:
            pv_by_source[name] = pv_nm
        else:
            pv_by_source[name] = alone[name] * 1e9
    return pv_by_source


def _dynamic_metrics(passes: Passes, terms: dict, machine: Machine) -> dict[str, float]:
    """The metrics of the cutting-force vibration's surface alone
    (:func:`~ufmt.machining.surface.dynamic_metrics`; NaN where that source is off)."""
    if DYNAMIC not in terms:
        return dict.fromkeys(DYNAMIC_METRICS, math.nan)
    return dynamic_metrics(passes, terms[DYNAMIC], machine)


def _record_metrics(response: Response, machine: Machine, force_scale: float) -> dict[str, float]:
    """The record window's metrics: zre_peak_nm, tip_acc_peak_mm_s2 (raw, the head's z
    acceleration at the tool point), carrier_acc_peak_mm_s2 (raw, the tool carrier's),
    tip_acc_measured_mm_s2 (the head's at the tool point as the accelerometer chain reports
    it: the sensor on the fly-cutting head, the disc that carries the tool; on the shank's
    own carrier the chain would report tens of times Fig. 12, docs/ufmt-model.md), force_peak_n,
    and the
    force_scale used."""
    per = response.periods
    return {
        "zre_peak_nm": _mean_smooth_peak(response.z_re, per) * 1e9,
        "tip_acc_peak_mm_s2": _mean_peak(response.tip_acc[:, 2], per) * 1e3,
        "carrier_acc_peak_mm_s2": _mean_peak(response.carrier_acc, per) * 1e3,
        "tip_acc_measured_mm_s2": _accelerometer_peak(
            machine, response.t, response.tip_acc[:, 2], per
        ),
        "force_peak_n": float(np.linalg.norm(response.force, axis=1).max()),
        "force_scale": float(force_scale),
    }


def _accelerometer_peak(machine: Machine, t: np.ndarray, acc: np.ndarray, periods: int) -> float:
    """The accelerometer chain's average peak [mm/s^2] of the tool tip's z acceleration
    ``acc`` [m/s^2] at times ``t`` [s] over ``periods`` spindle periods."""
    return accelerometer_peak(t, acc, periods, AccelerometerChain.of(machine)) * 1e3


def _extrapolated_acceleration(
    measured: float,
    basis: ModalBasis,
    machine: Machine,
    process: Process,
    zeta: np.ndarray,
    options: SimulationOptions,
) -> float:
    """The accelerometer's peak [mm/s^2] extrapolated to fine sampling (Richardson).

    The sampled force smears the engagement step over one sample, and the acceleration
    follows the force directly, so the peak converges at second order in the sample step
    (tests/test_convergence.py checks the rate). a(n) + (4/3) (a_p(2n) - a_p(n)) removes
    that term, a_p the periodic path's record at the same slide position
    (:func:`_periodic_acceleration`); ``measured`` a(n) is the run's own value.
    """
    fine = replace(options, n_phi=2 * options.n_phi)
    a_fine = _periodic_acceleration(basis, machine, process, zeta, fine)
    if options.method == "periodic":
        a_coarse = measured  # the record does not depend on the table's rows
    else:
        a_coarse = _periodic_acceleration(basis, machine, process, zeta, options)
    return measured + (a_fine - a_coarse) * 4.0 / 3.0


def _periodic_acceleration(
    basis: ModalBasis,
    machine: Machine,
    process: Process,
    zeta: np.ndarray,
    options: SimulationOptions,
) -> float:
    """The accelerometer's peak [mm/s^2] of the periodic path's record window at
    ``options.n_phi``: that of ``_response`` with ``method="periodic"`` to rounding, from the
    tool tip's z acceleration alone
    (:func:`~ufmt.machining.periodic_path.record_tip_acceleration`: the record does not read
    the table's rows, of which the geometry then holds ACCELEROMETER_TABLE_ROWS, nor the static
    correction, which does not reach the acceleration)."""
    record = replace(options, table_rows=ACCELEROMETER_TABLE_ROWS)
    geos = _geometries(basis, machine, None, record)
    t, acc = record_tip_acceleration(geos, process, zeta, options.force_scale)
    return _accelerometer_peak(machine, t, acc, 1)


def _mean_peak(signal: np.ndarray, periods: int) -> float:
    """Mean over the spindle periods of the largest |signal| in each."""
    return float(np.abs(signal).reshape(periods, -1).max(axis=1).mean())


def _mean_smooth_peak(signal: np.ndarray, periods: int) -> float:
    """:func:`_mean_peak` of a continuous signal (a displacement), each largest sample refined
    by the parabola through it and its neighbours: the peak between samples (the ringing tool
    carrier is sampled 17-41 times per period, where the largest sample misses its peak by up
    to 1 - cos(pi / 17) = 1.7 %). Not for an acceleration, which jumps with the force (there
    the parabola overshoots)."""
    s = np.abs(signal).reshape(periods, -1)
    rows = np.arange(periods)
    i = np.argmax(s, axis=1)
    a, b, c = s[rows, i - 1], s[rows, i], s[rows, (i + 1) % s.shape[1]]
    curve = a - 2 * b + c
    lift = np.where(curve < 0, (a - c) ** 2 / (-8 * np.where(curve < 0, curve, -1.0)), 0.0)
    return float(np.mean(b + lift))
