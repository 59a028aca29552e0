"""What an optimiser study asks for: its objective or objectives, its ``[[constraint]]`` limits,
and the scoring of searched points that keeps an infeasible point from ever being reported.

Fields of ``optimise-process`` and ``optimise-design``::

    objective = "pv_measured_nm"          # one metric (ufmt.studies.metric), or
    objectives = ["pv_measured_nm", "pv_feed_marks_nm", "cutting_time_min"]  # a Pareto front

    [[constraint]]                        # optional, any number
    metric = "pv_feed_marks_nm"           # a record metric (or the kind's derived one:
    max = 10.0                            #   cutting_time_min in optimise-process)
                                          # max (metric <= limit) or min (metric >= limit)

Constraint handling: a searched point's **violation** is the sum over constraints of how far it
lies beyond each limit, relative to the limit's size (0 when every constraint holds; infinite
where a constrained metric is not a number). The single-objective search minimises the
penalised objective :func:`penalised`: a point that violates any constraint scores
``PENALTY (1 + violation)``, above every feasible point's objective, so the search moves
towards feasibility first (a static exterior penalty with a feasibility-first ranking; the
Pareto search uses pymoo's constrained domination instead, :mod:`ufmt.studies.pareto`). The
reported optima are chosen from the scored points with violation 0 only: an infeasible point is
never reported, and a study in which no scored point is feasible says so in one line.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from ufmt.design import METRICS
from ufmt.errors import StudyError, closest_name
from ufmt.studies.outputs import short
from ufmt.tables import Where

PENALTY = 1e9  # objective floor of a point violating a constraint (below optimise.FAILED)
VIOLATION = "violation"  # column of a scored frame: the summed relative constraint violation
_CONSTRAINT_FIELDS = ("metric", "max", "min")


@dataclass(frozen=True)
class Constraint:
    """``metric <= limit`` (``upper``) or ``metric >= limit``."""

    metric: str
    limit: float
    upper: bool = True

    def __str__(self) -> str:
        return f"{self.metric} {'<=' if self.upper else '>='} {short(self.limit)}"

    def excess(self, values) -> np.ndarray:
        """Signed distance beyond the limit [the metric's unit]: <= 0 where it holds; +inf where
        the value is not a number."""
        v = np.asarray(values, dtype=float)
        excess = v - self.limit if self.upper else self.limit - v
        return np.where(np.isfinite(v), excess, math.inf)

    def violation(self, values) -> np.ndarray:
        """Relative violation: max(excess, 0) / |limit| (or / 1 for a zero limit)."""
        scale = abs(self.limit) if self.limit else 1.0
        return np.maximum(self.excess(values), 0.0) / scale


def _metric_name(at: Where, field: str, name, allowed: Sequence[str]) -> str:
    """``name`` if it is one of ``allowed``, else one line with a did-you-mean."""
    if not isinstance(name, str) or name not in allowed:
        near = closest_name(str(name), allowed)
        hint = f"did you mean {near!r}? " if near else ""
        at.fail(field, f"{name!r} is not a metric: {hint}choose from {', '.join(allowed)}")
    return name


def read_constraints(
    where: Where, data: Mapping, derived: Sequence[str] = ()
) -> tuple[Constraint, ...]:
    """The ``[[constraint]]`` tables (metric and exactly one of max, min)."""
    allowed = (*METRICS, *derived)
    constraints = []
    for i, table in enumerate(where.tables("constraint", data.get("constraint", []))):
        at = where.sub(f"constraint[{i}]")
        at.keys(table, _CONSTRAINT_FIELDS, required=("metric",))
        metric = _metric_name(at, "metric", table["metric"], allowed)
        given = [key for key in ("max", "min") if key in table]
        if len(given) != 1:
            at.fail_table("give exactly one of max (metric <= max), min (metric >= min)")
        limit = at.number(given[0], table[given[0]])
        constraints.append(Constraint(metric, limit, upper=given[0] == "max"))
    return tuple(constraints)


def read_objectives(where: Where, data: Mapping, derived: Sequence[str] = ()) -> tuple[str, ...]:
    """``objectives``: two or more distinct metrics (a Pareto front), or () if not given."""
    if "objectives" not in data:
        return ()
    if "objective" in data:
        where.fail("objectives", "give objective (one metric) or objectives (a front), not both")
    allowed = (*METRICS, *derived)
    items = where.items("objectives", data["objectives"], "metric name", required=True)
    names = [_metric_name(where, f"objectives[{i}]", m, allowed) for i, m in enumerate(items)]
    names = where.unique("objectives", names)
    if len(names) < 2:
        where.fail("objectives", "a front needs two or more metrics; use objective for one")
    return tuple(names)


def violation(frame: pd.DataFrame, constraints: Sequence[Constraint]) -> np.ndarray:
    """Summed relative violation of every row of ``frame`` (0: feasible; inf where a
    constrained metric is not a number)."""
    total = np.zeros(len(frame))
    for c in constraints:
        total = total + c.violation(frame[c.metric].to_numpy(float))
    return total


def excess_matrix(frame: pd.DataFrame, constraints: Sequence[Constraint]) -> np.ndarray:
    """(rows, constraints) signed excesses relative to each limit's size (<= 0: holds; a
    non-number is 1), pymoo's inequality-constraint layout."""
    columns = []
    for c in constraints:
        scale = abs(c.limit) if c.limit else 1.0
        e = c.excess(frame[c.metric].to_numpy(float)) / scale
        columns.append(np.where(np.isfinite(e), e, 1.0))
    return np.column_stack(columns) if columns else np.zeros((len(frame), 0))


