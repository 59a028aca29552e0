"""A measured map beside the prediction of a simulated cut: both through the same pipeline
(:func:`ufmt.measured.analysis.analyse`, the predicted surface being the simulation's surface
as the interferometer sees it on the grid its exports write, :func:`ufmt.exports.export_grid`), a
table of every metric with both values and their ratio measured / predicted, and the share of
each band of the measured spectrum each source explains (:mod:`.attribution`)."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

from ufmt.measured.analysis import MeasuredSurface, analyse
from ufmt.measured.read import HeightMap


@dataclass(frozen=True, eq=False)
class Comparison:
    """The measured and the predicted :class:`MeasuredSurface`, and the simulation."""

    measured: MeasuredSurface
    predicted: MeasuredSurface
    simulation: object
    attribution: dict

    def to_frame(self):
        """One row per metric: ``metric``, ``measured``, ``predicted``, ``ratio`` (measured /
        predicted; NaN where either is missing or the prediction is 0)."""
        import pandas as pd

        rows = []
        for key, measured in self.measured.metrics.items():
            predicted = self.predicted.metrics.get(key, math.nan)
            ratio = measured / predicted if predicted not in (0.0,) else math.nan
            rows.append((key, measured, predicted, ratio))
        return pd.DataFrame(rows, columns=["metric", "measured", "predicted", "ratio"])

    def to_dict(self) -> dict:
        """JSON-ready: the file, the process, and per metric its measured and predicted
        values and their ratio (None where not finite)."""
        sim = self.simulation
        table = {
            row.metric: {
                k: (float(v) if math.isfinite(v) else None)
                for k, v in (("measured", row.measured), ("predicted", row.predicted),
                             ("ratio", row.ratio))
            }
            for row in self.to_frame().itertuples()
        }  # fmt: skip
        return {
            "file": self.measured.map.path,
            "rpm": sim.process.rpm,
            "feed_mm_min": sim.process.feed_mm_min,
            "depth_um": sim.process.depth_um,
            "metrics": table,
            "attribution": self.attribution,
        }

    def plot(self):
        """Maps on one scale, PSDs overlaid (:func:`~ufmt.plots.measured.plot_comparison`)."""
        from ufmt.plots.measured import plot_comparison

        return plot_comparison(self)

    def save(self, directory) -> list[Path]:
        """Write comparison.json, comparison.csv and comparison.png to ``directory``."""
        from ufmt import files
        from ufmt.plots import save_figure

        with files.FileSet(directory, manifest="comparison.json") as out:
            frame = self.to_frame()
            files.write_with(out.staged("comparison.csv"), lambda b: frame.to_csv(b, index=False))
            save_figure(self.plot(), out.staged("comparison.png"))
            text = json.dumps(self.to_dict(), indent=2, allow_nan=False) + "\n"
            out.add("comparison.json", text.encode())
        return [
            Path(directory) / n for n in ("comparison.json", "comparison.csv", "comparison.png")
        ]


def compare(measured: MeasuredSurface, simulation, mode_frequencies_hz=()) -> Comparison:
    """The :class:`Comparison` of a measured surface with a
    :class:`ufmt.simulate.SimulationResult`, the prediction analysed with the measured
    surface's options (clear-aperture margin, cutoff); the measured spectrum over its clear
    aperture attributed to the sources of the simulated machine and process and to the
    natural frequencies ``mode_frequencies_hz`` [Hz]."""
    from ufmt.exports import export_grid
    from ufmt.measured.attribution import attribute_map, source_lines

    x, y, z = export_grid(simulation.measured_surface())
    options = measured.options
    cutoff = options.get("cutoff_mm")
    predicted = analyse(
        HeightMap(x, y, z, "prediction"),
        aperture_margin=options["aperture_margin_mm"] * 1e-3,
        cutoff=None if cutoff is None else cutoff * 1e-3,
    )
    lines = source_lines(simulation.machine, simulation.process, mode_frequencies_hz)
    shares = attribute_map(measured.map, lines, measured.aperture_margin)
    return Comparison(measured, predicted, simulation, shares)
