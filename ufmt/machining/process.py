"""Cutting-process parameters: spindle speed, feed speed and depth of cut (paper Table 1)."""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

from ufmt.errors import ProcessError

#: Validated range of each field (paper Table 1): (low, high, unit).
TABLE1_RANGE = {
    "rpm": (200.0, 400.0, "rpm"),
    "feed_mm_min": (4.0, 16.0, "mm/min"),
    "depth_um": (2.0, 8.0, "um"),
}


class ProcessRangeWarning(UserWarning):
    """A process parameter outside the range the paper validated (Table 1)."""


@dataclass(frozen=True)
class Process:
    """Fly-cutting process, validated on construction.

    Attributes
    ----------
    rpm : spindle speed n [rev/min].
    feed_mm_min : feed speed v of the slide [mm/min].
    depth_um : depth of cut a_p [um].

    Raises ProcessError if a field is not a finite number > 0; warns (ProcessRangeWarning) if it
    lies outside Table 1 (200-400 rpm, 4-16 mm/min, 2-8 um).
    """

    rpm: float
    feed_mm_min: float
    depth_um: float

    def __post_init__(self):
        for name, (low, high, unit) in TABLE1_RANGE.items():
            raw = getattr(self, name)
            try:
                if isinstance(raw, bool | str | bytes):  # float() would take True and "300"
                    raise TypeError
                value = float(raw)
            except (TypeError, ValueError):
                raise ProcessError(f"process: field {name!r}: {raw!r} is not a number") from None
            if not math.isfinite(value) or value <= 0.0:
                raise ProcessError(
                    f"process: field {name!r}: {value!r} must be a finite number > 0 [{unit}]"
                )
            if not low <= value <= high:
                warnings.warn(
                    f"process: field {name!r}: {value:g} {unit} is outside the validated range "
                    f"{low:g}-{high:g} {unit} (paper Table 1)",
                    ProcessRangeWarning,
                    stacklevel=3,
                )
            object.__setattr__(self, name, value)

    @property
    def spindle_hz(self) -> float:
        """Spindle frequency f = n / 60 [Hz]."""
        return self.rpm / 60.0

    @property
    def feed_m_s(self) -> float:
        """Feed speed v [m/s]."""
        return self.feed_mm_min / 60.0e3

    @property
    def depth_m(self) -> float:
        """Depth of cut a_p [m]."""
        return self.depth_um * 1e-6

    @property
    def feed_per_rev_m(self) -> float:
        """Feed per spindle revolution v / f [m]."""
        return self.feed_m_s / self.spindle_hz
