"""Reading settings and reference TOML files with one-line user errors."""

from __future__ import annotations

import tomllib
from pathlib import Path

from ufmt.errors import StudyError, UfmtError


def read_toml(path: str | Path, error: type[UfmtError] = StudyError) -> dict:
    """The table in ``path``; a missing file or malformed TOML raises ``error`` (one line)."""
    where = str(path)
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise error(f"{where}: file not found") from None
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{where}: malformed TOML: {' '.join(str(exc).split())}") from None
    except RecursionError:
        raise error(f"{where}: malformed TOML: values nested too deeply") from None
    except IsADirectoryError:
        raise error(f"{where}: is a directory, not a file") from None
    except (OSError, UnicodeDecodeError) as exc:
        reason = getattr(exc, "strerror", None) or "not UTF-8 text"
        raise error(f"{where}: cannot read: {reason}") from None
