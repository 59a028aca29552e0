"""Study outputs on disk: the resumable points table, meta.json and the results index.

Layout of ``results/<study>/``:

* ``points.csv``: one row per evaluated point (tidy; units in the column names: ``pv_nm``,
  ``feed_mm_min``, ``head_angular_stiffness_Nm_rad``, ...). ``group`` names the sweep axis,
  grid or optimiser stage a row belongs to and ``index`` its position in that group. Rows are
  appended and flushed as points finish, so a killed run loses nothing; at the end of a run the
  file is rewritten sorted by (group, index).
* the kind's own tables (``optima.csv``, ``pareto.csv``, ``indices.csv``, ...; named by the
  kind's module, :attr:`ufmt.studies.spec.StudyKind.tables`) and PNG plots.
* ``meta.json``: the study file's text, the model file and its SHA-256, the physics code's
  SHA-256, package versions, git revision, run timings and the headline finding.

``results/README.md`` is regenerated after every run from the ``meta.json`` files.

A rerun that computes no new point rewrites nothing: its ``meta.json`` keeps the circumstances
of the run that computed the points (:func:`settled_meta`), so every file it writes again
(points.csv, the tables, the plots, the index) has the same bytes and a clean clone stays
clean.
"""

from __future__ import annotations

import csv
import datetime
import io
import json
import math
import os
import platform
import re
import subprocess
from collections.abc import Iterable, Mapping
from importlib import metadata
from pathlib import Path

import pandas as pd

from ufmt import files
from ufmt.jsonout import dumps_strict

POINTS = "points.csv"
META = "meta.json"
INDEX = "README.md"
PACKAGES = (
    "ufmt",
    "numpy",
    "scipy",
    "pandas",
    "joblib",
    "cvxpy",
    "SALib",
    "dask",
    "distributed",
    "matplotlib",
    "threadpoolctl",
    "tqdm",
)


#: Columns of points.csv that hold text; every other column must parse as a float.
TEXT_COLUMNS = ("group", "status", "message")
STATUSES = ("ok", "error", "invalid")  # invalid: outside the surface model's domain
_INTEGER = re.compile(r"[+-]?[0-9]+")


class PointLog:
    """Append-only CSV of evaluated points that survives being killed mid-write.

    The file is created atomically (header written to a temporary file, then renamed) and
    appended to. On reading, every row is validated: a row with the wrong number of fields,
    bytes that are not UTF-8, a number that does not parse, or a status other than "ok",
    "error" or "invalid" (a partial or corrupt line) is dropped, so its point is computed
    again; the file is then rewritten with the valid rows. The header grows if a record
    brings new fields (the file is then rewritten once).
    """

    def __init__(self, path: Path, columns: Iterable[str]):
        self.path = Path(path)
        self.columns = list(columns)
        self._fd: int | None = None
        self.dropped = 0  # rows dropped as invalid by the last read

    def read(self) -> list[dict]:
        """The valid rows already on disk ([] if none); invalid ones are dropped (class doc)."""
        if not self.path.exists():
            return []
        lines = self.path.read_bytes().splitlines(keepends=True)
        header = _parse_line(lines[0]) if lines else None
        if not header or len(set(header)) != len(header) or not {"group", "status"} <= set(header):
            self.dropped = max(len(lines) - 1, 0)
            self.path.unlink()
            return []
        rows = []
        for line in lines[1:]:
            row = _valid_row(line, header)
            if row is not None:
                rows.append(row)
        self.dropped = len(lines) - 1 - len(rows)
        self.columns = list(dict.fromkeys([*self.columns, *header]))
        if self.dropped:
            write_table(pd.DataFrame(rows, columns=header), self.path)
        return rows

    def append(self, row: Mapping) -> None:
        """Write one row to the operating system in one ``write`` (:func:`ufmt.files.append`)."""
        new = [k for k in row if k not in self.columns]
        self.columns += new
        if self._fd is None or new:
            self._open()
        line = io.StringIO(newline="")
        csv.writer(line).writerow([_cell(row.get(c)) for c in self.columns])
        files.append(self._fd, line.getvalue().encode("utf-8"), self.path)

    def close(self) -> None:
        """Close the file (appending reopens it)."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None

    def _open(self) -> None:
        """Open for appending; rewrite the file first if its header differs from ``columns``."""
        self.close()
        if self.path.exists() and self.path.stat().st_size > 0:
            with self.path.open(newline="", encoding="utf-8") as f:
                header = next(csv.reader(f))
            if header != self.columns:
                write_table(read_table(self.path).reindex(columns=self.columns), self.path)
        else:
            write_table(pd.DataFrame(columns=self.columns), self.path)
        self._fd = files.open_append(self.path)


def _parse_line(line: bytes) -> list[str] | None:
    """The fields of one CSV line, or None if it is not UTF-8, not one complete record or
    not newline-terminated (a line cut off mid-write)."""
    if not line.endswith(b"\n"):
        return None
    try:
        text = line.decode("utf-8")
        records = list(csv.reader([text]))
    except (UnicodeDecodeError, csv.Error):
        return None
    return records[0] if len(records) == 1 else None


def _number(text: str) -> float | int:
    """A points.csv number as written: int for integer literals, float otherwise."""
    if not text:
        return math.nan
    return int(text) if _INTEGER.fullmatch(text) else float(text)


def _valid_row(line: bytes, header: list[str]) -> dict | None:
    """The row of a points.csv ``line`` as a dict (numbers as floats), or None if invalid."""
    fields = _parse_line(line)
    if fields is None or len(fields) != len(header):
        return None
    row = {}
    for name, text in zip(header, fields, strict=True):
        if name in TEXT_COLUMNS:
            row[name] = text
            continue
        try:
            row[name] = _number(text)
        except ValueError:
            return None
    if row.get("status") not in STATUSES or not row.get("group"):
        return None
    return row


def _cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value)
    return " ".join(str(value).split())


def read_table(path: Path) -> pd.DataFrame:
    """A results CSV with text columns as strings ("" for empty) and numbers as floats."""
    table = pd.read_csv(path, keep_default_na=False, na_values={"nan", "NaN", ""})
    for column in table.columns:
        if table[column].dtype == object or pd.api.types.is_string_dtype(table[column]):
            table[column] = table[column].fillna("").astype(str)
    return table


def write_table(table: pd.DataFrame, path: Path) -> None:
    """Write ``table`` atomically (:mod:`ufmt.files`), floats at full precision."""
    files.write_with(path, lambda buffer: table.to_csv(buffer, index=False))


def write_json(data: Mapping, path: Path) -> None:
    """Write ``data`` as indented strict JSON (null for non-finite numbers) atomically."""
    _write_text(dumps_strict(data, indent=2) + "\n", path)


def _write_text(text: str, path: Path) -> None:
    files.write_text(path, text)


#: meta.json entries that describe the run (when, where, with what, how fast), not its results
RUN_ENTRIES = ("started", "run", "git", "versions")


def settled_meta(meta: Mapping, previous: Mapping) -> dict:
    """The ``meta.json`` of a finished run: ``meta``, except that a run which computed no new
    point (``run.points_new == 0``) of a study whose ``previous`` run completed with the same
    fingerprint keeps that run's :data:`RUN_ENTRIES` (its timings, revision and versions are
    those of the points on disk; a wall time of a reuse would say 0 points/s)."""
    reused = meta.get("run", {}).get("points_new") == 0
    same = previous.get("status") == "complete" and previous.get("fingerprint") == meta.get(
        "fingerprint"
    )
    if not (reused and same):
        return dict(meta)
    merged = {**meta, **{k: previous[k] for k in RUN_ENTRIES if k in previous}}
    order = [*(k for k in previous if k in merged), *(k for k in merged if k not in previous)]
    return {k: merged[k] for k in order}  # the previous file's key order: the same bytes


def read_meta(out_dir: Path) -> dict:
    """The ``meta.json`` of a study's results directory ({} if absent or unreadable)."""
    try:
        return json.loads((Path(out_dir) / META).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}


