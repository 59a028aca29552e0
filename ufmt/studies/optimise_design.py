"""Study kind ``optimise-design``: bearing stiffnesses that buy their price in PV.

Fields: ``[[bound]]`` over design parameters (the head air bearing's radial, axial and angular
stiffness in the packaged study), ``objective`` (a record metric, default the interferometer's
PV, :mod:`ufmt.studies.metric`), ``[cost]`` (parameter -> weight [the objective's unit per
multiple of the calibrated stiffness]), ``[optimiser]`` (:mod:`ufmt.studies.optimise`). The
study minimises ``objective + cost``, with ``cost = sum_i w_i k_i / k_i,calibrated``: each
weight ``w_i`` is what one calibrated stiffness's worth of bearing costs, so a stiffer bearing
must buy its price in the objective.

Tables: ``optima.csv`` (the calibrated design and the optimum; ``objective`` names the metric,
``objective_nm`` is its value plus the cost), ``convergence.csv``; figures: the convergence and
the trade-off of the objective against stiffness cost.
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
from ufmt.plots.studies import plot_convergence, plot_design_tradeoff
from ufmt.studies import outputs
from ufmt.studies.fields import Parameters, read_bounds
from ufmt.studies.metric import metric_unit, metric_words, read_metric
from ufmt.studies.optimise import (
    CONVERGENCE,
    OPTIMA,
    Space,
    batch_objective,
    convergence_table,
    minimise,
    minimise_budget,
    read_optimiser,
    start_point,
)
from ufmt.studies.outputs import short
from ufmt.studies.spec import StudyKind
from ufmt.tables import Where


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
        "cost": weights,
        "optimiser": read_optimiser(where, data),
    }
    return {"bounds": bounds, "options": options}


def planned_points(study) -> int:
    """Upper bound on the points requested: the search, the calibrated design, the optimum."""
    return minimise_budget(len(study.bounds), study.options["optimiser"]) + 2


def analyse(study, evaluator, baseline: Mapping, out_dir: Path) -> str:
    """Bearing stiffnesses minimising objective + stiffness cost; returns the headline."""
    options = study.options["optimiser"]
    metric = study.options.get("objective", "pv_nm")
    words, unit = metric_words(metric), metric_unit(metric)
    space = Space.from_bounds(study.bounds, baseline)
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

    objective = batch_objective(evaluator, "search", space, {}, cost, metric=metric)
    found = minimise(objective, space.dim, options, start_point(space, baseline))
    candidates = {"optimum": space.points(found.u[None])[0]}
    if np.all(np.isfinite(reference)):
        candidates = {"calibrated": dict(zip(space.names, reference, strict=True)), **candidates}
    rows = evaluator.evaluate([("optimum", p) for p in candidates.values()])
    optima = pd.DataFrame(
        [{"design": name, **row} for name, row in zip(candidates, rows, strict=True)]
    ).drop(columns=["group", "index"])
    optima["cost_nm"] = cost(optima[list(space.names)].to_numpy(float))
    optima["objective"] = metric
    optima["objective_nm"] = optima[metric] + optima["cost_nm"]
    outputs.write_table(optima, out_dir / OPTIMA)
    outputs.write_table(convergence_table([("search", found)]), out_dir / CONVERGENCE)

    best = optima[optima["design"] == "optimum"].iloc[0]
    parts = []
    for name, ref in zip(space.names, reference, strict=True):
        ratio = f" ({short(best[name] / ref)}x calibrated)" if ref > 0 else ""
        parts.append(f"{name} = {short(best[name])}{ratio}")
    text = (
        f"Objective {words} ({metric}) + stiffness cost: optimum {', '.join(parts)}:"
        f" {metric} {short(best[metric])} {unit}, cost {short(best['cost_nm'])} {unit},"
        f" objective {short(best['objective_nm'])} {unit}"
    )
    if "calibrated" in candidates:
        cal = optima[optima["design"] == "calibrated"].iloc[0]
        text += (
            f" (calibrated design: {metric} {short(cal[metric])} {unit},"
            f" objective {short(cal['objective_nm'])} {unit})"
        )
    return text + "."


def figures(out_dir: Path) -> dict[str, Figure]:
    """The optimiser's convergence and the trade-off of PV against stiffness cost."""
    points = outputs.read_table(out_dir / outputs.POINTS)
    return {
        "convergence.png": plot_convergence(outputs.read_table(out_dir / CONVERGENCE)),
        "tradeoff.png": plot_design_tradeoff(
            points, outputs.read_table(out_dir / OPTIMA), outputs.read_meta(out_dir)
        ),
    }


OPTIMISE_DESIGN = StudyKind(
    name="optimise-design",
    fields=("bound", "objective", "cost", "optimiser"),
    tables=(OPTIMA, CONVERGENCE),
    parse=parse,
    planned_points=planned_points,
    analyse=analyse,
    figures=figures,
)
