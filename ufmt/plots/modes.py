"""Mode-shape drawing (3-D) and the comparison chart of the validation table.

Plots read solved shapes and written tables; they never solve. Rigid bodies are drawn as their
inertia-equivalent boxes (the box with the body's mass and principal moments, axes along x, y,
z), beams as lines from their start to their end, virtual bodies and hinge points as dots; the
undeformed machine in grey dashes, the mode (scaled) in solid lines coloured by the
displacement magnitude, the tool tip and the workpiece (when the model has a ``[machine]``
table) as a star and a square; :func:`animate_mode` writes a mode as an animated GIF.
Functions take an optional ``ax`` and return the Figure.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from itertools import product
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator
from mpl_toolkits.mplot3d.art3d import Line3DCollection

from ufmt.errors import UfmtError
from ufmt.kinds import kind_of
from ufmt.machining.cutting import tool_tip
from ufmt.model.schema import GROUND, Beam, Model, RigidBody
from ufmt.plots import new_axes, new_figure

DISPLAY_SHARE = 0.12  # default scale: largest drawn displacement = this share of the machine size
ERROR_BAND_PERCENT = 3.0  # the validation target band (|error| <= 3 %), drawn on the error panel
GROUND_CUT_RATIO = 3.0  # a grounded body more than this times the rest's size is kept whole
TICKS_PER_AXIS = 4
MIN_AXIS_SHARE = 0.4  # each axis of the view spans at least this share of the largest
MODE_CMAP = "plasma"  # colour of the displacement magnitude
MAGNITUDE_LABEL = "|displacement| [share of the mode's largest]"
ANIMATION_FRAMES = 16  # frames of one period of the animated mode
ANIMATION_FPS = 12
ANIMATION_DPI = 72


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
    """(low, high) corners [m] of the drawn region: the machine plus a margin.

    A body on ground (the foundation block) is drawn cut to the region of the bodies above it
    when those span at least 1/GROUND_CUT_RATIO of its size; a grounded body that dwarfs the
    rest (a bridge carrying a small spindle) is the machine itself and is kept whole.
    """
    grounded = {b for h in model.hinges if GROUND in h.between for b in h.between}
    free = [_body_points(b) for b in model.bodies if b.name not in grounded]
    hinges = [h.at[None, :] for h in model.hinges if GROUND not in h.between]
    free = np.vstack([p for p in free if p is not None] + hinges)
    size = float(np.max(np.ptp(free, axis=0)))
    points = [free]
    for body in model.bodies:
        corners = _body_points(body) if body.name in grounded else None
        if corners is not None and np.max(np.ptp(corners, axis=0)) > GROUND_CUT_RATIO * size:
            points.append(corners)
    points = np.vstack(points)
    low, high = points.min(axis=0), points.max(axis=0)
    largest = float(np.max(high - low))
    # a flat machine keeps some depth on its thin axes, so their ticks do not collide
    half = np.maximum(high - low, MIN_AXIS_SHARE * largest) / 2.0
    centre = (low + high) / 2.0
    pad = VIEW_MARGIN * largest
    return centre - half - pad, centre + half + pad


def beam_polyline(beam: Beam, positions: np.ndarray, motion: np.ndarray):
    """A beam's drawn line from its start to its end, and the displacement of each vertex.

    positions : (g, 3) [m] stations in any order (the MSTMM stores them from the beam's
        input end, which may be its end); motion : (g, 6) [m, rad] at those stations.
    Returns (line (g + 2, 3) [m], displacement (g + 2, 3) [m]): start, the stations sorted
    along the axis, end; the ends take the displacement of their nearest station.
    """
    axis = beam.end - beam.start
    order = np.argsort((positions - beam.start) @ axis)
    disp = motion[order, :3]
    line = np.vstack([beam.start, positions[order], beam.end])
    return line, np.vstack([disp[:1], disp, disp[-1:]])


def _geometry(model: Model, shapes, index: int, view: tuple[np.ndarray, np.ndarray]):
    """Undeformed corners/polylines/points of every body and their motion in mode ``index``
    (:data:`BODY_DRAWINGS` of each body's kind), as (boxes, beams, dots)."""
    layers = {"boxes": [], "beams": [], "dots": []}
    for body in model.bodies:
        drawing = BODY_DRAWINGS[kind_of(body).FORM]
        item = drawing.drawn(model, body, shapes, index, view)
        if item is not None:
            layers[drawing.layer].append(item)
    return layers["boxes"], layers["beams"], layers["dots"]


def _box_outline(body: RigidBody) -> np.ndarray:
    """Corner points [m] of a rigid body's inertia-equivalent box."""
    return body.center_of_mass + _CORNERS * equivalent_box(body)


def _drawn_box(model: Model, body: RigidBody, shapes, index: int, view):
    """(body, corners, moved corners) of the box cut to the view; None if outside it."""
    half = equivalent_box(body) / 2.0
    low = np.maximum(body.center_of_mass - half, view[0])
    high = np.minimum(body.center_of_mass + half, view[1])
    if np.any(low >= high):
        return None
    corners = (low + high) / 2.0 + _CORNERS * (high - low)
    moved = _rigid_points(corners, body.center_of_mass, shapes.rigid[body.name][index])
    return body, corners, moved


def _beam_outline(body: Beam) -> np.ndarray:
    """The two ends [m] of a beam."""
    return np.vstack([body.start, body.end])


def _drawn_beam(model: Model, body: Beam, shapes, index: int, view):
    """(body, polyline, displacement) of a beam (:func:`beam_polyline`)."""
    pos, _, motion = shapes.beams[body.name]
    return (body, *beam_polyline(body, pos, motion[index]))


def _drawn_dot(model: Model, body, shapes, index: int, view):
    """(body, point, displacement) of a virtual body at its hinges' point."""
    return body, _virtual_point(model, body.name), shapes.virtual[body.name][index, :3]


@dataclass(frozen=True)
class BodyDrawing:
    """How the mode plots draw one body form.

    layer : "boxes", "beams" or "dots" (the style it is drawn in); outline(body) : the points
    [m] that bound the body (sets the view), or None for a point body placed by its hinges;
    drawn(model, body, shapes, index, view) : the layer's item in mode ``index``, or None.
    """

    layer: str
    outline: Callable[..., np.ndarray | None]
    drawn: Callable[..., tuple | None]


#: body form (:data:`ufmt.kinds.FORMS`) -> its drawing (a new kind of an existing form: none)
BODY_DRAWINGS = {
    "mass": BodyDrawing("boxes", _box_outline, _drawn_box),
    "member": BodyDrawing("beams", _beam_outline, _drawn_beam),
    "point": BodyDrawing("dots", lambda body: None, _drawn_dot),
}


def _body_points(body) -> np.ndarray | None:
    """Points [m] that bound a body (:attr:`BodyDrawing.outline`); None for a point body."""
    return BODY_DRAWINGS[kind_of(body).FORM].outline(body)


def _virtual_point(model: Model, name: str) -> np.ndarray:
    """The point [m] of a virtual body: that of its first hinge."""
    return np.asarray(next(h.at for h in model.hinges if name in h.between), dtype=float)


def _tool_tip(model: Model, shapes, index: int):
    """(position [m], displacement [m]) of the tool tip at spindle angle 0, or None.

    None when the model has no ``[machine]`` table or its tool body is not rigid.
    """
    machine = model.machine
    if machine is None or machine.tool_body not in shapes.rigid:
        return None
    tip = machine.frame @ tool_tip(0.0, machine)  # machine frame -> the file's
    body = model.body(machine.tool_body)
    return tip, _rigid_points(tip[None, :], body.center_of_mass, shapes.rigid[body.name][index])[0]


def _workpiece_point(model: Model, shapes, index: int):
    """(position [m], displacement [m]) of the workpiece's top centre, or None (as
    :func:`_tool_tip`)."""
    machine = model.machine
    if machine is None or machine.workpiece_body not in shapes.rigid:
        return None
    point = np.array([*machine.workpiece_center_xy, machine.cutting_plane_z], dtype=float)
    point = machine.frame @ point  # machine frame -> the file's
    body = model.body(machine.workpiece_body)
    motion = shapes.rigid[body.name][index]
    return point, _rigid_points(point[None, :], body.center_of_mass, motion)[0]


def _largest(boxes, beams, dots) -> float:
    """The largest displacement [m per m/sqrt(kg)] of every drawn point."""
    return max(
        [float(np.max(np.linalg.norm(d, axis=1))) for _, _, d in boxes + beams]
        + [float(np.linalg.norm(d)) for _, _, d in dots]
    )


def plot_mode(
    model: Model,
    shapes,
    index: int,
    scale: float | None = None,
    description: str = "",
    ax=None,
    colorbar: bool = True,
    phase: float = 1.0,
) -> Figure:
    """Draw mode ``index`` (0-based) of MSTMM ``shapes`` in 3-D.

    The undeformed machine in thin grey dashes; the deformed one in solid lines coloured by
    the displacement magnitude (share of the mode's largest, colour bar); bodies numbered at
    their deformed centre, the numbers keyed to the names beside the axes (no name sits on the
    drawing); the tool tip (star) and the workpiece's top centre (square) where the model has
    a ``[machine]`` table.

    Parameters
    ----------
    model : the model the shapes belong to.
    shapes : :class:`ufmt.mstmm.modes.ModeShapes`.
    index : mode index, 0-based.
    scale : factor on the unit-modal-mass displacements [m per m/sqrt(kg)]; default: the
        largest drawn displacement is DISPLAY_SHARE of the machine's largest extent.
    description : second title line (e.g. the dominant bodies and directions).
    ax : a 3-D axes to draw in (default: a new figure).
    colorbar : add the colour bar of the displacement magnitude.
    phase : factor in [-1, 1] on the drawn displacements (the animation's cos(2 pi t / T)).

    Returns
    -------
    matplotlib.figure.Figure
    """
    n = shapes.frequencies_hz.size
    if not 0 <= index < n:
        raise UfmtError(
            f"mode index {index}: outside 0..{n - 1} (a 0-based position in the {n} solved "
            f"shapes; mode number = index + 1, as ModalSolution.plot(model=..., mode=N) takes it)"
        )
    view = _view_box(model)
    boxes, beams, dots = _geometry(model, shapes, index, view)
    extent = float(np.max(view[1] - view[0])) / (1.0 + 2.0 * VIEW_MARGIN)
    largest = _largest(boxes, beams, dots)
    if scale is None:
        scale = DISPLAY_SHARE * extent / largest if largest > 0 else 1.0
    fig, ax = new_axes(ax, (10, 7.5), projection="3d")
    norm = Normalize(0.0, 1.0)
    keys = _draw_bodies(ax, boxes, beams, dots, scale * phase, largest or 1.0, norm)
    hinge_points = np.array(
        [h.at for h in model.hinges if np.all((h.at >= view[0]) & (h.at <= view[1]))]
    )
    ax.scatter(*hinge_points.T, color="0.35", s=5, alpha=0.6, label="hinge points (undeformed)")
    for point, marker, name, colour in (
        (_tool_tip(model, shapes, index), "*", "tool tip", "m"),
        (_workpiece_point(model, shapes, index), "s", "workpiece (top centre)", "c"),
    ):
        if point is not None:
            ax.scatter(
                *(point[0] + scale * phase * point[1]),
                marker=marker,
                s=150 if marker == "*" else 70,
                color=colour,
                edgecolors="k",
                depthshade=False,
                label=name,
                zorder=10,
            )
    f = shapes.frequencies_hz[index]
    title = f"Mode {index + 1}: {f:.2f} Hz (MSTMM), displacements x {scale:.3g}"
    ax.set_title(title + (f"\n{description}" if description else ""), fontsize=10)
    _set_view(ax, view)
    legend = ax.legend(loc="upper left", fontsize=7, bbox_to_anchor=(0.0, 1.0))
    legend.set_zorder(20)
    if colorbar:
        mappable = ScalarMappable(norm=norm, cmap=MODE_CMAP)
        fig.colorbar(mappable, ax=ax, shrink=0.6, pad=0.02, label=MAGNITUDE_LABEL)
    fig.text(0.99, 0.02, "\n".join(keys), fontsize=7, ha="right", va="bottom")
    return fig


def _draw_bodies(ax, boxes, beams, dots, scale, largest, norm) -> list[str]:
    """Undeformed (grey dashes) and deformed (coloured by |displacement|) bodies; returns the
    "number: name" key of the numbered bodies."""
    cmap = _cmap()
    undeformed = {"color": "0.6", "lw": 0.6, "ls": (0, (3, 2))}
    segments, magnitudes, keys = [], [], []
    for k, (body, corners, moved) in enumerate(boxes):
        size = np.linalg.norm(moved, axis=1) / largest
        for i, j in _EDGES:
            ax.plot(*corners[[i, j]].T, **undeformed)
            segments.append((corners + scale * moved)[[i, j]])
            magnitudes.append(0.5 * (size[i] + size[j]))
        number = str(body.number if body.number is not None else k + 1)
        centre = corners.mean(axis=0) + scale * moved.mean(axis=0)
        ax.text(
            *centre,
            number,
            fontsize=7,
            ha="center",
            va="center",
            zorder=15,
            bbox={"boxstyle": "round,pad=0.15", "fc": "w", "ec": "0.5", "alpha": 0.85},
        )
        keys.append(f"{number}: {body.name}")
    for body, line, disp in beams:
        ax.plot(*line.T, gid=f"beam:{body.name}:undeformed", **{**undeformed, "lw": 1.2})
        moved = line + scale * disp
        ax.plot(*moved.T, color="k", lw=3.2, gid=f"beam:{body.name}:mode")  # outline
        size = np.linalg.norm(disp, axis=1) / largest
        for i in range(len(line) - 1):
            segments.append(moved[i : i + 2])
            magnitudes.append(0.5 * (size[i] + size[i + 1]))
    for _, point, disp in dots:
        ax.scatter(*(point + scale * disp), color=cmap(norm(np.linalg.norm(disp) / largest)), s=12)
    collection = Line3DCollection(segments, cmap=cmap, norm=norm, linewidths=1.8)
    collection.set_array(np.asarray(magnitudes))
    ax.add_collection3d(collection)
    ax.plot([], [], label="undeformed", **undeformed)
    ax.plot([], [], color=cmap(0.8), lw=1.8, label="mode shape (colour: |displacement|)")
    return keys


def _set_view(ax, view) -> None:
    for name, (lo, hi) in zip("xyz", zip(*view, strict=True), strict=True):
        getattr(ax, f"set_{name}label")(f"{name} [m]")
        getattr(ax, f"set_{name}lim")(lo, hi)
        getattr(ax, f"{name}axis").set_major_locator(MaxNLocator(TICKS_PER_AXIS))
    ax.tick_params(labelsize=7)
    ax.set_box_aspect(view[1] - view[0], zoom=0.9)
    ax.view_init(elev=18, azim=-55)


def _cmap():
    from matplotlib import colormaps

    return colormaps[MODE_CMAP]


def animate_mode(
    model: Model,
    shapes,
    index: int,
    path,
    scale: float | None = None,
    description: str = "",
    frames: int = ANIMATION_FRAMES,
    fps: int = ANIMATION_FPS,
):
    """Write mode ``index`` as an animated GIF to ``path``: the deformed machine swinging
    through one period (displacements x ``scale`` cos(2 pi k / frames)), with matplotlib's
    PillowWriter. Returns the path."""
    from matplotlib.animation import FuncAnimation, PillowWriter

    if scale is None:
        view = _view_box(model)
        largest = _largest(*_geometry(model, shapes, index, view))
        extent = float(np.max(view[1] - view[0])) / (1.0 + 2.0 * VIEW_MARGIN)
        scale = DISPLAY_SHARE * extent / largest if largest > 0 else 1.0
    fig = plot_mode(model, shapes, index, scale, description)
    ax = fig.axes[0]

    def draw(k):
        ax.cla()
        for text in fig.texts:
            text.remove()
        phase = np.cos(2.0 * np.pi * k / frames)
        plot_mode(model, shapes, index, scale, description, ax=ax, colorbar=False, phase=phase)

    animation = FuncAnimation(fig, draw, frames=frames)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    animation.save(path, writer=PillowWriter(fps=fps), dpi=ANIMATION_DPI)
    return path


def plot_frequencies(table: pd.DataFrame, ax=None) -> Figure:
    """Frequencies of every mode and errors of the tested ones (validation table columns).

    ax : two axes (frequencies, errors); default a new figure.
    """
    if ax is None:
        fig = new_figure((10, 7.5))
        top, bottom = fig.subplots(2, 1, height_ratios=[3, 2])
    else:
        top, bottom = ax
        fig = top.figure
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
        bottom.axhline(
            sign * ERROR_BAND_PERCENT,
            color="k",
            ls="--",
            lw=0.8,
            label=f"target band ±{ERROR_BAND_PERCENT:g} %" if sign > 0 else None,
        )
    bottom.axhline(0.0, color="k", lw=0.5)
    bottom.set_xticks(x, [str(m) for m in tested["mode"]])
    bottom.set_xlabel("mode (tested in Table 3)")
    bottom.set_ylabel("error against the test [%]")
    bottom.grid(alpha=0.3, axis="y")
    bottom.legend(fontsize=8, ncols=4)
    return fig


MAX_BODIES_SHOWN = 8  # bodies named in the energy-share chart; the rest are summed as "other"


def plot_modal_solution(solution, model: Model | None = None, ax=None) -> Figure:
    """Natural frequency of each mode of a :class:`ufmt.mstmm.solve.ModalSolution`.

    Without the model: frequency [Hz, log axis] against mode number. With it (and shapes):
    one stacked bar per mode of the kinetic-energy share of each body (the bodies with the
    most energy over all modes; the rest as "other"), the frequency under each mode number.

    Returns
    -------
    matplotlib.figure.Figure
    """
    f = solution.frequencies_hz
    mode = np.arange(1, f.size + 1)
    if model is None or solution.shapes is None:
        fig, ax = new_axes(ax, (max(5.0, 0.25 * f.size + 2), 3.5))
        ax.semilogy(mode, f, "o-", ms=4, lw=0.8)
        ax.set_xlabel("mode")
        ax.set_ylabel("natural frequency [Hz]")
        ax.set_xticks(mode)
        ax.grid(alpha=0.3, which="both")
        ax.set_title(f"{f.size} natural frequencies ({solution.method})")
        return fig
    shares = solution.energy_shares(model).sum(axis=2)  # (modes, bodies)
    names = [b.name for b in model.bodies]
    ranked = np.argsort(-shares.sum(axis=0))
    shown = ranked[:MAX_BODIES_SHOWN]
    fig, ax = new_axes(ax, (max(6.0, 0.4 * f.size + 3), 4.5))
    bottom = np.zeros(f.size)
    columns = [(names[i], shares[:, i]) for i in shown]
    if ranked.size > shown.size:
        columns.append(("other", shares[:, ranked[MAX_BODIES_SHOWN:]].sum(axis=1)))
    for n, (name, share) in enumerate(columns):
        colour = "0.7" if name == "other" else PALETTE[n % len(PALETTE)]
        ax.bar(mode, 100 * share, bottom=100 * bottom, color=colour, label=name, width=0.8)
        bottom += share
    ax.set_xticks(mode, [f"{m}\n{v:.3g}" for m, v in zip(mode, f, strict=True)], fontsize=7)
    ax.set_xlabel("mode and natural frequency [Hz]")
    ax.set_ylabel("kinetic energy [% of the mode's]")
    ax.set_ylim(0, 100)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    ax.set_title(f"{model.name}: which body moves in each mode ({solution.method})")
    return fig
