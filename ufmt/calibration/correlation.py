"""Test-analysis correlation: a model's modes against a modal test (:mod:`.modal_test`).

The model's mode shapes are read at the test's sensors (the translation of the sensor point
along the sensor's axis: a rigid body's point moves by ``r_C + θ × (P - C)``, paper eq. 2.5; a
beam's point is its axis point nearest P, carried rigidly by the cross-section's rotation).
The modal assurance criterion of test mode i and model mode j over the sensors where test
mode i is measured is

    MAC_ij = |φ_i · ψ_j|² / ((φ_i · φ_i)(ψ_j · ψ_j))        (Allemang and Brown, 1982)

1 for proportional shapes, 0 for orthogonal ones; it is blind to the scale and sign of either
shape, so a test's arbitrary normalisation does not matter.

Pairing. The candidates are the model modes below FREQUENCY_WINDOW (2) times the highest
test frequency: a test covers a band, and a model mode far above it is no partner whatever
its shape at a few sensors. Test modes measured at two sensors or more are paired by MAC:
the one-to-one assignment of candidates that maximises the sum of their MACs (the Hungarian
method, :func:`scipy.optimize.linear_sum_assignment`); a model mode the sensors cannot see (a
NaN MAC: zero motion at every sensor) counts as MAC 0 there. Test modes without a shape are
paired by order: test mode k with candidate k, unless MAC pairing took it (then unpaired).
Each pair says how it was paired (``paired_by``: ``mac`` or ``order``). The frequency error
of a pair is ``100 (f_model / f_test - 1)`` [%].
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment

from ufmt.assembled import assembled_modes
from ufmt.calibration.modal_test import AXES, ModalTest, modal_test
from ufmt.calibration.sensors import BEAM_END, check_sensors
from ufmt.calibration.test_file import read_test
from ufmt.errors import StudyError
from ufmt.kinds import kind_of
from ufmt.kinematics import carried_motion
from ufmt.model.load import as_model
from ufmt.model.schema import Beam, Model
from ufmt.mstmm.modes import ModeShapes, beam_shape
from ufmt.mstmm.overall import TransferSystem
from ufmt.mstmm.solve import solve_modes

FREQUENCY_WINDOW = 2.0  # [-] model modes up to this times the highest test frequency pair


def sensor_shapes(model: Model, shapes: ModeShapes, sensors, source: str = "") -> np.ndarray:
    """(n_modes, S) model shapes at the sensors (the translation along each sensor's axis,
    in the normalisation of ``shapes``); sensors off their bodies or outside the machine are
    one line naming the test file ``source`` (:func:`ufmt.calibration.sensors.check_sensors`)."""
    check_sensors(model, sensors, source)
    out = np.zeros((shapes.frequencies_hz.size, len(sensors)))
    system = None
    for j, sensor in enumerate(sensors):
        body = model.body(sensor.body)
        point = np.asarray(sensor.position, dtype=float)

        def along(p, body=body):  # a point carried by a field body's section
            nonlocal system
            system = system or TransferSystem(model)
            return _beam_point(system, shapes, body, p)

        motion = kind_of(body).sensor_motion(body, shapes, point, along)
        if motion is None:  # check_sensors refuses these first
            raise StudyError(f"sensor {sensor.label}: body {body.name!r} has no material point")
        out[:, j] = motion[:, AXES.index(sensor.direction)]
    return out


def _beam_point(system, shapes, beam: Beam, point) -> np.ndarray:
    """Motion (n, 6) of ``point`` carried by the beam section nearest to it."""
    start, end = np.asarray(beam.start, float), np.asarray(beam.end, float)
    axis = end - start
    fraction = min(max(float((point - start) @ axis) / float(axis @ axis), 0.0), 1.0)
    positions, motion = beam_shape(system, shapes, beam.name, [fraction])
    return carried_motion(motion[:, 0], positions[0], point)


def mac_matrix(test_shapes: np.ndarray, model_shapes: np.ndarray) -> np.ndarray:
    """(n_test, n_model) MAC (module docstring); NaN test components are left out of that
    test mode's MAC, and a test mode measured nowhere has NaN MACs."""
    measured = np.isfinite(test_shapes)
    phi = np.where(measured, test_shapes, 0.0)
    cross = phi @ model_shapes.T
    test_norm = np.sum(phi**2, axis=1)[:, None]
    model_norm = measured.astype(float) @ (model_shapes.T**2)
    with np.errstate(invalid="ignore", divide="ignore"):
        mac = cross**2 / (test_norm * model_norm)
    mac[~measured.any(axis=1)] = np.nan
    return mac


