"""Reading input files (models, studies, settings, reference data) with one-line user errors,
in one wording for every file: ``<file>: file not found``, ``<file>: is a directory, not a
file``, ``<file>: not UTF-8 text (byte N)``, ``<file>: cannot read: <reason>``, ``<file>:
malformed TOML: <parser message>``."""

from __future__ import annotations

import os
import tomllib
from pathlib import Path

from ufmt.errors import StudyError, UfmtError
from ufmt.limits import MAX_INPUT_BYTES


def read_text(
    path: str | Path, error: type[UfmtError] = StudyError, max_bytes: int = MAX_INPUT_BYTES
) -> str:
    """The UTF-8 text of ``path`` (universal newlines; a leading byte-order mark is not
    content); a file that cannot be read, or longer than ``max_bytes`` (refused from its size
    before reading, or after reading ``max_bytes`` of a device or pipe), raises ``error``
    (one line)."""
    try:
        with open(path, "rb") as fh:
            size = os.fstat(fh.fileno()).st_size
            data = fh.read(max_bytes + 1) if size <= max_bytes else b""
        if size > max_bytes or len(data) > max_bytes:
            shown = f"{size:,} bytes" if size > max_bytes else f"more than {max_bytes:,} bytes"
            raise error(f"{path}: {shown}; an input file holds at most {max_bytes:,}")
        return data.decode("utf-8-sig").replace("\r\n", "\n").replace("\r", "\n")
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
    """The table in ``path`` (read as :func:`read_text` reads it); a file that cannot be read
    or malformed TOML raises ``error`` (one line)."""
    return parse_toml(read_text(path, error), str(path), error)


def _unreadable(exc: OSError | UnicodeDecodeError) -> str:
    """Why a file could not be read, in the words of the module docstring."""
    if isinstance(exc, FileNotFoundError):
        return "file not found"
    if isinstance(exc, IsADirectoryError):
        return "is a directory, not a file"
    if isinstance(exc, UnicodeDecodeError):
        return f"not UTF-8 text (byte {exc.start})"
    return f"cannot read: {exc.strerror or exc}"
