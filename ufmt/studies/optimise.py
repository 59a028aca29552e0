"""Optimisers: minimum-PV and fastest cutting recipes, the PV-time Pareto front, bearing design.

Search coordinates: each bound maps to a unit coordinate ``u`` in [0, 1], linear in the value
or in its log10 for ``spacing = "log"`` bounds (stiffnesses span decades).

:func:`minimise` is global search followed by local convex refinement:

1. **Global**: :func:`scipy.optimize.differential_evolution` (seeded; ``vectorized`` with
   ``updating="deferred"`` so every generation is one batch the study's workers evaluate in
   parallel; no gradient polish). PV is multimodal where a spindle harmonic crosses a mode.
2. **Convex trust-region steps** (cvxpy): around the incumbent ``u0``, fit the convex
   quadratic ``q(d) = c + g.d + d.H.d / 2`` (``d = u - u0``, ``H`` positive semidefinite) to
   samples in the trust box by least squares (a semidefinite program), minimise ``q`` over the
   box intersected with the bounds (a convex QP), evaluate the candidate with the true model,
   accept it if it is better, and grow or shrink the box by the ratio of achieved to predicted
   decrease.

Every value this module reports comes from an evaluation of the true model (surrogates only
propose candidates), and each reported optimum is evaluated once more in group ``optimum``.

optimise-process (study kind): over rpm, feed and depth within Table 1's bounds,

* (a) the **minimum-PV recipe**: :func:`minimise` over all three;
* (b) the **fastest recipe** whose PV stays under ``target_pv_nm`` (default 100 nm). The
  cutting time of one finishing pass over the workpiece is :func:`cutting_time_min`: the slide
  travels the workpiece length along the feed (y) plus the tool-circle diameter 2R (the tool
  circle enters before the leading edge and clears the trailing edge), at the feed speed.
  Time depends on feed alone, so the fastest recipe is the largest feed ``v`` with
  ``min over (rpm, depth) of PV(rpm, v, depth) <= target`` (an epsilon-constraint problem):
  that minimum is found at ``pareto_levels`` feeds across the bounds, then by bisection on the
  feed between the last feasible and the first infeasible level;
* the **Pareto front** of PV against cutting time: the non-dominated points among every
  recipe evaluated in the study.

optimise-design (study kind): the design parameters within their bounds (the head air
bearing's radial, axial and angular stiffness in the packaged study) minimising
``PV + cost``, with ``cost = sum_i w_i k_i / k_i,calibrated`` [nm]: each weight ``w_i`` [nm]
is what one calibrated stiffness's worth of bearing costs, so a stiffer bearing must buy its
price in PV.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from ufmt.errors import StudyError, UfmtError
from ufmt.studies import outputs
from ufmt.studies.outputs import short

FAILED = 1e12  # objective of a failed point during global search
TRUST_RADIUS = 0.1  # initial trust box half-width in unit coordinates
MIN_RADIUS = 1e-3  # refinement stops below this half-width
BISECTION_STEPS = 4  # feed bisection steps for the fastest recipe

BatchObjective = Callable[[np.ndarray], np.ndarray]  # (n, dim) unit coordinates -> (n,)


# ---------------------------------------------------------------------------------------------
# search space


@dataclass(frozen=True)
class Space:
    """Box of parameters; ``log`` entries are searched in log10 of the value."""

    names: tuple[str, ...]
    low: np.ndarray
    high: np.ndarray
    log: np.ndarray

    @classmethod
    def from_bounds(cls, bounds, baseline: Mapping[str, float]) -> Space:
        """The box of study bounds, relative ones scaled by ``baseline``."""
        resolved = np.array([b.resolved(baseline) for b in bounds], dtype=float)
        return cls(
            tuple(b.parameter for b in bounds),
            resolved[:, 0],
            resolved[:, 1],
            np.array([b.log for b in bounds]),
        )

    @property
    def dim(self) -> int:
        """Number of searched parameters."""
        return len(self.names)

    def _search(self, values) -> np.ndarray:
        """Search coordinates: the value, or its log10 for log bounds."""
        v = np.asarray(values, dtype=float)
        return np.log10(v, out=v.copy(), where=self.log)

    def values(self, u: np.ndarray) -> np.ndarray:
        """Parameter values [SI] of unit coordinates ``u`` (..., dim)."""
        lo, hi = self._search(self.low), self._search(self.high)
        t = lo + np.clip(np.asarray(u, dtype=float), 0.0, 1.0) * (hi - lo)
        return np.power(10.0, t, out=t.copy(), where=self.log)

    def unit(self, values) -> np.ndarray:
        """Unit coordinates of parameter ``values`` (..., dim)."""
        lo, hi = self._search(self.low), self._search(self.high)
        return (self._search(values) - lo) / (hi - lo)

    def without(self, name: str) -> Space:
        """The box without parameter ``name``."""
        keep = [i for i, n in enumerate(self.names) if n != name]
        names = tuple(self.names[i] for i in keep)
        return Space(names, self.low[keep], self.high[keep], self.log[keep])

    def points(self, u: np.ndarray) -> list[dict[str, float]]:
        """Parameter dicts of the rows of ``u`` (n, dim)."""
        return [dict(zip(self.names, map(float, row), strict=True)) for row in self.values(u)]


# ---------------------------------------------------------------------------------------------
# search


@dataclass
class SearchResult:
    """Best point found: unit coordinates ``u``, objective ``value``; ``history`` holds every
    objective value in evaluation order (for convergence plots), the first ``n_global`` of them
    from the global search."""

    u: np.ndarray
    value: float
    history: list[float] = field(default_factory=list)
    n_global: int = 0


class _Recorder:
    """Wraps a batch objective, keeping every value and the best point seen."""

    def __init__(self, objective: BatchObjective):
        self.objective = objective
        self.history: list[float] = []
        self.best_u: np.ndarray | None = None
        self.best = math.inf

    def __call__(self, u: np.ndarray) -> np.ndarray:
        u = np.atleast_2d(u)
        values = np.asarray(self.objective(u), dtype=float)
        self.history += values.tolist()
        finite = np.where(np.isfinite(values), values, math.inf)
        i = int(np.argmin(finite))
        if finite[i] < self.best:
            self.best, self.best_u = float(finite[i]), u[i].copy()
        return values


def global_search(
    objective: BatchObjective, dim: int, options: Mapping, x0: np.ndarray | None = None
) -> SearchResult:
    """Differential evolution over the unit box, one batch per generation.

    ``options``: seed, popsize (population = popsize * dim), maxiter, tol (scipy's); ``x0``
    (optional) joins the initial population (the current design or recipe, so the result is
    never worse than it).
    """
    from scipy.optimize import differential_evolution

    recorder = _Recorder(objective)

    def batch(x: np.ndarray) -> np.ndarray:  # scipy's vectorized layout: x is (dim, S)
        values = recorder(x.T)
        return np.where(np.isfinite(values), values, FAILED)

    differential_evolution(
        batch,
        [(0.0, 1.0)] * dim,
        rng=np.random.default_rng(options["seed"]),
        popsize=options["popsize"],
        maxiter=options["maxiter"],
        tol=options["tol"],
        polish=False,
        updating="deferred",
        vectorized=True,
        x0=x0,
    )
    if recorder.best_u is None:
        raise StudyError(
            "global search: every evaluated point failed (status and message in points.csv)"
        )
    return SearchResult(recorder.best_u, recorder.best, recorder.history, len(recorder.history))


def fit_convex_quadratic(d: np.ndarray, y: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Least-squares convex quadratic ``c + g.d + d.H.d / 2`` through samples ``(d, y)``.

    Solved with cvxpy as a semidefinite program (``H`` positive semidefinite). Returns
    (c, g, H).
    """
    import cvxpy as cp

    n, dim = d.shape
    # fit in scaled coordinates (each d column and y spanning ~1), then scale back
    d_scale = np.where(np.ptp(d, axis=0) > 0, np.ptp(d, axis=0), 1.0)
    y_shift, y_scale = float(np.median(y)), max(float(np.ptp(y)), 1e-300)
    ds = d / d_scale
    outer = np.einsum("ni,nj->nij", ds, ds).reshape(n, dim * dim)
    H = cp.Variable((dim, dim), PSD=True)
    g = cp.Variable(dim)
    c = cp.Variable()
    residual = c + ds @ g + 0.5 * outer @ cp.vec(H, order="C") - (y - y_shift) / y_scale
    cp.Problem(cp.Minimize(cp.sum_squares(residual))).solve(solver=cp.CLARABEL)
    Hs = 0.5 * (H.value + H.value.T)
    return (
        float(c.value) * y_scale + y_shift,
        y_scale * np.asarray(g.value, dtype=float) / d_scale,
        y_scale * Hs / np.outer(d_scale, d_scale),
    )


def minimise_quadratic(
    g: np.ndarray, H: np.ndarray, low: np.ndarray, high: np.ndarray
) -> tuple[np.ndarray, float]:
    """Minimiser ``d`` of the convex ``g.d + d.H.d / 2`` over the box [low, high] (a QP solved
    with cvxpy) and its predicted change."""
    import cvxpy as cp

    d = cp.Variable(len(g))
    objective = g @ d + 0.5 * cp.quad_form(d, cp.psd_wrap(H))
    cp.Problem(cp.Minimize(objective), [d >= low, d <= high]).solve(solver=cp.CLARABEL)
    step = np.clip(np.asarray(d.value, dtype=float), low, high)
    return step, float(g @ step + 0.5 * step @ H @ step)


def trust_region_refine(
    objective: BatchObjective,
    u0: np.ndarray,
    f0: float,
    steps: int,
    seed: int,
    radius: float = TRUST_RADIUS,
) -> SearchResult:
    """Convex-surrogate trust-region steps from ``u0`` (objective ``f0``) in the unit box.

    Each step evaluates ``2 * (1 + dim + dim (dim + 1) / 2)`` samples in the trust box (the
    box's centre, its face centres, the rest uniform at random), fits a convex quadratic
    (:func:`fit_convex_quadratic`), evaluates the surrogate's minimiser
    (:func:`minimise_quadratic`) and accepts it if it lowers the objective.
    """
    rng = np.random.default_rng(seed)
    recorder = _Recorder(objective)
    u0 = np.asarray(u0, dtype=float)
    dim = len(u0)
    n_samples = 2 * (1 + dim + dim * (dim + 1) // 2)
    for _ in range(steps):
        if radius < MIN_RADIUS:
            break
        low = np.maximum(-radius, -u0)
        high = np.minimum(radius, 1.0 - u0)
        faces = np.concatenate([np.diag(high), np.diag(low)])
        extra = rng.uniform(low, high, size=(max(n_samples - 1 - 2 * dim, 0), dim))
        d = np.concatenate([faces, extra])
        y = recorder(u0 + d)
        d, y = np.vstack([np.zeros(dim), d]), np.concatenate([[f0], y])
        keep = np.isfinite(y)
        c, g, H = fit_convex_quadratic(d[keep], y[keep])
        step, predicted = minimise_quadratic(g, H, low, high)
        f_new = float(recorder(u0 + step)[0])
        achieved = f0 - f_new
        ratio = achieved / -predicted if predicted < 0 else (1.0 if achieved > 0 else 0.0)
        best_sample = int(np.argmin(np.where(keep, y, math.inf)))
        if np.isfinite(f_new) and f_new < min(f0, y[best_sample]):
            u0, f0 = u0 + step, f_new
        elif y[best_sample] < f0:
            u0, f0 = u0 + d[best_sample], float(y[best_sample])
        radius *= 2.0 if ratio > 0.75 else (0.5 if ratio < 0.25 else 1.0)
        radius = min(radius, 0.5)
    return SearchResult(u0, f0, recorder.history)


def minimise(
    objective: BatchObjective, dim: int, options: Mapping, x0: np.ndarray | None = None
) -> SearchResult:
    """Global search (from ``x0`` if given), then convex trust-region refinement."""
    found = global_search(objective, dim, options, x0)
    refined = trust_region_refine(
        objective, found.u, found.value, options["refine_steps"], options["seed"]
    )
    history = found.history + refined.history
    return SearchResult(refined.u, refined.value, history, found.n_global)


def minimise_budget(dim: int, options: Mapping) -> int:
    """Most evaluations :func:`minimise` requests: differential evolution's population
    (popsize * dim) for its initial generation and each of maxiter more, then per refinement
    step the trust-box samples and the surrogate's minimiser."""
    population = options["popsize"] * dim
    n_samples = 2 * (1 + dim + dim * (dim + 1) // 2)
    per_step = max(n_samples - 1, 2 * dim) + 1
    return population * (options["maxiter"] + 1) + options["refine_steps"] * per_step


def budget(study) -> int:
    """Upper bound on the points an optimiser study requests (its progress bar's total)."""
    options = study.options["optimiser"]
    dim = len(study.bounds)
    if study.kind == "optimise-design":
        return minimise_budget(dim, options) + 2  # + the calibrated design and the optimum
    stages = 1 + study.options["pareto_levels"] + BISECTION_STEPS
    return minimise_budget(dim, options) + (stages - 1) * minimise_budget(dim - 1, options) + 2


def pareto_mask(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """True for points not dominated in (a, b), both minimised (ties kept once)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    order = np.lexsort((b, a))
    mask = np.zeros(len(a), dtype=bool)
    best_b = math.inf
    for i in order:  # sorted by a then b: a point is on the front if it beats every b so far
        if b[i] < best_b:
            mask[i] = True
            best_b = b[i]
    return mask


def cutting_time_min(feed_mm_min: np.ndarray | float, travel_mm: float) -> np.ndarray | float:
    """Time of one finishing pass [min]: slide travel (workpiece length along y + 2 R) / feed."""
    return travel_mm / np.asarray(feed_mm_min, dtype=float)


# ---------------------------------------------------------------------------------------------
# study kinds


def _objective(evaluator, group: str, space: Space, fixed: Mapping, cost=None) -> BatchObjective:
    """Batch objective: PV [nm] (+ ``cost(values)``) of points of ``space`` with ``fixed``."""

    def objective(u: np.ndarray) -> np.ndarray:
        points = [{**fixed, **p} for p in space.points(u)]
        pv = evaluator.values(group, points)
        return pv if cost is None else pv + cost(space.values(u))

    return objective


def _convergence(stages: Sequence[tuple[str, SearchResult]]) -> pd.DataFrame:
    frames = []
    for stage, result in stages:
        values = np.asarray(result.history, dtype=float)
        best = np.minimum.accumulate(np.where(np.isfinite(values), values, math.inf))
        frames.append(
            pd.DataFrame(
                {
                    "stage": stage,
                    "phase": np.where(
                        np.arange(len(values)) < result.n_global, "global", "trust-region"
                    ),
                    "evaluation": np.arange(1, len(values) + 1),
                    "objective_nm": values,
                    "best_objective_nm": best,
                }
            )
        )
    return pd.concat(frames, ignore_index=True)


def _travel_mm(study, evaluator) -> float:
    """Slide travel of one pass [mm]: the study's workpiece length + 2 R, else the model's."""
    length = study.options["workpiece_length_mm"]
    radius = study.options["tool_radius_mm"]
    if length is not None:
        return length + 2.0 * radius
    from ufmt.evaluate import cutting_travel_mm

    try:
        return cutting_travel_mm(evaluator.model)
    except UfmtError as exc:
        raise StudyError(f"{study.path}: cutting time needs the workpiece: {exc}") from None


def _start(space: Space, baseline: Mapping) -> np.ndarray | None:
    """Unit coordinates of the baseline (calibrated design, reference process) if inside."""
    u = space.unit([baseline.get(name, math.nan) for name in space.names])
    return u if np.all((u >= 0.0) & (u <= 1.0)) else None


def run_optimise_process(study, evaluator, baseline: Mapping, out_dir: Path) -> str:
    """Minimum-PV recipe, fastest recipe under the PV target, Pareto front; returns headline.

    The searches (module docstring) propose recipes; the reported ones are the best of every
    evaluated recipe: the lowest PV, and the shortest time with PV <= target.
    """
    options = study.options["optimiser"]
    target = study.options["target_pv_nm"]
    travel = _travel_mm(study, evaluator)
    space = Space.from_bounds(study.bounds, baseline)
    objective = _objective(evaluator, "min-pv", space, {})
    stages = [("min-pv", minimise(objective, space.dim, options, _start(space, baseline)))]

    feed_i = space.names.index("feed_mm_min")
    others = space.without("feed_mm_min")
    level_feeds = np.linspace(space.low[feed_i], space.high[feed_i], study.options["pareto_levels"])

    def feasible_at(feed: float, stage: str) -> bool:
        """Whether min over (rpm, depth) of PV at this feed is <= target."""
        fixed = {"feed_mm_min": float(feed)}
        result = minimise(_objective(evaluator, stage, others, fixed), others.dim, options)
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

    table = evaluator.table()
    ok = table[table["status"] == "ok"].copy()
    ok["cutting_time_min"] = cutting_time_min(ok["feed_mm_min"], travel)
    recipes = {"min-pv": ok.loc[ok["pv_nm"].idxmin()]}
    under = ok[ok["pv_nm"] <= target].sort_values(["cutting_time_min", "pv_nm"], kind="stable")
    if not under.empty:
        recipes["fastest-under-target"] = under.iloc[0]
    points = [{n: float(r[n]) for n in space.names} for r in recipes.values()]
    rows = evaluator.evaluate([("optimum", p) for p in points])
    optima = pd.DataFrame(
        [{"optimum": name, **row} for name, row in zip(recipes, rows, strict=True)]
    ).drop(columns=["group", "index"])
    optima["travel_mm"] = travel
    optima["cutting_time_min"] = cutting_time_min(optima["feed_mm_min"], travel)
    optima["target_pv_nm"] = target
    outputs.write_table(optima, out_dir / outputs.OPTIMA)

    front = ok[pareto_mask(ok["cutting_time_min"], ok["pv_nm"])]
    front = front.sort_values("cutting_time_min").drop_duplicates(["cutting_time_min", "pv_nm"])
    outputs.write_table(front.reset_index(drop=True), out_dir / outputs.PARETO)
    outputs.write_table(_convergence(stages), out_dir / outputs.CONVERGENCE)

    best = optima.iloc[0]
    text = (
        f"Minimum PV {short(best['pv_nm'])} nm at {short(best['rpm'])} rpm,"
        f" {short(best['feed_mm_min'])} mm/min, {short(best['depth_um'])} um"
        f" ({short(best['cutting_time_min'])} min per pass)"
    )
    if under.empty:
        return text + f"; no recipe within the bounds keeps PV under {short(target)} nm."
    fast = optima.iloc[1]
    return text + (
        f"; fastest recipe with PV <= {short(target)} nm: {short(fast['feed_mm_min'])} mm/min"
        f" at {short(fast['rpm'])} rpm, {short(fast['depth_um'])} um,"
        f" {short(fast['cutting_time_min'])} min per pass (PV {short(fast['pv_nm'])} nm)."
    )


def run_optimise_design(study, evaluator, baseline: Mapping, out_dir: Path) -> str:
    """Bearing stiffnesses minimising PV + stiffness cost; returns the headline."""
    options = study.options["optimiser"]
    space = Space.from_bounds(study.bounds, baseline)
    reference = np.array([baseline.get(name, math.nan) for name in space.names])
    weights = np.array([study.options["cost"].get(name, 0.0) for name in space.names])
    unknown = [
        n for n, r, w in zip(space.names, reference, weights, strict=True) if w and not r > 0
    ]
    if unknown:
        raise StudyError(
            f"{study.path}: field 'cost.{unknown[0]}': the calibrated value is not a finite"
            " number > 0 (released or rigid), so a cost per calibrated multiple is undefined"
        )
    safe_reference = np.where(weights > 0, reference, 1.0)

    def cost(values: np.ndarray) -> np.ndarray:
        return (weights * values / safe_reference).sum(axis=-1)

    objective = _objective(evaluator, "search", space, {}, cost)
    found = minimise(objective, space.dim, options, _start(space, baseline))
    candidates = {"optimum": space.points(found.u[None])[0]}
    if np.all(np.isfinite(reference)):
        candidates = {"calibrated": dict(zip(space.names, reference, strict=True)), **candidates}
    rows = evaluator.evaluate([("optimum", p) for p in candidates.values()])
    optima = pd.DataFrame(
        [{"design": name, **row} for name, row in zip(candidates, rows, strict=True)]
    ).drop(columns=["group", "index"])
    optima["cost_nm"] = cost(optima[list(space.names)].to_numpy(float))
    optima["objective_nm"] = optima["pv_nm"] + optima["cost_nm"]
    outputs.write_table(optima, out_dir / outputs.OPTIMA)
    outputs.write_table(_convergence([("search", found)]), out_dir / outputs.CONVERGENCE)

    best = optima[optima["design"] == "optimum"].iloc[0]
    parts = []
    for name, ref in zip(space.names, reference, strict=True):
        ratio = f" ({short(best[name] / ref)}x calibrated)" if ref > 0 else ""
        parts.append(f"{name} = {short(best[name])}{ratio}")
    text = (
        f"Optimum {', '.join(parts)}: PV {short(best['pv_nm'])} nm, cost"
        f" {short(best['cost_nm'])} nm, objective {short(best['objective_nm'])} nm"
    )
    if "calibrated" in candidates:
        cal = optima[optima["design"] == "calibrated"].iloc[0]
        text += (
            f" (calibrated design: PV {short(cal['pv_nm'])} nm,"
            f" objective {short(cal['objective_nm'])} nm)"
        )
    return text + "."