def penalised(values: np.ndarray, violations: np.ndarray) -> np.ndarray:
    """The objective a search minimises: ``values`` where feasible, ``PENALTY (1 +
    violation)`` where not (NaN stays NaN: a failed point)."""
    values = np.asarray(values, dtype=float)
    out = np.where(violations > 0, PENALTY * (1.0 + np.minimum(violations, 1e3)), values)
    return np.where(np.isfinite(values) | (violations > 0), out, math.nan)


def feasible_rows(
    frame: pd.DataFrame, columns: Sequence[str], constraints: Sequence[Constraint], name: str
) -> pd.DataFrame:
    """The rows of ``frame`` with every ``columns`` finite and violation 0; a one-line
    :class:`StudyError` naming the constraints if there is none."""
    finite = np.all(np.isfinite(frame[list(columns)].to_numpy(float)), axis=1)
    ok = frame[finite & (frame[VIOLATION].to_numpy(float) == 0.0)]
    if ok.empty:
        held = "; ".join(map(str, constraints)) or "none"
        raise StudyError(
            f"{name}: no evaluated point has a finite {', '.join(columns)} and meets every"
            f" constraint (constraints: {held}; see points.csv)"
        )
    return ok


Derive = Callable[[pd.DataFrame], pd.DataFrame]  # adds the kind's derived columns to a frame


class Scorer:
    """Scores batches of searched points and keeps every scored point (:meth:`table`, the
    frame the optima are chosen from).

    A point's score holds each of ``metrics`` (record metrics), the kind's derived columns
    (``derive``), and its constraint :data:`VIOLATION`. Nominal: the record of the point.
    Robust (``draws``, a list of band samples, and ``quantile`` q): each metric is the q
    quantile of the point's records at every draw (the point's own values win over a draw's),
    NaN if any draw failed; the constraints then hold at that quantile too.
    """

    def __init__(
        self,
        evaluator,
        metrics: Sequence[str],
        constraints: Sequence[Constraint] = (),
        derive: Derive | None = None,
        draws: Sequence[Mapping[str, float]] = (),
        quantile: float | None = None,
    ):
        self.evaluator = evaluator
        self.metrics = tuple(dict.fromkeys(metrics))
        self.constraints = tuple(constraints)
        self.derive = derive
        self.draws = list(draws) if quantile is not None else []
        self.quantile = quantile
        self._log: list[pd.DataFrame] = []

    def frame(self, group: str, points: Sequence[Mapping[str, float]]) -> pd.DataFrame:
        """The scores of ``points`` (one row each, in order), evaluated in ``group``."""
        frame = pd.DataFrame([dict(p) for p in points])
        if self.draws:
            items = [(group, {**d, **p}) for p in points for d in self.draws]
        else:
            items = [(group, p) for p in points]
        rows = self.evaluator.evaluate(items)
        for m in self.metrics:
            y = np.array([_number(r.get(m)) for r in rows])
            if self.draws:
                y = y.reshape(len(points), len(self.draws))
                finite = np.all(np.isfinite(y), axis=1)
                q = np.quantile(np.where(finite[:, None], y, 0.0), self.quantile, axis=1)
                y = np.where(finite, q, math.nan)
            frame[m] = y
        if self.derive is not None:
            frame = self.derive(frame)
        frame[VIOLATION] = violation(frame, self.constraints)
        frame.insert(0, "stage", group)
        self._log.append(frame)
        return frame

    def objective(self, group: str, space, fixed: Mapping[str, float], column: str):
        """Batch objective over unit coordinates of ``space`` (with ``fixed`` values):
        (n, 1 + constraints) columns, ``column`` then each constraint's relative excess
        (:func:`excess_matrix`), which :mod:`ufmt.studies.optimise` penalises."""

        def batch(u: np.ndarray) -> np.ndarray:
            points = [{**fixed, **p} for p in space.points(u)]
            scored = self.frame(group, points)
            value = scored[column].to_numpy(float)
            return np.column_stack([value, excess_matrix(scored, self.constraints)])

        return batch

    def table(self) -> pd.DataFrame:
        """Every scored point, in scoring order."""
        return pd.concat(self._log, ignore_index=True) if self._log else pd.DataFrame()


def _number(value) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan
