"""Reading a study file: its common fields, its kind's own fields (through the kind registry)
and every value it can set, checked against its model before any point runs.

The file format is :mod:`ufmt.studies.spec`'s; each kind's fields are its module's.
"""

from __future__ import annotations

import hashlib
import json
import tomllib
from collections.abc import Mapping
from pathlib import Path

from ufmt.errors import StudyError
from ufmt.studies.kinds import KINDS
from ufmt.studies.spec import (
    COMMON_FIELDS,
    Study,
    StudyContext,
    check_keys,
    check_values,
    name_hint,
    read_common,
    study_baseline,
)


def load_study(path: str | Path) -> Study:
    """Read and validate the study file at ``path``.

    Raises
    ------
    StudyError
        One line naming the file and the field.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise StudyError(f"{path}: file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise StudyError(f"{path}: cannot read: {exc}") from None
    return parse_study(text, path)


def parse_study(text: str, path: str | Path = "study.toml") -> Study:
    """Parse and validate study TOML ``text``; ``path`` names it and anchors relative paths."""
    path = Path(path)
    where = StudyContext(str(path))
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        where.fail("", f"malformed TOML: {' '.join(str(exc).split())}")
    except RecursionError:
        where.fail("", "malformed TOML: values nested too deeply")
    content_sha = _content_sha256(data)
    names = tuple(KINDS)
    kind = data.get("kind")
    if kind is None:
        where.fail("kind", f"missing (one of {', '.join(names)})")
    if kind not in names:
        where.fail("kind", f"unknown study kind {kind!r} ({name_hint(str(kind), names, 'kinds')})")
    study_kind = KINDS[kind]
    check_keys(where, "", data, COMMON_FIELDS + study_kind.fields)
    common = read_common(where, data, path)
    study = dict(path=path, kind=kind, text=text, content_sha256=content_sha, **common)
    parts = study_kind.parse(where, data, common["base"])
    parsed = Study(**study, **parts)
    baseline = study_baseline(where, parsed)
    check_values(where, parsed, baseline)
    return Study(**study, **parts, baseline=baseline)


def _content_sha256(data: Mapping) -> str:
    """SHA-256 of a parsed TOML table's canonical JSON (comments and layout do not count)."""
    text = json.dumps(data, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()
