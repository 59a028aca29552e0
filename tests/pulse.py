"""A closed form of z_re under the fly-cutting force pulse, independent of the response paths.

The cut's force acts once per spindle period T while the leading arc is over the plate
(angles [a, b], :func:`engagement`): a pulse of a few milliseconds. On a modal basis with its
damping D (``ufmt.machining.damping.damping_matrix``: structural ratios, hinge dampers, the
tool carrier's dashpot) the modal equations q'' + D q' + W^2 q = f / M are written in
first-order form x' = A x + B f and diagonalised here (numpy's eig of the 2n x 2n state
matrix, every pole kept: no conjugate pairing), z' = lambda z + u. The modal force of the
point force at the tip and its reaction on the workpiece is a trigonometric polynomial of
degree <= 3 in the spindle angle (the chip's cos(phi), the force's direction, the tip's arm),
so u = sum_k g_k e^(i k W_s t) on the pulse (W_s the spindle's angular speed) and Duhamel's
integral has the closed form

    int_a^s e^(lambda (t - tau)) e^(mu tau) dtau
        = (e^(lambda (t - s) + mu s) - e^(lambda (t - a) + mu a)) / (mu - lambda),

periodic over the previous revolutions through the geometric factor e^(lambda T) /
(1 - e^(lambda T)). z_re(t) = c(phi(t)) . q(t) plus the static residual's share of the
instantaneous force. The force is written from the documented formula (docs/ufmt-model.md,
'Cutting force'), not taken from ``ufmt.machining.cutting``; nothing here is sampled, so the
peak is the continuous one (a bounded scalar search).

``python tests/pulse.py [MODEL]`` prints the decomposition of z_re's peak at the reference cut
(each mode's static compliance and its share of the peak).
"""

from __future__ import annotations

import sys

import numpy as np
from scipy.optimize import minimize_scalar

from ufmt.machining.cutting import DEFAULT_COEFFICIENTS, ForceCoefficients
from ufmt.machining.damping import damping_matrix
from ufmt.machining.response import record_slide

#: Harmonics of the modal force over the pulse (degree <= 3), sampled exactly at 8 angles.
ORDERS = np.arange(-3, 4)


def engagement(machine) -> tuple[float, float]:
    """Spindle angles [a, b] [rad] of the pulse in the steady cut: the leading arc over the
    plate's x extent, |s_x + sense R sin(phi)| <= l_x / 2, solved here by arcsin."""
    ends = (np.array([-1.0, 1.0]) * machine.workpiece_size[0] / 2 - machine.offset_x) / (
        machine.sense * machine.tool_radius
    )
    lo, hi = np.sort(np.arcsin(ends))
    return float(lo), float(hi)


def tip(phi, machine) -> np.ndarray:
    """Tool tip (..., 3) [m] at angle phi (eq. 4.1)."""
    phi = np.asarray(phi, dtype=float)
    x0, y0 = machine.spindle_axis_xy
    r, s = machine.tool_radius, machine.sense
    z = np.full(phi.shape, machine.cutting_plane_z)
    return np.stack([x0 + s * r * np.sin(phi), y0 + r * np.cos(phi), z], axis=-1)


def force(phi, process, machine, scale: float, k: ForceCoefficients = DEFAULT_COEFFICIENTS):
    """Force on the tool (..., 3) [N] while it cuts: F = K_e b + K_c a_p (v/f) cos(phi) per
    component, cutting along -t, feed along -n, thrust along +z."""
    phi = np.asarray(phi, dtype=float)
    chip = process.depth_m * process.feed_per_rev_m * np.cos(phi)
    edge = np.sqrt(2 * machine.nose_radius * process.depth_m)
    s, c, sense = np.sin(phi), np.cos(phi), machine.sense
    t = np.stack([sense * c, -s, 0 * s], axis=-1)
    n = np.stack([sense * s, c, 0 * s], axis=-1)
    z = np.stack([0 * s, 0 * s, 1 + 0 * s], axis=-1)
    cut = (k.cutting * chip + k.edge_cutting * edge)[..., None]
    feed = (k.feed * chip + k.edge_feed * edge)[..., None]
    thrust = (k.thrust * chip + k.edge_thrust * edge)[..., None]
    return scale * (-cut * t - feed * n + thrust * z)


def relative_shapes(basis, machine, phi, slide_y: float) -> np.ndarray:
    """(n, P, 3): the tip on the tool body minus the material point under it on the workpiece
    body (the tip moved by slide_y along y, file coordinates) per mode, at angles phi (P,)."""
    p = tip(phi, machine)
    work = p + np.array([0.0, slide_y, 0.0])
    return basis.point_shapes(machine.tool_body, p) - basis.point_shapes(
        machine.workpiece_body, work
    )


def state_modes(basis, zeta):
    """Poles (2n,) [1/s], outputs (n, 2n) and inputs (2n, n) [1/kg] of the modal equations:
    q = Re(outputs z), z' = poles z + inputs f for the modal force f (n,) [N]."""
    n = basis.n_modes
    d = damping_matrix(basis, zeta)
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-np.diag(basis.omega**2), -d]])
    lam, vec = np.linalg.eig(a)
    inv = np.linalg.inv(vec)
    return lam, vec[:n], inv[:, n:] / basis.modal_mass


