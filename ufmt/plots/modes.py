"""Mode-shape drawing (3-D) and the comparison chart of the validation table.

Plots read solved shapes and written tables; they never solve. Rigid bodies are drawn as their
inertia-equivalent boxes (the box with the body's mass and principal moments, axes along x, y,
z), beams as lines, virtual bodies and hinge points as dots; the undeformed machine in grey,
the mode (scaled) in colour. Figures use matplotlib's object API on the Agg canvas.
"""

from __future__ import annotations

from itertools import product
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ufmt.model.schema import GROUND, Beam, Model, RigidBody

DPI = 120
DISPLAY_SHARE = 0.12  # default scale: largest drawn displacement = this share of the machine size
ERROR_BAND_PERCENT = 3.0  # issue 3's target band, drawn on the error panel


def equivalent_box(body: RigidBody) -> np.ndarray:
    """Edge lengths [m] of the box with the body's mass and principal moments (x, y, z).

    ``I_x = m (b^2 + c^2) / 12`` etc. give ``a^2 = 6 (I_y + I_z - I_x) / m``.
    """
    ix, iy, iz = np.diag(body.inertia)
    squares = 6.0 * np.array([iy + iz - ix, ix + iz - iy, ix + iy - iz]) / body.mass
    return np.sqrt(np.clip(squares, 0.0, None))


_CORNERS = np.array(list(product((-0.5, 0.5), repeat=3)))  # (8, 3)
_EDGES = [
    (i, j) for i in range(8) for j in range(i + 1, 8) if np.sum(_CORNERS[i] != _CORNERS[j]) == 1
]
# body palette: matplotlib's tab10 without its grey, which draws the undeformed machine
PALETTE = ["C0", "C1", "C2", "C3", "C4", "C5", "C6", "C8", "C9"]
VIEW_MARGIN = 0.15  # share of the machine's extent added around it


def _rigid_points(points: np.ndarray, center: np.ndarray, motion: np.ndarray) -> np.ndarray:
    """Translation of points (P, 3) of a rigid body with motion [r_C; theta] (6,)."""
    return motion[:3] + np.cross(motion[3:], points - center)


