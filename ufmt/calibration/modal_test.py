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
A sensor is the triple (body, point, direction); a mode need not be measured at every sensor
(missing components are NaN and left out of that mode's MAC).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ufmt.errors import StudyError
from ufmt.tables import Where

REQUIRED = ("mode", "frequency_hz")
SHAPE_COLUMNS = ("body", "x_m", "y_m", "z_m", "direction", "shape")
COLUMNS = (*REQUIRED, "damping_ratio", *SHAPE_COLUMNS)
AXES = ("x", "y", "z")


@dataclass(frozen=True)
class Sensor:
    """A measured translation: the ``body`` it sits on, its ``point`` (x, y, z) [m] in the
    global frame and its ``direction`` (``x``, ``y`` or ``z``)."""

    body: str
    point: tuple[float, float, float]
    direction: str

    @property
    def label(self) -> str:
        """Short name, e.g. ``head(0,0,0.965)z``."""
        return f"{self.body}({','.join(f'{c:g}' for c in self.point)}){self.direction}"


@dataclass(frozen=True, eq=False)
class ModalTest:
    """A modal test: ``modes`` (n,) test mode numbers, ascending; ``frequencies_hz`` (n,) [Hz];
    ``damping_ratio`` (n,) [-] (NaN: not measured); ``sensors`` (S,); ``shapes`` (n, S) real
    shape components (NaN: not measured at that sensor); ``source`` the file."""

    source: str
    modes: np.ndarray
    frequencies_hz: np.ndarray
    damping_ratio: np.ndarray
    sensors: tuple[Sensor, ...]
    shapes: np.ndarray

    def __repr__(self) -> str:
        f = self.frequencies_hz
        return (
            f"ModalTest({self.source!r}, modes={f.size} ({f.min():.4g}-{f.max():.4g} Hz), "
            f"sensors={len(self.sensors)}, shaped={int(self.has_shape().sum())})"
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
                x, y, z = s.point
                rows.append(
                    base
                    | {"body": s.body, "x_m": x, "y_m": y, "z_m": z, "direction": s.direction}
                    | {"shape": self.shapes[i, j]}
                )
        return pd.DataFrame(rows, columns=list(COLUMNS))

    def save(self, path) -> Path:
        """Write the test as CSV (the layout :func:`read_modal_test` reads)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        self.to_frame().to_csv(path, index=False, float_format="%.10g")
        return path


def modal_test(modes, frequencies_hz, damping_ratio=None, sensors=(), shapes=None, source=""):
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
    )


def read_modal_test(path) -> ModalTest:
    """Read a modal-test CSV (module docstring); a mistake is one line naming the file, the
    row (as a spreadsheet numbers it, header = row 1) and the column."""
    where = Where(str(path), error=StudyError)
    try:
        frame = pd.read_csv(path, dtype={"body": str, "direction": str}, comment="#")
    except FileNotFoundError:
        where.fail_table("no such file")
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        where.fail_table(f"not a readable CSV file ({exc})")
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
        _read_row(where.sub(f"row {i + 2}"), row, shaped, by_mode, sensors)
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


def _read_row(where: Where, row: dict, shaped, by_mode: dict, sensors: dict) -> None:
    """Check one CSV row and add it to ``by_mode`` (mode -> frequency, damping, shape)."""
    k = where.integer("mode", _cell(row["mode"]), low=1)
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
    point = tuple(where.number(c, _cell(row[c]), unit="[m]") for c in ("x_m", "y_m", "z_m"))
    direction = where.choice("direction", _cell(row["direction"]), AXES, "direction")
    sensor = Sensor(body, point, direction)
    j = sensors.setdefault(sensor, len(sensors))
    if j in entry["shape"]:
        where.fail("shape", f"mode {k} is measured twice at {sensor.label}")
    entry["shape"][j] = where.number("shape", _cell(row["shape"]))


def _cell(value):
    """None for an empty CSV cell, else the value (numpy integers as int)."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return None
    return value.item() if isinstance(value, np.generic) else value
