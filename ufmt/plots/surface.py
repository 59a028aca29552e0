"""Figures of a simulation's machined surface: the surface map (as cut and as the
interferometer measures it) and the PV of each error source.

One surface figure serves the API (``SimulationResult.plot`` / ``.save``), the CLI
(``ufmt simulate --plot``) and the report. The map shows the height about its mean [nm] in a
diverging colour map centred on zero, the two points that set the PV marked, the clear
aperture outlined. The feed marks (scallops tens of um apart) are not drawn on the map: its
grid is about 1 mm, which would only alias them into a moire. Where they are switched on, a
strip below the map (an inset when drawing into a given axes) draws their profile across the
feed at their own scale (the parabolic scallop of the tool nose, eq. 4.1, at the largest
scallop inside the clear aperture). The clear aperture is that of the default instrument
(:class:`ufmt.machining.instruments.Interferometer`).
"""

from __future__ import annotations

import textwrap

import numpy as np
from matplotlib.colors import TwoSlopeNorm
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from ufmt.machining.instruments import (
    Interferometer,
    interferometer_surface,
    plane_removed,
    scallop_height,
)
from ufmt.machining.surface import DEFAULT_APERTURE_MARGIN
from ufmt.plots import new_axes, new_figure

STAGES = ("machined", "measured")
FEED_MARKS = "feed_marks"
SOURCE_NAMES = {
    "dynamic": "cutting-force\nvibration",
    "total (every source)": "total, whole\nplate",
}
SCALLOPS_SHOWN = 4  # scallop periods drawn in the feed-mark inset
TITLE_CHARS = 70  # the per-source line wraps here: it fits the map's width at 9 pt


def measured_map(result, instrument: Interferometer | None = None):
    """(x [m], y [m], z [m]) of the surface as the interferometer reports it: the clear
    aperture, piston and tilt removed, the feed marks as their mean where it does not resolve
    them (:mod:`ufmt.machining.instruments`); its PV is ``metrics["pv_measured_nm"]``."""
    instrument = instrument or Interferometer()
    s = result.smooth_surface
    margin = instrument.aperture_margin
    cx, cy = (s.x[0] + s.x[-1]) / 2, (s.y[0] + s.y[-1]) / 2
    in_x = np.abs(s.x - cx) <= (s.x[-1] - s.x[0]) / 2 - margin + 1e-12
    in_y = np.abs(s.y - cy) <= (s.y[-1] - s.y[0]) / 2 - margin + 1e-12
    scallops = result.surface if FEED_MARKS in result.sources else None
    feed = result.process.feed_per_rev_m
    seen = interferometer_surface(s, result.machine, feed, scallops=scallops, instrument=instrument)
    z = seen.z
    x, y, z = s.x[in_x], s.y[in_y], z[np.ix_(in_y, in_x)]
    return x, y, plane_removed(x, y, z)


def plot_surface_map(result, stage: str = "machined", ax=None) -> Figure:
    """Map of a :class:`ufmt.simulate.SimulationResult`'s surface [nm] about its mean.

    stage: "machined" (the whole plate as cut, without the feed marks: the surface the
    bands and the whole-plate PV of every smooth source use) or "measured" (the clear
    aperture as the interferometer reports it, :func:`measured_map`). The highest and lowest
    points are marked, the clear aperture outlined, the feed marks drawn at their own scale
    where they are switched on. Draws into ``ax`` if given, else a new figure.
    """
    if stage not in STAGES:
        raise ValueError(f"stage must be one of {STAGES}, got {stage!r}")
    if ax is None:
        fig = new_figure((7.2, 7.6))
        ax, strip = fig.subplots(2, 1, height_ratios=[5, 1.2])
    else:
        fig, strip = ax.figure, None
    if stage == "machined":
        s = result.smooth_surface
        x, y, z = s.x, s.y, s.z - s.z[s.core_rows].mean()
    else:
        x, y, z = measured_map(result)
    x_mm, y_mm, z_nm = x * 1e3, y * 1e3, z * 1e9
    limit = float(np.abs(z_nm).max()) or 1.0
    mesh = ax.pcolormesh(
        x_mm,
        y_mm,
        z_nm,
        shading="nearest",
        cmap="RdBu_r",
        norm=TwoSlopeNorm(0.0, -limit, limit),
        rasterized=True,
    )
    about = "its mean" if stage == "machined" else "the best-fit plane (piston, tilt)"
    fig.colorbar(mesh, ax=ax, label=f"height about {about} [nm]", shrink=0.85)
    _mark_extremes(ax, x_mm, y_mm, z_nm)
    _outline_aperture(ax, result.smooth_surface, stage)
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm] (against the feed)")
    ax.set_title(_title(result, stage), fontsize=9)
    _feed_marks(strip if strip is not None else ax.inset_axes([0.02, 0.02, 0.34, 0.2]), result)
    if strip is None:
        ax.legend(fontsize=7.5, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncols=2)
    else:
        fig.legend(fontsize=7.5, loc="outside lower center", ncols=2)
    return fig


def _title(result, stage: str) -> str:
    m = result.metrics
    parts = ", ".join(
        f"{k} {v:.1f}" for k, v in result.pv_by_source_nm.items() if v is not None and v > 0
    )
    if stage == "machined":
        head = (
            f"As machined: PV {m['pv_nm']:.1f} nm over the whole plate with the feed marks,"
            f"\n{m['pv_aperture_nm']:.1f} nm over the clear aperture"
        )
    else:
        head = (
            f"As the interferometer measures it: PV {m['pv_measured_nm']:.1f} nm,"
            f" RMS {m['rms_measured_nm']:.1f} nm\n(clear aperture, piston and tilt removed)"
        )
    sources = textwrap.fill(f"PV of each source alone [nm]: {parts or 'none'}", TITLE_CHARS)
    return f"{head}\n{sources}"


