"""The budget of every request: sizes checked before anything is allocated.

Each limit bounds the memory or the work of one command; a request above it is refused with
one line (:class:`~ufmt.errors.UfmtError` or the caller's error class) that names the field,
the allowed range and, where it is a size, what the request would need. The limits sit well
above what the packaged model and the paper's studies use (docs/ufmt-model.md, "Requests,
budgets and argument order").

* ``MAX_INPUT_BYTES`` [bytes]: a model file, a modal test or a settings file.
* ``MAX_MAP_BYTES`` [bytes]: a height map read as text (an SDF export).
* ``MAX_BODIES`` [-]: bodies of a model. The overall transfer matrix, the assembled static
  solve and the mode shapes grow with the body count (6 or 12 states per body, dense
  matrices: memory ~ bodies^2, work ~ bodies^3 per frequency); ``MAX_HINGES`` [-] likewise
  (each hinge that closes a loop adds 12 unknowns to the overall transfer equation).
* ``MAX_MODE_COUNT`` [-]: modes asked for (``modes --count``, ``simulate --modes``, ``frf
  --modes``). The hinge damping of a basis is a dense (n, n) matrix and every mode is one
  Wittrick-Williams bracket and one null vector.
* ``MAX_MODE_FREQUENCY_HZ`` [Hz]: the top of ``ufmt modes --fmax``: beyond it the
  rigid-body model is out of its scope and the transfer matrices of the MSTMM determinant
  lose their conditioning. The API's ``solve_modes(fmax_hz=...)`` takes up to
  ``MAX_FREQUENCY_HZ`` (the correlation asks for the first ``count`` modes below it); the
  modes counted below ``fmax_hz`` (Wittrick-Williams, cheap) must not exceed
  ``MAX_MODE_COUNT`` before any is solved.
* ``MAX_FRF_POINTS`` [-]: frequencies of an FRF (each a (3, 3) complex response per point
  pair and one column of the modal sum).
* ``MAX_FREQUENCY_HZ`` [Hz]: the top of an FRF's axis and of a mode search through the API
  (``(2 pi f)^2`` stays finite).
* ``MAX_TABLE_ROWS`` [-]: slide positions of the periodic response table (each row holds
  ``samples_per_rev`` samples of every mode).
* ``MAX_UNCERTAINTY_SAMPLES`` [-]: Latin-hypercube samples of ``simulate --uncertainty`` (one
  whole simulation each; a progress bar on stderr while they run).
"""

from __future__ import annotations

import math
import numbers

from ufmt.errors import UfmtError

MAX_INPUT_BYTES = 8 << 20  # [bytes] a model, modal-test or settings file
MAX_MAP_BYTES = 1 << 30  # [bytes] a height map (a 410 mm plate's SDF export is ~14 MB)
MAX_BODIES = 300  # [-] bodies of one model
MAX_HINGES = 600  # [-] hinges of one model
MAX_NAME_CHARS = 200  # [-] characters of a body or hinge name (messages quote names)
MAX_MODE_COUNT = 1000  # [-] modes of one request
MAX_MODE_FREQUENCY_HZ = 2e4  # [Hz] top of a mode search
MAX_FRF_POINTS = 10**5  # [-] frequencies of one FRF
MAX_FREQUENCY_HZ = 1e6  # [Hz] an FRF's frequency axis (far above every mode a model holds)
MAX_TABLE_ROWS = 4096  # [-] slide positions of the periodic response table
MAX_UNCERTAINTY_SAMPLES = 2000  # [-] samples of one --uncertainty request


def count(name: str, value, low: int, high: int, error: type[UfmtError] = UfmtError) -> int:
    """``value`` as an int in [low, high], else ``error`` naming ``name`` and the range; a
    boolean, a fraction, NaN or text is refused (not converted)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise error(f"{name}: {shown(value)} is not an integer (allowed {low}-{high:,})")
    if not (math.isfinite(value) and value == int(value)):
        raise error(f"{name}: {shown(value)} is not an integer (allowed {low}-{high:,})")
    if not low <= value <= high:
        raise error(f"{name}: {int(value):,} is outside the allowed {low}-{high:,}")
    return int(value)


def number(name: str, value, low: float, high: float, error: type[UfmtError] = UfmtError):
    """``value`` as a finite float in [low, high], else ``error`` naming ``name`` and the
    range; a boolean or text is refused."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise error(f"{name}: {shown(value)} is not a number (allowed {low:g}-{high:g})")
    if not (math.isfinite(value) and low <= value <= high):
        raise error(f"{name}: {float(value)!r} is outside the allowed {low:g}-{high:g}")
    return float(value)


def shown(value) -> str:
    """``value`` for a message: its repr, cut to 60 characters."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
