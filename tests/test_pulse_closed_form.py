"""z_re's peak against a closed form of the response to the cutting pulse (tests/pulse.py).

The force acts for a few milliseconds per spindle period (the leading arc over the plate).
With the tool carrier as an oscillator its entry step rings: z_re peaks half a carrier
period after the entry, long before any machine mode below a few hundred hertz has moved.
Such a mode's share of the peak is then mass-controlled, F c^2 t^2 / (2 M) at time t after
the step, whatever its stiffness, so softening it leaves the peak while the static compliance
F c^2 / (M w^2) grows. A mode alone under a pulse much shorter than its period peaks after
the pulse at its impulse's response, I c^2 / (M w) times a factor of its damping ratio, not
at its static compliance. Without the carrier the peak comes late in the pulse and follows
the mode. The oracles: the closed form (Duhamel's integral, periodic over the
spindle period, no sampling) and the convergence of the sampled response to it at second
order in the sample step (the entry step sampled as a ramp over one sample)."""

from __future__ import annotations

import numpy as np
import pytest
from pulse import PulseResponse, force, relative_shapes

import ufmt
from ufmt.design import apply_design, design_value
from ufmt.machining.basis import ModalBasis
from ufmt.machining.cutting import DEFAULT_COEFFICIENTS
from ufmt.machining.machine_frame import in_machine_frame
from ufmt.machining.modal import modal_basis
from ufmt.machining.process import Process
from ufmt.machining.static import residual_flexibility
from ufmt.machining.tool import with_tool
from ufmt.model.machine import machine_of, read_machine
from ufmt.model.schema import Model
from ufmt.simulate import simulate

REFERENCE = Process(300, 15, 4)
#: z_re alone: its peak reads neither the error sources nor the PSD line profiles
ZRE_ONLY = {"sources": ("dynamic",), "line_spacing": None}
#: the packaged machine's plate and tool circle; its carrier (28.5 nm/N, 15 g, 3 %) and a
#: damping ratio near the packaged head mode's (3.8-6.3 % with the bearing's dampers)
PLATE = {
    "tool_body": "head",
    "workpiece_body": "slider",
    "spindle_axis_xy": [0.0, 0.0],
    "cutting_plane_z": 0.0,
    "tool_radius": 0.3,
    "workpiece_size": [0.0524, 0.0524],
    "workpiece_center_xy": [0.0, 0.0],
    "rotation": "cw",
    "modal_damping_ratio": 0.06,
}
CARRIER = {
    **PLATE,
    "tool_compliance_m_per_N": 2.85e-8,
    "tool_mass_kg": 0.015,
    "tool_damping_ratio": 0.03,
}


def head_basis(head_hz: float) -> ModalBasis:
    """Three modes of a head heaving and tilting over a still workpiece: a 350 kg head mode at
    ``head_hz`` between modes at 180 and 754 Hz (effective masses 640 and 97 kg at the tool
    point), as the packaged head's axial bearing mode sits among its neighbours."""
    hz = np.array([180.0, head_hz, 754.0])
    head, work = np.zeros((3, 6)), np.zeros((3, 6))
    head[:, 2] = 1 / np.sqrt([640.0, 350.0, 97.0])
    head[:, 3] = [2e-3, -1e-3, 3e-3]
    work[:, 2] = [-2e-3, 1e-3, -4e-3]
    order = np.argsort(hz)
    return ModalBasis(
        omega=2 * np.pi * hz[order],
        modal_mass=np.ones(3),
        body_shapes={"head": head[order], "slider": work[order]},
        body_centers={"head": [0, 0, 0.15], "slider": [0, 0, -0.15]},
    )


def synthetic_case(head_hz: float, n_phi: int, zeta: float = 0.06):
    """simulate's z_re peak [nm] on :func:`head_basis` with the carrier and structural
    damping ``zeta``, and the closed form."""
    machine = read_machine({**CARRIER, "modal_damping_ratio": zeta})
    basis = head_basis(head_hz)
    model = Model("syn", (), (), machine=machine)
    run = simulate(model, REFERENCE, basis=basis, n_phi=n_phi, static_correction=False, **ZRE_ONLY)
    closed = PulseResponse(with_tool(basis, machine), machine, REFERENCE, zeta, 1.0)
    return run.metrics["zre_peak_nm"], closed


def static_compliance(closed: PulseResponse) -> np.ndarray:
    """Each mode's static tool-workpiece compliance in z at phi = 0, c^2 / (M w^2) [m/N]."""
    b = closed.basis
    c = relative_shapes(b, closed.machine, np.array([0.0]), closed.slide_y)[:, 0, 2]
    return c**2 / (b.modal_mass * b.omega**2)