def _mark_extremes(ax, x_mm, y_mm, z_nm) -> None:
    """Mark the highest and lowest points of the drawn map (the two ends of its PV)."""
    for pick, marker, name in ((np.argmax, "^", "highest"), (np.argmin, "v", "lowest")):
        i, j = np.unravel_index(pick(z_nm), z_nm.shape)
        ax.plot(
            x_mm[j],
            y_mm[i],
            marker,
            ms=10,
            mfc="w",
            mec="k",
            mew=1.5,
            clip_on=False,
            label=f"{name}: {z_nm[i, j]:+.1f} nm at ({x_mm[j]:.0f}, {y_mm[i]:.0f}) mm",
        )


def _outline_aperture(ax, surface, stage: str) -> None:
    """Outline the clear aperture (the plate less the default edge margin)."""
    m = DEFAULT_APERTURE_MARGIN
    x0, x1 = surface.x[0] + m, surface.x[-1] - m
    y0, y1 = surface.y[0] + m, surface.y[-1] - m
    label = f"clear aperture ({m * 1e3:g} mm edge margin)"
    ax.add_patch(
        Rectangle(
            (x0 * 1e3, y0 * 1e3),
            (x1 - x0) * 1e3,
            (y1 - y0) * 1e3,
            fill=False,
            ls="--",
            lw=1.2,
            ec="k" if stage == "machined" else "0.4",
            label=label,
        )
    )


def scallop_profile(result, periods: int = SCALLOPS_SHOWN):
    """(y [um], height [nm], x [mm]) of the feed marks across the feed at their own scale:
    the parabolic scallop h (2 s - 1)^2 over ``periods`` periods, at the x inside the clear
    aperture where it is largest; None where the feed marks are switched off."""
    if FEED_MARKS not in result.sources:
        return None
    machine = result.machine
    half = machine.workpiece_size[0] / 2 - DEFAULT_APERTURE_MARGIN
    x = float(np.clip(machine.offset_x, -half, half))
    h = float(scallop_height(np.array([x]), machine, result.process.feed_per_rev_m)[0])
    spacing = np.sqrt(8.0 * machine.nose_radius * h)  # (v/f) cos(phi)
    s = np.linspace(0.0, periods, 100 * periods + 1)
    return s * spacing * 1e6, h * (2.0 * (s % 1.0) - 1.0) ** 2 * 1e9, x * 1e3


def _feed_marks(inset, result) -> None:
    """The feed marks across the feed at their own scale in ``inset`` (or a note there)."""
    profile = scallop_profile(result)
    if profile is None:
        inset.set_axis_off()
        inset.text(0, 0.5, "feed marks switched off", transform=inset.transAxes, fontsize=8)
        return
    y_um, z_nm, x_mm = profile
    inset.plot(y_um, z_nm, color="k", lw=0.8)
    inset.fill_between(y_um, z_nm, z_nm.max(), color="0.85")
    inset.set_facecolor("white")
    inset.tick_params(labelsize=7, pad=1)
    inset.set_xlabel("across the feed [µm]", fontsize=7, labelpad=1)
    inset.set_ylabel("[nm]", fontsize=7, labelpad=1)
    inset.set_title(
        f"feed marks at x = {x_mm:.0f} mm at their own scale (too fine for the map's grid)",
        fontsize=7,
        pad=2,
    )


def plot_pv_by_source(results, labels, ax=None) -> Figure:
    """Bar chart of PV per source [nm] for one or more results (e.g. the points of a sweep):
    every source that acts in one of them (zero ones named below the chart), the total,
    values printed on the bars."""
    fig, ax = new_axes(ax, (7.5, 4.2))
    names = [n for n in results[0].pv_by_source_nm if any(r.pv_by_source_nm[n] for r in results)]
    idle = [n for n in results[0].pv_by_source_nm if n not in names]
    measured = all(np.isfinite(r.metrics.get("pv_measured_nm", np.nan)) for r in results)
    categories = [*names, "total (every source)"]
    if measured:
        categories.append("total, as\nmeasured")
    width = 0.8 / len(results)
    pos = np.arange(len(categories))
    for k, (result, label) in enumerate(zip(results, labels, strict=True)):
        values = [result.pv_by_source_nm[n] for n in names] + [result.metrics["pv_nm"]]
        if measured:
            values.append(result.metrics["pv_measured_nm"])
        bars = ax.bar(pos + k * width, values, width, label=label)
        ax.bar_label(bars, fmt="%.1f", fontsize=7, padding=1)
    names_shown = [SOURCE_NAMES.get(c, c.replace("_", " ")) for c in categories]
    ax.set_xticks(pos + (len(results) - 1) * width / 2, names_shown)
    ax.tick_params(axis="x", labelsize=8)
    ax.set_ylabel("PV [nm]")
    ax.margins(y=0.12)
    if len(results) > 1:
        ax.legend(fontsize=8)
    else:
        ax.set_title(f"PV of each error source alone and in total: {labels[0]}", fontsize=10)
    if idle:
        idle_names = ", ".join(SOURCE_NAMES.get(n, n.replace("_", " ")) for n in idle)
        ax.set_xlabel(f"no effect (0 nm or switched off): {idle_names}", fontsize=8)
    return fig
