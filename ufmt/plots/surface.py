"""Figures of a simulation's machined surface: the surface map and the PV of each source."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure


def plot_surface_map(result, ax=None) -> Figure:
    """Map of the machined surface [nm] of a :class:`ufmt.simulate.SimulationResult`.

    Draws the surface without the feed marks (their scallops, tens of um apart, would alias on
    the grid into a moire); the title gives the PV with every source, the clear-aperture PV and
    the PV of each switched-on source alone. Draws into ``ax`` if given (its figure is
    returned), else into a new figure.
    """
    if ax is None:
        fig = Figure(figsize=(6.4, 5.2))
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    s = result.smooth_surface
    z = (s.z - s.z.max()) * 1e9
    mesh = ax.pcolormesh(s.x * 1e3, s.y * 1e3, z, shading="auto", cmap="viridis")
    fig.colorbar(mesh, ax=ax, label="height below the highest point [nm]")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm] (against the feed)")
    ax.set_aspect("equal")
    m = result.metrics
    parts = ", ".join(
        f"{k} {v:.1f}" for k, v in result.pv_by_source_nm.items() if v is not None and v > 0
    )
    ax.set_title(
        f"PV {m['pv_nm']:.1f} nm, aperture {m['pv_aperture_nm']:.1f} nm (feed marks not drawn)\n"
        f"alone: {parts or 'none'} [nm]",
        fontsize=9,
    )
    return fig


def plot_pv_by_source(results, labels, ax=None) -> Figure:
    """Bar chart of PV per source [nm] for one or more results (e.g. the points of a sweep)."""
    if ax is None:
        fig = Figure(figsize=(7.0, 4.0))
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    names = list(results[0].pv_by_source_nm)
    width = 0.8 / (len(names) + 1)
    pos = np.arange(len(results))
    for i, name in enumerate(names):
        values = [r.pv_by_source_nm[name] or 0.0 for r in results]
        ax.bar(pos + i * width, values, width, label=name)
    ax.bar(pos + len(names) * width, [r.metrics["pv_nm"] for r in results], width, label="total")
    ax.set_xticks(pos + 0.4 - width / 2, labels)
    ax.set_ylabel("PV [nm]")
    ax.legend(fontsize=8)
    return fig