def carrier_half_period(closed: PulseResponse) -> float:
    """Half the damped period [s] of the tool carrier's mode (its pole, the largest |lambda|)."""
    return np.pi / np.abs(closed.lam.imag).max()


def assert_second_order(coarse: float, fine: float, exact: float) -> None:
    """Errors of n and 2 n samples per revolution in the ratio 4 (order 2 in the step)."""
    ratio = (exact - coarse) / (exact - fine)
    assert 3.7 < ratio < 4.3, (coarse, fine, exact, ratio)


@pytest.mark.parametrize(("head_hz", "zeta"), [(450.0, 0.06), (82.0, 0.01)])
def test_zre_peak_converges_to_the_closed_form_at_second_order(head_hz, zeta):
    """simulate's z_re peak tends to the closed form's as dt^2 (the entry step's ramp); the
    peak lies half a carrier period after the entry, the tool pushed up (z_re > 0). At 1 %
    the 82 Hz mode still rings from the previous revolution (e^(-zeta w T) = 0.36): the
    periodic sum carries a tenth of the peak there."""
    coarse, closed = synthetic_case(head_hz, 16384, zeta)
    fine, _ = synthetic_case(head_hz, 32768, zeta)
    peak, when = closed.peak()
    assert_second_order(coarse, fine, peak * 1e9)
    assert when == pytest.approx(carrier_half_period(closed), rel=1e-2)
    assert closed.z_re(np.array([closed.a + when]))[0] == pytest.approx(peak, rel=1e-12)


def test_softening_a_slow_mode_moves_the_static_compliance_not_the_peak():
    """A tenfold softer head mode (450 -> 142 Hz) raises the static compliance by ~10 % but
    its share of the peak stays F c^2 t^2 / (2 M): the peak moves by < 1e-3 of F times the
    static change, in the closed form and in simulate alike."""
    runs = {hz: synthetic_case(hz, 16384) for hz in (450.0, 450.0 / np.sqrt(10.0))}
    (stiff, c_stiff), (soft, c_soft) = runs.values()
    entry = force(np.array([c_stiff.a * c_stiff.spin]), REFERENCE, c_stiff.machine, 1.0)[0, 2]
    rise = static_compliance(c_soft).sum() - static_compliance(c_stiff).sum()
    assert rise > 0.05 * static_compliance(c_stiff).sum()
    peaks = []
    for hz, (_, closed) in zip(runs, runs.values(), strict=True):
        peak, when = closed.peak()
        peaks.append(peak)
        head = int(np.argmin(np.abs(closed.basis.omega - 2 * np.pi * hz)))
        c = relative_shapes(closed.basis, closed.machine, np.array([0.0]), closed.slide_y)
        share = closed.modal(np.array([closed.a + when]))[head, 0]
        # mass-controlled: corrections (w t)^2 / 12 and zeta w t / 3 are below 1 % here
        assert share == pytest.approx(entry * c[head, 0, 2] ** 2 * when**2 / 2, rel=2e-2)
    assert abs(peaks[1] - peaks[0]) < 1e-3 * entry * rise
    assert abs(soft - stiff) * 1e-9 < 1e-3 * entry * rise


def test_without_the_carrier_the_peak_follows_the_softened_mode():
    """With a rigid tool (no carrier to ring) the peak comes late in the pulse, where the
    head mode has built up: softening it tenfold raises the peak by more than F times the
    static compliance's rise (its overshoot adds), simulate and the closed form alike."""
    machine = read_machine(PLATE)
    model = Model("syn", (), (), machine=machine)
    peaks, statics = [], []
    for hz in (450.0, 450.0 / np.sqrt(10.0)):
        basis = head_basis(hz)
        coarse, fine = (
            simulate(model, REFERENCE, basis=basis, n_phi=n, static_correction=False, **ZRE_ONLY)
            for n in (4096, 8192)
        )
        closed = PulseResponse(basis, machine, REFERENCE, 0.06, 1.0)
        peak, when = closed.peak()
        assert when > 0.5 * (closed.b - closed.a)  # in the pulse's second half
        fine = fine.metrics["zre_peak_nm"]
        assert_second_order(coarse.metrics["zre_peak_nm"], fine, peak * 1e9)
        peaks.append((fine, peak * 1e9))
        statics.append(static_compliance(closed).sum())
    entry = force(np.array([closed.a * closed.spin]), REFERENCE, machine, 1.0)[0, 2]
    moved_sim, moved = (peaks[1][i] - peaks[0][i] for i in (0, 1))
    assert moved > entry * (statics[1] - statics[0]) * 1e9
    assert moved_sim == pytest.approx(moved, rel=1e-3)


