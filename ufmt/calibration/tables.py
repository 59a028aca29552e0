"""Checks shared by the tables of a calibration file (``ufmt/data/calibration.toml``)."""

from __future__ import annotations

import math

from ufmt.errors import StudyError


def fail(where: str, problem: str):
    """Raise the one-line error of a calibration table: ``where``, then ``problem``."""
    raise StudyError(f"{where}: {problem}")


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
