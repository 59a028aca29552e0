"""A modal test from a universal file (UFF, ``.uff``/``.unv``) as modal-analysis software
exports it, read with pyuff.

* Nodes: dataset 15 or 2411 (positions in the global frame; a node listed twice, a NaN
  coordinate or a displacement coordinate system other than the global one is refused).
* Length unit: dataset 164 (its length factor: file units per metre) or the unit the user
  declares (``unit``, one of :data:`LENGTH_UNITS`); neither: refused (never guessed); both and
  different: refused.
* Modes: dataset 55, one per mode. Normal modes (analysis type 2): frequency and viscous
  damping ratio. Complex modes (analysis type 3): frequency ``|λ|/2π`` and damping ratio
  ``-Re λ/|λ|`` of the eigenvalue λ; the shape rotated to its largest component and its real
  part taken; its modal phase collinearity (MPC) reported. Mode numbers are any positive
  integers, each once; a NaN, zero or unstable eigenvalue is refused.
* Measured directions: the translations r1, r2, r3 of a node are the sensors x, y, z; a
  direction that is exactly 0 in every mode of the file was not measured (software writes 0
  for it) and is no sensor.
* Bodies: which body a node is on is not in the UFF: ``<name>.nodes.csv`` beside it (columns
  ``node``, ``body``) says; nodes it does not list are left out.

A file that does not end with a dataset delimiter (``-1``) is truncated and refused. Every
refusal is one line naming the file and the dataset.

MPC (modal phase collinearity, Pappa, Elliott and Schenk, 1993): with ``S_xx = Re φ·Re φ``,
``S_yy = Im φ·Im φ`` and ``S_xy = Re φ·Im φ``, ``MPC = ((S_xx - S_yy)² + 4 S_xy²) /
(S_xx + S_yy)²``: 1 for a shape whose components share one phase (a normal mode, any complex
scaling of it), 0 for real and imaginary parts of equal norm in quadrature.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ufmt.errors import StudyError
from ufmt.limits import MAX_INPUT_BYTES
from ufmt.tables import Where

LENGTH_UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254, "ft": 0.3048}  # [m] per unit
NODE_SETS = (15, 2411)
MODE_SET = 55
NORMAL, COMPLEX = 2, 3  # dataset 55 analysis types read
AXES = ("x", "y", "z")  # the translations r1, r2, r3: global axes


def length_scale(where: Where, unit: str | None) -> float | None:
    """Metres per declared ``unit`` (None: none declared)."""
    if unit is None:
        return None
    return LENGTH_UNITS[where.choice("unit", unit, tuple(LENGTH_UNITS), "length unit")]


def read_uff(path, unit: str | None, node_map: Callable[[Path], dict[int, str]]) -> dict:
    """The arguments of :func:`ufmt.calibration.modal_test.modal_test` from a universal file
    (module docstring; ``sensors`` as (body, position [m], axis) triples) and its node map,
    read by ``node_map``."""
    where = Where(str(path), error=StudyError)
    sets = _read_sets(where, Path(path))
    modes = [d for d in sets if d.get("type") == MODE_SET]
    if not modes:
        where.fail_table("no mode shapes (dataset 55)")
    nodes = uff_nodes(where, sets, unit)
    mapping = Path(path).with_suffix(".nodes.csv")
    bodies = node_map(mapping)
    read = [_mode(where.sub(f"dataset 55 [{i}]"), d) for i, d in enumerate(modes)]
    numbers = [r[0] for r in read]
    where.sub("dataset 55").unique("mode_n", numbers)
    listed = sorted(n for n in bodies if any(n in r[4] for r in read))
    for n in listed:
        if n not in nodes:
            where.fail_table(f"node {n} has a mode shape but no position (dataset 15 or 2411)")
    values = np.array([[r[4].get(n, np.full(3, np.nan)) for n in listed] for r in read])
    values = values.reshape(len(read), len(listed) * 3)
    measured = np.any(np.isfinite(values) & (values != 0.0), axis=0)
    if not measured.any():
        where.fail_table(f"no measured node of the file is in its node map {mapping.name}")
    placed = [(n, a) for n in listed for a in AXES]
    sensors = [(bodies[n], nodes[n], a) for (n, a), m in zip(placed, measured, strict=True) if m]
    return {
        "modes": numbers,
        "frequencies_hz": [r[1] for r in read],
        "damping_ratio": [r[2] for r in read],
        "sensors": sensors,
        "shapes": values[:, measured],
        "source": str(path),
        "mpc": [r[3] for r in read],
    }


def _read_sets(where: Where, path: Path) -> list[dict]:
    """Every dataset of the file (pyuff); a missing, oversized, truncated or unreadable file is
    one line."""
    import pyuff

    if not path.is_file():
        where.fail_table("file not found" if not path.exists() else "not a file")
    size = path.stat().st_size
    if size > MAX_INPUT_BYTES:
        where.fail_table(f"{size:,} bytes; an input file holds at most {MAX_INPUT_BYTES:,}")
    with path.open("rb") as handle:
        handle.seek(max(0, size - 256))
        tail = handle.read().split(b"\n")
    last = next((line.strip() for line in reversed(tail) if line.strip()), b"")
    if last != b"-1":
        where.fail_table("truncated: the file does not end with a dataset delimiter (-1)")
    try:
        sets = pyuff.UFF(str(path)).read_sets()
    except Exception as exc:  # pyuff raises bare exceptions on malformed files
        where.fail_table(f"not a readable universal file ({type(exc).__name__}: {exc})")
    return sets if isinstance(sets, list) else [sets]


def uff_nodes(where: Where, sets: list[dict], unit: str | None) -> dict[int, tuple]:
    """node -> position (x, y, z) [m] from datasets 15 and 2411, in the unit of dataset 164
    or the declared ``unit``."""
    scale = _unit_scale(where, sets, unit)
    out: dict[int, tuple] = {}
    for d in (d for d in sets if d.get("type") in NODE_SETS):
        here = where.sub(f"dataset {d['type']}")
        xyz = np.stack([np.asarray(d[k], dtype=float) for k in ("x", "y", "z")], axis=1)
        for n, p, cs in zip(d["node_nums"], xyz, d.get("disp_cs", [0] * len(xyz)), strict=True):
            n = int(n)
            if n in out:
                here.fail("node_nums", f"node {n} is listed more than once")
            if not np.all(np.isfinite(p)):
                here.fail("x y z", f"node {n} has a position that is not a finite number")
            if int(cs) != 0:
                here.fail(
                    "disp_cs",
                    f"node {n} measures in coordinate system {int(cs)}, not the global one "
                    "(export the shapes in the global frame)",
                )
            out[n] = tuple(float(c) * scale for c in p)
    if not out:
        where.fail_table("no node positions (dataset 15 or 2411)")
    return out


def _unit_scale(where: Where, sets: list[dict], unit: str | None) -> float:
    """Metres per file unit: dataset 164's length factor or the declared unit."""
    declared = length_scale(where, unit)
    units = [d for d in sets if d.get("type") == 164]
    if not units:
        if declared is None:
            where.fail_table(
                "no units (dataset 164): declare the length unit of its node positions "
                f"(--test-unit or unit=, one of {', '.join(LENGTH_UNITS)})"
            )
        return declared
    factor = float(units[0].get("length", math.nan))
    if not (math.isfinite(factor) and factor > 0):
        where.sub("dataset 164").fail("length", f"{factor:g} is not a positive unit factor")
    scale = 1.0 / factor
    if declared is not None and not math.isclose(declared, scale, rel_tol=1e-6):
        where.sub("dataset 164").fail(
            "length", f"the file's unit ({scale:g} m) differs from the declared {unit!r}"
        )
    return scale


