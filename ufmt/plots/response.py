"""Simulation plots: tool-tip motion (paper Figs. 6, 7), z_re (Fig. 13), FRF; the surface (Fig. 14)
is :mod:`ufmt.plots.surface`.

Plotting reads results and never recomputes them. Each function takes the data and an optional
``ax`` (a sequence of axes for the multi-panel tool-tip figure) and returns the Figure;
:func:`ufmt.plots.save_figure` writes it. Time plots show the record window (mid-cut, the
paper's "middle 2 s of the cutting process") as time from the window's start, with the time
since the first touch in the axis label, and shade the intervals in which the tool cuts.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ufmt import files
from ufmt.defaults import REFERENCE_RPM
from ufmt.plots import DPI, new_axes, new_figure
from ufmt.plots.psd import plot_psd
from ufmt.plots.surface import plot_pv_by_source, plot_surface_map

_AXES = ("x", "y", "z")
CUT_SHADE = {"color": "tab:orange", "alpha": 0.35, "lw": 1.2}  # edges keep 1 px cuts visible
SPINDLE_HARMONICS = 10  # harmonics of the spindle frequency marked on the FRF


def _window_time(response) -> tuple[np.ndarray, str]:
    """Time from the start of the record window [s] and the axis label naming its start."""
    t0 = float(response.t[0])
    return response.t - t0, f"time in the record window [s] (window starts {t0:.1f} s into the cut)"


def _shade_cutting(ax, t: np.ndarray, force: np.ndarray, label: bool) -> None:
    """Shade the time intervals in which the tool touches the workpiece (``force`` [N], one
    row per sample of ``t``, non-zero)."""
    cutting = np.linalg.norm(force, axis=1) > 0
    ax.fill_between(
        t,
        0,
        1,
        where=cutting,
        transform=ax.get_xaxis_transform(),
        label="tool cutting" if label else None,
        **CUT_SHADE,
    )


def engagement(t: np.ndarray, response) -> tuple[float, float] | None:
    """(start, end) [s, window time] of the first engagement wholly inside the window (the
    force non-zero from a sample after the first to one before the last), or None."""
    cutting = np.linalg.norm(response.force, axis=1) > 0
    edges = np.flatnonzero(np.diff(cutting.astype(np.int8)))
    starts = [i + 1 for i in edges if not cutting[i]]
    ends = [i for i in edges if cutting[i]]
    for start in starts:
        after = [e for e in ends if e >= start]
        if after:
            return float(t[start]), float(t[after[0]])
    return None


#: The zoom on one engagement shows it from ZOOM_BEFORE of its length before it starts to
#: ZOOM_AFTER of its length after it ends (the free vibration it leaves).
ZOOM_BEFORE, ZOOM_AFTER = 0.5, 2.0


def _zoom(ax, zoom, t: np.ndarray, data, response, span) -> None:
    """Draw ``data`` against ``t`` in ``zoom`` over one engagement ``span`` and mark it on
    ``ax`` (the whole window)."""
    start, end = span
    length = end - start
    low, high = start - ZOOM_BEFORE * length, end + ZOOM_AFTER * length
    inside = (t >= low) & (t <= high)
    _shade_cutting(zoom, t[inside], response.force[inside], label=False)
    zoom.plot(t[inside], data[inside], lw=0.9)
    zoom.set_xlim(low, high)
    zoom.grid(alpha=0.3)
    ax.axvspan(low, high, color="0.6", alpha=0.25, lw=0)


def plot_tool_tip(response, quantity: str = "displacement", ax=None) -> Figure:
    """Tool-tip displacement [nm] or acceleration [mm/s^2] in x, y, z against time (Figs. 6, 7):
    the record window, and beside it (on a new figure) one engagement zoomed (grey band on the
    left).

    ax : three axes (x, y, z panels) to draw the window in (no zoom); default a new figure.
    """
    if quantity == "displacement":
        data, unit, scale = response.tip_disp, "nm", 1e9
    elif quantity == "acceleration":
        data, unit, scale = response.tip_acc, "mm/s$^2$", 1e3
    else:
        raise ValueError(f"quantity must be 'displacement' or 'acceleration', got {quantity!r}")
    t, label = _window_time(response)
    span = engagement(t, response) if ax is None else None
    zooms = []
    if ax is None:
        fig = new_figure((12, 7) if span else (8, 7))
        grid = fig.subplots(
            3, 2 if span else 1, squeeze=False, width_ratios=[2, 1] if span else None
        )
        axes, zooms = list(grid[:, 0]), list(grid[:, 1]) if span else []
    else:
        axes = list(ax)
        fig = axes[0].figure
    for i, a in enumerate(axes):
        _shade_cutting(a, t, response.force, label=i == 0)
        a.plot(t, data[:, i] * scale, lw=0.8)
        a.set_ylabel(f"{_AXES[i]} [{unit}]")
        a.grid(alpha=0.3)
        if zooms:
            _zoom(a, zooms[i], t, data[:, i] * scale, response, span)
    axes[-1].set_xlabel(label)
    if zooms:
        zooms[-1].set_xlabel("time [s], one engagement (grey band on the left)")
        zooms[0].set_title("one engagement, zoomed", fontsize="small")
    axes[0].legend(fontsize="small", loc="upper right")
    axes[0].set_title(f"Tool-tip {quantity} ({response.method} response)")
    return fig


def plot_zre(response, ax=None) -> Figure:
    """Relative tool-workpiece z displacement z_re [nm] against time (Fig. 13): the record
    window and beside it (on a new figure) one engagement zoomed (grey band on the left)."""
    t, label = _window_time(response)
    span = engagement(t, response) if ax is None else None
    zoom = None
    if span:
        fig = new_figure((12, 3.5))
        ax, zoom = fig.subplots(1, 2, width_ratios=[2, 1])
    else:
        fig, ax = new_axes(ax, (8, 3.5))
    _shade_cutting(ax, t, response.force, label=True)
    ax.plot(t, response.z_re * 1e9, lw=0.8, label="$z_{re}$")
    if zoom is not None:
        _zoom(ax, zoom, t, response.z_re * 1e9, response, span)
        zoom.set_xlabel("time [s], one engagement (grey band on the left)")
        zoom.set_title("one engagement, zoomed", fontsize="small")
    ax.set_xlabel(label)
    ax.set_ylabel("$z_{re}$ [nm]")
    ax.set_title(f"Relative tool-workpiece displacement in z ({response.method} response)")
    ax.legend(fontsize="small", loc="upper right")
    ax.grid(alpha=0.3)
    return fig


def plot_frf(
    freq_hz,
    receptance,
    natural_hz=None,
    spindle_rpm: float | None = REFERENCE_RPM,
    ax=None,
) -> Figure:
    """Magnitude [m/N] and phase [deg] of the tool-workpiece receptance in z.

    natural_hz : natural frequencies [Hz] marked on the magnitude (triangles); none if None.
    spindle_rpm : spindle speed [rev/min] whose first SPINDLE_HARMONICS harmonics are drawn as
        dotted lines (default the reference process, 300 rpm); None draws none.
    ax : two axes (magnitude, phase); default a new figure.
    """
    if ax is None:
        fig = new_figure((8, 6))
        mag, phase = fig.subplots(2, 1, sharex=True)
    else:
        mag, phase = ax
        fig = mag.figure
    freq_hz = np.asarray(freq_hz, dtype=float)
    magnitude = np.abs(receptance)
    # an identically zero FRF (no mode couples the two ends) has nothing on a log axis
    draw = mag.loglog if np.any(magnitude > 0) else mag.semilogx
    draw(freq_hz, magnitude, lw=0.9, label="$|H_{zz}|$")
    phase.semilogx(freq_hz, np.degrees(np.angle(receptance)), lw=0.9)
    if spindle_rpm:
        harmonics = spindle_rpm / 60.0 * np.arange(1, SPINDLE_HARMONICS + 1)
        harmonics = harmonics[(harmonics >= freq_hz[0]) & (harmonics <= freq_hz[-1])]
        for k, f in enumerate(harmonics):
            label = f"spindle harmonics ({spindle_rpm:g} rpm, 1-{SPINDLE_HARMONICS}x)"
            for a in (mag, phase):
                a.axvline(
                    f, color="0.5", ls=":", lw=0.8, label=label if k == 0 and a is mag else None
                )
    if natural_hz is not None:
        f = np.asarray(natural_hz, dtype=float)
        f = f[(f >= freq_hz[0]) & (f <= freq_hz[-1])]
        level = np.interp(np.log(f), np.log(freq_hz), magnitude)
        mag.plot(f, level, "v", ms=5, color="r", label="natural frequencies")
    mag.set_ylabel("$|H_{zz}|$ [m/N]")
    mag.grid(alpha=0.3, which="both")
    mag.legend(fontsize="small")
    phase.set_ylabel("phase [deg]")
    phase.set_xlabel("frequency [Hz]")
    phase.grid(alpha=0.3, which="both")
    mag.set_title("Tool-workpiece receptance in z")
    return fig


def simulation_figures(result) -> dict[str, Figure]:
    """The figures of a :class:`ufmt.simulate.SimulationResult` by file stem: Figs. 6, 7, 13,
    14 (the surface as machined and as the interferometer measures it, the maps of
    ``SimulationResult.plot``), the surface PSDs and the PV of each error source alone next to
    the total."""
    r = result.response
    figures = {
        "tool_tip_displacement": plot_tool_tip(r, "displacement"),
        "tool_tip_acceleration": plot_tool_tip(r, "acceleration"),
        "z_re": plot_zre(r),
        "surface": plot_surface_map(result, "machined"),
        "surface_measured": plot_surface_map(result, "measured"),
        "psd": plot_psd(result),
        "pv_by_source": plot_pv_by_source([result], [_process_label(result.process)]),
    }
    return figures


def _process_label(process) -> str:
    return f"{process.rpm:g} rpm, {process.feed_mm_min:g} mm/min, {process.depth_um:g} µm"


def plot_simulation(result, directory) -> list[Path]:
    """Write :func:`simulation_figures` to ``directory`` as PNGs, as one set
    (:class:`ufmt.files.FileSet`); returns the paths."""
    figures = simulation_figures(result)
    with files.FileSet(directory) as out:
        return [out.add(f"{name}.png", files.figure_png(fig, DPI)) for name, fig in figures.items()]