@pytest.mark.parametrize("hz", [25.0, 50.0])
def test_a_mode_alone_peaks_on_the_pulse_impulse_not_its_static_compliance(hz):
    """One 350 kg mode under a 1.06 ms pulse (a 10 mm plate): the peak after the pulse is
    kappa(zeta) I / (M w), the damped impulse response's largest value, to (w T_p)^2 / 12
    (the pulse's finite length: (w T_p)^2 / 24 undamped), not F / (M w^2); simulate equals
    the closed form to 1e-4 (a slow mode's sampling error is (w dt)^2 small)."""
    zeta, mass = 0.2, 350.0
    machine = read_machine({**PLATE, "workpiece_size": [0.01, 0.01], "modal_damping_ratio": zeta})
    basis = ModalBasis(
        omega=np.array([2 * np.pi * hz]),
        modal_mass=np.array([mass]),
        body_shapes={"head": np.array([[0, 0, 1.0, 0, 0, 0]]), "slider": np.zeros((1, 6))},
        body_centers={"head": [0, 0, 0.15], "slider": [0, 0, -0.15]},
    )
    model = Model("syn", (), (), machine=machine)
    run = simulate(
        model, REFERENCE, basis=basis, static_correction=False, aperture_margin=1e-3, **ZRE_ONLY
    )
    closed = PulseResponse(basis, machine, REFERENCE, zeta, 1.0)
    peak, when = closed.peak()
    assert when > closed.b - closed.a  # after the pulse
    assert run.metrics["zre_peak_nm"] == pytest.approx(peak * 1e9, rel=1e-4)
    # the impulse: thrust s (K_t a_p (v/f) cos(phi) + K_et b) integrated over the arc [a, b]
    k, spin = DEFAULT_COEFFICIENTS, closed.spin
    chip = REFERENCE.depth_m * REFERENCE.feed_per_rev_m
    edge = np.sqrt(2 * machine.nose_radius * REFERENCE.depth_m)
    lo, hi = closed.a * spin, closed.b * spin
    impulse = (
        k.thrust * chip * (np.sin(hi) - np.sin(lo)) + k.edge_thrust * edge * (hi - lo)
    ) / spin
    w, root = 2 * np.pi * hz, np.sqrt(1 - zeta**2)
    kappa = np.exp(-zeta / root * np.arctan(root / zeta))
    short = (w * (closed.b - closed.a)) ** 2 / 12
    assert peak == pytest.approx(kappa * impulse / (mass * w), rel=short)
    static = force(np.array([0.0]), REFERENCE, machine, 1.0)[0, 2] / (mass * w**2)
    assert peak < 0.6 * static  # far below the static compliance's answer


@pytest.mark.slow
def test_packaged_zre_peak_and_the_softened_head_bearing():
    """The packaged machine and its head's axial bearing softened tenfold: simulate's z_re
    peak converges at second order to the closed form on the same basis and static residual
    (the basis' truncation is common to both: the residual carries the modes above it); the
    peak lies half a carrier period after the entry and moves by < 1e-3 of F times the
    static compliance's rise (`ufmt frf` at 1 Hz)."""
    base = ufmt.load_model()
    value = design_value(base, "head_axial_stiffness_N_m")
    soft = apply_design(base, {"head_axial_stiffness_N_m": 0.1 * value})
    peaks, statics = [], []
    for model in (base, soft):
        coarse, fine = (
            simulate(model, REFERENCE, n_phi=n, **ZRE_ONLY).metrics["zre_peak_nm"]
            for n in (32768, 65536)
        )
        framed = in_machine_frame(model)
        machine = machine_of(framed)
        basis = with_tool(modal_basis(framed), machine)
        residual = residual_flexibility(framed, basis, machine)
        closed = PulseResponse(
            basis, machine, REFERENCE, machine.modal_damping_ratio, machine.force_scale, residual
        )
        peak, when = closed.peak()
        assert_second_order(coarse, fine, peak * 1e9)
        assert when == pytest.approx(carrier_half_period(closed), rel=1e-2)
        peaks.append((fine, peak))
        h = ufmt.frf(model, fmin_hz=1.0, fmax_hz=2.0, points=2).values[0]
        statics.append(abs(h))
    entry = force(np.array([closed.a * closed.spin]), REFERENCE, machine, machine.force_scale)
    rise = statics[1] - statics[0]
    assert rise > 0.05 * statics[0]
    for i in (0, 1):  # simulate's, the closed form's
        moved = abs(peaks[1][i] - peaks[0][i]) * (1e-9 if i == 0 else 1.0)
        assert moved < 1e-3 * entry[0, 2] * rise
