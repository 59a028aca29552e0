"""Decisions with their intervals: the difference of a metric between two recipes or designs
over the documented bands, with common random numbers, and the band draws a robust objective
takes its quantile over.

Fields of ``optimise-process``, ``optimise-design``, ``sweep`` and ``grid``::

    intervals = 16                 # band samples per comparison (default 0: no comparison)
    interval_inputs = ["machine.*", "hinge.h31.*", "hinge.h25.*"]   # documented bands
                                   #   (ufmt.studies.bands; the default shown)
    interval_seed = 1
    robust = "q90"                 # optimisers only: minimise the 90 % quantile over the bands
    robust_samples = 8             #   of so many band samples instead of the nominal value

A comparison of a decision ``b`` against ``a`` (every optimum against the base: the calibrated
design or the study's base recipe; a sweep's or grid's best point against its worst) evaluates
both at the same n Latin-hypercube samples of the bands (log-uniform on the log-scale bands,
as ``ufmt simulate --uncertainty`` samples them): **common random numbers**, so the spread of
the difference is the spread of the decision's effect, not of the machine. The difference's
5-95 % interval is **resolved** where it excludes 0. A band of a parameter the study decides
(a searched or swept one) is left out of the draws, and the decision's own values win over a
draw's. Each comparison costs 2 n + 2 evaluations (the base's are shared by every optimum).

Table ``decisions.csv``: per comparison and metric, both nominal values and their difference,
the difference's quantiles over the samples, the samples resolved (both finite), and whether
the interval excludes 0. The comparisons' points are logged in ``decision_points.csv`` (resumed
like points.csv), not in points.csv: those rows are other machines (band samples), not the
study's recipes or designs, so points.csv's lowest value stays the study's own.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from ufmt.design import design_parameters, design_target, unknown_design_parameter
from ufmt.metric_names import metric_unit
from ufmt.studies.bands import damping_bands, documented_bands, matching
from ufmt.studies.intervals import sample_designs
from ufmt.studies.outputs import short
from ufmt.tables import Where

DECISIONS = "decisions.csv"
BAND_POINTS = "decision_points.csv"  # the comparisons' points (kept out of points.csv)
DEFAULT_INPUTS = ("machine.*", "hinge.h31.*", "hinge.h25.*")
INTERVAL = (0.05, 0.5, 0.95)
GROUP = "decision"  # points.csv group of the comparisons' points
MAX_SAMPLES = 256
FIELDS = ("intervals", "interval_inputs", "interval_seed")
ROBUST_FIELDS = ("robust", "robust_samples")
_ROBUST = re.compile(r"q(?P<percent>[0-9]{1,2}(\.[0-9]+)?)")


def read_decisions(
    where: Where, data: Mapping, parameters, decided: Sequence[str], robust: bool = False
) -> tuple[dict, tuple[str, ...]]:
    """The fields above: (options, the sampled band names). ``decided``: the parameters the
    study searches or sweeps (their bands are left out)."""
    options = {
        "intervals": where.integer("intervals", data.get("intervals", 0), 0, MAX_SAMPLES),
        "interval_seed": where.integer("interval_seed", data.get("interval_seed", 1), 0),
        "robust": None,
        "robust_samples": 0,
    }
    if robust and "robust" in data:
        options["robust"] = _quantile(where, data["robust"])
        options["robust_samples"] = where.integer(
            "robust_samples", data.get("robust_samples", 8), 2, MAX_SAMPLES
        )
    elif robust and "robust_samples" in data:
        where.fail("robust_samples", 'give robust (the quantile, e.g. "q90") with it')
    if not (options["intervals"] or options["robust"]):
        if "interval_inputs" in data:
            where.fail("interval_inputs", "give intervals (or robust) > 0 with it")
        return options, ()
    patterns = where.items(
        "interval_inputs", data.get("interval_inputs", list(DEFAULT_INPUTS)), "band pattern"
    )
    names = _bands(where, patterns, parameters, decided, given="interval_inputs" in data)
    options["inputs"] = names
    return options, names


def _quantile(where: Where, value) -> float:
    """``"q90"`` -> 0.9, or a probability in (0, 1)."""
    if isinstance(value, str):
        match = _ROBUST.fullmatch(value)
        q = float(match["percent"]) / 100.0 if match else math.nan
    else:
        q = where.number("robust", value, allowed='"q<percent>" or a probability in (0, 1)')
    if not 0.0 < q < 1.0:
        where.fail("robust", f'{value!r}: give "q<percent>" (e.g. "q90") or a number in (0, 1)')
    return q


def robust_label(quantile: float) -> str:
    """0.9 -> "q90" (the column suffix of a robust metric)."""
    return f"q{100 * quantile:g}"


def _all_bands() -> dict:
    return {**documented_bands(), **damping_bands()}


def _bands(where: Where, patterns, parameters, decided, given: bool) -> tuple[str, ...]:
    """Band names matching ``patterns`` that the study's model has and that are not one of
    the ``decided`` parameters (nor set by one)."""
    bands = _all_bands()
    names = []
    for i, pattern in enumerate(patterns):
        found = matching(str(pattern), bands) or ([pattern] if pattern in bands else [])
        if not found:
            where.fail(f"interval_inputs[{i}]", f"{pattern!r} matches no documented band")
        names += found
    kept = [n for n in dict.fromkeys(names) if _usable(n, parameters, decided)]
    if not kept:
        field = "interval_inputs" if given else "intervals"
        where.fail(field, "no documented band is an input of this study's model")
    return tuple(kept)


def _usable(name: str, parameters, decided: Sequence[str]) -> bool:
    """Whether band ``name`` is a design parameter of the model that no decided parameter
    sets."""
    if unknown_design_parameter(name, parameters.model, parameters.declared):
        return False
    target = _target(name, parameters)
    for other in decided:
        if other == name:
            return False
        theirs = _target(other, parameters)
        if target and theirs and theirs[:2] == target[:2] and set(theirs[2]) & set(target[2]):
            return False
    return True


def _target(name: str, parameters):
    try:
        return design_target(name, design_parameters(parameters.model, parameters.declared))
    except (KeyError, ValueError):
        return None


def draws(names: Sequence[str], n: int, seed: int) -> list[dict[str, float]]:
    """``n`` Latin-hypercube samples of the bands ``names`` (parameter -> value [SI])."""
    if n <= 0 or not names:
        return []
    bands = _all_bands()
    table = sample_designs({name: bands[name] for name in names}, n, seed)
    return [{k: float(v) for k, v in row.items()} for row in table.to_dict("records")]


def difference_interval(ya: np.ndarray, yb: np.ndarray) -> dict[str, float]:
    """Quantiles (5, 50, 95 %) of ``yb - ya`` over the samples where both are finite, their
    count, and whether the 5-95 % interval excludes 0."""
    d = np.asarray(yb, dtype=float) - np.asarray(ya, dtype=float)
    d = d[np.isfinite(d)]
    row = {f"difference_q{100 * q:02.0f}": math.nan for q in INTERVAL}
    if len(d):
        row.update({f"difference_q{100 * q:02.0f}": float(np.quantile(d, q)) for q in INTERVAL})
    low, high = row["difference_q05"], row["difference_q95"]
    row["samples_resolved"] = len(d)
    row["resolved"] = bool(len(d) and (low > 0 or high < 0))
    return row


def compare(
    evaluator,
    comparisons: Sequence[tuple[str, Mapping, Mapping]],
    metrics: Sequence[str],
    samples: Sequence[Mapping[str, float]],
) -> pd.DataFrame:
    """The ``decisions.csv`` table of (name, a, b) comparisons of points ``a`` -> ``b``: each
    evaluated nominally and at every band sample (the same ``samples`` for both)."""
    rows = []
    for name, a, b in comparisons:
        points = [a, b, *({**d, **a} for d in samples), *({**d, **b} for d in samples)]
        records = evaluator.evaluate([(GROUP, p) for p in points])
        n = len(samples)
        for metric in metrics:
            y = np.array([_number(r.get(metric)) for r in records])
            ya, yb = y[2 : 2 + n], y[2 + n :]
            rows.append(
                {
                    "comparison": name,
                    "metric": metric,
                    "from_value": y[0],
                    "to_value": y[1],
                    "difference": y[1] - y[0],
                    **difference_interval(ya, yb),
                    "samples": n,
                }
            )
    return pd.DataFrame(rows)


def compare_logged(evaluator, comparisons, metrics, samples) -> pd.DataFrame:
    """:func:`compare` with the points logged in :data:`BAND_POINTS` (the study's
    evaluator's sibling), not in points.csv."""
    sibling = evaluator.sibling(BAND_POINTS, len(comparisons) * (2 * len(samples) + 2))
    try:
        return compare(sibling, comparisons, metrics, samples)
    finally:
        sibling.close()


def sentence(row: Mapping) -> str:
    """One comparison as words: "min-pv against base: pv_measured_nm -2.1 nm [-3.0, -1.2]:
    resolved" (the difference, its 5-95 % interval; :func:`sentences` says over what)."""
    unit = metric_unit(row["metric"])
    if not row["samples_resolved"]:
        return f"{row['comparison']}: {row['metric']} not resolved in any band sample"
    verdict = "resolved" if row["resolved"] else "not resolved"
    return (
        f"{row['comparison']}: {row['metric']} {_signed(row['difference'])} {unit}"
        f" [{_signed(row['difference_q05'])}, {_signed(row['difference_q95'])}]: {verdict}"
    )


def sentences(table: pd.DataFrame) -> str:
    """Every comparison of ``table`` as words, then once what the intervals are: the
    difference's 5-95 % over the band samples with common random numbers; resolved when the
    interval excludes 0."""
    said = "; ".join(sentence(r) for r in table.to_dict("records"))
    n = int(table["samples_resolved"].max()) if len(table) else 0
    return f"{said} (5-95 % over {n} band samples, common random numbers; resolved: excludes 0)"


def _signed(value: float) -> str:
    return ("+" if value > 0 else "") + short(value)


def _number(value) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def compare_to_base(
    study, evaluator, base: Mapping, chosen: Mapping[str, Mapping], metrics: Sequence[str]
) -> tuple[str, pd.DataFrame | None]:
    """Every ``chosen`` point (name -> point) against ``base`` at the study's ``intervals``
    band samples (the ``decisions.csv`` table); returns the
    headline's sentences and the table (None without intervals)."""
    options = study.options
    n = options.get("intervals", 0)
    if not n:
        return "", None
    samples = draws(options["inputs"], n, options["interval_seed"])
    comparisons = [(f"{name} against {base_name(study)}", base, p) for name, p in chosen.items()]
    table = compare_logged(evaluator, comparisons, metrics, samples)
    return sentences(table), table


def base_name(study) -> str:
    """What the comparisons are against: the calibrated design or the reference recipe."""
    return "the calibrated design" if study.kind == "optimise-design" else "the base recipe"
