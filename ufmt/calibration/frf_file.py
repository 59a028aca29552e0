"""Measured frequency response functions of a machine: a universal file of FRFs (dataset 58,
read with pyuff) or a CSV FRF table, with the node map beside it (docs/modal-test.md).

Universal file (``.uff``/``.unv``). Every dataset 58 is one FRF (function type 4) between a
response node and direction and a reference node and direction (1, 2, 3 = +x, +y, +z; -1, -2,
-3 the opposite sense, whose values are negated so that every FRF is along +x, +y or +z), on
one evenly spaced frequency axis [Hz] shared by all, complex. Its ordinate is displacement (8:
receptance), velocity (11: mobility) or acceleration (12: accelerance) per force (13). Node
positions come from datasets 15 or 2411 in the file, in the file's units: dataset 164 (SI
value = file value / its length factor) or the unit the caller declares (``unit``: m, cm,
mm, in); with neither, the file is refused with one line asking for the unit. The ordinates
are converted to SI with the same factors (x force / length); a file with no units and no
node positions has SI ordinates.

CSV FRF table: a column ``frequency_hz`` [Hz] (evenly spaced) and one column per FRF named
``<response>/<reference>``, each a node number and a direction (``101z/201x``; ``-z`` for the
opposite sense), whose cells are complex numbers in Python notation (``1.2e-08-3.4e-09j``) in
SI. A comment line ``# kind = receptance`` (or ``mobility``, ``accelerance``; default
receptance) says what the values are.

The node map ``<name>.nodes.csv`` beside either file has the columns ``node``, ``body`` and,
when the file has no node positions (a CSV table always), ``x_m``, ``y_m``, ``z_m`` [m] in the
model's global frame (given, they take precedence over the file's). FRFs whose response or
reference node the map does not list are left out.
"""

from __future__ import annotations

import io
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ufmt.calibration.modal_test import AXES, UFF_SUFFIXES, Sensor
from ufmt.errors import StudyError
from ufmt.limits import MAX_INPUT_BYTES
from ufmt.tables import Where
from ufmt.tomlfile import read_text

KINDS = {8: "receptance", 11: "mobility", 12: "accelerance"}  # UFF ordinate data type
FORCE = 13  # UFF data type of the ordinate's denominator: force
FRF_FUNCTION = 4  # UFF function type of an FRF
#: [m] per unit of node positions a caller may declare
UNITS = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "in": 0.0254}
NODE_COLUMNS = ("node", "body")
POSITION_COLUMNS = ("x_m", "y_m", "z_m")
CHANNEL = re.compile(r"^\s*(\d+)\s*([+-]?)\s*([xyz])\s*$")
SPACING_RTOL = 1e-6  # relative spread of the frequency step still taken as even


