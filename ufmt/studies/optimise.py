"""The optimiser of the optimise-process and optimise-design study kinds, and what both kinds
share: the ``[optimiser]`` table, the batch objective, the convergence table.

Search coordinates: each bound maps to a unit coordinate ``u`` in [0, 1], linear in the value
or in its log10 for ``spacing = "log"`` bounds (stiffnesses span decades).

:func:`minimise` is global search followed by local convex refinement:

1. **Global**: :func:`scipy.optimize.differential_evolution` (seeded; ``vectorized`` with
   ``updating="deferred"`` so every generation is one batch the study's workers evaluate in
   parallel, in chunks each evaluated as one batch (:mod:`ufmt.studies.parallel`); no
   gradient polish). PV is multimodal where a spindle harmonic crosses a mode.
2. **Convex trust-region steps** (cvxpy): around the incumbent ``u0``, fit the convex
   quadratic ``q(d) = c + g.d + d.H.d / 2`` (``d = u - u0``, ``H`` positive semidefinite) to
   samples in the trust box by least squares (a semidefinite program), minimise ``q`` over the
   box intersected with the bounds (a convex QP), evaluate the candidate with the true model,
   accept it if it is better, and grow or shrink the box by the ratio of achieved to predicted
   decrease.

Every value the optimiser kinds report comes from an evaluation of the true model (surrogates
only propose candidates), and each reported optimum is evaluated once more in group
``optimum``.

``[optimiser]`` fields: ``seed``, ``popsize`` (population = popsize * searched parameters),
``maxiter`` (generations after the first), ``tol`` (scipy's), ``refine_steps`` (trust-region
steps).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from ufmt.errors import StudyError
from ufmt.studies.goals import PENALTY, penalised
from ufmt.tables import Where

FAILED = 1e12  # objective of a failed point during global search
TRUST_RADIUS = 0.1  # initial trust box half-width in unit coordinates
MIN_RADIUS = 1e-3  # refinement stops below this half-width
OPTIMISER_DEFAULTS = {"seed": 1, "popsize": 8, "maxiter": 20, "tol": 1e-3, "refine_steps": 4}
OPTIMA = "optima.csv"  # the reported optima, each evaluated once more
CONVERGENCE = "convergence.csv"  # every objective value of every search stage

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
    """Wraps a batch objective, keeping every (penalised) value and the best point seen.

    The objective returns (n,) values, or (n, 1 + m): the value and m constraint excesses
    (<= 0 where each holds, :mod:`ufmt.studies.goals`); a call returns the penalised values
    (:func:`ufmt.studies.goals.penalised`) and keeps the parts in ``last``.
    """

    def __init__(self, objective: BatchObjective):
        self.objective = objective
        self.history: list[float] = []
        self.best_u: np.ndarray | None = None
        self.best = math.inf
        self.last: tuple[np.ndarray, np.ndarray] = (np.zeros(0), np.zeros((0, 0)))

    def __call__(self, u: np.ndarray) -> np.ndarray:
        u = np.atleast_2d(u)
        raw = np.asarray(self.objective(u), dtype=float)
        raw = raw[:, None] if raw.ndim == 1 else raw
        f, g = raw[:, 0], raw[:, 1:]
        self.last = (f, g)
        values = penalised(f, np.maximum(g, 0.0).sum(axis=1))
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
    g: np.ndarray,
    H: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    linear: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, float]:
    """Minimiser ``d`` of the convex ``g.d + d.H.d / 2`` over the box [low, high] (a QP solved
    with cvxpy) and its predicted change; ``linear = (a, B)`` adds ``a + B d <= 0`` (the
    constraints' linear models), dropped where no step in the box meets them."""
    import cvxpy as cp

    d = cp.Variable(len(g))
    objective = cp.Minimize(g @ d + 0.5 * cp.quad_form(d, cp.psd_wrap(H)))
    box = [d >= low, d <= high]
    problem = cp.Problem(objective, box + ([linear[0] + linear[1] @ d <= 0] if linear else []))
    problem.solve(solver=cp.CLARABEL)
    if d.value is None or problem.status not in ("optimal", "optimal_inaccurate"):
        cp.Problem(objective, box).solve(solver=cp.CLARABEL)
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
    (:func:`fit_convex_quadratic`) to the objective and, for a constrained objective, a
    linear model to each constraint's excess (least squares), evaluates the surrogate's
    minimiser subject to the linear models (:func:`minimise_quadratic`, a sequential-QP step)
    and accepts it if it lowers the penalised objective.
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
        d = np.concatenate([np.zeros((1, dim)), faces, extra])  # the centre: a reused point
        y = recorder(u0 + d)
        f, excess = recorder.last
        keep = np.isfinite(f)
        c, g, H = fit_convex_quadratic(d[keep], f[keep])
        step, predicted = minimise_quadratic(g, H, low, high, _linear_models(d, excess, keep))
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


def _linear_models(d: np.ndarray, excess: np.ndarray, keep: np.ndarray):
    """Least-squares ``a + B d`` of each constraint's excess (columns of ``excess``) over the
    samples ``d`` kept, or None without constraints."""
    if excess.shape[1] == 0:
        return None
    rows = keep & np.all(np.isfinite(excess), axis=1)
    design = np.column_stack([np.ones(rows.sum()), d[rows]])
    coefficients, *_ = np.linalg.lstsq(design, excess[rows], rcond=None)
    return coefficients[0], coefficients[1:].T


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
    per_step = max(n_samples - 1, 2 * dim) + 2  # the samples, the centre, the candidate
    return population * (options["maxiter"] + 1) + options["refine_steps"] * per_step


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


# ---------------------------------------------------------------------------------------------
# shared by the optimiser study kinds


def read_optimiser(where: Where, data: Mapping) -> dict[str, Any]:
    """The ``[optimiser]`` table of ``data`` (at ``where``) with its defaults filled."""
    table = where.mapping("optimiser", data.get("optimiser", {}), "[optimiser]")
    at = where.sub("optimiser")
    at.keys(table, tuple(OPTIMISER_DEFAULTS))
    options = dict(OPTIMISER_DEFAULTS)
    for key in ("seed", "refine_steps"):
        options[key] = at.integer(key, table.get(key, options[key]), 0)
    for key in ("popsize", "maxiter"):
        options[key] = at.integer(key, table.get(key, options[key]), 1)
    options["tol"] = at.number("tol", table.get("tol", options["tol"]), sign="nonnegative")
    return options


def convergence_table(stages: Sequence[tuple[str, SearchResult]]) -> pd.DataFrame:
    """Every objective value [nm] of each (stage, search), in evaluation order, with its phase
    (global or trust-region) and the best value so far (the table of ``convergence.csv``); a
    point that breaks a constraint has no value (its penalty is not an objective)."""
    frames = []
    for stage, result in stages:
        values = np.asarray(result.history, dtype=float)
        values = np.where(values < PENALTY, values, math.nan)
        best = np.minimum.accumulate(np.where(np.isfinite(values), values, math.inf))
        best = np.where(np.isfinite(best), best, math.nan)  # none feasible yet
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


def start_point(space: Space, baseline: Mapping) -> np.ndarray | None:
    """Unit coordinates of the baseline (calibrated design, reference process) if inside."""
    u = space.unit([baseline.get(name, math.nan) for name in space.names])
    return u if np.all((u >= 0.0) & (u <= 1.0)) else None
