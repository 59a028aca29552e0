"""Checks shared by the tables of a calibration file (``ufmt/data/calibration.toml``)."""

from __future__ import annotations

import math

from ufmt.errors import StudyError, closest_name


def fail(where: str, problem: str):
    """Raise the one-line error of a calibration table: ``where``, then ``problem``."""
    raise StudyError(f"{where}: {problem}")


def suggest(word: str, choices) -> str:
    """`` (did you mean 'x'?)`` for the closest of ``choices``, or nothing."""
    close = closest_name(word, choices)
    return f" (did you mean {close!r}?)" if close else ""


def check_keys(where: str, table, allowed) -> None:
    """One error for the first field of ``table`` not in ``allowed``, with the closest name."""
    for key in table:
        if key not in allowed:
            fail(where, f"unknown field {key!r}{suggest(key, allowed)}; fields: {list(allowed)}")


def read_band(where: str, band, valid, rule: str) -> tuple[float, float]:
    """A table's ``band``: [lower, upper], two finite numbers for which ``valid(lower,
    upper)`` holds (``rule`` says it in words); else one error naming the field and the rule."""
    if (
        not isinstance(band, list)
        or len(band) != 2
        or not all(isinstance(b, int | float) and math.isfinite(b) for b in band)
        or not valid(*band)
    ):
        fail(where, f"field 'band': {band!r} must be [lower, upper] with {rule}")
    return float(band[0]), float(band[1])