@dataclass(frozen=True, eq=False, repr=False)
class MeasuredFrf:
    """Measured FRFs: ``values`` (P, F) complex [SI of ``kind``] at ``frequencies_hz`` (F,),
    evenly spaced; ``outputs`` and ``inputs`` (P,) the response and reference sensors of each
    FRF (body, point [m], direction); ``kind`` receptance, mobility or accelerance."""

    source: str
    frequencies_hz: np.ndarray
    values: np.ndarray
    outputs: tuple[Sensor, ...]
    inputs: tuple[Sensor, ...]
    kind: str
    nodes: tuple[tuple[int, int], ...] = ()  # (response node, reference node) per FRF

    def __repr__(self) -> str:
        f = self.frequencies_hz
        return (
            f"MeasuredFrf({self.source!r}: {len(self.outputs)} {self.kind} FRFs, {f.size} "
            f"lines {f[0]:.4g}-{f[-1]:.4g} Hz, {len(set(self.inputs))} references)"
        )

    @property
    def labels(self) -> list[str]:
        """``<response sensor>/<reference sensor>`` per FRF."""
        return [f"{o.label}/{i.label}" for o, i in zip(self.outputs, self.inputs, strict=True)]

    def to_frame(self) -> pd.DataFrame:
        """Long table: frequency_hz, frf (label), real, imag, magnitude."""
        p, f = self.values.shape
        return pd.DataFrame(
            {
                "frequency_hz": np.tile(self.frequencies_hz, p),
                "frf": np.repeat(self.labels, f),
                "real": self.values.real.ravel(),
                "imag": self.values.imag.ravel(),
                "magnitude": np.abs(self.values).ravel(),
            }
        )

    def plot(self, ax=None):
        """Every FRF's magnitude against frequency."""
        from ufmt.plots import new_axes

        _, ax = new_axes(ax, figsize=(7.0, 4.0))
        for label, h in zip(self.labels, self.values, strict=True):
            ax.semilogy(self.frequencies_hz, np.abs(h), lw=0.8, label=label)
        ax.set_xlabel("frequency [Hz]")
        ax.set_ylabel(f"|H| ({self.kind}, SI)")
        ax.set_title(Path(self.source).name)
        return ax.figure

    def save(self, path, nodes: dict[int, Sensor] | None = None) -> Path:
        """Write the FRFs as a CSV FRF table (module docstring) with node numbers ``nodes``
        (node -> a sensor at it; default: numbered in order of first appearance) and its
        ``.nodes.csv`` beside it."""
        from ufmt import files

        numbers = nodes_of(self) if nodes is None else nodes
        at = {(s.body, s.position): n for n, s in numbers.items()}
        cols = {"frequency_hz": self.frequencies_hz}
        for o, i, h in zip(self.outputs, self.inputs, self.values, strict=True):
            out_node, in_node = at[(o.body, o.position)], at[(i.body, i.position)]
            name = f"{out_node}{o.direction}/{in_node}{i.direction}"
            cols[name] = [repr(complex(v)) for v in h]
        text = f"# kind = {self.kind}\n" + pd.DataFrame(cols).to_csv(index=False)
        table = node_frame(numbers)
        files.write_with(
            Path(path).with_suffix(".nodes.csv"), lambda b: table.to_csv(b, index=False)
        )
        return files.write_with(path, lambda b: b.write(text.encode()))


def save_uff(measured: MeasuredFrf, path, nodes: dict[int, Sensor] | None = None) -> Path:
    """Write ``measured`` as a universal file (datasets 164 SI, 2411 the nodes [m], one 58 per
    FRF) with its ``.nodes.csv`` (node, body) beside it; ``nodes`` as in
    :meth:`MeasuredFrf.save`."""
    import pyuff

    from ufmt import files

    numbers = nodes_of(measured) if nodes is None else nodes
    at = {(s.body, s.position): n for n, s in numbers.items()}
    code = {v: k for k, v in KINDS.items()}[measured.kind]
    points = np.array([s.position for s in numbers.values()])
    sets = [
        pyuff.prepare_164(
            units_code=1,
            units_description="SI",
            temp_mode=1,
            length=1.0,
            force=1.0,
            temp=1.0,
            temp_offset=273.15,
        ),
        pyuff.prepare_2411(
            node_nums=list(numbers),
            def_cs=[0] * len(numbers),
            disp_cs=[0] * len(numbers),
            color=[0] * len(numbers),
            x=points[:, 0],
            y=points[:, 1],
            z=points[:, 2],
        ),
    ]
    for o, i, h in zip(measured.outputs, measured.inputs, measured.values, strict=True):
        sets.append(
            pyuff.prepare_58(
                func_type=FRF_FUNCTION,
                id1="FRF",
                rsp_node=at[(o.body, o.position)],
                rsp_dir=AXES.index(o.direction) + 1,
                ref_node=at[(i.body, i.position)],
                ref_dir=AXES.index(i.direction) + 1,
                data=np.asarray(h, complex),
                x=measured.frequencies_hz,
                abscissa_spacing=1,
                abscissa_spec_data_type=18,
                ordinate_spec_data_type=code,
                orddenom_spec_data_type=FORCE,
            )
        )
    table = node_frame(numbers)[list(NODE_COLUMNS)]
    files.write_with(Path(path).with_suffix(".nodes.csv"), lambda b: table.to_csv(b, index=False))
    pyuff.UFF(str(path), "w").write_sets(sets, mode="overwrite")
    return Path(path)


