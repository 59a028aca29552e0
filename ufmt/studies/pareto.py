"""Several objectives at once: the Pareto front of an optimiser study with ``objectives = [...]``
(:mod:`ufmt.studies.goals`), searched with NSGA-II.

Why pymoo: scipy has no multi-objective optimiser (its minimisers take one scalar objective, so
a front would need a scalarisation swept over weights, which misses the non-convex parts of a
front); pymoo's NSGA-II (Deb et al., IEEE Trans. Evol. Comput. 6, 2002) keeps a whole
population on the front, handles inequality constraints by constrained domination (a feasible
point beats an infeasible one; two infeasible ones by their violation) and takes a whole
generation as one batch, which the study's workers evaluate in parallel. It is maintained,
seeded and small.

Search: the unit box of the study's bounds; population ``popsize * dim`` (at least 8),
``maxiter + 1`` generations, ``seed`` (the ``[optimiser]`` table). The reported front is the
non-dominated set (:func:`nondominated`) of every feasible point the search evaluated, not only
the last population; the reported optima are the lowest of each objective on it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
import pandas as pd

MIN_POPULATION = 8
FAILED = 1e12  # an objective of a failed point (pymoo needs finite numbers)
CHUNK = 512  # rows compared at once in nondominated

#: (n, dim) unit coordinates -> ((n, objectives) values, (n, constraints) excesses <= 0 held)
Batch = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


def population(dim: int, options: Mapping) -> int:
    """NSGA-II population: ``popsize * dim``, at least :data:`MIN_POPULATION`."""
    return max(MIN_POPULATION, options["popsize"] * dim)


def budget(dim: int, options: Mapping) -> int:
    """Most evaluations of :func:`nsga2`: the population in each of ``maxiter + 1``
    generations."""
    return population(dim, options) * (options["maxiter"] + 1)


def nsga2(batch: Batch, dim: int, n_objectives: int, n_constraints: int, options: Mapping) -> None:
    """Run NSGA-II over the unit box; every generation is one call of ``batch`` (whose
    caller keeps the evaluated points)."""
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.core.problem import Problem
    from pymoo.optimize import minimize

    class _Problem(Problem):
        def __init__(self):
            super().__init__(
                n_var=dim, n_obj=n_objectives, n_ieq_constr=n_constraints, xl=0.0, xu=1.0
            )

        def _evaluate(self, x, out, *args, **kwargs):
            f, g = batch(np.atleast_2d(x))
            out["F"] = np.where(np.isfinite(f), f, FAILED)
            if n_constraints:
                out["G"] = g

    minimize(
        _Problem(),
        NSGA2(pop_size=population(dim, options)),
        ("n_gen", options["maxiter"] + 1),
        seed=options["seed"],
        verbose=False,
    )


def nondominated(values: np.ndarray) -> np.ndarray:
    """True for the rows of ``values`` (n, k) that no other row dominates (every objective
    minimised; a row dominates another if it is no worse in each objective and better in
    one). Equal rows do not dominate each other: both are kept."""
    values = np.asarray(values, dtype=float)
    keep = np.ones(len(values), dtype=bool)
    for start in range(0, len(values), CHUNK):
        block = values[start : start + CHUNK]
        no_worse = np.all(values[None, :, :] <= block[:, None, :], axis=2)
        better = np.any(values[None, :, :] < block[:, None, :], axis=2)
        keep[start : start + len(block)] = ~np.any(no_worse & better, axis=1)
    return keep


def front_table(
    scored: pd.DataFrame, objectives: Sequence[str], parameters: Sequence[str]
) -> pd.DataFrame:
    """The non-dominated rows of the feasible ``scored`` points (finite objectives), without
    repeats of the same parameters, sorted by the first objective."""
    unique = scored.drop_duplicates(list(parameters))
    front = unique[nondominated(unique[list(objectives)].to_numpy(float))]
    return front.sort_values(list(objectives), kind="stable").reset_index(drop=True)


def search_front(scorer, space, objectives: Sequence[str], options: Mapping) -> pd.DataFrame:
    """NSGA-II over ``space`` scoring each generation with ``scorer``
    (:class:`ufmt.studies.goals.Scorer`, group ``front``); returns every scored point."""
    from ufmt.studies.goals import excess_matrix

    constraints = scorer.constraints

    def batch(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        scored = scorer.frame("front", space.points(u))
        return scored[list(objectives)].to_numpy(float), excess_matrix(scored, constraints)

    nsga2(batch, space.dim, len(objectives), len(constraints), options)
    return scorer.table()
