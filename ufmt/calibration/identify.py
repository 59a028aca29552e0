"""Identification of hinge stiffnesses against the modal test (paper section 2.5, "MSTMM&GA").

Sensitivity-based model updating in log-stiffness. Each parameter p scales listed components of
listed hinges by one factor, ``k = s_p k_prior``, and is identified as ``u_p = ln s_p`` within
``ln band_p``. With the paired model modes f_m(u) and the test frequencies f_t,m the cost is

    J(u) = sum_m (ln f_m(u) - ln f_t,m)^2 + rho^2 sum_p u_p^2 + penalty * (shape mismatches)

where a shape mismatch is a tested mode whose computed shape contradicts its Table 3 tag (wrong
symmetry class or a named body that does not move;
:func:`ufmt.calibration.frequencies.check_tag`), a mode that is not paired by order, or a
tool-tip z mode of section 4.1 whose tool tip moves less in z than its neighbours'
(:func:`ufmt.calibration.frequencies.tool_tip_neighbours`).

Local iteration: at u_i, with the residual r and the exact sensitivities S = d ln f / d u,
cvxpy solves the bounded, regularised least-squares step

    min_d |r + S d|^2 + rho^2 |u_i + d|^2
    s.t.  |d_p| <= t  and  ln band_p[0] <= u_i,p + d_p <= ln band_p[1]

and the step is taken if J decreases, else t is halved (a trust region). It stops when no
paired frequency changes by more than ``tolerance_percent`` in a step, t falls below
``min_trust_region``, or after ``max_iterations``. It stalls when it stops with the
acceptance levels unmet; then scipy's differential evolution searches all of ln band for the
lowest J (deterministic seed, the local result in its initial population), and the local
iteration restarts from its best point. The lower J of the two runs is kept.

Pairing inside the loop is by symmetry class and rank
(:func:`ufmt.calibration.frequencies.pair_by_class`):
for a model whose class sequence is Table 3's it is the pairing by order, and it keeps J smooth
when modes of different classes (e.g. Table 3 modes 12 and 13, 0.4 % apart) change places.
Pairing by order is enforced through the penalty and checked again on the final MSTMM solution.

Cheap model. J and the exact sensitivities S come from the reduced model of
:class:`ufmt.calibration.reduced.ReducedModel` (the prior assembled once; stiffness affine in
the factors); the result is checked by the MSTMM at the end (:mod:`ufmt.calibration.pipeline`,
``ufmt calibrate`` reports the difference).

The calibration file is read by :mod:`ufmt.calibration.settings`; the whole run (identify,
check, fit the response, write the model and the log) is :mod:`ufmt.calibration.pipeline`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np
import pandas as pd
from scipy.optimize import differential_evolution
from threadpoolctl import threadpool_limits
from tqdm import tqdm

from ufmt.calibration.frequencies import (
    ModeSet,
    Reference,
    check_tag,
    pair_by_class,
    tool_tip_neighbours,
)
from ufmt.calibration.reduced import ReducedModel
from ufmt.calibration.rounding import rounded
from ufmt.calibration.settings import Constraint, Parameter, Settings, Targets
from ufmt.model.schema import Model

UNPAIRED_RESIDUAL = 1.0  # ln-frequency residual of a Table 3 mode with no model partner


# ---------------------------------------------------------------------------------------------
# the objective


@dataclass(frozen=True, eq=False)
class Evaluation:
    """The model at one point u: frequencies, pairing, residuals, mismatches and J."""

    u: np.ndarray
    frequencies_hz: np.ndarray
    shapes: np.ndarray
    modes: ModeSet
    paired: np.ndarray  # model mode index per target (-1: none)
    residual: np.ndarray  # ln f_model - ln f_target per target
    mismatches: dict[int, str]  # target mode -> reason
    shares: np.ndarray  # strain-energy share of the constrained hinges per target (0: none)
    constraint: np.ndarray  # its violation per target [ln f] (>= 0)
    cost: float

    @property
    def errors_percent(self) -> np.ndarray:
        """Frequency error of each paired target [%]."""
        return 100.0 * np.expm1(self.residual)


@dataclass(frozen=True, eq=False)
class Problem:
    """Targets, reference tags and the cheap model: evaluates J (module docstring)."""

    reduced: ReducedModel
    targets: Targets
    reference: Reference | None
    settings: Settings
    constraint: Constraint | None = None
    lower: np.ndarray = field(init=False)
    upper: np.ndarray = field(init=False)

    def __post_init__(self):
        bands = np.log(np.array([p.band for p in self.reduced.parameters]))
        object.__setattr__(self, "lower", bands[:, 0])
        object.__setattr__(self, "upper", bands[:, 1])

    def evaluate(self, u) -> Evaluation:
        u = np.asarray(u, dtype=float)
        f, shapes = self.reduced.solve(u, self.settings.n_modes)
        modes = self.reduced.modeset(f, shapes)
        numbers = self.targets.modes
        if self.reference is None:
            paired = np.array([k - 1 for k in numbers])
        else:
            paired = pair_by_class(self.reference, numbers, modes)
        ok = paired >= 0
        residual = np.full(len(numbers), UNPAIRED_RESIDUAL)
        residual[ok] = np.log(f[paired[ok]] / self.targets.frequencies_hz[ok])
        mismatches = self._mismatches(modes, paired)
        shares = self.shares(u, f, shapes, paired)
        violation = self.constraint.violation(shares) if self.constraint else np.zeros(0)
        weight = self.constraint.weight if self.constraint else 0.0
        cost = (
            float(residual @ residual)
            + self.settings.regularisation**2 * float(u @ u)
            + self.settings.shape_penalty * len(mismatches)
            + weight**2 * float(violation @ violation)
        )
        return Evaluation(
            u, f, shapes, modes, paired, residual, mismatches, shares, violation, cost
        )

    def shares(self, u, frequencies_hz, shapes, paired) -> np.ndarray:
        """Strain-energy share of the constrained hinges in each paired target mode."""
        if self.constraint is None:
            return np.zeros(0)
        ok = paired >= 0
        if self.constraint.modes:
            ok &= np.isin(self.targets.modes, self.constraint.modes)
        out = np.zeros(len(paired))
        out[ok] = self.reduced.energy_shares(
            u, frequencies_hz[paired[ok]], shapes[paired[ok]], self.constraint.hinges
        )
        return out

    def constraint_jacobian(self, e: Evaluation, step: float = 1e-5) -> np.ndarray:
        """d share / d u (targets, P) by forward differences (same pairing as ``e``)."""
        cols = []
        for p in range(e.u.size):
            u = e.u.copy()
            u[p] += step
            f, shapes = self.reduced.solve(u, self.settings.n_modes)
            cols.append((self.shares(u, f, shapes, e.paired) - e.shares) / step)
        return np.array(cols).T

    def _mismatches(self, modes: ModeSet, paired: np.ndarray) -> dict[int, str]:
        out = {}
        for k, j in zip(self.targets.modes, paired, strict=True):
            if j < 0:
                out[k] = "no model mode of its class"
            elif j != k - 1:
                out[k] = f"paired with model mode {j + 1}, not by order"
            elif self.reference is not None and self.reference.modes[k].tag is not None:
                status, detail = check_tag(modes, j, self.reference.modes[k].tag)
                if status in ("class", "bodies"):
                    out[k] = f"{status}: {detail}"
        if self.reference is not None and self.reference.tool_tip_z_modes:
            tip = [k for k in self.reference.tool_tip_z_modes if k <= modes.frequencies_hz.size]
            for k, above in tool_tip_neighbours(modes, tip).items():
                if not above and k not in out:
                    out[k] = "tool tip moves less in z than in a neighbouring mode"
        return out

    def cost(self, u) -> float:
        """J(u) (for the global search)."""
        return self.evaluate(u).cost


# ---------------------------------------------------------------------------------------------
# local iteration and global start


class _StepProblem:
    """The cvxpy bounded, regularised least-squares step (built once, re-solved per step).

    With a constraint, its linearised violation ``w pos(a + G d)`` (a: share - limit times
    ln(factor)/2, G its gradient) joins the squared residuals.
    """

    def __init__(self, n_targets: int, n_params: int, rho: float, constraint=None):
        self.d = cp.Variable(n_params)
        self.sens = cp.Parameter((n_targets, n_params))
        self.res = cp.Parameter(n_targets)
        self.u = cp.Parameter(n_params)
        self.low = cp.Parameter(n_params)
        self.high = cp.Parameter(n_params)
        self.trust = cp.Parameter(nonneg=True)
        objective = cp.sum_squares(self.res + self.sens @ self.d) + rho**2 * cp.sum_squares(
            self.u + self.d
        )
        self.constraint = constraint
        if constraint is not None:
            self.excess = cp.Parameter(n_targets)
            self.gradient = cp.Parameter((n_targets, n_params))
            objective += constraint.weight**2 * cp.sum_squares(
                cp.pos(self.excess + self.gradient @ self.d)
            )
        constraints = [
            cp.abs(self.d) <= self.trust,
            self.u + self.d >= self.low,
            self.u + self.d <= self.high,
        ]
        self.problem = cp.Problem(cp.Minimize(objective), constraints)

    def step(self, sens, res, u, low, high, trust, shares=None, gradient=None) -> np.ndarray:
        self.sens.value, self.res.value, self.u.value = sens, res, u
        self.low.value, self.high.value, self.trust.value = low, high, trust
        if self.constraint is not None:
            half = 0.5 * math.log(self.constraint.factor)
            self.excess.value = half * (shares - self.constraint.limit)
            self.gradient.value = half * gradient
        self.problem.solve(solver=cp.CLARABEL)
        if self.d.value is None:
            raise RuntimeError(f"least-squares step failed: {self.problem.status}")
        return np.clip(u + self.d.value, low, high) - u


def local_iteration(problem: Problem, u0, stage: str, log: _Log) -> Evaluation:
    """Trust-region iteration of bounded least-squares steps from u0 (module docstring)."""
    s = problem.settings
    current = problem.evaluate(u0)
    stepper = _StepProblem(
        len(problem.targets.modes), len(u0), s.regularisation, problem.constraint
    )
    trust = s.trust_region
    log.add(stage, 0, current, 0.0, trust)
    for it in range(1, s.max_iterations + 1):
        ok = current.paired >= 0
        sens = np.zeros((len(ok), len(u0)))
        sens[ok] = problem.reduced.sensitivities(current.u, current.frequencies_hz, current.shapes)[
            current.paired[ok]
        ]
        gradient = problem.constraint_jacobian(current) if problem.constraint else None
        while True:
            d = stepper.step(
                sens,
                current.residual,
                current.u,
                problem.lower,
                problem.upper,
                trust,
                current.shares,
                gradient,
            )
            trial = problem.evaluate(current.u + d)
            if trial.cost < current.cost or trust < s.min_trust_region:
                break
            trust /= 2.0
        if trial.cost >= current.cost:
            log.add(stage, it, current, 0.0, trust)
            break
        change = 100.0 * np.max(np.abs(trial.residual - current.residual))
        current = trial
        log.add(stage, it, current, change, trust)
        trust = min(2.0 * trust, s.trust_region) if np.max(np.abs(d)) >= 0.99 * trust else trust
        if change < s.tolerance_percent:
            break
    return current


def global_start(problem: Problem, x0, log: _Log) -> np.ndarray:
    """Differential evolution over ln band for the lowest J; its best point (deterministic)."""
    s = problem.settings
    generation = [0]

    def record(intermediate_result):
        generation[0] += 1
        log.add(
            "global",
            generation[0],
            problem.evaluate(intermediate_result.x),
            math.nan,
            math.nan,
        )

    result = differential_evolution(
        problem.cost,
        list(zip(problem.lower, problem.upper, strict=True)),
        maxiter=s.generations,
        popsize=s.population,
        rng=s.seed,
        x0=np.clip(x0, problem.lower, problem.upper),
        polish=False,
        callback=record,
    )
    return result.x


def _meets(e: Evaluation, s: Settings) -> bool:
    err = np.abs(e.errors_percent)
    return (
        not e.mismatches
        and not np.any(e.constraint > 0.0)
        and err.max() <= s.accept_max_percent
        and err.mean() <= s.accept_mean_percent
    )


class _Log:
    """The iteration log (one row per step) and, optionally, a tqdm bar per stage on stderr
    showing the current max and mean |frequency error|."""

    def __init__(self, settings: Settings, progress: bool):
        self.rows: list = []
        self.settings = settings
        self.progress = progress
        self.bar = None
        self.stage = None

    def add(self, stage: str, it: int, e: Evaluation, change: float, trust: float) -> None:
        err = np.abs(e.errors_percent)
        row = {
            "stage": stage,
            "iteration": it,
            "cost": e.cost,
            "max_abs_error_percent": err.max(),
            "mean_abs_error_percent": err.mean(),
            "max_change_percent": change,
            "trust_region": trust,
            "shape_mismatches": len(e.mismatches),
            "mismatched_modes": " ".join(str(k) for k in sorted(e.mismatches)),
            "constraint_violation": float(np.max(e.constraint, initial=0.0)),
        }
        self.rows.append((row, e.u.copy()))
        if self.progress:
            if stage != self.stage:
                self.close()
                total = (
                    self.settings.generations if stage == "global" else self.settings.max_iterations
                )
                self.bar = tqdm(total=total, desc=stage, unit="step", dynamic_ncols=True)
                self.stage = stage
            self.bar.n = it
            self.bar.set_postfix_str(
                f"max {err.max():.3f} %, mean {err.mean():.3f} %, mismatches {len(e.mismatches)}"
            )

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def frame(self, parameters) -> pd.DataFrame:
        """One row per iteration, then the factor s of each parameter."""
        rows = []
        for row, u in self.rows:
            rows.append(
                row | {f"s[{p.name}]": math.exp(v) for p, v in zip(parameters, u, strict=True)}
            )
        return pd.DataFrame(rows)


@dataclass(frozen=True, eq=False)
class Identification:
    """Result: the factors, the final evaluation, the iteration log and the run time."""

    parameters: tuple[Parameter, ...]
    u: np.ndarray
    evaluation: Evaluation
    log: pd.DataFrame
    used_global_start: bool
    seconds: float

    @property
    def scales(self) -> np.ndarray:
        """Identified factors s = exp(u) [-]."""
        return np.exp(self.u)


def identify(
    prior: Model,
    parameters,
    targets: Targets,
    settings: Settings,
    reference: Reference | None = None,
    u0=None,
    constraint: Constraint | None = None,
    progress: bool = False,
) -> Identification:
    """Identify the parameters' factors so the model's modes match ``targets``.

    Runs the local iteration from ``u0`` (default the prior, u = 0); if it stalls and
    ``settings.global_start``, differential evolution and a second local iteration (module
    docstring). ``reference`` supplies the tags and tool-tip modes (None: order pairing only,
    no shape checks); ``constraint`` adds its violation to J; ``progress`` shows a tqdm bar per
    stage on stderr. The factors are rounded to
    :data:`~ufmt.calibration.rounding.SIGNIFICANT` digits (the written model does not depend on
    the last bits of the arithmetic).
    """
    with threadpool_limits(limits=1):  # small dense matrices: one BLAS thread is fastest
        return _identify(
            prior, tuple(parameters), targets, settings, reference, u0, constraint, progress
        )


def _identify(
    prior, parameters, targets, settings, reference, u0, constraint, progress
) -> Identification:
    t0 = time.perf_counter()
    problem = Problem(
        ReducedModel.build(prior, parameters, settings.elements_per_beam),
        targets,
        reference,
        settings,
        constraint,
    )
    log = _Log(settings, progress)
    start = np.zeros(len(parameters)) if u0 is None else np.asarray(u0, dtype=float)
    try:
        best = local_iteration(problem, start, "local", log)
        used = False
        if settings.global_start and not _meets(best, settings):
            used = True
            x = global_start(problem, best.u, log)
            second = local_iteration(problem, x, "local after global start", log)
            if second.cost < best.cost:
                best = second
    finally:
        log.close()
    best = problem.evaluate(np.log(rounded(np.exp(best.u))))
    return Identification(
        parameters, best.u, best, log.frame(parameters), used, time.perf_counter() - t0
    )