def nodes_of(measured: MeasuredFrf) -> dict[int, Sensor]:
    """Node numbers 1, 2, ... for the points of ``measured`` in order of first appearance."""
    points = dict.fromkeys((s.body, s.position) for s in measured.outputs + measured.inputs)
    return {k + 1: Sensor(b, p, "x") for k, (b, p) in enumerate(points)}


def node_frame(nodes: dict[int, Sensor]) -> pd.DataFrame:
    """The node map table: node, body, x_m, y_m, z_m."""
    rows = [
        {"node": n, "body": s.body} | dict(zip(POSITION_COLUMNS, s.position, strict=True))
        for n, s in nodes.items()
    ]
    return pd.DataFrame(rows, columns=[*NODE_COLUMNS, *POSITION_COLUMNS])


def is_frf_file(path) -> bool:
    """True for a universal file holding a dataset 58 or a CSV FRF table (a ``frequency_hz``
    column and a ``<response>/<reference>`` column in its header)."""
    path = Path(path)
    if not path.is_file() or path.stat().st_size > MAX_INPUT_BYTES:
        return False
    if path.suffix.lower() in UFF_SUFFIXES:
        text = path.read_bytes().decode("latin-1")
        return re.search(r"^\s*-1[ \t]*\r?\n[ \t]*58b?\b", text, re.MULTILINE) is not None
    for line in path.read_text(errors="replace").splitlines():
        if line.strip() and not line.lstrip().startswith("#"):
            header = [c.strip() for c in line.split(",")]
            return "frequency_hz" in header and any("/" in c for c in header)
    return False


def read_measured_frf(path, unit: str | None = None) -> MeasuredFrf:
    """Read measured FRFs (module docstring): a universal file or a CSV FRF table. ``unit``:
    the unit of the universal file's node positions when it has no dataset 164."""
    where = Where(str(path), error=StudyError)
    if not Path(path).is_file():
        where.fail_table("file not found" if not Path(path).exists() else "not a file")
    size = Path(path).stat().st_size
    if size > MAX_INPUT_BYTES:
        where.fail_table(f"{size:,} bytes; an input file holds at most {MAX_INPUT_BYTES:,}")
    if unit is not None and unit not in UNITS:
        where.fail("unit", f"unknown unit {unit!r} (valid units: {', '.join(UNITS)})")
    if Path(path).suffix.lower() in UFF_SUFFIXES:
        return _read_uff(where, Path(path), unit)
    return _read_table(where, Path(path))


def _read_uff(where: Where, path: Path, unit: str | None) -> MeasuredFrf:
    """The FRFs of a universal file (module docstring)."""
    import pyuff

    try:
        sets = pyuff.UFF(str(path)).read_sets()
    except Exception as exc:  # pyuff raises bare exceptions on malformed files
        where.fail_table(f"not a readable universal file ({type(exc).__name__}: {exc})")
    sets = sets if isinstance(sets, list) else [sets]
    length, force = _units(where, sets, unit)
    geometry = _geometry(where, sets, length)
    scale = 1.0 if math.isnan(length) else force / length  # no units at all: SI ordinates
    frfs = [d for d in sets if d.get("type") == 58]
    if not frfs:
        where.fail_table("no measured FRFs (dataset 58)")
    freq, kinds, channels, rows = None, set(), [], []
    for i, d in enumerate(frfs):
        here = where.sub(f"dataset 58 [{i}]")
        if d.get("func_type") != FRF_FUNCTION:
            here.fail("func_type", f"{d.get('func_type')} is not an FRF (allowed: 4)")
        kind = d.get("ordinate_spec_data_type")
        if kind not in KINDS or d.get("orddenom_spec_data_type") != FORCE:
            here.fail(
                "ordinate_spec_data_type",
                f"{kind} / {d.get('orddenom_spec_data_type')} is not displacement, velocity "
                "or acceleration per force (allowed: 8, 11 or 12 over 13)",
            )
        kinds.add(KINDS[kind])
        x = np.asarray(d["x"], dtype=float)
        if freq is None:
            first, freq = x, _axis(here, x)
        elif x.shape != first.shape or not np.allclose(x, first, rtol=SPACING_RTOL):
            here.fail("x", "its frequency lines differ from the first FRF's")
        data = np.asarray(d["data"])
        if not np.iscomplexobj(data) or data.shape != x.shape or not np.all(np.isfinite(data)):
            here.fail("data", "expected finite complex FRF values, one per frequency line")
        data = data[x.size - freq.size :]  # without a 0 Hz line
        out = _direction(here, "rsp_dir", d.get("rsp_dir"))
        inp = _direction(here, "ref_dir", d.get("ref_dir"))
        channels.append(((int(d["rsp_node"]), out[0]), (int(d["ref_node"]), inp[0])))
        rows.append(data * out[1] * inp[1] * scale)
    if len(kinds) > 1:
        where.fail_table(f"FRFs of different kinds ({', '.join(sorted(kinds))})")
    return _assemble(where, path, freq, np.array(rows), channels, kinds.pop(), geometry)


