"""The accelerometer's record computed alone equals the full periodic response's (oracle: the
same record as :func:`periodic_response` forms it, every body's motion, the static correction,
the force and the z_re table, on the same geometry), and the reported, extrapolated peak equals
the Richardson step taken on two full periodic responses, the fine one at twice the samples
(``ufmt.simulate._response`` with the run's options), to rounding."""

from __future__ import annotations

import importlib
from dataclasses import replace

import numpy as np
import pytest
from synthetic import SMALL, synthetic_basis

from ufmt.defaults import DEFAULT_BASIS_CUTOFF_HZ
from ufmt.machining.cut_geometry import cut_geometry
from ufmt.machining.cutting import FORCE_PARTS
from ufmt.machining.damping import damped_modes
from ufmt.machining.instruments import AccelerometerChain, accelerometer_peak
from ufmt.machining.periodic_path import periodic_response, record_tip_acceleration
from ufmt.machining.process import Process
from ufmt.machining.recurrence import modal_damping
from ufmt.model.machine import read_machine
from ufmt.simulate import simulate

#: ufmt.simulate the module (the package exports the function under the same name)
simulation = importlib.import_module("ufmt.simulate")
REFERENCE = Process(300.0, 15.0, 4.0)


def full_peak(response, machine) -> float:
    """The accelerometer chain's peak [mm/s^2] of a full response's record window."""
    chain = AccelerometerChain.of(machine)
    return accelerometer_peak(response.t, response.tip_acc[:, 2], response.periods, chain) * 1e3


def assert_same_record(geos, process, zeta, force_scale):
    full = periodic_response(geos, process, zeta, force_scale)
    t, acc = record_tip_acceleration(geos, process, zeta, force_scale)
    np.testing.assert_array_equal(t, full.t)
    scale = np.abs(full.tip_acc[:, 2]).max()
    assert scale > 0
    np.testing.assert_allclose(acc, full.tip_acc[:, 2], rtol=0, atol=1e-12 * scale)


def test_the_record_alone_equals_the_full_record_with_classical_modes():
    """No hinge damping: the real recurrence's path."""
    basis = synthetic_basis()
    machine = read_machine(SMALL)
    assert damped_modes(basis, 0.02) is None
    geos = [cut_geometry(basis, machine, n_phi=512, part=part) for part in FORCE_PARTS]
    assert_same_record(geos, Process(400, 16, 4), 0.02, 1.3)


def test_the_record_alone_equals_the_full_record_with_complex_modes(packaged, packaged_basis):
    """The packaged model: hinge dampers, complex modes, the static correction (which the
    full record adds to the displacements only)."""
    machine = simulation._machine(packaged)
    residual = simulation._residual(packaged, packaged_basis, machine)
    zeta = modal_damping(machine.modal_damping_ratio, packaged_basis.n_modes)
    assert damped_modes(packaged_basis, zeta) is not None
    geos = [
        cut_geometry(packaged_basis, machine, n_phi=2048, table_rows=8, part=p, residual=residual)
        for p in FORCE_PARTS
    ]
    assert_same_record(geos, REFERENCE, zeta, machine.force_scale)


@pytest.mark.parametrize("process", (REFERENCE, Process(260.0, 11.0, 5.0)))
def test_the_reported_peak_equals_the_step_on_full_responses(packaged, packaged_basis, process):
    """The packaged model at default sampling, the periodic path."""
    assert_the_step_on_full_responses(packaged, packaged_basis, process, "periodic")


@pytest.mark.slow
def test_the_reported_peak_of_the_time_path_equals_the_step_on_full_responses(
    packaged, packaged_basis
):
    """The time path (its own a(n); the step's a_p(n) from a periodic record)."""
    assert_the_step_on_full_responses(packaged, packaged_basis, REFERENCE, "time")


def assert_the_step_on_full_responses(packaged, packaged_basis, process, method):
    """The reported peak against a(n) + 4/3 (a_p(2 n) - a_p(n)), a the run's own record and
    a_p a whole periodic response's (its static correction and every body's motion)."""
    result = simulate(packaged, process, basis=packaged_basis, method=method)
    machine = result.machine
    basis = simulation._basis(packaged, machine, packaged_basis, None, DEFAULT_BASIS_CUTOFF_HZ)
    residual = simulation._residual(packaged, basis, machine)
    zeta = modal_damping(machine.modal_damping_ratio, basis.n_modes)
    fine = simulation.SimulationOptions(
        zeta=machine.modal_damping_ratio,
        method="periodic",
        force_scale=machine.force_scale,
        coefficients=simulation.DEFAULT_COEFFICIENTS,
        n_phi=2 * result.samples_per_rev,
        table_rows=simulation.ACCELEROMETER_TABLE_ROWS,
        spacing=simulation.DEFAULT_SPACING,
        trailing_arc=False,
        record_periods=simulation.DEFAULT_RECORD_PERIODS,
        sources=simulation.SOURCES,
        aperture_margin=simulation.DEFAULT_APERTURE_MARGIN,
        psd2_patch=None,
        basis_cutoff_hz=DEFAULT_BASIS_CUTOFF_HZ,
    )
    a_fine = full_peak(simulation._response(basis, machine, process, residual, zeta, fine), machine)
    measured = a_coarse = full_peak(result.response, machine)
    if method == "time":
        coarse = replace(fine, n_phi=result.samples_per_rev)
        a_coarse = full_peak(
            simulation._response(basis, machine, process, residual, zeta, coarse), machine
        )
    expected = measured + (a_fine - a_coarse) * 4.0 / 3.0
    assert abs(a_fine - a_coarse) > 1e-6 * abs(a_coarse)  # the step does move the value
    assert result.metrics["tip_acc_measured_mm_s2"] == pytest.approx(expected, rel=1e-10)