def _view_box(model: Model) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) corners [m] of the drawn region: every body not hinged to ground + margin.

    A body on ground (the foundation block) is usually much larger than the machine; it is
    drawn cut to this region.
    """
    grounded = {b for h in model.hinges if GROUND in h.between for b in h.between}
    points = []
    for body in model.bodies:
        if body.name in grounded:
            continue
        if isinstance(body, RigidBody):
            points.append(body.center_of_mass + _CORNERS * equivalent_box(body))
        elif isinstance(body, Beam):
            points.append(np.vstack([body.start, body.end]))
    if not points:
        points = [h.at[None, :] for h in model.hinges]
    points = np.vstack(points)
    low, high = points.min(axis=0), points.max(axis=0)
    pad = VIEW_MARGIN * float(np.max(high - low))
    return low - pad, high + pad


def _geometry(model: Model, shapes, index: int, view: tuple[np.ndarray, np.ndarray]):
    """Undeformed corners/polylines/points of every body and their motion in mode ``index``."""
    boxes, beams, dots = [], [], []
    for body in model.bodies:
        if isinstance(body, RigidBody):
            half = equivalent_box(body) / 2.0
            low = np.maximum(body.center_of_mass - half, view[0])
            high = np.minimum(body.center_of_mass + half, view[1])
            if np.any(low >= high):
                continue
            corners = (low + high) / 2.0 + _CORNERS * (high - low)
            moved = _rigid_points(corners, body.center_of_mass, shapes.rigid[body.name][index])
            boxes.append((body, corners, moved))
        elif isinstance(body, Beam):
            pos, _, motion = shapes.beams[body.name]
            line = np.vstack([body.start, pos, body.end])
            disp = np.vstack([motion[index, :1, :3], motion[index, :, :3], motion[index, -1:, :3]])
            beams.append((body, line, disp))
        else:
            point = _virtual_point(model, body.name)
            dots.append((body, point, shapes.virtual[body.name][index, :3]))
    return boxes, beams, dots


def _virtual_point(model: Model, name: str) -> np.ndarray:
    """The point [m] of a virtual body: that of its first hinge."""
    return np.asarray(next(h.at for h in model.hinges if name in h.between), dtype=float)


def plot_mode(
    model: Model,
    shapes,
    index: int,
    path,
    scale: float | None = None,
    description: str = "",
) -> Path:
    """Draw mode ``index`` (0-based) of MSTMM ``shapes`` in 3-D to ``path`` (PNG).

    scale : factor on the unit-modal-mass displacements [m per m/sqrt(kg)]; default: the
        largest drawn displacement is DISPLAY_SHARE of the machine's largest extent.
    """
    view = _view_box(model)
    boxes, beams, dots = _geometry(model, shapes, index, view)
    extent = float(np.max(view[1] - view[0])) / (1.0 + 2.0 * VIEW_MARGIN)
    largest = max(
        [float(np.max(np.linalg.norm(d, axis=1))) for _, _, d in boxes + beams]
        + [float(np.linalg.norm(d)) for _, _, d in dots]
    )
    if scale is None:
        scale = DISPLAY_SHARE * extent / largest if largest > 0 else 1.0
    fig = Figure(figsize=(9, 7.5), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(projection="3d")
    for n, (body, corners, moved) in enumerate(boxes):
        colour = PALETTE[n % len(PALETTE)]
        for i, j in _EDGES:
            ax.plot(*corners[[i, j]].T, color="0.75", lw=0.7)
            ax.plot(*(corners + scale * moved)[[i, j]].T, color=colour, lw=1.3)
        label = f"{body.number} {body.name}" if body.number is not None else body.name
        ax.text(*(corners.mean(axis=0) + scale * moved.mean(axis=0)), label, fontsize=7)
    for _, line, disp in beams:
        ax.plot(*line.T, color="0.6", lw=2.0)
        ax.plot(*(line + scale * disp).T, color="k", lw=2.5)
    for _, point, disp in dots:
        ax.scatter(*(point + scale * disp), color="k", s=12)
    hinge_points = np.array(
        [h.at for h in model.hinges if np.all((h.at >= view[0]) & (h.at <= view[1]))]
    )
    ax.scatter(*hinge_points.T, color="r", s=6, alpha=0.6, label="hinge points (undeformed)")
    f = shapes.frequencies_hz[index]
    title = f"Mode {index + 1}: {f:.2f} Hz (MSTMM), displacements x {scale:.3g}"
    ax.set_title(title + (f"\n{description}" if description else ""), fontsize=10)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.set_xlim(view[0][0], view[1][0])
    ax.set_ylim(view[0][1], view[1][1])
    ax.set_zlim(view[0][2], view[1][2])
    ax.set_box_aspect(view[1] - view[0], zoom=1.1)
    ax.view_init(elev=18, azim=-55)
    ax.legend(loc="upper left", fontsize=7)
    return _save(fig, path)


def plot_frequencies(table: pd.DataFrame, path) -> Path:
    """Frequencies of every mode and errors of the tested ones (validation table columns)."""
    fig = Figure(figsize=(10, 7.5), layout="constrained")
    FigureCanvasAgg(fig)
    top, bottom = fig.subplots(2, 1, height_ratios=[3, 2])
    mode = table["mode"].to_numpy()
    top.plot(mode, table["mstmm_hz"], "o-", ms=4, lw=0.8, label="this project, MSTMM")
    top.plot(mode, table["assembled_hz"], "+", ms=8, label="this project, assembled model")
    for col, marker, label in (
        ("test_hz", "s", "modal test (Table 3)"),
        ("paper_mstmm_hz", "^", "paper MSTMM"),
        ("paper_fem_hz", "v", "paper FEM"),
    ):
        top.plot(mode, table[col], marker, ms=6, mfc="none", label=label)
    top.set_yscale("log")
    top.set_ylabel("natural frequency [Hz]")
    top.set_xticks(mode)
    top.grid(alpha=0.3, which="both")
    top.legend(fontsize=8)
    top.set_title("UFMT natural frequencies against Table 3")
    tested = table.dropna(subset=["test_hz"])
    x = np.arange(len(tested))
    width = 0.27
    for k, (col, label) in enumerate(
        (
            ("paper_mstmm_error_percent", "paper MSTMM"),
            ("paper_fem_error_percent", "paper FEM"),
            ("mstmm_error_percent", "this project, MSTMM"),
        )
    ):
        bottom.bar(x + (k - 1) * width, tested[col], width, label=label)
    for sign in (-1, 1):
        bottom.axhline(sign * ERROR_BAND_PERCENT, color="k", ls="--", lw=0.8)
    bottom.axhline(0.0, color="k", lw=0.5)
    bottom.set_xticks(x, [str(m) for m in tested["mode"]])
    bottom.set_xlabel("mode (tested in Table 3)")
    bottom.set_ylabel("error against the test [%]")
    bottom.grid(alpha=0.3, axis="y")
    bottom.legend(fontsize=8, ncols=3)
    return _save(fig, path)


def _save(fig: Figure, path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI)
    return path