def _units(where: Where, sets, unit: str | None) -> tuple[float, float]:
    """(length, force) factors: file value / factor = SI value."""
    units = [d for d in sets if d.get("type") == 164]
    if units:
        d = units[0]
        length = where.sub("dataset 164").number("length", d.get("length"), sign="positive")
        force = where.sub("dataset 164").number("force", d.get("force"), sign="positive")
        return length, force
    return (1.0 / UNITS[unit], 1.0) if unit is not None else (math.nan, 1.0)


def _geometry(where: Where, sets, length: float) -> dict[int, tuple[float, float, float]]:
    """node -> position [m] from datasets 15 and 2411 (none: empty)."""
    nodes: dict[int, tuple[float, float, float]] = {}
    for kind in (15, 2411):
        for d in (d for d in sets if d.get("type") == kind):
            for n, x, y, z in zip(d["node_nums"], d["x"], d["y"], d["z"], strict=True):
                if int(n) in nodes:
                    where.sub(f"dataset {kind}").fail("node_nums", f"node {int(n)} appears twice")
                nodes[int(n)] = (float(x), float(y), float(z))
    if nodes and math.isnan(length):
        where.fail_table(
            "node positions without units (no dataset 164): declare their unit "
            f"(unit= in the API; one of {', '.join(UNITS)})"
        )
    return {n: tuple(v / length for v in p) for n, p in nodes.items()}


def _axis(where: Where, x: np.ndarray) -> np.ndarray:
    """An evenly spaced, ascending, positive frequency axis [Hz]."""
    step = np.diff(x)
    if x.size < 3 or not np.all(np.isfinite(x)) or x[0] < 0 or not np.all(step > 0):
        where.fail("x", "expected at least 3 ascending frequency lines >= 0 [Hz]")
    if np.ptp(step) > SPACING_RTOL * step.mean():
        where.fail("x", "frequency lines not evenly spaced (the LSCF estimator needs them so)")
    return x[x > 0] if x[0] == 0 else x


def _direction(where: Where, field: str, value) -> tuple[str, float]:
    """(axis, sign) of a UFF direction code."""
    if value not in (1, 2, 3, -1, -2, -3):
        where.fail(field, f"{value} is not a translation (allowed: 1, 2, 3 or -1, -2, -3)")
    return AXES[abs(value) - 1], math.copysign(1.0, value)


