"""Study kind ``optimise-process``: cutting recipes (rpm, feed, depth) within Table 1's bounds.

Fields: ``[[bound]]`` over rpm, feed and depth (default: Table 1's ranges), ``objective``
(a record metric, default the interferometer's PV, :mod:`ufmt.studies.metric`), ``target``
(in the objective's unit, default 100; ``target_pv_nm`` is its older name),
``workpiece_length_mm`` and ``tool_radius_mm`` (both or neither; default: the model's
``[machine]``), ``pareto_levels`` (default 7), ``[optimiser]``
(:mod:`ufmt.studies.optimise`). The study finds

* (a) the **minimum recipe** (lowest objective; its row is named ``min-pv``):
  :func:`~ufmt.studies.optimise.minimise` over all three;
* (b) the **fastest recipe** whose objective stays under ``target``. The cutting time of one
  finishing pass over the workpiece is :func:`cutting_time_min`: the slide travels the
  workpiece length along the feed (y) plus the tool-circle diameter 2R (the tool circle enters
  before the leading edge and clears the trailing edge), at the feed speed. Time depends on
  feed alone, so the fastest recipe is the largest feed ``v`` with
  ``min over (rpm, depth) of objective(rpm, v, depth) <= target`` (an epsilon-constraint problem):
  that minimum is found at ``pareto_levels`` feeds across the bounds, then by bisection on the
  feed between the last feasible and the first infeasible level;
* the **Pareto front** of the objective against cutting time: the non-dominated points among
  every recipe evaluated in the study.

``[[constraint]]`` limits (:mod:`ufmt.studies.goals`; ``cutting_time_min`` is a metric here
too) hold for every reported recipe; ``objectives = [...]`` replaces (a) and (b) by the
Pareto front of several metrics (:mod:`ufmt.studies.pareto`, one ``min-<metric>`` row each);
``intervals`` compares each reported recipe with the base recipe over the documented bands and
``robust`` minimises a quantile over them (:mod:`ufmt.studies.decisions`).

Tables: ``optima.csv`` (with the ``objective`` metric's name and the ``target``),
``pareto.csv``, ``convergence.csv``, ``decisions.csv``; figures: the convergence and the Pareto
front. The headline names the objective.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from ufmt.design import PROCESS_PARAMETERS
from ufmt.errors import StudyError, UfmtError
from ufmt.evaluate import model_file
from ufmt.machining.process import TABLE1_RANGE
from ufmt.model.load import load_model
from ufmt.model.machine import machine_of
from ufmt.plots.fronts import plot_front
from ufmt.plots.studies import plot_convergence, plot_pareto
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
    pareto_mask,
    read_optimiser,
    start_point,
)
from ufmt.studies.outputs import short
from ufmt.studies.pareto import budget as front_budget
from ufmt.studies.pareto import front_table, search_front
from ufmt.studies.spec import Bound, StudyKind
from ufmt.tables import Where

BISECTION_STEPS = 4  # feed bisection steps for the fastest recipe
TABLE1_BOUNDS = {name: (low, high) for name, (low, high, _) in TABLE1_RANGE.items()}
PARETO = "pareto.csv"  # the non-dominated recipes in (cutting time, objective) or objectives
DERIVED = ("cutting_time_min",)  # a metric of the recipe itself, beside the record's


def parse(where: Where, data: Mapping, parameters: Parameters) -> dict:
    """The searched bounds (Table 1's where not given) and the kind's options."""
    given = read_bounds(where, data, parameters, required=False)
    for b in given:
        if b.parameter not in PROCESS_PARAMETERS:
            where.sub(f"bound {b.parameter!r}").fail(
                "parameter",
                f"optimise-process searches process parameters only ({', '.join(TABLE1_BOUNDS)})",
            )
    by_name = {b.parameter: b for b in given}
    bounds = tuple(by_name.get(p, Bound(p, *TABLE1_BOUNDS[p])) for p in TABLE1_BOUNDS)
    for b in bounds:
        if b.parameter in parameters.base:
            where.sub("base").fail(b.parameter, "is searched by optimise-process; remove it")
    if "target" in data and "target_pv_nm" in data:
        where.fail("target_pv_nm", "is the older name of 'target': give one of them")
    target_field = "target_pv_nm" if "target_pv_nm" in data else "target"
    options = {
        "objective": read_metric(where, data, "objective"),
        "target": where.number(target_field, data.get(target_field, 100.0), sign="positive"),
        "workpiece_length_mm": _optional_positive(where, data, "workpiece_length_mm"),
        "tool_radius_mm": _optional_positive(where, data, "tool_radius_mm"),
        "pareto_levels": where.integer("pareto_levels", data.get("pareto_levels", 7), 2),
        "optimiser": read_optimiser(where, data),
    }
    if (options["workpiece_length_mm"] is None) != (options["tool_radius_mm"] is None):
        where.fail("tool_radius_mm", "give both workpiece_length_mm and tool_radius_mm, or neither")
    options["objectives"] = read_objectives(where, data, DERIVED)
    options["constraints"] = read_constraints(where, data, DERIVED)
    decided = [b.parameter for b in bounds]
    decisions, inputs = read_decisions(where, data, parameters, decided, robust=True)
    return {"bounds": bounds, "options": {**options, **decisions}, "inputs": inputs}


def _optional_positive(where: Where, data: Mapping, field: str) -> float | None:
    """``data[field]`` as a finite number > 0, or None if not given."""
    return where.number(field, data[field], sign="positive") if field in data else None


def planned_points(study) -> int:
    """Upper bound on the points requested: the minimum-PV search over every bound, one search
    over the others per feed level and bisection step (or the front's search), each times
    the robust band samples; the optima (their comparisons' band samples are logged apart)."""
    opts = study.options
    options, dim = opts["optimiser"], len(study.bounds)
    if opts["objectives"]:
        search, chosen = front_budget(dim, options), len(opts["objectives"])
    else:
        stages = 1 + opts["pareto_levels"] + BISECTION_STEPS
        search = minimise_budget(dim, options) + (stages - 1) * minimise_budget(dim - 1, options)
        chosen = 2
    search *= max(opts["robust_samples"], 1)
    return search + chosen


def cutting_time_min(feed_mm_min: np.ndarray | float, travel_mm: float) -> np.ndarray | float:
    """Time of one finishing pass [min]: slide travel (workpiece length along y + 2 R) / feed."""
    return travel_mm / np.asarray(feed_mm_min, dtype=float)


def cutting_travel_mm(model: str | os.PathLike | None = None) -> float:
    """Slide travel of one finishing pass [mm]: workpiece length along y + 2 R, from the first
    touch of the tool circle to its exit (``Machine.cut_span`` of the model's ``[machine]``;
    None: the packaged UFMT)."""
    low, high = machine_of(load_model(model_file(model))).cut_span
    return (high - low) * 1e3


def _travel_mm(study, evaluator) -> float:
    """Slide travel of one pass [mm]: the study's workpiece length + 2 R, else the model's."""
    length = study.options["workpiece_length_mm"]
    radius = study.options["tool_radius_mm"]
    if length is not None:
        return length + 2.0 * radius
    try:
        return cutting_travel_mm(evaluator.model)
    except UfmtError as exc:
        raise StudyError(f"{study.path}: cutting time needs the workpiece: {exc}") from None


def _scorer(study, evaluator, travel: float) -> Scorer:
    """The study's scorer: its objective(s) and constraints, cutting time derived from feed,
    nominal or robust over its band samples."""
    opts = study.options
    goals = list(opts["objectives"] or [opts["objective"]])
    goals += [c.metric for c in opts["constraints"]]
    metrics = [m for m in goals if m not in DERIVED]

    def derive(frame: pd.DataFrame) -> pd.DataFrame:
        return frame.assign(cutting_time_min=cutting_time_min(frame["feed_mm_min"], travel))

    samples = draws(study.inputs, opts["robust_samples"], opts["interval_seed"])
    return Scorer(evaluator, metrics, opts["constraints"], derive, samples, opts["robust"])


def _minimum_and_fastest(study, scorer: Scorer, space: Space, baseline: Mapping) -> tuple:
    """Single objective: the searches of the module docstring; returns (recipes by name,
    stages, whether a recipe meets the target)."""
    opts = study.options
    options, target, metric = opts["optimiser"], opts["target"], opts["objective"]
    objective = scorer.objective("min-pv", space, {}, metric)
    stages = [("min-pv", minimise(objective, space.dim, options, start_point(space, baseline)))]
    feed_i = space.names.index("feed_mm_min")
    others = space.without("feed_mm_min")
    level_feeds = np.linspace(space.low[feed_i], space.high[feed_i], opts["pareto_levels"])

    def feasible_at(feed: float, stage: str) -> bool:
        """Whether min over (rpm, depth) of the objective at this feed is <= target."""
        stage_objective = scorer.objective(stage, others, {"feed_mm_min": float(feed)}, metric)
        result = minimise(stage_objective, others.dim, options)
        stages.append((stage, result))
        return result.value <= target

    feasible = [feasible_at(f, f"feed-{f:.4g}") for f in level_feeds]
    if any(feasible):
        k = len(feasible) - 1 - feasible[::-1].index(True)
        if k + 1 < len(level_feeds):
            lo, hi = level_feeds[k], level_feeds[k + 1]
            for step in range(BISECTION_STEPS):
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if feasible_at(mid, f"bisect-{step + 1}") else (lo, mid)
    ok = feasible_rows(scorer.table(), [metric], opts["constraints"], study.name)
    recipes = {"min-pv": ok.loc[ok[metric].idxmin()]}
    under = ok[ok[metric] <= target].sort_values(["cutting_time_min", metric], kind="stable")
    if not under.empty:
        recipes["fastest-under-target"] = under.iloc[0]
    return recipes, stages, ok


def analyse(study, evaluator, baseline: Mapping, out_dir: Path) -> str:
    """Minimum recipe, fastest recipe under the target and the front of the objective against
    cutting time; or, with ``objectives``, the Pareto front of them all. Returns the headline.

    The searches (module docstring) propose recipes; the reported ones are the best of every
    scored recipe that meets the constraints: the lowest objective, and the shortest time with
    objective <= target (or, with ``objectives``, the lowest of each on the front).
    """
    opts = study.options
    travel = _travel_mm(study, evaluator)
    space = Space.from_bounds(study.bounds, baseline)
    scorer = _scorer(study, evaluator, travel)
    if opts["objectives"]:
        scored = search_front(scorer, space, opts["objectives"], opts["optimiser"])
        ok = feasible_rows(scored, opts["objectives"], opts["constraints"], study.name)
        front = front_table(ok, opts["objectives"], space.names)
        recipes = {f"min-{m}": front.loc[front[m].idxmin()] for m in opts["objectives"]}
    else:
        recipes, stages, ok = _minimum_and_fastest(study, scorer, space, baseline)
        metric = opts["objective"]
        front = ok[pareto_mask(ok["cutting_time_min"], ok[metric])]
        front = front.sort_values("cutting_time_min").drop_duplicates(["cutting_time_min", metric])
        outputs.write_table(convergence_table(stages), out_dir / CONVERGENCE)
    chosen = {name: {n: float(r[n]) for n in space.names} for name, r in recipes.items()}
    rows = evaluator.evaluate([("optimum", p) for p in chosen.values()])
    optima = pd.DataFrame(
        [{"optimum": name, **row} for name, row in zip(recipes, rows, strict=True)]
    ).drop(columns=["group", "index"])
    optima["travel_mm"] = travel
    optima["cutting_time_min"] = cutting_time_min(optima["feed_mm_min"], travel)
    optima["objective"] = ", ".join(opts["objectives"]) or opts["objective"]
    optima["target"] = opts["target"]
    if opts["robust"] is not None:
        label = robust_label(opts["robust"])
        for m in scorer.metrics:
            optima[f"{m}_{label}"] = [float(r[m]) for r in recipes.values()]
    outputs.write_table(optima, out_dir / OPTIMA)
    outputs.write_table(front.reset_index(drop=True), out_dir / PARETO)
    base = {n: float(baseline[n]) for n in space.names}
    said, table = compare_to_base(study, evaluator, base, chosen, scorer.metrics)
    if table is not None:
        outputs.write_table(table, out_dir / DECISIONS)
    text = _front_text(study, front) if opts["objectives"] else _text(study, optima)
    return text + (f" Decisions: {said}." if said else "")


def _text(study, optima: pd.DataFrame) -> str:
    """The single-objective headline."""
    opts = study.options
    metric, target = opts["objective"], opts["target"]
    words, unit = metric_words(metric), metric_unit(metric)
    best = optima.iloc[0]
    text = (
        f"Objective {words} ({metric}{_robust_words(opts)}): minimum {short(best[metric])}"
        f" {unit} at {short(best['rpm'])} rpm, {short(best['feed_mm_min'])} mm/min,"
        f" {short(best['depth_um'])} um ({short(best['cutting_time_min'])} min per pass)"
    )
    if opts["constraints"]:
        text += f" subject to {', '.join(map(str, opts['constraints']))}"
    if len(optima) < 2:
        return text + f"; no recipe within the bounds keeps it under {short(target)} {unit}."
    fast = optima.iloc[1]
    return text + (
        f"; fastest recipe with {metric} <= {short(target)} {unit}:"
        f" {short(fast['feed_mm_min'])} mm/min at {short(fast['rpm'])} rpm,"
        f" {short(fast['depth_um'])} um, {short(fast['cutting_time_min'])} min per pass"
        f" ({short(fast[metric])} {unit})."
    )


def _front_text(study, front: pd.DataFrame) -> str:
    """The several-objectives headline: the front's size and each objective's span on it."""
    opts = study.options
    spans = [
        f"{metric_words(m)} ({m}) {short(front[m].min())}-{short(front[m].max())} {metric_unit(m)}"
        for m in opts["objectives"]
    ]
    text = f"Pareto front{_robust_words(opts)} of {len(front)} recipes: " + "; ".join(spans)
    if opts["constraints"]:
        text += f" (subject to {', '.join(map(str, opts['constraints']))})"
    return text + "."


def _robust_words(opts: Mapping) -> str:
    """', q90 over 8 band samples' for a robust study, else ''."""
    if opts["robust"] is None:
        return ""
    return f", {robust_label(opts['robust'])} over {opts['robust_samples']} band samples"


def figures(out_dir: Path) -> dict[str, Figure]:
    """The optimiser's convergence and the front of the objective against cutting time; with
    several objectives, their Pareto front."""
    optima = outputs.read_table(out_dir / OPTIMA)
    objectives = str(optima["objective"].iloc[0]).split(", ") if "objective" in optima else []
    if len(objectives) > 1:
        front = outputs.read_table(out_dir / PARETO)
        return {"pareto.png": plot_front(front, optima, objectives)}
    points = outputs.read_table(out_dir / outputs.POINTS)
    return {
        "convergence.png": plot_convergence(outputs.read_table(out_dir / CONVERGENCE)),
        "pareto.png": plot_pareto(
            points,
            outputs.read_table(out_dir / PARETO),
            outputs.read_table(out_dir / OPTIMA),
            bounds=outputs.read_meta(out_dir).get("bounds"),
        ),
    }


OPTIMISE_PROCESS = StudyKind(
    name="optimise-process",
    fields=(
        "bound",
        "objective",
        "target",
        "target_pv_nm",
        "workpiece_length_mm",
        "tool_radius_mm",
        "pareto_levels",
        "optimiser",
        "objectives",
        "constraint",
        *DECISION_FIELDS,
        *ROBUST_FIELDS,
    ),
    tables=(OPTIMA, PARETO, CONVERGENCE, DECISIONS, BAND_POINTS),
    parse=parse,
    planned_points=planned_points,
    analyse=analyse,
    figures=figures,
)
