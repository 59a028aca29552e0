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
from ufmt.studies.fields import COMMON_FIELDS, check_values, read_common, study_baseline
from ufmt.studies.kinds import KINDS
from ufmt.studies.spec import Study
from ufmt.tables import Where
from ufmt.tomlfile import parse_toml, read_text


def load_study(path: str | Path) -> Study:
    """Read and validate the study file at ``path``.

    Raises
    ------
    StudyError
        One line naming the file and the field.
    """
    path = Path(path)
    return parse_study(read_text(path, StudyError), path)


def parse_study(text: str, path: str | Path = "study.toml") -> Study:
    """Parse and validate study TOML ``text``; ``path`` names it and anchors relative paths."""
    path = Path(path)
    where = Where(str(path), error=StudyError)
    data = parse_toml(text, str(path), StudyError)
    content_sha = _content_sha256(data)
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
    check_values(where, parsed, parameters, baseline)
    return parsed


def _content_sha256(data: Mapping) -> str:
    """SHA-256 of a parsed TOML table's canonical JSON (comments and layout do not count)."""
    text = json.dumps(data, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()
