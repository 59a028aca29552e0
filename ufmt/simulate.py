"""Simulate fly-cutting on a machine model: cutting force, modal response, machined surface.

``simulate(model, process)`` is the Python API of ``ufmt simulate``: it takes the modal basis
of the model (or the one given), runs the periodic or the time-domain response and returns a
:class:`SimulationResult` with the arrays, the metrics and ``.plot(directory)``.
Process-independent work is cached per (basis, machine, options), so a new process on a known
basis costs only the response and the surface.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from ufmt.machining.basis import ModalBasis
from ufmt.machining.cutting import ForceCoefficients
from ufmt.machining.process import Process
from ufmt.machining.response import (
    DEFAULT_COEFFICIENTS,
    DEFAULT_N_PHI,
    DEFAULT_RECORD_PERIODS,
    DEFAULT_TABLE_ROWS,
    DEFAULT_ZETA,
    Response,
    cut_geometry,
    modal_damping,
    periodic_response,
    time_response,
)
from ufmt.machining.surface import DEFAULT_SPACING, Surface, machined_surface, surface_metrics
from ufmt.model.machine import Machine, machine_of, read_machine

METHODS = ("periodic", "time")


@dataclass(frozen=True, eq=False)
class SimulationResult:
    """Everything one simulation produced.

    metrics [nm, mm/s^2]: pv_nm, pv_tilt_removed_nm, rms_nm, psd1_rms_nm, psd2_rms_nm,
    grid_spacing_mm (see :func:`ufmt.machining.surface.surface_metrics`), zre_peak_nm (mean over the
    record window's spindle periods of the largest |z_re| in each; the window sits mid-cut, at
    :func:`ufmt.machining.response.record_slide`) and tip_acc_peak_mm_s2 (the same for the
    tool-tip z acceleration, in mm/s^2), force_scale.
    """

    process: Process
    method: str
    machine: Machine
    zeta: np.ndarray
    force_scale: float
    response: Response
    surface: Surface
    metrics: dict[str, float]

    def plot(self, directory) -> list[Path]:
        """Write the paper's Figs. 6, 7, 13 and 14 for this result as PNGs; returns the paths."""
        from ufmt.plots.response import plot_simulation

        return plot_simulation(self, directory)


def simulate(
    model,
    process: Process,
    *,
    n_modes: int = 30,
    zeta=DEFAULT_ZETA,
    method: str = "periodic",
    basis: ModalBasis | None = None,
    force_scale: float | None = None,
    coefficients: ForceCoefficients = DEFAULT_COEFFICIENTS,
    n_phi: int = DEFAULT_N_PHI,
    table_rows: int = DEFAULT_TABLE_ROWS,
    spacing: float | tuple[float, float] = DEFAULT_SPACING,
    nose_radius: float | None = None,
    trailing_arc: bool = False,
    record_periods: int = DEFAULT_RECORD_PERIODS,
) -> SimulationResult:
    """Machined surface and response of ``model`` under ``process``.

    Parameters
    ----------
    model : :class:`ufmt.model.schema.Model` with a ``[machine]`` table.
    process : :class:`Process` (rpm, feed_mm_min, depth_um).
    n_modes : modes kept (paper: 30).
    zeta : modal damping ratio, scalar or (n_modes,) array (default 0.03, see
        :mod:`ufmt.machining.response`).
    method : "periodic" (frequency domain, milliseconds; quasi-static in the slide position,
        so a few per cent low where transients at the plate's entry and exit edges set the PV)
        or "time" (every revolution of the whole workpiece, exact recurrence, seconds; use it
        for reference values). See :mod:`ufmt.machining.response`.
    basis : modal basis to use instead of ``ufmt.machining.modal.modal_basis(model, n_modes)``.
    force_scale : factor on the force coefficients; default the model's ``machine.force_scale``
        (1 when absent).
    coefficients, n_phi, table_rows : force model and discretisation (see
        :func:`ufmt.machining.response.cut_geometry`).
    spacing, nose_radius, trailing_arc : surface grid step [m] (one value or (x, y)),
        kinematic marks [m] (off) and back-cutting (off), see
        :func:`ufmt.machining.surface.machined_surface`. The defaults (grid 1 x 2 mm with
        refined edge bands, 192 table rows) keep the PV within ~1-3 % of a converged time-domain
        surface;
        ``spacing=2e-3, table_rows=96`` is about twice as fast and 1-7 % low.
    record_periods : spindle periods in the time path's record window.
    """
    machine = machine_of(model)
    if basis is None:
        from ufmt.machining.modal import modal_basis

        basis = modal_basis(model, n_modes)
    return _run(
        _truncated(basis, n_modes),
        machine,
        process,
        zeta=zeta,
        method=method,
        force_scale=machine.force_scale if force_scale is None else force_scale,
        coefficients=coefficients,
        n_phi=n_phi,
        table_rows=table_rows,
        spacing=spacing,
        nose_radius=nose_radius,
        trailing_arc=trailing_arc,
        record_periods=record_periods,
    )


