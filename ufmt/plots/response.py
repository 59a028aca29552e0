"""Simulation plots: tool-tip motion (paper Figs. 6, 7), z_re (Fig. 13), surface (Fig. 14), FRF.

Plotting reads results and never recomputes them. Figures are built with the object-oriented
matplotlib API (``matplotlib.figure.Figure``, Agg canvas), so no global backend state is used.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

_AXES = ("x", "y", "z")


def plot_tool_tip(response, path, quantity: str = "displacement") -> Path:
    """Tool-tip displacement [nm] or acceleration [mm/s^2] in x, y, z against time (Figs. 6, 7)."""
    if quantity == "displacement":
        data, unit, scale = response.tip_disp, "nm", 1e9
    elif quantity == "acceleration":
        data, unit, scale = response.tip_acc, "mm/s$^2$", 1e3
    else:
        raise ValueError(f"quantity must be 'displacement' or 'acceleration', got {quantity!r}")
    fig = Figure(figsize=(8, 7), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    for i, ax in enumerate(axes):
        ax.plot(response.t, data[:, i] * scale, lw=0.8)
        ax.set_ylabel(f"{_AXES[i]} [{unit}]")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    axes[-1].ticklabel_format(axis="x", useOffset=False)
    axes[0].set_title(f"Tool-tip {quantity} ({response.method} response)")
    return _save(fig, path)


def plot_zre(response, path) -> Path:
    """Relative tool-workpiece z displacement z_re [nm] against time (Fig. 13)."""
    fig = Figure(figsize=(8, 3.5), layout="constrained")
    ax = fig.subplots()
    ax.plot(response.t, response.z_re * 1e9, lw=0.8)
    ax.set_xlabel("time [s]")
    ax.ticklabel_format(axis="x", useOffset=False)
    ax.set_ylabel("$z_{re}$ [nm]")
    ax.set_title(f"Relative tool-workpiece displacement in z ({response.method} response)")
    ax.grid(alpha=0.3)
    return _save(fig, path)


def plot_surface(surface, path, pv_nm: float | None = None) -> Path:
    """Machined surface height [nm] over the workpiece [mm] (Fig. 14)."""
    fig = Figure(figsize=(6.5, 5.5), layout="constrained")
    ax = fig.subplots()
    z = surface.z * 1e9
    mesh = ax.pcolormesh(surface.x * 1e3, surface.y * 1e3, z, shading="auto", cmap="viridis")
    fig.colorbar(mesh, ax=ax, label="height [nm]")
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm] (opposite to the feed)")
    pv = float(np.ptp(z)) if pv_nm is None else pv_nm
    ax.set_title(f"Simulated machined surface, PV {pv:.2f} nm")
    return _save(fig, path)


def plot_frf(freq_hz, receptance, path) -> Path:
    """Magnitude [m/N] and phase [deg] of the tool-workpiece receptance in z."""
    fig = Figure(figsize=(8, 6), layout="constrained")
    mag, phase = fig.subplots(2, 1, sharex=True)
    mag.loglog(freq_hz, np.abs(receptance), lw=0.9)
    mag.set_ylabel("$|H_{zz}|$ [m/N]")
    mag.grid(alpha=0.3, which="both")
    phase.semilogx(freq_hz, np.degrees(np.angle(receptance)), lw=0.9)
    phase.set_ylabel("phase [deg]")
    phase.set_xlabel("frequency [Hz]")
    phase.grid(alpha=0.3, which="both")
    mag.set_title("Tool-workpiece receptance in z")
    return _save(fig, path)


def plot_simulation(result, directory) -> list[Path]:
    """The four figures of a :class:`ufmt.simulate.SimulationResult`, written to ``directory``."""
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    r = result.response
    return [
        plot_tool_tip(r, d / "tool_tip_displacement.png", "displacement"),
        plot_tool_tip(r, d / "tool_tip_acceleration.png", "acceleration"),
        plot_zre(r, d / "z_re.png"),
        plot_surface(result.surface, d / "surface.png", result.metrics["pv_nm"]),
    ]


def _save(fig: Figure, path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    return path
