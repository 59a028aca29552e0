"""The process values a study will run, checked as ``ufmt simulate`` checks one cut: every
rpm, feed and depth outside the paper's Table 1 gives simulate's own
:class:`~ufmt.machining.process.ProcessRangeWarning` wording (a feed of 0.05 "mm/min" is
most likely a feed per revolution in mm), so a unit slip in a study file is seen before the
run. The runner prints the warnings and records them in ``meta.json`` (``warnings``)."""

from __future__ import annotations

import warnings

from ufmt.design import PROCESS_PARAMETERS, REFERENCE_PROCESS
from ufmt.machining.process import Process, ProcessRangeWarning
from ufmt.studies.spec import Study


def study_values(study: Study) -> dict[str, set[float]]:
    """Every value each parameter takes in the study: its base, its axes' values and its
    bounds' ends (relative ones scaled by the baseline)."""
    baseline = study.baseline
    values: dict[str, set[float]] = {name: {float(v)} for name, v in study.base.items()}
    for group in study.groups:
        for axis in group.axes:
            values.setdefault(axis.parameter, set()).update(axis.resolved(baseline))
    for bound in study.bounds:
        values.setdefault(bound.parameter, set()).update(bound.resolved(baseline))
    return values


def process_warnings(study: Study) -> list[str]:
    """simulate's range warning for each process value of ``study`` outside Table 1, prefixed
    with the study file (one message per parameter and value, in parameter order)."""
    baseline = study.baseline
    reference = {p: float(baseline.get(p, REFERENCE_PROCESS[p])) for p in PROCESS_PARAMETERS}
    values = study_values(study)
    out = []
    for name in PROCESS_PARAMETERS:
        for value in sorted(values.get(name, ())):
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                Process(**{**reference, name: value})
            out += [
                f"{study.path}: {w.message}"
                for w in caught
                if issubclass(w.category, ProcessRangeWarning)
                and f"field {name!r}" in str(w.message)
            ]
    return list(dict.fromkeys(out))