def fit_force_scale(
    model_or_basis, reference_process: Process, target_pv_nm: float, *, machine=None, **options
) -> float:
    """Force scale factor that makes the surface PV of ``reference_process`` equal the target.

    z_re is linear in the force and, without kinematic marks, the surface is a minimum of
    z_re values, so PV(s) = s PV(1) for s > 0: the fit is the ratio target / PV(1).
    ``model_or_basis``: a Model (its basis from ``modal_basis``) or a :class:`ModalBasis`
    together with ``machine`` (a :class:`Machine` or a ``[machine]`` mapping). ``options`` go
    to :func:`simulate` (``nose_radius`` must stay off); fit the reference value with
    ``method="time"``.
    """
    if options.get("nose_radius") is not None:
        raise ValueError("fit_force_scale needs the kinematic marks off (PV is then linear)")
    if not target_pv_nm > 0:
        raise ValueError(f"target_pv_nm must be > 0, got {target_pv_nm!r}")
    options["force_scale"] = 1.0
    if isinstance(model_or_basis, ModalBasis):
        if machine is None:
            raise ValueError("fit_force_scale with a ModalBasis needs machine=")
        if isinstance(machine, Mapping):
            machine = read_machine(machine)
        n_modes = options.pop("n_modes", 30)
        result = _run(_truncated(model_or_basis, n_modes), machine, reference_process, **options)
    else:
        result = simulate(model_or_basis, reference_process, **options)
    return target_pv_nm / result.metrics["pv_nm"]


@lru_cache(maxsize=16)
def _truncated(basis: ModalBasis, n_modes: int) -> ModalBasis:
    """The first ``n_modes`` of ``basis``, one object per (basis, n) so caches keep hitting."""
    return basis.truncated(n_modes)


def _run(
    basis: ModalBasis,
    machine: Machine,
    process: Process,
    *,
    zeta=DEFAULT_ZETA,
    method: str = "periodic",
    force_scale: float = 1.0,
    coefficients: ForceCoefficients = DEFAULT_COEFFICIENTS,
    n_phi: int = DEFAULT_N_PHI,
    table_rows: int = DEFAULT_TABLE_ROWS,
    spacing: float | tuple[float, float] = DEFAULT_SPACING,
    nose_radius: float | None = None,
    trailing_arc: bool = False,
    record_periods: int = DEFAULT_RECORD_PERIODS,
) -> SimulationResult:
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if not (np.isfinite(force_scale) and force_scale > 0):
        raise ValueError(f"force_scale must be a finite number > 0, got {force_scale!r}")
    zeta = modal_damping(zeta, basis.n_modes)
    geo = cut_geometry(basis, machine, coefficients, n_phi, table_rows)
    if method == "periodic":
        response = periodic_response(geo, process, zeta, force_scale)
    else:
        response = time_response(geo, process, zeta, force_scale, record_periods)
    surface = machined_surface(
        response.table,
        machine,
        process.feed_per_rev_m,
        spacing=spacing,
        nose_radius=nose_radius,
        trailing_arc=trailing_arc,
    )
    metrics = surface_metrics(surface)
    per = response.periods
    metrics["zre_peak_nm"] = _mean_peak(response.z_re, per) * 1e9
    metrics["tip_acc_peak_mm_s2"] = _mean_peak(response.tip_acc[:, 2], per) * 1e3
    metrics["force_scale"] = float(force_scale)
    return SimulationResult(
        process=process,
        method=method,
        machine=machine,
        zeta=zeta,
        force_scale=float(force_scale),
        response=response,
        surface=surface,
        metrics=metrics,
    )


def _mean_peak(signal: np.ndarray, periods: int) -> float:
    """Mean over the spindle periods of the largest |signal| in each."""
    return float(np.abs(signal).reshape(periods, -1).max(axis=1).mean())
