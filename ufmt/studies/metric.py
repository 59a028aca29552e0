"""The metric a study ranks: which number of a point's record its finding, tables and figures
are about.

Sweeps, grids and sensitivity studies take ``metric = "<record metric>"``; the optimisers
take ``objective = "<record metric>"``. Any metric of a :func:`ufmt.evaluate` record
(:data:`ufmt.design.METRICS`) is allowed. The default is the interferometer's PV
(``pv_measured_nm``: the clear aperture with piston and tilt removed, the feed marks as the
instrument sees them), the number a shop measures and the paper's Table 4 reports; the
whole-plate PV (``pv_nm``) is dominated by what an interferometer removes as tilt. A study of
a function other than ``ufmt.evaluate`` defaults to ``pv_nm``, the one key such a function is
required to return. The headline, every table's ranking column and every figure of a study
name the metric they rank (:func:`metric_label`).
"""

from __future__ import annotations

from collections.abc import Mapping

from ufmt.design import METRICS
from ufmt.errors import closest_name
from ufmt.metric_names import metric_label, metric_unit, metric_words
from ufmt.tables import Where

__all__ = ["read_metric", "metric_label", "metric_unit", "metric_words"]

DEFAULT_METRIC = "pv_measured_nm"
#: Default of a study whose function is not ``ufmt.evaluate`` (its required output).
CUSTOM_FUNCTION_METRIC = "pv_nm"
EVALUATE_FUNCTION = "ufmt.evaluate:evaluate"


def read_metric(where: Where, data: Mapping, field: str) -> str:
    """The study's ``field`` (``metric`` or ``objective``): a record metric, or the default
    for the study's function (module docstring); an unknown name fails with a did-you-mean."""
    if field not in data:
        function = data.get("function", EVALUATE_FUNCTION)
        return DEFAULT_METRIC if function == EVALUATE_FUNCTION else CUSTOM_FUNCTION_METRIC
    name = data[field]
    if not isinstance(name, str) or name not in METRICS:
        near = closest_name(str(name), METRICS)
        hint = f"did you mean {near!r}? " if near else ""
        where.fail(
            field, f"{name!r} is not a record metric: {hint}choose from {', '.join(METRICS)}"
        )
    return name
