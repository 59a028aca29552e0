"""A measured map through the instrument pipeline of a simulated surface.

:func:`map_metrics` reports, with the keys of ``ufmt simulate`` where the quantity is the same:

* ``pv_measured_nm``, ``rms_measured_nm``: flatness as the interferometer reports it, the
  least-squares plane (piston and tilt) removed over the clear aperture, the map less
  ``aperture_margin`` [m] at every edge (as
  :func:`ufmt.machining.instruments.interferometer_metrics`). The default margin is the
  simulation's 5 mm on maps whose shorter side is at least 4 margins long (a full-aperture
  plate map), else none (a sub-aperture or microscope map is its own clear aperture).
* ``form_pv_nm``, ``waviness_pv_nm``, ``waviness_rms_nm``: the least-squares Legendre fit up
  to 2nd order over the whole map; form = PV of its 2nd-order part, waviness = what it leaves
  (as :func:`ufmt.machining.surface.surface_metrics`, whole plate).
* ``psd1_rms_nm``, ``psd2_rms_nm`` and their ``_along``/``_across`` parts: band RMS of the 1-D
  PSDs of the line profiles along the feed (y) and across it (x) over the same clear aperture
  as the PV, the Legendre fit up to 2nd order fitted and removed there
  (:func:`ufmt.measured.fits.band_rms_of`; :mod:`ufmt.machining.psd`: detrend, Hann window,
  band rules, as a simulated surface's bands), None where the clear aperture does not resolve
  the band; the overall value the larger direction. Profiles with a missing pixel are left out
  of the mean PSD (a band with no complete profile is None).
* ISO 25178-2 parameters ``sa_nm``, ``sq_nm``, ``sp_nm``, ``sv_nm``, ``sz_nm``, ``ssk``,
  ``sku`` of the map about its mean, unfiltered (:mod:`.areal`); with a ``cutoff`` lambda_c
  [m], the same of the S-L surface (the map less its least-squares plane, the F-operator, less
  the ISO 16610-21 Gaussian mean of that) with the suffix ``_lc`` (``sq_lc_nm``, ``ssk_lc``, ...).

The feed direction of the map is declared (``feed_direction`` "y": the columns run along the
feed, as ufmt writes its maps; "x": the rows do, the map is turned).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ufmt.errors import ModelError
from ufmt.machining.surface import DEFAULT_APERTURE_MARGIN
from ufmt.measured.areal import areal_parameters, gaussian_mean
from ufmt.measured.fits import aperture, band_rms_of, fit_removed, legendre_basis
from ufmt.measured.read import HeightMap, read_map

FEED_DIRECTIONS = ("y", "x")
#: A map gets the default clear-aperture margin if its shorter side spans this many margins.
FULL_APERTURE_MARGINS = 4


def default_margin(height_map: HeightMap) -> float:
    """Clear-aperture margin [m] of a map by default (module docstring)."""
    side = min(np.ptp(height_map.x), np.ptp(height_map.y))
    return (
        DEFAULT_APERTURE_MARGIN if side >= FULL_APERTURE_MARGINS * DEFAULT_APERTURE_MARGIN else 0.0
    )


def map_metrics(
    height_map: HeightMap, aperture_margin: float | None = None, cutoff: float | None = None
) -> dict[str, float]:
    """Metrics of a map whose feed runs along y (module docstring); ``aperture_margin`` [m]
    (None: :func:`default_margin`), ``cutoff`` lambda_c [m] of the areal S-L surface."""
    x, y, z = height_map.x, height_map.y, height_map.z
    margin = default_margin(height_map) if aperture_margin is None else aperture_margin
    in_x, in_y = aperture(height_map, margin)
    clear = z[np.ix_(in_y, in_x)]
    if not np.isfinite(clear).any():
        raise ModelError(f"{height_map.path}: no measured pixel inside the clear aperture")
    basis = legendre_basis(x, y)
    flat_clear, _ = fit_removed(basis[:3][:, in_y][:, :, in_x], clear)
    waviness, coef = fit_removed(basis, z)
    form = np.tensordot(coef[3:], basis[3:], axes=1)[np.isfinite(z)]
    out = {
        "pv_measured_nm": float(np.nanmax(flat_clear) - np.nanmin(flat_clear)) * 1e9,
        "rms_measured_nm": float(np.sqrt(np.nanmean(flat_clear**2))) * 1e9,
        "form_pv_nm": float(np.ptp(form)) * 1e9,
        "waviness_pv_nm": float(np.nanmax(waviness) - np.nanmin(waviness)) * 1e9,
        "waviness_rms_nm": float(np.sqrt(np.nanmean(waviness**2))) * 1e9,
        **band_rms_of(height_map, margin),
        **areal_parameters(z),
    }
    if cutoff is not None:
        flat = fit_removed(basis[:3], z)[0]  # F-operator: the plane, then the L-filter
        rough = flat - gaussian_mean(flat, height_map.spacing, cutoff)
        out.update({_lc(k): v for k, v in areal_parameters(rough).items()})
    return out


def _lc(key: str) -> str:
    """``sq_nm`` -> ``sq_lc_nm``, ``ssk`` -> ``ssk_lc``."""
    return key.replace("_nm", "_lc_nm") if key.endswith("_nm") else f"{key}_lc"


@dataclass(frozen=True, eq=False)
class MeasuredSurface:
    """A measured map (feed along y) and its metrics (:func:`map_metrics`; NaN where a band is
    unresolved); ``options`` how it was read and analysed."""

    map: HeightMap
    metrics: dict[str, float]
    options: dict = field(default_factory=dict)

    @property
    def aperture_margin(self) -> float:
        """Edge exclusion [m] of the clear aperture its PV and PSD bands read."""
        return self.options.get("aperture_margin_mm", 0.0) * 1e-3

    def to_dict(self) -> dict:
        """The file, the map's size and the metrics, NaN as None (JSON-ready)."""
        hx, hy = self.map.spacing
        out = {
            "file": self.map.path,
            **self.options,
            "nx": int(self.map.x.size),
            "ny": int(self.map.y.size),
            "spacing_x_mm": hx * 1e3,
            "spacing_y_mm": hy * 1e3,
            "missing_share": float(1.0 - self.map.valid.mean()),
        }
        for key, value in self.metrics.items():
            out[key] = None if not math.isfinite(value) else float(value)
        return out

    def to_frame(self):
        """The metrics as a pandas table, one row per metric: ``metric``, ``value``."""
        import pandas as pd

        rows = [(k, np.nan if v is None else v) for k, v in self.to_dict().items()]
        return pd.DataFrame(rows, columns=["metric", "value"])

    def plot(self, ax=None):
        """The map, piston and tilt removed, in nm (:func:`ufmt.plots.measured.plot_map`)."""
        from ufmt.plots.measured import plot_map

        return plot_map(self, ax=ax)

    def save(self, directory) -> list[Path]:
        """Write metrics.json (strict JSON), metrics.csv, surface_map.png and psd.png to
        ``directory`` as one set (:class:`ufmt.files.FileSet`, metrics.json last)."""
        from ufmt import files
        from ufmt.plots import save_figure
        from ufmt.plots.measured import plot_measured_psd

        with files.FileSet(directory, manifest="metrics.json") as out:
            frame = self.to_frame()
            files.write_with(out.staged("metrics.csv"), lambda b: frame.to_csv(b, index=False))
            save_figure(self.plot(), out.staged("surface_map.png"))
            save_figure(plot_measured_psd(self), out.staged("psd.png"))
            text = json.dumps(self.to_dict(), indent=2, allow_nan=False) + "\n"
            out.add("metrics.json", text.encode())
        names = ("metrics.json", "metrics.csv", "surface_map.png", "psd.png")
        return [Path(directory) / name for name in names]