def pair_modes(test: ModalTest, mac: np.ndarray, n_model: int) -> tuple[np.ndarray, list[str]]:
    """Model mode index (0-based, -1: unpaired) per test mode and how each was paired
    (``"mac"``, ``"order"`` or ``""``), as in the module docstring; ``mac`` (n_test, n_model)
    over the candidate model modes, NaN entries (a model mode the sensors cannot see) as 0."""
    shaped = test.has_shape() & np.isfinite(mac).any(axis=1)
    index = np.full(test.modes.size, -1)
    how = [""] * test.modes.size
    rows = np.flatnonzero(shaped)
    if rows.size and n_model:
        r, c = linear_sum_assignment(np.nan_to_num(mac[rows], nan=0.0), maximize=True)
        index[rows[r]] = c
        for i in rows[r]:
            how[i] = "mac"
    taken = set(index[index >= 0].tolist())
    for i in np.flatnonzero(~shaped):
        j = int(test.modes[i]) - 1
        if j < n_model and j not in taken:
            index[i], how[i] = j, "order"
            taken.add(j)
    return index, how


@dataclass(frozen=True, eq=False, repr=False)
class Correlation:
    """A model's modes against a modal test.

    ``table``: one row per test mode (test_mode, model_mode (1-based), paired_by, test_hz,
    model_hz, error_percent, mac, test_damping_ratio); ``mac`` (n_test, n_model) the MAC
    matrix (NaN rows: test modes without a shape); ``model_hz`` (n_model,) [Hz].
    """

    model_name: str
    test: ModalTest
    model_hz: np.ndarray
    mac: np.ndarray
    table: pd.DataFrame

    def __repr__(self) -> str:
        s = self.summary()
        return (
            f"Correlation({self.model_name!r} vs {self.test.source!r}: {s['paired']} of "
            f"{len(self.table)} test modes paired, max |error| "
            f"{s['max_abs_error_percent']:.3g} %, mean {s['mean_abs_error_percent']:.3g} %)"
        )

    def summary(self) -> dict:
        """Max and mean |frequency error| [%] and the lowest MAC over the paired modes."""
        paired = self.table.dropna(subset=["model_hz"])
        err = paired["error_percent"].abs()
        mac = paired["mac"].dropna()
        return {
            "paired": len(paired),
            "max_abs_error_percent": float(err.max()) if len(err) else float("nan"),
            "mean_abs_error_percent": float(err.mean()) if len(err) else float("nan"),
            "min_mac": float(mac.min()) if len(mac) else float("nan"),
        }

    def to_dict(self) -> dict:
        """The JSON of ``ufmt validate --test --json``: model, test file, summary, pairs."""
        pairs = [
            {k: (None if isinstance(v, float) and np.isnan(v) else v) for k, v in row.items()}
            for row in self.table.to_dict("records")
        ]
        return (
            {"model": self.model_name, "test": self.test.source} | self.summary() | {"pairs": pairs}
        )

    def to_frame(self) -> pd.DataFrame:
        """The pairing table (one row per test mode)."""
        return self.table.copy()

    def mac_frame(self) -> pd.DataFrame:
        """The MAC matrix, one row per test mode, one column ``model_N`` per model mode."""
        cols = [f"model_{j + 1}" for j in range(self.model_hz.size)]
        frame = pd.DataFrame(self.mac, columns=cols)
        frame.insert(0, "test_mode", self.test.modes)
        return frame

    def plot(self, ax=None):
        """The MAC matrix with the pairs marked (:func:`ufmt.plots.correlation.plot_mac`)."""
        from ufmt.plots.correlation import plot_mac

        return plot_mac(self, ax=ax)

    def save(self, directory) -> list[Path]:
        """Write ``correlation.csv`` (the table), ``mac.csv`` and ``mac.png``."""
        from ufmt import files
        from ufmt.plots import DPI

        table, mac = self.table, self.mac_frame()
        with files.FileSet(directory) as written:  # the three files or none
            table.to_csv(written.staged("correlation.csv"), index=False, float_format="%.10g")
            mac.to_csv(written.staged("mac.csv"), index=False, float_format="%.6g")
            written.add("mac.png", files.figure_png(self.plot(), DPI))
        return [written.directory / n for n in ("correlation.csv", "mac.csv", "mac.png")]


