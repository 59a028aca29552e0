"""A model's FRFs at the points and directions of measured FRFs (:mod:`.frf_file`), and the
two overlaid: the measured FRF and the model's, same response and reference, same kind.

The model's FRF between a response sensor and a reference sensor is the modal superposition
of :mod:`ufmt.machining.frf` (every mode below the basis cutoff, solved with the model as
loaded, the structural damping ratio ζ and the hinge dampers) plus the residual flexibility of
the modes above it; both sensors must sit on rigid bodies (an FRF at a beam point is NaN).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ufmt.calibration.frf_file import MeasuredFrf
from ufmt.defaults import DEFAULT_BASIS_CUTOFF_HZ
from ufmt.kinds import kind_of
from ufmt.kinematics import point_motion
from ufmt.machining.frf import AXES, modal_receptance, participation, point_end
from ufmt.machining.modal import modal_basis
from ufmt.machining.recurrence import DEFAULT_ZETA
from ufmt.machining.static import static_flexibility
from ufmt.model.load import as_model


def model_frfs(model, outputs, inputs, freq_hz, kind="receptance", zeta=None, cutoff_hz=None):
    """(P, F) complex FRFs of ``model`` between the sensors ``outputs`` and ``inputs`` (P each)
    at ``freq_hz`` (F,) as ``kind`` (module docstring); ``zeta`` default the model's
    ``machine.modal_damping_ratio``."""
    model = as_model(model)
    if zeta is None:
        zeta = DEFAULT_ZETA if model.machine is None else model.machine.modal_damping_ratio
    basis = modal_basis(model, None, cutoff_hz or DEFAULT_BASIS_CUTOFF_HZ, slide_y=0.0)
    freq = np.asarray(freq_hz, dtype=float)
    out = np.full((len(outputs), freq.size), np.nan, dtype=complex)
    rigid = {b.name for b in model.bodies if kind_of(b).ONE_FRAME}
    pairs = [
        p for p, (o, i) in enumerate(zip(outputs, inputs, strict=True)) if {o.body, i.body} <= rigid
    ]
    if not pairs:
        return out
    bodies = tuple(dict.fromkeys(s.body for p in pairs for s in (outputs[p], inputs[p])))
    flexibility = _residual(model, basis, bodies)
    for p in pairs:
        o, i = outputs[p], inputs[p]
        d_out, d_in = AXES[o.direction], AXES[i.direction]
        c_out = participation(basis, point_end(o.body, o.position), d_out)
        c_in = participation(basis, point_end(i.body, i.position), d_in)
        h = modal_receptance(basis, c_out, c_in, freq, zeta)
        row_out, row_in = (_row(basis, bodies, s, d) for s, d in ((o, d_out), (i, d_in)))
        out[p] = h + row_out @ flexibility @ row_in
    iw = 2j * np.pi * freq
    return out * {"receptance": 1.0, "mobility": iw, "accelerance": iw**2}[kind]


def _residual(model, basis, bodies) -> np.ndarray:
    """(6B, 6B) static flexibility of ``bodies`` minus the basis' own, sum v v^T / (M w^2)."""
    v = np.concatenate([basis.body_shapes[b] for b in bodies], axis=1)
    modal = (v.T / (basis.modal_mass * basis.omega**2)) @ v
    return static_flexibility(model, bodies) - modal


def _row(basis, bodies, sensor, direction) -> np.ndarray:
    """(6B,) map from the bodies' centre-of-mass motions to the sensor's translation."""
    row = np.zeros(6 * len(bodies))
    i = bodies.index(sensor.body)
    arm = np.asarray(sensor.position) - basis.body_centers[sensor.body]
    row[6 * i : 6 * i + 6] = np.asarray(direction) @ point_motion(arm)[:3, :]
    return row


def synthetic_frf(model, outputs, inputs, freq_hz, kind="receptance", zeta=None, source=""):
    """A :class:`MeasuredFrf` of the model's own FRFs (:func:`model_frfs`): a synthetic test
    for recovery checks and test planning."""
    values = model_frfs(model, outputs, inputs, freq_hz, kind, zeta)
    freq = np.asarray(freq_hz, dtype=float)
    return MeasuredFrf(source or "model FRFs", freq, values, tuple(outputs), tuple(inputs), kind)


@dataclass(frozen=True, eq=False, repr=False)
class FrfOverlay:
    """Measured and model FRFs at the same points: ``measured`` (:class:`MeasuredFrf`),
    ``model`` (P, F) complex, same kind and lines; ``model_name``."""

    model_name: str
    measured: MeasuredFrf
    model: np.ndarray

    def __repr__(self) -> str:
        return (
            f"FrfOverlay({self.model_name!r} vs {self.measured.source!r}: "
            f"{len(self.measured.outputs)} FRFs, median |log10 model/measured| "
            f"{self.log_ratio():.3g})"
        )

    def log_ratio(self) -> float:
        """Median over every FRF and line of |log10(|H_model| / |H_measured|)| [-]."""
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.abs(np.log10(np.abs(self.model) / np.abs(self.measured.values)))
        return float(np.nanmedian(ratio)) if np.isfinite(ratio).any() else float("nan")

    def to_frame(self) -> pd.DataFrame:
        """Long table: frequency_hz, frf, measured and model magnitude, phase [deg], real,
        imag (SI of the measured kind)."""
        m, h = self.measured.values, self.model
        table = self.measured.to_frame()[["frequency_hz", "frf"]]
        for name, v in (("measured", m), ("model", h)):
            table[f"{name}_magnitude"] = np.abs(v).ravel()
            table[f"{name}_phase_deg"] = np.degrees(np.angle(v)).ravel()
            table[f"{name}_real"] = v.real.ravel()
            table[f"{name}_imag"] = v.imag.ravel()
        return table

    def plot(self, ax=None):
        """One magnitude panel per FRF (:func:`ufmt.plots.frf_test.plot_overlay`)."""
        from ufmt.plots.frf_test import plot_overlay

        return plot_overlay(self, ax=ax)

    def save(self, directory) -> list[Path]:
        """Write ``frf-overlay.csv`` and ``frf-overlay.png``, as one set."""
        from ufmt import files
        from ufmt.plots import DPI

        table = self.to_frame()
        with files.FileSet(directory) as written:
            table.to_csv(written.staged("frf-overlay.csv"), index=False, float_format="%.8g")
            written.add("frf-overlay.png", files.figure_png(self.plot(), DPI))
        return [written.directory / n for n in ("frf-overlay.csv", "frf-overlay.png")]


def overlay(model, measured: MeasuredFrf, zeta=None) -> FrfOverlay:
    """The model's FRFs (:func:`model_frfs`) beside the measured ones."""
    model = as_model(model)
    h = model_frfs(
        model, measured.outputs, measured.inputs, measured.frequencies_hz, measured.kind, zeta
    )
    return FrfOverlay(model.name, measured, h)
