"""Figures of a measured map (:mod:`ufmt.measured`) and of its comparison with a prediction:
the map (piston and tilt removed), the 1-D PSDs along and across the feed over the clear
aperture, form removed there (the spectra the PSD band RMS are computed from,
:func:`ufmt.measured.fits.map_psd`), with the PSD1/PSD2 bands shaded and their KDP limits
(:data:`ufmt.plots.psd.KDP_SPEC_RMS_NM`, band RMS) named."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.colors import TwoSlopeNorm
from matplotlib.figure import Figure

from ufmt.machining.psd import BANDS, DIRECTIONS
from ufmt.measured.fits import map_psd, plane_removed
from ufmt.plots import new_axes, new_figure
from ufmt.plots.psd import BAND_COLOURS, DIRECTION_STYLE, KDP_SPEC_RMS_NM, aperture_words


def _draw_map(ax, height_map, z_nm, norm, title):
    """pcolormesh of ``z_nm`` (Ny, Nx) on the map's grid [mm]; returns the mesh."""
    mesh = ax.pcolormesh(
        height_map.x * 1e3, height_map.y * 1e3, np.ma.masked_invalid(z_nm),
        shading="nearest", cmap="RdBu_r", norm=norm, rasterized=True,
    )  # fmt: skip
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm] (across the feed)")
    ax.set_ylabel("y [mm] (along the feed)")
    ax.set_title(title, fontsize=9)
    return mesh


def _norm(*maps_nm) -> TwoSlopeNorm:
    """One symmetric colour scale for every map [nm]."""
    limit = max(float(np.nanmax(np.abs(z))) for z in maps_nm) or 1.0
    return TwoSlopeNorm(0.0, -limit, limit)


def plot_map(measured, ax=None) -> Figure:
    """The map of a :class:`ufmt.measured.analysis.MeasuredSurface` [nm], piston and tilt
    removed; missing pixels blank."""
    fig, ax = new_axes(ax, (6.4, 5.6))
    z_nm = plane_removed(measured.map) * 1e9
    mesh = _draw_map(ax, measured.map, z_nm, _norm(z_nm), _map_title(measured))
    fig.colorbar(mesh, ax=ax, label="height about the best-fit plane [nm]", shrink=0.85)
    return fig


def _map_title(measured) -> str:
    m = measured.metrics
    return (
        f"{Path(measured.map.path).name or 'map'}: PV {m['pv_measured_nm']:.1f} nm, "
        f"RMS {m['rms_measured_nm']:.2f} nm (clear aperture, piston and tilt removed)"
    )


def _psd_axes(ax, spec) -> None:
    """PSD1/PSD2 shaded and labelled with their limits, axis labels, grid, legend."""
    for name, (lam_min, lam_max) in BANDS.items():
        ax.axvspan(
            1e-3 / lam_max, 1e-3 / lam_min, color=BAND_COLOURS[name], alpha=0.12, lw=0,
            label=f"{name.upper()} {lam_min * 1e3:g}-{lam_max * 1e3:g} mm (KDP RMS <= "
            f"{spec[name]:g} nm)",
        )  # fmt: skip
    ax.set_xlabel("spatial frequency [1/mm]")
    ax.set_ylabel("PSD [nm$^2$ mm]")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7, loc="lower left")


def _psd_lines(ax, measured, label, ls) -> None:
    """The PSDs of a :class:`ufmt.measured.analysis.MeasuredSurface` along and across the
    feed over its clear aperture (its bands' spectra) on log-log axes."""
    for direction in DIRECTIONS:
        f, psd = map_psd(measured.map, direction, measured.aperture_margin)
        keep = (f > 0) & (psd > 0)
        if keep.any():
            style = {**DIRECTION_STYLE[direction], "ls": ls}
            style["label"] = f"{label}, {style['label']}"
            ax.loglog(f[keep] * 1e-3, psd[keep] * 1e21, lw=1.1, **style)


def plot_measured_psd(measured, ax=None, spec: dict[str, float] | None = None) -> Figure:
    """The 1-D PSDs [nm^2 mm] of a measured map along and across the feed over its clear
    aperture, form removed there (the spectra of its band RMS), PSD1/PSD2 shaded with their
    limits (``spec``, default the KDP ones)."""
    fig, ax = new_axes(ax, (7.2, 5.0))
    _psd_lines(ax, measured, "measured", "-")
    _psd_axes(ax, spec or KDP_SPEC_RMS_NM)
    words = aperture_words(measured.aperture_margin)
    ax.set_title(f"PSD of the measured map\n{words}", fontsize=9)
    return fig


def plot_comparison(comparison, spec: dict[str, float] | None = None) -> Figure:
    """Measured and predicted maps on one colour scale [nm] (piston and tilt removed) above
    their 1-D PSDs over the clear aperture overlaid (measured solid, predicted dotted)."""
    fig = new_figure((12.0, 9.6))
    top, bottom = fig.subfigures(2, 1, height_ratios=[1.1, 1])
    axes = top.subplots(1, 2)
    sides = (comparison.measured, comparison.predicted)
    maps = [plane_removed(s.map) * 1e9 for s in sides]
    norm = _norm(*maps)
    for ax, side, z_nm, name in zip(axes, sides, maps, ("measured", "predicted"), strict=True):
        mesh = _draw_map(
            ax, side.map, z_nm, norm, f"{name}: PV {side.metrics['pv_measured_nm']:.1f} nm"
        )
    top.colorbar(mesh, ax=axes, label="height about the best-fit plane [nm]", shrink=0.85)
    ax = bottom.subplots()
    _psd_lines(ax, comparison.measured, "measured", "-")
    _psd_lines(ax, comparison.predicted, "predicted", ":")
    _psd_axes(ax, spec or KDP_SPEC_RMS_NM)
    words = aperture_words(comparison.measured.aperture_margin)
    ax.set_title(f"measured and predicted PSDs\n{words}", fontsize=9)
    return fig
