"""The registry of study kinds: every kind a study file can name, by name.

A kind is a :class:`~ufmt.studies.spec.StudyKind` its own module defines (its fields and their
parser, the points it plans, its analysis, its tables and figures). A new kind is a new module
and one entry here.
"""

from __future__ import annotations

from ufmt.studies import (
    optimise_design,
    optimise_process,
    sensitivity,
    sweep,
    tolerances,
    uncertainty,
)

KINDS = {
    kind.name: kind
    for kind in (
        sweep.SWEEP,
        sweep.GRID,
        optimise_process.OPTIMISE_PROCESS,
        optimise_design.OPTIMISE_DESIGN,
        sensitivity.SENSITIVITY,
        uncertainty.UNCERTAINTY,
        tolerances.OPTIMISE_TOLERANCES,
    )
}
#: Every table a kind writes besides points.csv (a fresh run removes stale ones of any kind).
RESULT_TABLES = tuple(dict.fromkeys(table for kind in KINDS.values() for table in kind.tables))
