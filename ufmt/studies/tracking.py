"""Modes followed along a sweep: which mode moves as a bearing stiffens, and where the spindle
harmonics cross the modes as the speed changes (a Campbell-style table and figure).

Along a one-at-a-time axis of a design parameter, the first ``count`` modes are solved at every
point (:func:`ufmt.solve_modes`) and each mode is followed from one point to the next by its
mass-weighted modal assurance criterion (MAC),

    MAC_ij = (v_i^T M w_j)^2 / ((v_i^T M v_i) (w_j^T M w_j)),

with v the previous point's shapes, w this point's and M the model's mass (the design changes
stiffnesses, not masses): the pairing that maximises the summed MAC (an assignment problem,
``scipy.optimize.linear_sum_assignment``), so a mode keeps its track through a crossing or a
veering where sorting by frequency would swap it. A track's name is its dominant body and
direction at the axis' first point. A mode the previous point did not have within ``count``
starts a new track. Along the spindle speed the modes do not move (the model has no speed-
dependent term), so the table has the modes of the base design once and the figure draws the
spindle harmonics k rpm / 60 over them: where a harmonic meets a mode, the cutting force
drives that mode at resonance.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment

from ufmt.mstmm.modes import ModeShapes, kinetic_terms

#: Modes followed: the paper's response basis (its first 30 modes, section 3.3).
TRACKED_MODES = 30
#: A pairing below this MAC is reported as uncertain (``mac_previous`` in the table).
WEAK_MAC = 0.5


def cross_mac(model, previous: ModeShapes, current: ModeShapes) -> np.ndarray:
    """Mass-weighted MAC (n_previous, n_current) between two sets of shapes of ``model``."""
    n_prev = previous.frequencies_hz.size
    n_cur = current.frequencies_hz.size
    previous_beams = {
        name: _on_grid(model.body(name), entry, current.beams[name])
        for name, entry in previous.beams.items()
    }
    previous = replace(previous, beams=previous_beams)
    products = np.empty((n_prev, n_cur))
    for i in range(n_prev):
        rigid = {k: np.repeat(v[[i]], n_cur, axis=0) for k, v in previous.rigid.items()}
        beams = {
            k: (p, w, np.repeat(v[[i]], n_cur, axis=0)) for k, (p, w, v) in previous.beams.items()
        }
        products[i] = kinetic_terms(model, rigid, beams, current.rigid, current.beams).sum(
            axis=(1, 2)
        )
    norm_prev = kinetic_terms(model, previous.rigid, previous.beams).sum(axis=(1, 2))
    norm_cur = kinetic_terms(model, current.rigid, current.beams).sum(axis=(1, 2))
    return products**2 / np.outer(norm_prev, norm_cur)


def _on_grid(beam, entry: tuple, target: tuple) -> tuple:
    """A beam's field ``entry`` (positions (g, 3), weights (g,), motion (n, g, 6)) on the
    Gauss points of ``target``: the two designs' shapes may have chosen different numbers of
    points (the rule follows each design's highest mode); the field is a polynomial of
    degree g - 1 through its Gauss points (Lagrange), which the rule integrates exactly."""
    positions, _, motion = entry
    at, weights, _ = target
    if len(positions) == len(at) and np.array_equal(positions, at):
        return entry
    axis = (beam.end - beam.start) / beam.length
    nodes = (np.asarray(positions) - beam.start) @ axis
    x = (np.asarray(at) - beam.start) @ axis
    diff = nodes[:, None] - nodes[None, :]
    np.fill_diagonal(diff, 1.0)
    factors = (x[:, None, None] - nodes[None, None, :]) / diff[None, :, :]
    idx = np.arange(nodes.size)
    factors[:, idx, idx] = 1.0
    lagrange = factors.prod(axis=2)  # (targets, nodes): L_j(x_t)
    return at, weights, np.einsum("tg,ngk->ntk", lagrange, motion)


def follow(model, solutions: list) -> list[tuple[np.ndarray, np.ndarray]]:
    """Track number and MAC to the previous point for each mode of each solution (a list of
    :class:`ufmt.ModalSolution` along an axis, in axis order): [(track (n,), mac (n,)), ...];
    the first point's modes are tracks 0 .. n-1 with MAC NaN."""
    first = solutions[0].frequencies_hz.size
    out = [(np.arange(first), np.full(first, np.nan))]
    next_track = first
    for prev, cur in zip(solutions, solutions[1:], strict=False):
        mac = cross_mac(model, prev.shapes, cur.shapes)
        rows, cols = linear_sum_assignment(-mac)
        n = cur.frequencies_hz.size
        track, best = np.full(n, -1), np.full(n, np.nan)
        prev_track = out[-1][0]
        track[cols] = prev_track[rows]
        best[cols] = mac[rows, cols]
        for j in np.flatnonzero(track < 0):  # more modes than the previous point had
            track[j], next_track = next_track, next_track + 1
        out.append((track, best))
    return out


def tracked_modes(model_at, values, parameter: str, count: int = TRACKED_MODES) -> pd.DataFrame:
    """The table of modes along one axis: ``model_at(value)`` is the model at each value.

    Columns: parameter, value, mode (number at this point, from 1), frequency_hz, track,
    track_name (dominant body and direction at the first point), body, direction (dominant
    here), mac_previous (MAC with the same track's mode at the previous value; NaN at the
    first), weak_pairing (mac_previous < WEAK_MAC), track_ratio (the track's frequency at the
    axis' last value over its first).
    """
    from ufmt.mstmm.solve import solve_modes

    models = [model_at(v) for v in values]
    solutions = [solve_modes(m, count=count) for m in models]
    tracks = follow(models[0], solutions)
    frames = []
    names: dict[int, str] = {}
    for value, model, solution, (track, mac) in zip(values, models, solutions, tracks, strict=True):
        table = solution.to_frame(model)
        for t, body, direction in zip(track, table["body"], table["direction"], strict=True):
            if int(t) not in names:
                name = f"{body} {direction}"
                taken = sum(1 for n in names.values() if n.split(" #")[0] == name)
                names[int(t)] = name if not taken else f"{name} #{taken + 1}"
        frames.append(
            table.assign(parameter=parameter, value=float(value), track=track, mac_previous=mac)
        )
    table = pd.concat(frames, ignore_index=True)
    table["track_name"] = [names[int(t)] for t in table["track"]]
    table["weak_pairing"] = table["mac_previous"] < WEAK_MAC
    ends = table.groupby("track_name")["frequency_hz"].agg(["first", "last"])
    table["track_ratio"] = table["track_name"].map(ends["last"] / ends["first"])
    columns = ["parameter", "value", "mode", "frequency_hz", "track", "track_name"]
    extra = ["body", "direction", "energy_share", "mac_previous", "weak_pairing", "track_ratio"]
    return table[[*columns, *extra]]


def moved(table: pd.DataFrame, top: int = 3) -> Mapping[str, float]:
    """The ``top`` tracks whose frequency changes most over the axis [ratio last / first]
    (of one axis' rows of :func:`tracked_modes`)."""
    ratio = table.groupby("track_name", sort=False)["track_ratio"].first()
    return dict(ratio.sort_values(key=lambda r: -np.abs(np.log(r)), kind="stable").head(top))
