"""The constants every stage shares, each defined here once and imported where it is used.

* The reference process: the paper's cut of sections 3.3 and 4.2 (Figs. 6, 7, 12-14,
  Table 4): 300 rpm, 15 mm/min, 4 um. A process parameter a caller leaves out takes it.
* The paper's modes: Table 3 lists the first 30 natural frequencies, and the paper's modal
  basis (section 3.2) keeps the same 30; the validation table and the identification match
  that many.
* The default modal basis of the response: the paper's 30 modes.
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
DEFAULT_MODES = PAPER_MODES  # modes in the default modal basis of the response

DEFAULT_SPACING = (1e-3, 1.25e-3)  # surface grid step (x, y) [m]
