"""Reading input files (models, studies, settings, reference data) with one-line user errors,
in one wording for every file: ``<file>: file not found``, ``<file>: is a directory, not a
file``, ``<file>: not UTF-8 text (byte N)``, ``<file>: cannot read: <reason>``, ``<file>:
malformed TOML: <parser message>``."""

from __future__ import annotations

import tomllib
from pathlib import Path

from ufmt.errors import StudyError, UfmtError


def read_text(path: str | Path, error: type[UfmtError] = StudyError) -> str:
    """The UTF-8 text of ``path`` (universal newlines); a file that cannot be read raises
    ``error`` (one line)."""
    try:
        return Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise error(f"{path}: {_unreadable(exc)}") from None


def parse_toml(text: str, source: str, error: type[UfmtError] = StudyError) -> dict:
    """The table of TOML ``text`` (``source`` names it); malformed TOML raises ``error``."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{source}: malformed TOML: {' '.join(str(exc).split())}") from None
    except RecursionError:
        raise error(f"{source}: malformed TOML: values nested too deeply") from None


def read_toml(path: str | Path, error: type[UfmtError] = StudyError) -> dict:
    """The table in ``path`` (read as bytes, as TOML specifies); a file that cannot be read or
    malformed TOML raises ``error`` (one line)."""
    try:
        data = Path(path).read_bytes().decode("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise error(f"{path}: {_unreadable(exc)}") from None
    return parse_toml(data, str(path), error)


def _unreadable(exc: OSError | UnicodeDecodeError) -> str:
    """Why a file could not be read, in the words of the module docstring."""
    if isinstance(exc, FileNotFoundError):
        return "file not found"
    if isinstance(exc, IsADirectoryError):
        return "is a directory, not a file"
    if isinstance(exc, UnicodeDecodeError):
        return f"not UTF-8 text (byte {exc.start})"
    return f"cannot read: {exc.strerror or exc}"
