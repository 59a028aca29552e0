"""Study kind ``optimise-design``: bearing stiffnesses that buy their price in PV.

Fields: ``[[bound]]`` over design parameters (the head air bearing's radial, axial and angular
stiffness in the packaged study), ``objective`` (a record metric, default the interferometer's
PV, :mod:`ufmt.studies.metric`), ``[cost]`` (parameter -> weight [the objective's unit per
multiple of the calibrated stiffness]), ``[optimiser]`` (:mod:`ufmt.studies.optimise`). The
study minimises ``objective + cost``, with ``cost = sum_i w_i k_i / k_i,calibrated``: each
weight ``w_i`` is what one calibrated stiffness's worth of bearing costs, so a stiffer bearing
must buy its price in the objective.

``[[constraint]]`` limits (``cost_nm`` is a metric here too), ``objectives = [...]`` (a Pareto
front, e.g. the objective against ``cost_nm``), ``intervals`` (the optimum against the
calibrated design over the documented bands) and ``robust`` are those of optimise-process
(:mod:`ufmt.studies.goals`, :mod:`ufmt.studies.pareto`, :mod:`ufmt.studies.decisions`).

Tables: ``optima.csv`` (the calibrated design and the optimum; ``objective`` names the metric,
``objective_nm`` is its value plus the cost), ``convergence.csv``, ``pareto.csv``,
``decisions.csv``; figures: the convergence and the trade-off of the objective against
stiffness cost, or the front.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from ufmt.design import PROCESS_PARAMETERS
from ufmt.errors import StudyError
from ufmt.plots.fronts import plot_front
from ufmt.plots.studies import plot_convergence, plot_design_tradeoff
from ufmt.studies import outputs
from ufmt.studies.decisions import (
    BAND_POINTS,
    DECISIONS,
    ROBUST_FIELDS,
    compare_to_base,
    draws,
    read_decisions,
    robust_label,
)
from ufmt.studies.decisions import FIELDS as DECISION_FIELDS
from ufmt.studies.fields import Parameters, read_bounds
from ufmt.studies.goals import Scorer, feasible_rows, read_constraints, read_objectives
from ufmt.studies.metric import metric_unit, metric_words, read_metric
from ufmt.studies.optimise import (
    CONVERGENCE,
    OPTIMA,
    Space,
    convergence_table,
    minimise,
    minimise_budget,
    read_optimiser,
    start_point,
)
from ufmt.studies.outputs import short
from ufmt.studies.pareto import budget as front_budget
from ufmt.studies.pareto import front_table, search_front
from ufmt.studies.spec import StudyKind
from ufmt.tables import Where

DERIVED = ("cost_nm",)  # the stiffness cost, beside the record's metrics
PARETO = "pareto.csv"  # the non-dominated designs of several objectives


def parse(where: Where, data: Mapping, parameters: Parameters) -> dict:
    """The searched design bounds and the cost weights."""
    bounds = read_bounds(where, data, parameters, required=True)
    for b in bounds:
        if b.parameter in PROCESS_PARAMETERS:
            where.sub(f"bound {b.parameter!r}").fail(
                "parameter", "optimise-design searches design parameters only"
            )
        if b.parameter in parameters.base:
            where.sub("base").fail(b.parameter, "is searched by optimise-design; remove it")
    cost = where.mapping("cost", data.get("cost", {}), "[cost]")
    at = where.sub("cost")
    at.keys(cost, [b.parameter for b in bounds])
    weights = {
        key: at.number(key, value, sign="nonnegative", unit="[nm per calibrated multiple]")
        for key, value in cost.items()
    }
    options = {
        "objective": read_metric(where, data, "objective"),
        "objectives": read_objectives(where, data, DERIVED),
        "constraints": read_constraints(where, data, DERIVED),
        "cost": weights,
        "optimiser": read_optimiser(where, data),
    }
    records = [m for m in options["objectives"] if m not in DERIVED]
    if records:  # a front: objective_nm is its first record metric + cost
        options["objective"] = records[0]
    decided = [b.parameter for b in bounds]
    decisions, inputs = read_decisions(where, data, parameters, decided, robust=True)
    return {"bounds": bounds, "options": {**options, **decisions}, "inputs": inputs}


def planned_points(study) -> int:
    """Upper bound on the points requested: the search (times the robust band samples), the
    calibrated design and the optima (their comparisons' band samples are logged apart)."""
    opts = study.options
    dim, options = len(study.bounds), opts["optimiser"]
    search = front_budget(dim, options) if opts["objectives"] else minimise_budget(dim, options)
    chosen = max(len(opts["objectives"]), 1)
    search *= max(opts["robust_samples"], 1)
    return search + 1 + chosen


def _cost(study, space: Space, baseline: Mapping):
    """The stiffness cost of parameter values (..., dim) [the objective's unit]."""
    reference = np.array([baseline.get(name, math.nan) for name in space.names])
    weights = np.array([study.options["cost"].get(name, 0.0) for name in space.names])
    unknown = [
        n for n, r, w in zip(space.names, reference, weights, strict=True) if w and not r > 0
    ]
    if unknown:
        Where(str(study.path), "cost", error=StudyError).fail(
            unknown[0],
            "the calibrated value is not a finite number > 0 (released or rigid), so a cost"
            " per calibrated multiple is undefined",
        )
    safe_reference = np.where(weights > 0, reference, 1.0)

    def cost(values: np.ndarray) -> np.ndarray:
        return (weights * values / safe_reference).sum(axis=-1)

    return cost


def _scorer(study, evaluator, space: Space, cost) -> Scorer:
    """The study's scorer: objective(s), constraints; ``cost_nm`` and ``objective_nm``
    (the objective + cost) derived from the stiffnesses; nominal or robust."""
    opts = study.options
    goals = [opts["objective"], *opts["objectives"], *(c.metric for c in opts["constraints"])]
    metrics = [m for m in goals if m not in DERIVED]

    def derive(frame: pd.DataFrame) -> pd.DataFrame:
        frame = frame.assign(cost_nm=cost(frame[list(space.names)].to_numpy(float)))
        return frame.assign(objective_nm=frame[opts["objective"]] + frame["cost_nm"])

    samples = draws(study.inputs, opts["robust_samples"], opts["interval_seed"])
    return Scorer(evaluator, metrics, opts["constraints"], derive, samples, opts["robust"])


def analyse(study, evaluator, baseline: Mapping, out_dir: Path) -> str:
    """Bearing stiffnesses minimising objective + stiffness cost (or the Pareto front of
    ``objectives``) among the designs meeting the constraints; returns the headline."""
    opts = study.options
    metric = opts["objective"]
    space = Space.from_bounds(study.bounds, baseline)
    reference = np.array([baseline.get(name, math.nan) for name in space.names])
    cost = _cost(study, space, baseline)
    scorer = _scorer(study, evaluator, space, cost)
    if opts["objectives"]:
        scored = search_front(scorer, space, opts["objectives"], opts["optimiser"])
        ok = feasible_rows(scored, opts["objectives"], opts["constraints"], study.name)
        front = front_table(ok, opts["objectives"], space.names)
        outputs.write_table(front, out_dir / PARETO)
        picked = {f"min-{m}": front.loc[front[m].idxmin()] for m in opts["objectives"]}
    else:
        objective = scorer.objective("search", space, {}, "objective_nm")
        found = minimise(objective, space.dim, opts["optimiser"], start_point(space, baseline))
        outputs.write_table(convergence_table([("search", found)]), out_dir / CONVERGENCE)
        ok = feasible_rows(scorer.table(), ["objective_nm"], opts["constraints"], study.name)
        picked = {"optimum": ok.loc[ok["objective_nm"].idxmin()]}
    candidates = {name: {n: float(r[n]) for n in space.names} for name, r in picked.items()}
    if np.all(np.isfinite(reference)):
        candidates = {"calibrated": dict(zip(space.names, reference, strict=True)), **candidates}
    rows = evaluator.evaluate([("optimum", p) for p in candidates.values()])
    optima = pd.DataFrame(
        [{"design": name, **row} for name, row in zip(candidates, rows, strict=True)]
    ).drop(columns=["group", "index"])
    optima["cost_nm"] = cost(optima[list(space.names)].to_numpy(float))
    optima["objective"] = ", ".join(opts["objectives"]) or metric
    optima["objective_nm"] = optima[metric] + optima["cost_nm"]
    if opts["robust"] is not None:
        for m in scorer.metrics:
            robust = {name: float(r[m]) for name, r in picked.items()}
            optima[f"{m}_{robust_label(opts['robust'])}"] = optima["design"].map(robust)
    outputs.write_table(optima, out_dir / OPTIMA)
    said, table = "", None
    if "calibrated" in candidates:
        chosen = {k: v for k, v in candidates.items() if k != "calibrated"}
        said, table = compare_to_base(
            study, evaluator, candidates["calibrated"], chosen, scorer.metrics
        )
    if table is not None:
        outputs.write_table(table, out_dir / DECISIONS)
    text = _front_text(opts, front) if opts["objectives"] else _text(opts, optima, space, reference)
    return text + (f" Decisions: {said}." if said else "")


def _text(opts: Mapping, optima: pd.DataFrame, space: Space, reference: np.ndarray) -> str:
    """The single-objective headline."""
    metric = opts["objective"]
    words, unit = metric_words(metric), metric_unit(metric)
    best = optima[optima["design"] == "optimum"].iloc[0]
    parts = []
    for name, ref in zip(space.names, reference, strict=True):
        ratio = f" ({short(best[name] / ref)}x calibrated)" if ref > 0 else ""
        parts.append(f"{name} = {short(best[name])}{ratio}")
    robust = f", {robust_label(opts['robust'])} over the bands" if opts["robust"] else ""
    text = (
        f"Objective {words} ({metric}{robust}) + stiffness cost: optimum {', '.join(parts)}:"
        f" {metric} {short(best[metric])} {unit}, cost {short(best['cost_nm'])} {unit},"
        f" objective {short(best['objective_nm'])} {unit}"
    )
    if opts["constraints"]:
        text += f" subject to {', '.join(map(str, opts['constraints']))}"
    if "calibrated" in set(optima["design"]):
        cal = optima[optima["design"] == "calibrated"].iloc[0]
        text += (
            f" (calibrated design: {metric} {short(cal[metric])} {unit},"
            f" objective {short(cal['objective_nm'])} {unit})"
        )
    return text + "."


def _front_text(opts: Mapping, front: pd.DataFrame) -> str:
    """The several-objectives headline: the front's size and each objective's span on it."""
    spans = [
        f"{metric_words(m)} ({m}) {short(front[m].min())}-{short(front[m].max())} {metric_unit(m)}"
        for m in opts["objectives"]
    ]
    return f"Pareto front of {len(front)} designs: " + "; ".join(spans) + "."


def figures(out_dir: Path) -> dict[str, Figure]:
    """The optimiser's convergence and the trade-off of the objective against stiffness cost;
    with several objectives, their Pareto front."""
    optima = outputs.read_table(out_dir / OPTIMA)
    objectives = str(optima["objective"].iloc[0]).split(", ")
    if len(objectives) > 1:
        front = outputs.read_table(out_dir / PARETO)
        chosen = optima[optima["design"] != "calibrated"]
        return {"pareto.png": plot_front(front, chosen, objectives)}
    points = outputs.read_table(out_dir / outputs.POINTS)
    return {
        "convergence.png": plot_convergence(outputs.read_table(out_dir / CONVERGENCE)),
        "tradeoff.png": plot_design_tradeoff(points, optima, outputs.read_meta(out_dir)),
    }


OPTIMISE_DESIGN = StudyKind(
    name="optimise-design",
    fields=(
        "bound",
        "objective",
        "objectives",
        "constraint",
        "cost",
        "optimiser",
        *DECISION_FIELDS,
        *ROBUST_FIELDS,
    ),
    tables=(OPTIMA, CONVERGENCE, PARETO, DECISIONS, BAND_POINTS),
    parse=parse,
    planned_points=planned_points,
    analyse=analyse,
    figures=figures,
)
