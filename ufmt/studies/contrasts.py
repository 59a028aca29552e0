"""Intervals on a sweep's finding: a contrast ("PV falls by X % from 0.1x to 10x the head's
axial stiffness") evaluated at the uncertainty study's own samples of the uncertain inputs.

Fields of the ``uncertainty`` kind::

    [[contrast]]                     # optional, any number
    name = "head axial 0.1x -> 10x"  # what the finding says (the table's key)
    study = "sweep-stiffness"        # the study whose finding it qualifies (the report shows
                                     #   the interval beside that study's finding)
    parameter = "hinge.h31.stiffness[2]"  # the swept parameter (design, machine or process)
    scale = [0.1, 10.0]              # from, to as multiples of the calibrated value; or
    values = [200.0, 400.0]          #   from, to absolute [SI, process units]
    metric = "pv_measured_nm"        # or a list: ["pv_nm", "pv_measured_nm"] (one row each)
    samples = 32                     # the first n independent samples (default: all of them)

Method: the finding is the change of the metric between the two ends of the sweep, with every
other input at its calibrated value. Its interval is that change evaluated again at each of
the first n independent samples of the study's uncertain inputs (the same draws as
``distribution.csv``: Saltelli's A and B rows, or the Latin hypercube), the swept parameter
set to each end in turn; its quantiles (absolute and relative to the 'from' end) are the
finding's spread over the documented bands. A swept parameter that is also an uncertain input
takes the contrast's values in its points (it is the thing swept). Each contrast costs 2 n + 2
evaluations (the two ends at the calibrated inputs give the point value).

Table ``contrast.csv``: per contrast and metric, the point change, the quantiles of the
change [metric units] and of the relative change [%], and the fraction of samples in which the
metric falls.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from ufmt.design import METRICS, design_target
from ufmt.studies.fields import Parameters
from ufmt.studies.outputs import short
from ufmt.studies.spec import Axis, Group
from ufmt.tables import Where

CONTRAST = "contrast.csv"
QUANTILES = (0.05, 0.5, 0.95)
_FIELDS = ("name", "study", "parameter", "scale", "values", "metric", "samples")


def parse_contrasts(
    where: Where, data: Mapping, parameters: Parameters, inputs: Sequence[str]
) -> tuple[tuple[Group, ...], list[dict]]:
    """The ``[[contrast]]`` tables: one group per contrast (its two ends as one axis, so the
    swept parameter is a column of points.csv and its values are checked) and its options."""
    tables = where.tables("contrast", data.get("contrast", []))
    groups, contrasts = [], []
    for i, table in enumerate(tables):
        at = where.sub(f"contrast[{i}]")
        at.keys(table, _FIELDS, required=("name", "parameter", "metric"))
        name = at.string("name", table["name"])
        parameter = parameters.check(at, "parameter", table["parameter"])
        _refuse_alias(at, parameter, inputs, parameters)
        given = [key for key in ("scale", "values") if key in table]
        if len(given) != 1:
            at.fail_table("give exactly one of scale, values (the sweep's two ends)")
        ends = at.numbers(given[0], table[given[0]], 2, sign="positive")
        if ends[0] == ends[1]:
            at.fail(given[0], f"the two ends are equal ({ends[0]:g}): nothing is contrasted")
        given_metrics = table["metric"] if isinstance(table["metric"], list) else [table["metric"]]
        items = at.items("metric", given_metrics, "metric name", required=True)
        metrics = [at.choice(f"metric[{j}]", m, METRICS, "metric") for j, m in enumerate(items)]
        metrics = at.unique("metric", metrics)
        samples = at.integer("samples", table["samples"], 1) if "samples" in table else None
        study = at.string("study", table["study"]) if "study" in table else ""
        axis = Axis(parameter, tuple(ends), relative=given[0] == "scale")
        groups.append(Group(group_name(i), (axis,)))
        contrasts.append(
            {
                "name": name,
                "study": study,
                "parameter": parameter,
                "metrics": metrics,
                "samples": samples,
            }
        )
    names = [c["name"] for c in contrasts]
    where.unique("contrast", names)
    return tuple(groups), contrasts


def _refuse_alias(at: Where, parameter: str, inputs: Sequence[str], parameters) -> None:
    """A swept parameter naming the same hinge component as an uncertain input under another
    name would be overridden by the input in its points: ask for the input's name."""
    try:
        target = design_target(parameter, parameters.declared)
    except KeyError:
        return
    for name in inputs:
        try:
            other = design_target(name, parameters.declared)
        except KeyError:
            continue
        if name != parameter and other[:2] == target[:2] and set(other[2]) & set(target[2]):
            at.fail("parameter", f"{parameter!r} sets the uncertain input {name!r}: name it so")


