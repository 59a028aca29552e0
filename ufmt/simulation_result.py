"""The result of one cut (:func:`ufmt.simulate.simulate`): its metrics, arrays and surfaces,
with a short repr, ``.to_dict()``, ``.to_frame()``, ``.plot()`` and ``.save()``."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ufmt.machining.instruments import (
    interferometer_surface,
)
from ufmt.machining.process import Process
from ufmt.machining.response import Response
from ufmt.machining.surface import (
    Surface,
)
from ufmt.model.machine import Machine

#: Slide positions of the geometries that refine the accelerometer's peak: only their record
#: window is read, which does not depend on the rows (:func:`_periodic_acceleration`).


@dataclass(frozen=True, eq=False)
class SimulationResult:
    """Everything one simulation produced.

    metrics [nm, mm/s^2, N]: the surface metrics of
    :func:`ufmt.machining.surface.surface_metrics` (pv_nm, pv_aperture_nm, rms_nm, form and
    waviness, ...), the PSD band RMS of the line profiles over the whole plate
    (:func:`ufmt.machining.lines.line_band_rms`; psd1_rms_nm, psd2_rms_nm: the larger of
    psd1_rms_along_nm and psd1_rms_across_nm, ...; NaN where not resolved; PSD2 on the
    ``psd2_patch`` if given) and psd_line_spacing_mm their step, zre_peak_nm (mean over
    the record window's spindle periods of the largest |z_re| in each; the window sits mid-cut,
    at :func:`ufmt.machining.response.record_slide`), tip_acc_peak_mm_s2 (the same for the
    head's z acceleration at the tool point), carrier_acc_peak_mm_s2 (for the tool carrier's,
    the shank's ringing mass); tip_acc_measured_mm_s2 the head's as the paper's accelerometer
    chain reports it, :class:`ufmt.machining.instruments.AccelerometerChain`),
    pv_dynamic_nm, pv_dynamic_steady_nm and edge_runout_nm (the cutting-force vibration's
    surface alone: whole plate, steady cut, what the edges add; :func:`ufmt.machining.surface.
    dynamic_metrics`), force_peak_n (largest cutting-force magnitude in the window),
    force_scale; pv_measured_nm and rms_measured_nm (flatness as the interferometer reports it:
    clear aperture, piston and tilt removed, scallops seen as their mean) and roughness_pv_nm,
    roughness_rq_nm (the feed marks), :mod:`ufmt.machining.instruments`. n_modes: the
    machine's modes in the basis; basis_cutoff_hz: the frequency [Hz] below which it holds
    every mode (the cutoff it was chosen by, or its highest mode when chosen by count);
    basis_highest_hz: its highest natural frequency [Hz]; samples_per_rev: samples per
    spindle revolution of the response (``n_phi``); tool_mode_hz: the natural frequency [Hz]
    of the tool carrier on its shank, the basis' one mode more (None: a rigid or massless
    tool, :mod:`ufmt.machining.tool`). pv_by_source_nm: source -> PV [nm] of the
    surface with that source alone (None where switched off). sources: the switched-on
    sources. surface: every source (the metrics' surface); smooth_surface: the same without
    the feed marks, whose scallops (wavelength (v/f) cos(phi), tens of um) the grid only
    samples (the map uses it). psd_spectra: the line profiles' mean PSD per direction, (points
    per line, step [m], frequency [1/m], PSD [m^2 m]) (:func:`ufmt.machining.lines.
    line_spectra`; None: the bands read the smooth surface's grid).
    """

    process: Process
    method: str
    machine: Machine
    zeta: np.ndarray
    force_scale: float
    response: Response
    surface: Surface
    smooth_surface: Surface
    metrics: dict[str, float]
    pv_by_source_nm: dict[str, float | None]
    sources: tuple[str, ...]
    n_modes: int
    basis_cutoff_hz: float
    basis_highest_hz: float
    samples_per_rev: int
    tool_mode_hz: float | None = None
    psd_spectra: dict | None = None

    def __repr__(self) -> str:
        p = self.process
        m = self.metrics
        by = ", ".join(f"{k}={_short(v)}" for k, v in self.pv_by_source_nm.items())
        return (
            f"SimulationResult({p.rpm:g} rpm, {p.feed_mm_min:g} mm/min, {p.depth_um:g} um, "
            f"{self.method}: pv_nm={_short(m['pv_nm'])}, "
            f"pv_aperture_nm={_short(m['pv_aperture_nm'])}, rms_nm={_short(m['rms_nm'])}, "
            f"force_peak_n={_short(m['force_peak_n'])}, pv_by_source_nm={{{by}}})"
        )

    def to_dict(self) -> dict:
        """Inputs, metrics and pv_by_source_nm as plain JSON values (NaN -> None)."""
        p = self.process
        out = {
            "method": self.method,
            "rpm": p.rpm,
            "feed_mm_min": p.feed_mm_min,
            "depth_um": p.depth_um,
            "n_modes": self.n_modes,
            "basis_cutoff_hz": self.basis_cutoff_hz,
            "basis_highest_hz": self.basis_highest_hz,
            "samples_per_rev": self.samples_per_rev,
            "tool_mode_hz": self.tool_mode_hz,
            "sources": list(self.sources),
            **{k: _json_number(v) for k, v in self.metrics.items()},
            "pv_by_source_nm": {k: _json_number(v) for k, v in self.pv_by_source_nm.items()},
        }
        return out

    def to_frame(self, kind: str = "summary"):
        """A tidy pandas table: ``kind="summary"`` one row (the process, the metrics and
        ``pv_<source>_nm`` per source); ``kind="time"`` the record window's time histories,
        one row per sample (:func:`ufmt.exports.time_frame`)."""
        import pandas as pd

        if kind == "time":
            from ufmt.exports import time_frame  # loaded only to export, never to compute

            return time_frame(self.response)
        if kind != "summary":
            raise ValueError(f"kind must be 'summary' or 'time', got {kind!r}")
        row = {k: v for k, v in self.to_dict().items() if k not in ("pv_by_source_nm", "sources")}
        for name, value in self.pv_by_source_nm.items():
            row[f"pv_{name}_nm"] = np.nan if value is None else value
        return pd.DataFrame([{k: np.nan if v is None else v for k, v in row.items()}])

    def plot(self, ax=None, stage: str = "machined"):
        """The surface map (:func:`ufmt.plots.surface.plot_surface_map`: ``stage`` "machined"
        or "measured" by the interferometer); returns the matplotlib Figure."""
        from ufmt.plots.surface import plot_surface_map

        return plot_surface_map(self, stage=stage, ax=ax)

    def measured_surface(self) -> Surface:
        """The surface as the interferometer sees it: without the feed marks, plus their mean
        where it does not resolve them
        (:func:`~ufmt.machining.instruments.interferometer_surface`)."""
        scallops = self.surface if "feed_marks" in self.sources else None
        feed = self.process.feed_per_rev_m
        return interferometer_surface(self.smooth_surface, self.machine, feed, scallops=scallops)

    def save(self, directory) -> list[Path]:
        """Write metrics.json (strict JSON), summary.csv, time.csv (the record window), the
        surface as the interferometer sees it (:meth:`measured_surface`) as surface.xyz,
        surface.sdf (ISO 25178-71) and surface.x3p (ISO 25178-72),
        surface.npz (x_m, y_m, z_m: every source; z_smooth_m: without the feed marks;
        z_measured_m: as the interferometer sees it) and the
        maps surface.png and surface_measured.png (:mod:`ufmt.exports`), as one set
        (:class:`ufmt.files.FileSet`, metrics.json last): a failure keeps the earlier set."""
        from ufmt import files
        from ufmt.exports import write_sdf, write_x3p, write_xyz
        from ufmt.plots import save_figure

        s = self.surface
        with files.FileSet(directory, manifest="metrics.json") as out:
            for name, kind in (("summary.csv", "summary"), ("time.csv", "time")):
                frame = self.to_frame(kind)
                files.write_with(
                    out.staged(name),
                    lambda b, f=frame: f.to_csv(b, index=False, float_format="%.8g"),
                )
            seen = self.measured_surface()
            write_xyz(seen, out.staged("surface.xyz"))
            write_sdf(seen, out.staged("surface.sdf"))
            write_x3p(seen, out.staged("surface.x3p"))
            files.write_with(
                out.staged("surface.npz"),
                lambda b: np.savez_compressed(
                    b,
                    x_m=s.x,
                    y_m=s.y,
                    z_m=s.z,
                    z_smooth_m=self.smooth_surface.z,
                    z_measured_m=seen.z,
                ),
            )
            for stage, name in (("machined", "surface.png"), ("measured", "surface_measured.png")):
                save_figure(self.plot(stage=stage), out.staged(name))
            metrics = json.dumps(self.to_dict(), indent=2, allow_nan=False) + "\n"
            out.add("metrics.json", metrics.encode())
        names = ("metrics.json", "summary.csv", "time.csv", "surface.xyz", "surface.sdf")
        names += ("surface.x3p", "surface.npz", "surface.png", "surface_measured.png")
        return [Path(directory) / name for name in names]


def _short(value) -> str:
    return (
        "None"
        if value is None or (isinstance(value, float) and math.isnan(value))
        else f"{value:.4g}"
    )


def _json_number(value):
    """A float for JSON: None for NaN or infinity."""
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) else None
