"""A probability of meeting the specification as the tolerance optimiser's constraint: the
cheapest tolerances with P(metric <= level) >= p over a fixed sample of the uncertain inputs.

Common random numbers: the uncertain inputs are one fixed Latin hypercube of M samples u_i
(the study's ``uncertain`` bands, its seed), so the constraint is a deterministic function of
the tolerances. Each sample has its own separable budget of the form the nominal fit chose
(:mod:`ufmt.studies.tolerances`), ``y_i = r_i + sum_j c_ij tau_j`` (linear) or
``y_i^2 = r_i^2 + sum_j c_ij^2 tau_j^2`` (rss), solved exactly from k + 1 model runs at u_i
(every tolerance tight, then each loose alone; :func:`sample_budgets`).

The chance constraint on the sample reads: at least ``need = ceil(p M)`` of the M budgets
meet the level. With a fixed set S of samples that must meet it, the program (minimise
sum b_j / tau_j subject to y_i(tau) <= level for i in S, tau_min <= tau <= 1) is convex in
x = log tau (each budget is a sum of exponentials of x with non-negative weights; the cost
is too), solved by SLSQP with analytic gradients: its optimum is global. S starts as every
sample, then the sample binding hardest at the optimum (the largest y_i) is discarded and the
program solved again, until ``need`` are left: greedy sampling-and-discarding (Campi and
Garatti, J. Optim. Theory Appl. 148, 2011). The allocation meets the level in at least
``need`` of the sample's budgets, and the discarding is exact where the samples' budgets are
ordered (one sample binding at every allocation, e.g. an uncertain factor on the whole
budget); otherwise it is an upper bound on the chance-constrained optimum's cost.
"""

from __future__ import annotations

import math

import numpy as np

FEASIBILITY_RTOL = 1e-9  # a budget this close above the level meets it


def sample_points(tau_min: np.ndarray) -> np.ndarray:
    """The k + 1 normalised tolerance vectors of one sample's budget: every tolerance tight,
    then each loose alone."""
    k = len(tau_min)
    return np.vstack([tau_min, np.where(np.eye(k, dtype=bool), 1.0, tau_min)])


def sample_budgets(y: np.ndarray, tau_min: np.ndarray, form: str) -> tuple[np.ndarray, ...]:
    """(r (M,), c (M, k)) of each sample's budget, exact from its k + 1 runs ``y`` (M, k + 1)
    at :func:`sample_points`; a negative share (a source that lowers the metric) is 0."""
    power = 2 if form == "rss" else 1
    z = np.asarray(y, dtype=float) ** power
    c = np.maximum(z[:, 1:] - z[:, :1], 0.0) / (1.0 - tau_min**power)
    r = np.maximum(z[:, 0] - c @ tau_min**power, 0.0)
    return r ** (1 / power), c ** (1 / power)


def predict_samples(tau: np.ndarray, r: np.ndarray, c: np.ndarray, form: str) -> np.ndarray:
    """Each sample's budget at normalised tolerances ``tau`` (k,): (M,)."""
    if form == "rss":
        return np.sqrt(r**2 + ((c * tau) ** 2).sum(axis=1))
    return r + c @ tau


def allocate_with_probability(
    r: np.ndarray,
    c: np.ndarray,
    form: str,
    level: float,
    probability: float,
    tau_min: np.ndarray,
    b: np.ndarray,
) -> np.ndarray | None:
    """The cheapest normalised tolerances meeting ``level`` in at least ceil(p M) of the
    samples' budgets (greedy discarding of the hardest sample), or None where even the
    tightest tolerances do not."""
    need = math.ceil(probability * len(r) - 1e-12)
    at_tightest = predict_samples(tau_min, r, c, form)
    if np.count_nonzero(at_tightest <= level * (1 + FEASIBILITY_RTOL)) < need:
        return None
    kept = np.flatnonzero(at_tightest <= level * (1 + FEASIBILITY_RTOL))
    tau = _solve(r[kept], c[kept], form, level, tau_min, b)
    while len(kept) > need:
        y = predict_samples(tau, r[kept], c[kept], form)
        kept = np.delete(kept, int(np.argmax(y)))
        tau = _solve(r[kept], c[kept], form, level, tau_min, b)
    return tau


def _solve(r, c, form: str, level: float, tau_min: np.ndarray, b: np.ndarray) -> np.ndarray:
    """min sum b_j / tau_j s.t. every budget of (r, c) <= level, tau_min <= tau <= 1: convex
    in x = log tau, SLSQP from the tightest (feasible) point."""
    from scipy.optimize import minimize

    power = 2 if form == "rss" else 1
    weights, room = c**power, level**power - r**power  # sum_j w_ij e^(p x_j) <= room_i

    def cost(x):
        return float(b @ np.exp(-x)), -b * np.exp(-x)

    def slack(x):
        return room - weights @ np.exp(power * x)

    def slack_jacobian(x):
        return -weights * power * np.exp(power * x)

    lower = np.log(tau_min)
    if np.all(slack(np.zeros_like(lower)) >= 0):
        return np.ones_like(tau_min)  # every tolerance loose meets it
    result = minimize(
        cost,
        lower.copy(),
        jac=True,
        method="SLSQP",
        bounds=list(zip(lower, np.zeros_like(lower), strict=True)),
        constraints=[{"type": "ineq", "fun": slack, "jac": slack_jacobian}],
        options={"ftol": 1e-14, "maxiter": 500},
    )
    x = np.clip(result.x, lower, 0.0)
    if np.any(slack(x) < -FEASIBILITY_RTOL * np.abs(room)):  # pull back onto the feasible set
        x = _feasible(x, lower, slack)
    return np.exp(x)


def _feasible(x: np.ndarray, lower: np.ndarray, slack) -> np.ndarray:
    """The point on the segment from ``x`` to the tightest corner ``lower`` (feasible) where
    every constraint holds, by bisection."""
    low, high = 0.0, 1.0  # fraction of the way to lower
    for _ in range(60):
        mid = 0.5 * (low + high)
        if np.all(slack(x + mid * (lower - x)) >= 0):
            high = mid
        else:
            low = mid
    return x + high * (lower - x)
