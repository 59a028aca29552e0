"""Reading a study file: its common fields, its kind's own fields (through the kind registry)
and every value it can set, checked against its model before any point runs.

The file format is :mod:`ufmt.studies.spec`'s; each kind's fields are its module's, read with
:mod:`ufmt.studies.fields`.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from pathlib import Path

from ufmt.errors import StudyError
from ufmt.studies.fields import (
    COMMON_FIELDS,
    MAX_POINTS,
    check_values,
    read_common,
    study_baseline,
)
from ufmt.studies.kinds import KINDS
from ufmt.studies.spec import Study
from ufmt.tables import Where
from ufmt.tomlfile import parse_toml, read_text

MAX_STUDY_BYTES = 4 << 20  # [bytes] a study file (meta.json holds its text once)


def load_study(path: str | Path) -> Study:
    """Read and validate the study file at ``path``.

    Raises
    ------
    StudyError
        One line naming the file and the field.
    """
    path = Path(path)
    try:
        size = path.stat().st_size
    except OSError:
        size = 0  # read_text gives the one-line reason
    if size > MAX_STUDY_BYTES:
        Where(str(path), error=StudyError).fail_table(
            f"{size:,} bytes; a study file holds at most {MAX_STUDY_BYTES:,} (its points are"
            " described by axes, grids and bounds, not listed at length)"
        )
    return parse_study(read_text(path, StudyError, MAX_STUDY_BYTES), path)


def parse_study(text: str, path: str | Path = "study.toml") -> Study:
    """Parse and validate study TOML ``text``; ``path`` names it and anchors relative paths."""
    path = Path(path)
    where = Where(str(path), error=StudyError)
    data = parse_toml(text, str(path), StudyError)
    try:
        content_sha = _content_sha256(data)
    except RecursionError:  # a deep dotted key: tomllib nests it without recursing
        where.fail_table("malformed TOML: tables nested too deeply")
    names = tuple(KINDS)
    if "kind" not in data:
        where.missing("kind", f"one of {', '.join(names)}")
    kind = where.choice("kind", data["kind"], names, "study kind")
    study_kind = KINDS[kind]
    where.keys(data, COMMON_FIELDS + study_kind.fields)
    common, parameters = read_common(where, data, path)
    study = dict(path=path, kind=kind, text=text, content_sha256=content_sha, **common)
    parts = study_kind.parse(where, data, parameters)
    baseline = study_baseline(Study(**study, **parts), parameters)
    parsed = Study(**study, **parts, baseline=baseline)
    planned = study_kind.planned_points(parsed)  # a count: no point list is made yet
    if planned > MAX_POINTS:
        where.fail_table(
            f"{planned:,} points in all (every axis, grid and value list, or the optimiser's"
            f" budget) is more than the allowed {MAX_POINTS:,}"
        )
    check_values(where, parsed, parameters, baseline)
    return parsed


def _content_sha256(data: Mapping) -> str:
    """SHA-256 of a parsed TOML table's canonical JSON (comments and layout do not count)."""
    text = json.dumps(data, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()