def package_versions() -> dict[str, str]:
    """Installed versions of the packages results depend on, and Python's."""
    versions = {"python": platform.python_version()}
    for name in PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions


def git_revision(where: Path) -> dict[str, str | bool]:
    """Git commit of the repository holding ``where`` and whether the tree has changes."""

    def git(*args):
        return subprocess.run(
            ["git", "-C", str(where), *args], capture_output=True, text=True, timeout=10
        )

    try:
        head = git("rev-parse", "HEAD")
        status = git("status", "--porcelain")
    except (OSError, subprocess.TimeoutExpired):
        return {"revision": "unknown", "dirty": False}
    revision = head.stdout.strip() if head.returncode == 0 else "unknown"
    return {"revision": revision, "dirty": bool(status.stdout.strip())}


def now() -> str:
    """Current UTC time, ISO 8601 to the second."""
    return datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")


def write_index(results_root: Path) -> Path:
    """Regenerate ``results/README.md``: every study with its kind, finding and files."""
    results_root = Path(results_root)
    lines = [
        "# Results",
        "",
        "Generated by `ufmt run` after every study run (`ufmt.studies.outputs.write_index`);",
        "do not edit by hand. Each study directory holds `points.csv` (one row per evaluated",
        "point, units in the column names), `meta.json` (inputs, model and code hashes,",
        "package versions, git revision, timings) and its plots.",
        "All of it on one page (validation, FRF, studies): [report.html](report.html).",
        "",
    ]
    others = []
    for out_dir in sorted(p for p in results_root.iterdir() if p.is_dir()):
        meta = read_meta(out_dir)
        if meta.get("kind") is None:
            others.append(out_dir.name)
            continue
        run = meta.get("run", {})
        lines += [f"## [{out_dir.name}]({out_dir.name}/) ({meta['kind']})", ""]
        if meta.get("description"):
            lines += [meta["description"], ""]
        plate = meta.get("plate_mm")
        if plate:
            lines += [f"Plate: {plate[0]:.4g} mm × {plate[1]:.4g} mm.", ""]
        lines += [f"**Finding:** {meta.get('headline') or '(run incomplete)'}", ""]
        lines += [
            f"Study file `{meta.get('study_file', '?')}`; {run.get('points_total', '?')} points,"
            f" {run.get('wall_s', '?')} s wall time with {run.get('jobs', '?')} job(s)"
            f" ({run.get('backend', '?')}); model SHA-256 `{str(meta.get('model_sha256'))[:12]}`,"
            f" git `{str(meta.get('git', {}).get('revision'))[:12]}`.",
            "",
        ]
        files = sorted(p.name for p in out_dir.iterdir() if p.suffix in (".csv", ".png"))
        lines += [f"- [{name}]({out_dir.name}/{name})" for name in files] + [""]
    if others:
        lines += ["## Other outputs", ""]
        lines += [f"- [{name}/]({name}/)" for name in others] + [""]
    path = results_root / INDEX
    _write_text("\n".join(lines).rstrip("\n") + "\n", path)
    return path


# ---------------------------------------------------------------------------------------------
# numbers in headlines


def short(value: float) -> str:
    """A number in 3 significant digits."""
    return f"{value:.3g}"
