"""User-facing errors: the CLI prints their message as one line and exits non-zero."""

import difflib


class UfmtError(Exception):
    """An error caused by the user's input (file, field, argument), not by a bug."""


class ModelError(UfmtError, ValueError):
    """A model file that cannot be read or is invalid; the message names file, element, field."""


class StudyError(UfmtError, ValueError):
    """A study file or study argument that is invalid; the message names file and field."""


class ProcessError(UfmtError, ValueError):
    """Cutting-process parameters that are non-physical (<= 0, NaN)."""


def closest_name(word, choices, cutoff: float = 0.6) -> str | None:
    """The valid name closest to a misspelled ``word`` (difflib ratio >= cutoff), or None."""
    close = difflib.get_close_matches(str(word), [str(c) for c in choices], n=1, cutoff=cutoff)
    return close[0] if close else None


class OutputError(UfmtError, OSError):
    """An output that cannot be written (full disk, permissions, a directory in the way); the
    message names the path. Also an ``OSError`` (``errno`` is the cause's)."""

    def __str__(self) -> str:
        return str(self.strerror)


class RunFailed(UfmtError):
    """A study run stopped by an error after its points began (a full disk, a permission):
    the finished rows are kept and a rerun resumes; the CLI exits with status 1."""

    exit_status = 1
