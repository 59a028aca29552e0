"""The precision of the calibration's results: SIGNIFICANT digits.

Every identified stiffness factor (:mod:`ufmt.calibration.identify`) and every fitted
``[machine]`` value (:mod:`ufmt.calibration.response_fit`) is rounded with :func:`rounded`
before its final evaluation, so the model ``ufmt calibrate`` writes does not depend on the last
bits of the arithmetic (deterministic files: a rerun on an unchanged prior writes the same
bytes).
"""

from __future__ import annotations

import numpy as np

SIGNIFICANT = 6  # digits of every identified factor written to the model (deterministic files)


def rounded(values) -> np.ndarray:
    """``values`` rounded to SIGNIFICANT significant digits."""
    return np.array([float(f"{v:.{SIGNIFICANT}g}") for v in np.atleast_1d(values)])