def _read_table(where: Where, path: Path) -> MeasuredFrf:
    """The FRFs of a CSV FRF table (module docstring)."""
    text = read_text(path)
    kind = "receptance"
    for line in text.splitlines():
        found = re.match(r"^\s*#\s*kind\s*=\s*(\S+)", line)
        if found:
            kind = where.choice("kind", found.group(1), tuple(KINDS.values()), "kind")
    try:
        frame = pd.read_csv(io.StringIO(text), dtype=str, comment="#")
    except (pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        where.fail_table(f"not a readable CSV file ({' '.join(str(exc).split())})")
    if "frequency_hz" not in frame.columns:
        where.missing("frequency_hz")
    where.unique("column", list(frame.columns))
    freq = _axis(where.sub("column frequency_hz"), _numbers(where, frame, "frequency_hz", float))
    keep = slice(frame.shape[0] - freq.size, None)
    channels, rows = [], []
    for name in (c for c in frame.columns if c != "frequency_hz"):
        ends = name.split("/")
        found = [CHANNEL.match(e) for e in ends]
        if len(ends) != 2 or not all(found):
            where.fail(name, "expected a column name <node><x|y|z>/<node><x|y|z>, e.g. 101z/201x")
        (o, i) = ((int(m.group(1)), m.group(3), -1.0 if m.group(2) == "-" else 1.0) for m in found)
        channels.append(((o[0], o[1]), (i[0], i[1])))
        rows.append(_numbers(where, frame, name, complex)[keep] * o[2] * i[2])
    if not rows:
        where.fail_table("no FRF columns (<response>/<reference>, e.g. 101z/201x)")
    return _assemble(where, path, freq, np.array(rows), channels, kind, {})


def _numbers(where: Where, frame: pd.DataFrame, column: str, kind) -> np.ndarray:
    """A column's cells as ``kind`` (float or complex), finite; one line at the first bad row."""
    out = []
    for row, cell in enumerate(frame[column]):
        try:
            value = kind(str(cell).strip().replace(" ", ""))
        except ValueError:
            value = math.nan
        if not np.isfinite(value):
            where.sub(f"row {row + 2}").fail(column, f"{cell!r} is not a finite {kind.__name__}")
        out.append(value)
    return np.array(out)


def _assemble(where, path: Path, freq, values, channels, kind, geometry) -> MeasuredFrf:
    """Place the FRFs' nodes with the node map; drop FRFs at unmapped nodes."""
    nodes = _node_map(path.with_suffix(".nodes.csv"), geometry)
    seen = set()
    keep, outputs, inputs, pairs = [], [], [], []
    for p, ((on, od), (rn, rd)) in enumerate(channels):
        if (on, od, rn, rd) in seen:
            where.fail_table(f"FRF {on}{od}/{rn}{rd} appears twice")
        seen.add((on, od, rn, rd))
        if on in nodes and rn in nodes:
            keep.append(p)
            outputs.append(Sensor(*nodes[on], od))
            inputs.append(Sensor(*nodes[rn], rd))
            pairs.append((on, rn))
    if not keep:
        where.fail_table("no FRF between nodes listed in its node map (.nodes.csv)")
    return MeasuredFrf(
        str(path), freq, values[keep], tuple(outputs), tuple(inputs), kind, tuple(pairs)
    )


def _node_map(path: Path, geometry: dict) -> dict[int, tuple[str, tuple]]:
    """node -> (body, position [m]) from the node map and the file's geometry."""
    where = Where(str(path), error=StudyError)
    if not path.exists():
        where.fail_table("file not found (measured FRFs need their node map: node, body)")
    try:
        frame = pd.read_csv(io.StringIO(read_text(path)), dtype=str, comment="#")
    except (pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        where.fail_table(f"not a readable CSV file ({' '.join(str(exc).split())})")
    placed = all(c in frame.columns for c in POSITION_COLUMNS)
    required = NODE_COLUMNS if geometry else (*NODE_COLUMNS, *POSITION_COLUMNS)
    where.keys(
        dict.fromkeys(frame.columns), valid=(*NODE_COLUMNS, *POSITION_COLUMNS), required=required
    )
    out = {}
    for i, row in enumerate(frame.to_dict("records")):
        here = where.sub(f"row {i + 2}")
        node = here.integer("node", _integer(row["node"]), low=0)
        if node in out:
            here.fail("node", f"node {node} appears twice")
        body = here.string("body", row["body"]).strip()
        if placed:
            point = tuple(here.number(c, _float(row[c]), unit="[m]") for c in POSITION_COLUMNS)
        elif node in geometry:
            point = geometry[node]
        else:
            here.fail("node", f"node {node} has no position in the FRF file (add x_m, y_m, z_m)")
        out[node] = (body, point)
    return out


def _integer(cell):
    try:
        return int(str(cell).strip())
    except ValueError:
        return cell


def _float(cell):
    try:
        return float(str(cell).strip())
    except ValueError:
        return cell
