"""Plots: figures drawn from results (matplotlib object API, Agg canvas).

Every plot function takes data (a result object or a table read from disk) and an optional
``ax``, and returns the :class:`matplotlib.figure.Figure`; it never solves and never writes.
:func:`save_figure` writes a figure to a PNG.
"""

from __future__ import annotations

from pathlib import Path

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ufmt import files

DPI = 120


def new_axes(ax=None, figsize=(6.4, 4.8), **subplot):
    """(figure, axes): ``ax`` and its figure when given, else a new constrained-layout figure.

    ``subplot`` is passed to ``Figure.add_subplot`` (e.g. ``projection="3d"``).
    """
    if ax is not None:
        return ax.figure, ax
    fig = new_figure(figsize)
    return fig, fig.add_subplot(**subplot)


def new_figure(figsize=(6.4, 4.8)) -> Figure:
    """A constrained-layout figure on its own Agg canvas (no pyplot state)."""
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def save_figure(fig: Figure, path, dpi: int = DPI) -> Path:
    """Write ``fig`` to ``path`` (PNG, atomically: :mod:`ufmt.files`; parent folders created);
    returns the path."""
    return files.write_bytes(path, files.figure_png(fig, dpi))


def plate_label(plate_mm) -> str:
    """ "150 mm × 150 mm plate" of a study's ``meta["plate_mm"]``, or '' without one."""
    if not plate_mm or len(plate_mm) != 2:
        return ""
    return f"{plate_mm[0]:.4g} mm × {plate_mm[1]:.4g} mm plate"


def mark_plate(fig: Figure, plate_mm) -> Figure:
    """Name the plate a study's figure is for in its suptitle (or first title)."""
    text = plate_label(plate_mm)
    if text and fig.get_suptitle():
        fig.suptitle(f"{fig.get_suptitle()}\n({text})")
    elif text and fig.axes:
        ax = fig.axes[0]
        ax.set_title(f"{ax.get_title()}\n({text})" if ax.get_title() else f"({text})")
    return fig