def correlate(model, test, count: int | None = None, unit: str | None = None) -> Correlation:
    """Pair the MSTMM modes of ``model`` (a path or a :class:`~ufmt.model.schema.Model`) with
    the modes of ``test`` (a path, read in length ``unit``, or a :class:`ModalTest`).

    The candidates are the model modes below FREQUENCY_WINDOW times the highest test
    frequency (``count``: at most that many of them); a measured-FRF file is reduced to its
    modes first (:func:`ufmt.calibration.test_file.read_test`).
    """
    model = as_model(model)
    test = test if isinstance(test, ModalTest) else read_test(test, unit)
    fmax = FREQUENCY_WINDOW * float(test.frequencies_hz.max())
    solution = solve_modes(model, fmax_hz=fmax, count=count, shapes=bool(test.sensors))
    model_hz = solution.frequencies_hz
    if test.sensors:
        model_shapes = sensor_shapes(model, solution.shapes, test.sensors, test.source)
        mac = mac_matrix(test.shapes, model_shapes)
    else:
        mac = np.full((test.modes.size, model_hz.size), np.nan)
    index, how = pair_modes(test, mac, model_hz.size)
    return Correlation(model.name, test, model_hz, mac, _table(test, model_hz, mac, index, how))


def _table(test: ModalTest, model_hz, mac, index, how) -> pd.DataFrame:
    paired = index >= 0
    f_model = np.where(paired, model_hz[np.maximum(index, 0)], np.nan)
    rows = np.arange(test.modes.size)
    return pd.DataFrame(
        {
            "test_mode": test.modes,
            "model_mode": pd.Series(index + 1).where(paired).astype("Int64"),
            "paired_by": how,
            "test_hz": test.frequencies_hz,
            "model_hz": f_model,
            "error_percent": 100.0 * (f_model / test.frequencies_hz - 1.0),
            "mac": np.where(paired, mac[rows, np.maximum(index, 0)], np.nan),
            "test_damping_ratio": test.damping_ratio,
        }
    )


def assembled_test(model, sensors, count: int, source: str = "assembled model") -> ModalTest:
    """The modal test the independent assembled model predicts (:mod:`ufmt.assembled`): its
    first ``count`` frequencies and its mass-normalised shapes at ``sensors`` (rigid bodies and
    beam mesh nodes; a beam sensor must sit on a node, e.g. a beam end). A synthetic test for
    recovery checks and test planning, independent of the MSTMM that :func:`correlate` uses."""
    model = as_model(model)
    modes = assembled_modes(model, count=count)
    am, shapes = modes.assembled, modes.shapes
    out = np.zeros((modes.frequencies_hz.size, len(sensors)))
    for j, sensor in enumerate(sensors):
        body = model.body(sensor.body)
        point = np.asarray(sensor.position, dtype=float)
        nodes = am.node_positions[body.name]
        node = int(np.argmin(np.linalg.norm(nodes - point, axis=1)))
        if kind_of(body).MESHED and np.linalg.norm(nodes[node] - point) > BEAM_END:
            raise StudyError(f"sensor {sensor.label}: not on a mesh node of beam {body.name!r}")
        motion = carried_motion(shapes[:, am.body_dofs[body.name][node]], nodes[node], point)
        out[:, j] = motion[:, AXES.index(sensor.direction)]
    n = modes.frequencies_hz.size
    return modal_test(np.arange(1, n + 1), modes.frequencies_hz, None, sensors, out, source)