def periodic_pulse(lam, g, spin: float, a: float, b: float, t) -> np.ndarray:
    """Periodic response z (m, T) of z' = lam z + u, u = sum_k g[:, k] e^(i ORDERS[k] spin tau)
    on tau in [a, b] of each period 2 pi / spin and 0 elsewhere, at times t in [a, a + period)
    [s]; lam (m,), g (m, K)."""
    period = 2 * np.pi / spin
    lam = lam[:, None, None]
    mu = 1j * ORDERS[None, :, None] * spin
    t = np.asarray(t, dtype=float)[None, None, :]
    s = np.minimum(t, b)

    def integral(upper):
        return (np.exp(lam * (t - upper) + mu * upper) - np.exp(lam * (t - a) + mu * a)) / (
            mu - lam
        )

    e = np.exp(lam * period)
    total = integral(s) + e / (1 - e) * integral(b)
    return np.einsum("mk,mkt->mt", g, total)


class PulseResponse:
    """z_re(t) [m] of ``basis`` in the steady cut of ``process`` (module docstring).

    ``residual``: the static correction (None: modal sum alone); ``scale``: the force scale.
    """

    def __init__(self, basis, machine, process, zeta, scale, residual=None):
        self.basis, self.machine, self.process, self.residual = basis, machine, process, residual
        self.scale = scale
        self.spin = 2 * np.pi * process.spindle_hz
        self.slide_y = record_slide(machine)
        self.lam, self.out, self.inp = state_modes(basis, zeta)
        lo, hi = engagement(machine)
        self.a, self.b = lo / self.spin, hi / self.spin
        phi = 2 * np.pi * np.arange(8) / 8
        shapes = relative_shapes(basis, machine, phi, self.slide_y)
        modal = np.einsum("npi,pi->np", shapes, force(phi, process, machine, scale))
        hat = np.fft.fft(modal, axis=1) / 8  # exact: degree <= 3 < 8 / 2
        self.g = self.inp @ hat[:, ORDERS % 8]  # (2n, K)

    @property
    def period(self) -> float:
        """Spindle period T [s]."""
        return 2 * np.pi / self.spin

    def modal(self, t) -> np.ndarray:
        """Each mode's share of z_re (n, T) [m] at times t in [a, a + T) [s]: c_s q_s."""
        t = np.asarray(t, dtype=float)
        z = periodic_pulse(self.lam, self.g, self.spin, self.a, self.b, t)
        q = np.einsum("nm,mt->nt", self.out, z).real
        c = relative_shapes(self.basis, self.machine, self.spin * t, self.slide_y)[..., 2]
        return c * q

    def static(self, t) -> np.ndarray:
        """The static residual's share of z_re (T,) [m] (0 without a residual)."""
        t = np.asarray(t, dtype=float)
        if self.residual is None:
            return np.zeros(t.shape)
        phi = self.spin * t
        on = (t >= self.a) & (t <= self.b)
        f = force(phi, self.process, self.machine, self.scale) * on[:, None]
        p = tip(phi, self.machine)
        tool, work = self.residual.relative(p, p + np.array([0.0, self.slide_y, 0.0]), f)
        return tool[:, 2] - work[:, 2]

    def z_re(self, t) -> np.ndarray:
        """z_re (T,) [m] at times t in [a, a + T) [s]."""
        return self.modal(t).sum(axis=0) + self.static(t)

    def peak(self, grid: int = 4000) -> tuple[float, float]:
        """The largest |z_re| [m] over a period and its time after the pulse's start [s]:
        a grid over the pulse and a decay after it, refined by a bounded scalar search."""
        lead = np.linspace(self.a, self.b, grid)
        tail = self.b + np.geomspace(1e-7, self.period - (self.b - self.a) - 1e-7, grid)
        t = np.concatenate([lead, tail])
        z = np.abs(self.z_re(t))
        i = int(np.argmax(z))
        lo, hi = t[max(i - 1, 0)], t[min(i + 1, t.size - 1)]
        best = minimize_scalar(
            lambda x: -abs(self.z_re(np.array([x]))[0]),
            bounds=(lo, hi),
            method="bounded",
            options={"xatol": 1e-12},
        )
        return float(-best.fun), float(best.x - self.a)


def main(argv) -> None:
    """Print the decomposition of z_re's peak of a model at the reference cut."""
    import ufmt
    from ufmt.machining.machine_frame import in_machine_frame
    from ufmt.machining.modal import modal_basis
    from ufmt.machining.process import Process
    from ufmt.machining.static import residual_flexibility
    from ufmt.machining.tool import with_tool
    from ufmt.model.machine import machine_of

    model = in_machine_frame(ufmt.load_model(argv[0] if argv else None))
    machine = machine_of(model)
    basis = with_tool(modal_basis(model), machine)
    residual = residual_flexibility(model, basis, machine)
    process = Process(300, 15, 4)
    pulse = PulseResponse(
        basis, machine, process, machine.modal_damping_ratio, machine.force_scale, residual
    )
    peak, when = pulse.peak()
    shares = pulse.modal(np.array([pulse.a + when]))[:, 0]
    c = relative_shapes(basis, machine, np.array([0.0]), pulse.slide_y)[:, 0, 2]
    static = c**2 / (basis.modal_mass * basis.omega**2)
    print(f"pulse {1e3 * (pulse.b - pulse.a):.4f} ms of {1e3 * pulse.period:.1f} ms")
    print(f"z_re peak {peak * 1e9:.4f} nm at {when * 1e3:.5f} ms after entry")
    print(f"static residual's share {pulse.static(np.array([pulse.a + when]))[0] * 1e9:.4f} nm")
    print("mode  f [Hz]  static [nm/N]  share of the peak [nm]")
    for s in np.argsort(-static)[:8]:
        f = basis.omega[s] / (2 * np.pi)
        print(f"{s:4d} {f:9.2f} {static[s] * 1e9:10.4f} {shares[s] * 1e9:12.5f}")


if __name__ == "__main__":
    main(sys.argv[1:])