def analyse(
    height_map: HeightMap,
    feed_direction: str = "y",
    aperture_margin: float | None = None,
    cutoff: float | None = None,
) -> MeasuredSurface:
    """The :class:`MeasuredSurface` of a map (module docstring)."""
    if feed_direction not in FEED_DIRECTIONS:
        raise ModelError(
            f"{height_map.path}: feed_direction {feed_direction!r} is not one of "
            f"{', '.join(FEED_DIRECTIONS)}"
        )
    if cutoff is not None and not (math.isfinite(cutoff) and cutoff > 0):
        raise ModelError(f"{height_map.path}: cutoff {cutoff!r} m must be finite and > 0")
    turned = height_map.transposed() if feed_direction == "x" else height_map
    margin = default_margin(turned) if aperture_margin is None else aperture_margin
    options = {"feed_direction": feed_direction, "aperture_margin_mm": margin * 1e3}
    if cutoff is not None:
        options["cutoff_mm"] = cutoff * 1e3
    return MeasuredSurface(turned, map_metrics(turned, margin, cutoff), options)


def read_surface(
    path,
    feed_direction: str = "y",
    aperture_margin: float | None = None,
    cutoff: float | None = None,
    unit: str | None = None,
) -> MeasuredSurface:
    """Read a measured map (:func:`ufmt.measured.read.read_map`: MetroPro, x3p, SDF, xyz,
    ufmt's exports; ``unit`` for a file without one) and analyse it (:func:`analyse`):
    ``feed_direction`` "y" or "x", ``aperture_margin`` [m], ``cutoff`` lambda_c [m]."""
    return analyse(read_map(path, unit), feed_direction, aperture_margin, cutoff)