def group_name(index: int) -> str:
    """The points.csv group of contrast ``index``."""
    return f"contrast-{index}"


def planned(study, independent: int) -> int:
    """Evaluations of every contrast: 2 n + 2 each."""
    total = 0
    for contrast in study.options.get("contrasts", []):
        n = min(contrast["samples"] or independent, independent)
        total += 2 * n + 2
    return total


def evaluate_contrasts(study, evaluator, baseline: Mapping, draws: list[dict]) -> pd.DataFrame:
    """``contrast.csv`` of the study's contrasts at the independent ``draws`` (input dicts)."""
    rows = []
    for i, contrast in enumerate(study.options.get("contrasts", [])):
        group = study.groups[i]
        (axis,) = group.axes
        low, high = axis.resolved(baseline)
        n = min(contrast["samples"] or len(draws), len(draws))
        used = draws[:n]
        name = axis.parameter
        points = [{name: low}, {name: high}]
        points += [{**d, name: v} for d in used for v in (low, high)]
        records = evaluator.evaluate([(group.name, p) for p in points])
        for metric in contrast["metrics"]:
            y = np.array([_number(r.get(metric)) for r in records])
            rows.append(_row(contrast, metric, (low, high), y[:2], y[2:].reshape(n, 2)))
    return pd.DataFrame(rows)


def _number(value) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def _row(contrast: Mapping, metric: str, span, point, ends: np.ndarray) -> dict:
    """One contrast's row for ``metric``: its point change at the two ends ``span`` and the
    quantiles of its change over the samples (``ends``: n x 2)."""
    change = ends[:, 1] - ends[:, 0]
    relative = 100.0 * change / ends[:, 0]
    valid = np.isfinite(change) & np.isfinite(relative)
    row = {
        "name": contrast["name"],
        "study": contrast["study"],
        "parameter": contrast["parameter"],
        "from": span[0],
        "to": span[1],
        "metric": metric,
        "point_from": float(point[0]),
        "point_to": float(point[1]),
        "point_change": float(point[1] - point[0]),
        "point_change_pct": float(100.0 * (point[1] - point[0]) / point[0]),
        "samples": len(change),
        "resolved": int(np.count_nonzero(valid)),
    }
    for q in QUANTILES:
        column = f"q{100 * q:02.0f}"
        found = valid.any()
        row[f"change_{column}"] = float(np.quantile(change[valid], q)) if found else math.nan
        row[f"change_pct_{column}"] = float(np.quantile(relative[valid], q)) if found else math.nan
    row["p_falls"] = float(np.mean(change[valid] < 0)) if valid.any() else math.nan
    return row


def change_text(row: Mapping) -> str:
    """The point change and its 5-95 % interval in per cent, "-10.5 % [-10.7, -0.2]" (the
    form the README and the report quote)."""
    return (
        f"{row['point_change_pct']:+.1f} % [{row['change_pct_q05']:+.1f},"
        f" {row['change_pct_q95']:+.1f}]"
    )


def sentence(row: Mapping) -> str:
    """One contrast row as the finding with its 5-95 % interval, e.g. "head axial 0.1x -> 10x:
    pv_nm 502 -> 490, -2.4 % [-3.1, -0.2], falls in 30/32" (the samples it falls in)."""
    if not row["resolved"]:
        return f"{row['name']}: {row['metric']} not resolved in any sample"
    falls = round(row["p_falls"] * row["resolved"])
    return (
        f"{row['name']}: {row['metric']} {short(row['point_from'])} -> {short(row['point_to'])},"
        f" {change_text(row)}, falls in {falls}/{row['resolved']}"
    )
