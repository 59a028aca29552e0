"""The constants every stage shares, each defined here once and imported where it is used.

* The reference process: the paper's cut of sections 3.3 and 4.2 (Figs. 6, 7, 12-14,
  Table 4): 300 rpm, 15 mm/min, 4 um. A process parameter a caller leaves out takes it.
* The paper's modes: Table 3 lists the first 30 natural frequencies, and the paper's modal
  basis (section 3.2) keeps the same 30; the validation table and the identification match
  that many.
* The default modal basis of the response: every mode below 5 kHz (68 on the packaged UFMT),
  with the static residual of the modes above. The cutting force rises within microseconds
  when the tool engages (2.8 % of a revolution at the reference cut), so the tool-tip
  response holds modes far above the spindle harmonics; the paper's 30 (to ~700 Hz) drop the
  response to that step. Doubling the cutoff moves no surface metric by more than 0.1 % on the
  packaged model (tests/test_convergence.py). The paper's 30 remain an option (``n_modes``).
* The default sampling: samples per spindle revolution from the basis, at least
  ``SAMPLES_PER_MODE_PERIOD`` per period of its highest mode and ``SAMPLES_PER_GRID_STEP`` per
  surface grid step along the tool's circle (the engagement), as a power of two and never below
  512 (:func:`ufmt.machining.cut_geometry.samples_per_rev`).
* The default surface grid: 1 mm across the feed (x), 1.25 mm along it (y); see
  :mod:`ufmt.machining.surface` for why x is finer.
"""

from __future__ import annotations

from types import MappingProxyType

REFERENCE_RPM = 300.0  # [rev/min]
REFERENCE_FEED_MM_MIN = 15.0  # [mm/min]
REFERENCE_DEPTH_UM = 4.0  # [um]
#: The reference process by parameter name (read-only).
REFERENCE_PROCESS = MappingProxyType(
    {"rpm": REFERENCE_RPM, "feed_mm_min": REFERENCE_FEED_MM_MIN, "depth_um": REFERENCE_DEPTH_UM}
)

PAPER_MODES = 30  # Table 3 and the paper's basis (sections 2.5, 3.2)
DEFAULT_BASIS_CUTOFF_HZ = 5000.0  # [Hz] the default basis: every mode below this
SAMPLES_PER_MODE_PERIOD = 4  # default sampling: samples per period of the basis' highest mode
SAMPLES_PER_GRID_STEP = 4  # and per surface grid step across the feed along the tip's circle
SAMPLES_PER_TOOL_PERIOD = 32  # and per period of the tool carrier's mode (ufmt.machining.tool)
MIN_SAMPLES_PER_REV = 512

DEFAULT_SPACING = (1e-3, 1.25e-3)  # surface grid step (x, y) [m]
