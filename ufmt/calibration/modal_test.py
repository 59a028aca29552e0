"""A modal test of any machine: measured natural frequencies, damping and mode shapes at named
sensor points, read from one tidy CSV file (the format is documented in ``docs/modal-test.md``).

Layout: one row per mode and sensor (long format), columns

=================  ========  =============================================================
column             required  meaning
=================  ========  =============================================================
``mode``           yes       test mode number (1, 2, ...), as the test numbers it
``frequency_hz``   yes       measured natural frequency [Hz] (equal on every row of a mode)
``damping_ratio``  no        measured modal damping ratio [-] (equal on a mode's rows)
``body``           no        body of the model the sensor sits on (empty: no shape on row)
``x_m y_m z_m``    with body sensor position in the global frame [m]
``direction``      with body measured translation: ``x``, ``y`` or ``z`` (global axes)
``shape``          with body real mode-shape component (any scale, any sign)
=================  ========  =============================================================

A file with only ``mode`` and ``frequency_hz`` (one row per mode) is a frequency-only test.
Lines starting with ``#`` are comments (the test's source, its conditions).

Positions are in metres unless a length unit is declared (``unit``: then in that unit).
A universal file (UFF, ``.uff``/``.unv``) is read by :mod:`ufmt.calibration.uff`.
A sensor is the triple (body, point, direction); a mode need not be measured at every sensor
(missing components are NaN and left out of that mode's MAC).
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ufmt.calibration.uff import AXES, length_scale, read_uff
from ufmt.errors import StudyError
from ufmt.tables import Where
from ufmt.tomlfile import read_text

REQUIRED = ("mode", "frequency_hz")
SHAPE_COLUMNS = ("body", "x_m", "y_m", "z_m", "direction", "shape")
COLUMNS = (*REQUIRED, "damping_ratio", *SHAPE_COLUMNS)
UFF_SUFFIXES = (".uff", ".unv")
NODE_COLUMNS = ("node", "body")


@dataclass(frozen=True)
class Sensor:
    """A measured translation: the ``body`` it sits on, its ``position`` (x, y, z) [m] in the
    global frame and its ``direction`` (``x``, ``y`` or ``z``)."""

    body: str
    position: tuple[float, float, float]
    direction: str

    @property
    def label(self) -> str:
        """Short name, e.g. ``head(0,0,0.965)z``."""
        return f"{self.body}({','.join(f'{c:g}' for c in self.position)}){self.direction}"


@dataclass(frozen=True, eq=False)
class ModalTest:
    """A modal test: ``modes`` (n,) test mode numbers, ascending; ``frequencies_hz`` (n,) [Hz];
    ``damping_ratio`` (n,) [-] (NaN: not measured); ``sensors`` (S,); ``shapes`` (n, S) real
    shape components (NaN: not measured at that sensor); ``source`` the file; ``mpc`` (n,)
    modal phase collinearity of complex test modes [-] (NaN: a real mode; None: all NaN)."""

    source: str
    modes: np.ndarray
    frequencies_hz: np.ndarray
    damping_ratio: np.ndarray
    sensors: tuple[Sensor, ...]
    shapes: np.ndarray
    mpc: np.ndarray | None = None

    def __post_init__(self):
        if self.mpc is None:
            object.__setattr__(self, "mpc", np.full(self.modes.size, np.nan))

    def __repr__(self) -> str:
        f, mpc = self.frequencies_hz, self.mpc[np.isfinite(self.mpc)]
        complex_ = f", lowest MPC {mpc.min():.3f}" if mpc.size else ""
        return (
            f"ModalTest({self.source!r}, modes={f.size} ({f.min():.4g}-{f.max():.4g} Hz), "
            f"sensors={len(self.sensors)}, shaped={int(self.has_shape().sum())}{complex_})"
        )

    def has_shape(self, minimum: int = 2) -> np.ndarray:
        """(n,) bool: the mode is measured at ``minimum`` sensors or more (a MAC needs two)."""
        return np.sum(np.isfinite(self.shapes), axis=1) >= minimum

    def to_frame(self) -> pd.DataFrame:
        """The test in its file layout (one row per mode and measured sensor)."""
        rows = []
        for i, k in enumerate(self.modes):
            base = {
                "mode": int(k),
                "frequency_hz": self.frequencies_hz[i],
                "damping_ratio": self.damping_ratio[i],
            }
            measured = np.flatnonzero(np.isfinite(self.shapes[i]))
            if not measured.size:
                rows.append(base)
            for j in measured:
                s = self.sensors[j]
                x, y, z = s.position
                rows.append(
                    base
                    | {"body": s.body, "x_m": x, "y_m": y, "z_m": z, "direction": s.direction}
                    | {"shape": self.shapes[i, j]}
                )
        return pd.DataFrame(rows, columns=list(COLUMNS))

    def save(self, path) -> Path:
        """Write the test as CSV (the layout :func:`read_modal_test` reads)."""
        from ufmt import files

        table = self.to_frame()
        return files.write_with(path, lambda b: table.to_csv(b, index=False, float_format="%.10g"))


def modal_test(
    modes, frequencies_hz, damping_ratio=None, sensors=(), shapes=None, source="", mpc=None
):
    """A :class:`ModalTest` from arrays (a synthetic or converted test); shapes (n, S)."""
    modes = np.asarray(modes, dtype=int)
    n = modes.size
    damping = np.full(n, np.nan) if damping_ratio is None else np.asarray(damping_ratio, float)
    shapes = np.full((n, len(sensors)), np.nan) if shapes is None else np.asarray(shapes, float)
    order = np.argsort(modes)
    return ModalTest(
        source,
        modes[order],
        np.asarray(frequencies_hz, dtype=float)[order],
        damping[order],
        tuple(sensors),
        shapes[order].reshape(n, len(sensors)),
        None if mpc is None else np.asarray(mpc, dtype=float)[order],
    )


def read_modal_test(path, unit: str | None = None) -> ModalTest:
    """Read a modal-test file: a CSV (module docstring; a mistake is one line naming the file,
    the row as a spreadsheet numbers it, header = row 1, and the column) or a universal file
    (``.uff``/``.unv``, :func:`ufmt.calibration.uff.read_uff`). ``unit``: the length unit of
    the positions (``m``, ``cm``, ``mm``, ``in``, ``ft``; a UFF without dataset 164 needs it)."""
    if Path(path).suffix.lower() in UFF_SUFFIXES:
        read = read_uff(path, unit, node_map)
        return modal_test(**read | {"sensors": [Sensor(*s) for s in read["sensors"]]})
    where = Where(str(path), error=StudyError)
    scale = length_scale(where, unit) or 1.0
    frame = _read_csv(where, path, str)  # cell by cell: one text cell blames its own row
    where.keys(dict.fromkeys(frame.columns), valid=COLUMNS, required=REQUIRED)
    shaped = [c for c in SHAPE_COLUMNS if c in frame.columns]
    if shaped and len(shaped) != len(SHAPE_COLUMNS):
        missing = [c for c in SHAPE_COLUMNS if c not in frame.columns]
        where.missing(missing[0], "required with the shape columns " + ", ".join(shaped))
    if frame.empty:
        where.fail_table("no modes (at least one row is required)")
    by_mode: dict[int, dict] = {}
    sensors: dict[Sensor, int] = {}
    for i, row in enumerate(frame.to_dict("records")):
        _read_row(where.sub(f"row {i + 2}"), row, shaped, by_mode, sensors, scale)
    modes = sorted(by_mode)
    shapes = np.full((len(modes), len(sensors)), np.nan)
    for i, k in enumerate(modes):
        for j, value in by_mode[k]["shape"].items():
            shapes[i, j] = value
    return ModalTest(
        str(path),
        np.array(modes, dtype=int),
        np.array([by_mode[k]["frequency_hz"] for k in modes]),
        np.array([by_mode[k]["damping_ratio"] for k in modes]),
        tuple(sensors),
        shapes,
    )


MAX_TEST_MODE = 10**6  # [-] highest test mode number (an int64 array holds the numbers)


def _read_row(where: Where, row: dict, shaped, by_mode: dict, sensors: dict, scale) -> None:
    """Check one CSV row and add it to ``by_mode`` (mode -> frequency, damping, shape);
    positions times ``scale`` [m per file unit]."""
    k = where.integer("mode", _cell(row["mode"]), low=1, high=MAX_TEST_MODE)
    f = where.number("frequency_hz", _cell(row["frequency_hz"]), sign="positive", unit="[Hz]")
    zeta = _cell(row.get("damping_ratio"))
    zeta = math.nan if zeta is None else where.number("damping_ratio", zeta)
    if not math.isnan(zeta):
        where.within("damping_ratio", zeta, 0.0, 1.0)
    entry = by_mode.setdefault(k, {"frequency_hz": f, "damping_ratio": zeta, "shape": {}})
    for key, value in (("frequency_hz", f), ("damping_ratio", zeta)):
        first = entry[key]
        if value != first and not (math.isnan(value) and math.isnan(first)):
            where.fail(key, f"{value:g} differs from {first:g} on another row of mode {k}")
    if not shaped or _cell(row["body"]) is None:
        return
    body = where.string("body", row["body"]).strip()
    point = tuple(scale * where.number(c, _cell(row[c])) for c in ("x_m", "y_m", "z_m"))
    direction = where.choice("direction", _cell(row["direction"]), AXES, "direction")
    sensor = Sensor(body, point, direction)
    j = sensors.setdefault(sensor, len(sensors))
    if j in entry["shape"]:
        where.fail("shape", f"mode {k} is measured twice at {sensor.label}")
    entry["shape"][j] = where.number("shape", _cell(row["shape"]))


def _read_csv(where: Where, path, dtype) -> pd.DataFrame:
    """The CSV at ``path`` (``#`` comment lines), unreadable files in the one wording of
    :mod:`ufmt.tomlfile`."""
    text = read_text(path)
    try:
        return pd.read_csv(io.StringIO(text), dtype=dtype, comment="#")
    except (pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        where.fail_table(f"not a readable CSV file ({' '.join(str(exc).split())})")


def _cell(value):
    """None for an empty CSV cell, a number for a cell that holds one (int where it is an
    integer), else the value (numpy integers as int)."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return None
    if isinstance(value, str):  # a CSV read as text: its number, else the text itself
        for kind in (int, float):
            try:
                return kind(value.strip())
            except ValueError:
                pass
        return value
    return value.item() if isinstance(value, np.generic) else value


def node_map(path: Path) -> dict[int, str]:
    """node -> body from the node-map CSV beside a universal file (columns node, body)."""
    where = Where(str(path), error=StudyError)
    if not path.exists():
        where.fail_table("file not found (a universal file needs its node map: node, body)")
    frame = _read_csv(where, path, {"body": str})
    where.keys(dict.fromkeys(frame.columns), valid=NODE_COLUMNS, required=NODE_COLUMNS)
    out = {}
    for i, row in enumerate(frame.to_dict("records")):
        here = where.sub(f"row {i + 2}")
        node = here.integer("node", _cell(row["node"]), low=0)
        if node in out:
            here.fail("node", f"node {node} is listed more than once")
        out[node] = here.string("body", _cell(row["body"])).strip()
    return out