def _mode(where: Where, d: dict) -> tuple[int, float, float, float, dict]:
    """(mode number, frequency [Hz], damping ratio, MPC, node -> (3,) real translations) of
    one dataset 55."""
    kind = d.get("analysis_type")
    if kind not in (NORMAL, COMPLEX):
        where.fail("analysis_type", f"{kind} is not a normal (2) or complex (3) mode")
    number = where.integer("mode_n", d.get("mode_n"), low=1)
    parts = np.stack([np.asarray(d[k]) for k in ("r1", "r2", "r3")], axis=1)
    nodes = [int(n) for n in d["node_nums"]]
    if len(nodes) != parts.shape[0]:
        where.fail("node_nums", f"{len(nodes)} nodes for {parts.shape[0]} shape rows")
    where.unique("node_nums", nodes)
    if not np.all(np.isfinite(parts)):
        where.fail("r1 r2 r3", f"mode {number} has a shape value that is not a finite number")
    if kind == COMPLEX:
        lam = complex(d.get("eig", math.nan))
        if not (math.isfinite(abs(lam)) and abs(lam) > 0.0) or lam.real > 0.0:
            where.fail("eig", f"{lam} is not a stable, nonzero eigenvalue (allowed: Re <= 0)")
        f, zeta = abs(lam) / (2 * math.pi), -lam.real / abs(lam)
        mpc = modal_phase_collinearity(parts.ravel())
        big = parts.flat[np.argmax(np.abs(parts))]
        parts = (parts * np.conj(big) / abs(big)).real if abs(big) > 0 else parts.real
    else:
        f = where.number("freq", float(d.get("freq", math.nan)), sign="positive", unit="[Hz]")
        zeta = where.within(
            "modal_damp_vis", where.number("modal_damp_vis", d.get("modal_damp_vis", 0.0)), 0, 1
        )
        mpc = math.nan
    return number, f, zeta, mpc, dict(zip(nodes, parts.astype(float), strict=True))


def modal_phase_collinearity(phi) -> float:
    """MPC [-] of a complex shape (module docstring; Pappa et al. 1993), NaN for a zero shape."""
    phi = np.asarray(phi, dtype=complex)
    re, im = phi.real, phi.imag
    sxx, syy, sxy = re @ re, im @ im, re @ im
    total = sxx + syy
    return float(((sxx - syy) ** 2 + 4 * sxy**2) / total**2) if total > 0 else math.nan
