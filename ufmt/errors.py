"""User-facing errors: the CLI prints their message as one line and exits non-zero."""


class UfmtError(Exception):
    """An error caused by the user's input (file, field, argument), not by a bug."""


class ModelError(UfmtError, ValueError):
    """A model file that cannot be read or is invalid; the message names file, element, field."""


class StudyError(UfmtError, ValueError):
    """A study file or study argument that is invalid; the message names file and field."""


class ProcessError(UfmtError, ValueError):
    """Cutting-process parameters that are non-physical (<= 0, NaN)."""
