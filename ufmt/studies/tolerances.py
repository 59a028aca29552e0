"""Study kind ``optimise-tolerances``: the cheapest tolerances and stiffnesses that keep a
surface metric inside its specification (the error budget solved backwards).

Fields::

    metric = "psd1_rms_nm"           # the specified metric (a record output)
    limit = 5.0                      # the specification: metric <= limit
    budget = "auto"                  # how the sources combine: rss | linear | auto (the better fit)
    levels = 6                       # specification levels of the trade-off curve
    corrections = 3                  # model-checked corrections of the level per optimum
    seed = 1
    uncertain = ["machine.force_scale"]  # optional: the model's documented bands (shell
                                     #   patterns, ufmt.studies.bands.model_bands) sampled at
                                     #   the optimum for its interval (a Latin hypercube)
    uncertain_samples = 32
    probability = 0.9                # optional: the specification is P(metric <= limit) >= p
                                     #   over the uncertain_samples (needs uncertain)

    [[variable]]                     # one per designed quantity (at least one)
    parameter = "machine.straightness_m"
    kind = "tolerance"               # tolerance (an error amplitude) | stiffness
    range = [5e-9, 2e-7]             # the tightest and the loosest tolerance (stiffness: the
                                     #   stiffest and the softest), either order [SI]; default:
                                     #   the documented band (if its low end is > 0)
    cost = [1.0, 1.0]                # a, b of cost = a + b t_max / t (relative units)
    reason = "..."                   # the cost model's source or the assumption and its reason

The cost of a tolerance t rises as it tightens, ``a + b t_max / t`` with t_max the loosest
tolerance of its range (a: the part that does not depend on it; b: the cost of the loosest
grade, doubled for each halving: the usual inverse law of tolerance cost, stated as an
assumption with its reason in the study file). A stiffness k enters through its compliance
t = 1 / k, so its cost is ``a + b k / k_min``: proportional to the stiffness (the bearing
area and supply flow), as in the optimise-design kind.

Method (the structure the error budget offers): the geometric sources are linear in their
amplitudes and a compliance scales its deflection, so the metric is nearly separable,
``y = r + sum_j c_j tau_j`` (worst-case stacking, PV-like) or
``y^2 = r^2 + sum_j c_j^2 tau_j^2`` (independent contributions, RMS-like), with
``tau_j = t_j / t_max,j`` in (0, 1]. The coefficients are fitted by non-negative least squares
to ``2 k + 2`` evaluations of the true model (all tight, all loose, each variable loose alone,
k Latin-hypercube points); ``budget.csv`` reports both fits' largest relative residual, the
measure of how separable the budget is. The allocation is then a convex, separable program
(sum of ``b_j / tau_j`` subject to the one budget constraint), which the optimiser exploits:
each tolerance has a closed form given the budget's multiplier, and one scalar root finding
(scipy) gives the global optimum of the fitted budget, with no search over the k-dimensional
box. Every optimum is evaluated with the true model; where it misses the limit the level
given to the budget is scaled by limit / evaluated and the program solved again (up to
``corrections`` times). Every reported metric value is an evaluation of the model, never of
the fitted budget.

How sure the answer is: with ``uncertain``, the optimum at the limit is evaluated again at a
Latin hypercube of those documented bands (:func:`ufmt.studies.intervals.sample_designs`;
an input fixed in ``[base]``, e.g. at the worst case of its band for the design, is sampled
over its band here), giving the metric's 5-95 % interval and the probability of meeting the
limit at the allocated tolerances.

A probability of meeting the specification (``probability = p``): the allocation at the
limit is then the cheapest whose metric meets the limit in at least ceil(p M) of the M fixed
samples of the ``uncertain`` bands (common random numbers: the interval's Latin hypercube),
each sample with its own separable budget from k + 1 model runs (:mod:`ufmt.studies.chance`:
a convex program per set of samples, greedy discarding of the hardest). The allocation is
checked with the model at every sample (the interval's runs); where fewer than ceil(p M)
meet, the level is scaled by limit / (the ceil(p M)-th smallest evaluated value) and solved
again. The trade-off curve stays the nominal one (the inputs at their base values).

Tables: ``budget.csv`` (per variable: range, fitted contribution at the loosest tolerance,
cost model and reason; the fits' residuals), ``allocation.csv`` (every model-checked
allocation at the study's limit), ``tradeoff.csv`` (the cheapest allocation at each
specification level, evaluated), ``interval.csv`` (with ``uncertain``: the metric's
quantiles at the optimum and P(meet) with its 95 % interval). Figure: cost against the
specification level.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from ufmt.design import METRICS, PROCESS_PARAMETERS
from ufmt.errors import StudyError
from ufmt.plots.uncertainty import plot_tradeoff
from ufmt.studies import chance, outputs
from ufmt.studies.bands import matching, model_bands, no_bands
from ufmt.studies.fields import Parameters
from ufmt.studies.intervals import sample_designs
from ufmt.studies.outputs import short
from ufmt.studies.spec import Bound, StudyKind
from ufmt.studies.uncertainty import summarise, unit_sample
from ufmt.tables import Where

BUDGETS = ("auto", "rss", "linear")
KINDS_ = ("tolerance", "stiffness")
BUDGET = "budget.csv"
MAX_COST = 1e12  # [-] a cost coefficient in relative units (sums of many stay finite)
ALLOCATION = "allocation.csv"
TRADEOFF = "tradeoff.csv"
INTERVAL = "interval.csv"
_VARIABLE_FIELDS = ("parameter", "kind", "range", "cost", "reason")
MEETS_RTOL = 1e-9  # an evaluated metric this close above the limit meets it
NOMINAL = "nominal"  # the allocation meeting the limit with the uncertain inputs at their base


# ---------------------------------------------------------------------------------------------
# the study file


def parse(where: Where, data: Mapping, parameters: Parameters) -> dict:
    """The variables (as bounds, then the uncertain inputs) and the specification."""
    tables = where.tables("variable", data.get("variable", []), required=True)
    bands = model_bands(parameters.model, damping=False)
    bounds, variables = [], []
    for i, table in enumerate(tables):
        bound, variable = _variable(where, i, table, bands, parameters)
        if bound.parameter in parameters.base:
            where.sub("base").fail(bound.parameter, "is a designed variable; remove it")
        bounds.append(bound)
        variables.append(variable)
    where.unique("variable", [b.parameter for b in bounds])
    if "limit" not in data:
        where.missing("limit", "the specification: metric <= limit")
    uncertain = _uncertain(where, data, bands, [b.parameter for b in bounds], parameters)
    probability = None
    if "probability" in data:
        probability = where.number("probability", data["probability"], allowed="in (0, 1)")
        if not 0.0 < probability < 1.0:
            where.fail("probability", f"{probability:g} is outside (0, 1)")
        if not uncertain:
            where.missing("uncertain", "a probability is taken over the uncertain bands")
    options = {
        "variables": variables,
        "probability": probability,
        "uncertain": [b.parameter for b in uncertain],
        "uncertain_samples": where.integer(
            "uncertain_samples", data.get("uncertain_samples", 32), 2, 10_000
        ),
        "metric": where.choice("metric", data.get("metric", "pv_measured_nm"), METRICS, "metric"),
        "limit": where.number("limit", data["limit"], sign="positive"),
        "budget": where.choice("budget", data.get("budget", "auto"), BUDGETS, "budget"),
        "levels": where.integer("levels", data.get("levels", 6), 2, 100),
        "corrections": where.integer("corrections", data.get("corrections", 3), 0, 20),
        "seed": where.integer("seed", data.get("seed", 1), 0),
    }
    return {"bounds": (*bounds, *uncertain), "options": options}


def _uncertain(where: Where, data: Mapping, bands, designed, parameters) -> list[Bound]:
    """The documented bands of ``uncertain`` (patterns), as bounds after the variables."""
    patterns = where.items("uncertain", data.get("uncertain", []), "parameter pattern")
    names = []
    for i, pattern in enumerate(patterns):
        pattern = where.string(f"uncertain[{i}]", pattern)
        found = matching(pattern, bands)
        if not found and not bands:
            where.fail(f"uncertain[{i}]", str(no_bands(parameters.model)))
        if not found:
            where.fail(f"uncertain[{i}]", f"{pattern!r} matches no documented band")
        for name in found:
            parameters.check(where, f"uncertain[{i}]", name)
            if name in designed:
                where.fail(f"uncertain[{i}]", f"{name!r} is a designed variable, not uncertain")
        names += [n for n in found if n not in names]
    return [Bound(n, bands[n].low, bands[n].high, bands[n].log) for n in names]


def _variable(where: Where, i: int, table: Mapping, bands, parameters) -> tuple[Bound, dict]:
    """One ``[[variable]]``: its bound and its cost model."""
    at = where.sub(f"variable[{i}]")
    at.keys(table, _VARIABLE_FIELDS, required=("parameter",))
    name = parameters.check(at, "parameter", table["parameter"])
    if name in PROCESS_PARAMETERS:
        at.fail("parameter", f"{name!r} is a process parameter, not a tolerance")
    at = where.sub(f"variable {name!r}")
    kind = at.choice("kind", table.get("kind", "tolerance"), KINDS_, "kind")
    if "range" in table:
        low, high = sorted(at.numbers("range", table["range"], 2, sign="positive"))
        if low == high:
            at.fail("range", f"empty range [{low:g}, {high:g}] (allowed: two different ends)")
    elif name in bands and bands[name].low > 0:
        low, high = bands[name].low, bands[name].high
    else:
        at.missing("range", "no documented band > 0 for this parameter")
    if "cost" not in table:
        at.missing("cost", "[a, b] of a + b t_max / t")
    a, b = at.numbers("cost", table["cost"], 2, sign="nonnegative")
    if b <= 0:
        at.fail("cost", f"b = {b:g} must be > 0 (a cost that rises as t tightens)")
    if max(a, b) > MAX_COST:
        at.fail("cost", f"[{a:g}, {b:g}]: each at most {MAX_COST:g} (relative units)")
    if "reason" not in table:
        at.missing("reason", "state the cost model's source or assumption")
    reason = at.string("reason", table["reason"])
    variable = {"parameter": name, "kind": kind, "a": a, "b": b, "reason": reason}
    return Bound(name, low, high, log=True), variable


# ---------------------------------------------------------------------------------------------
# tolerances <-> parameter values


def loosest(bound: Bound, kind: str) -> tuple[float, float]:
    """(t_max, tau_min): the loosest tolerance [SI] and the tightest as a fraction of it (a
    stiffness: compliance 1 / k)."""
    if kind == "stiffness":
        return 1.0 / bound.low, bound.low / bound.high
    return bound.high, bound.low / bound.high


def values_of(tau: np.ndarray, bounds, variables) -> np.ndarray:
    """Parameter values [SI] of normalised tolerances ``tau`` (..., k)."""
    t_max = np.array([loosest(b, v["kind"])[0] for b, v in zip(bounds, variables, strict=True)])
    t = np.asarray(tau, dtype=float) * t_max
    stiff = np.array([v["kind"] == "stiffness" for v in variables])
    return np.where(stiff, 1.0 / t, t)


def cost_of(tau: np.ndarray, variables) -> np.ndarray:
    """Cost sum_j a_j + b_j / tau_j of normalised tolerances ``tau`` (..., k)."""
    a = np.array([v["a"] for v in variables])
    b = np.array([v["b"] for v in variables])
    return np.sum(a + b / np.asarray(tau, dtype=float), axis=-1)


# ---------------------------------------------------------------------------------------------
# the separable budget


def design_of_experiments(tau_min: np.ndarray, seed: int) -> np.ndarray:
    """2 k + 2 normalised tolerance vectors: all tight, all loose, each loose alone, and k
    Latin-hypercube points (log-uniform between tight and loose)."""
    k = len(tau_min)
    oat = np.where(np.eye(k, dtype=bool), 1.0, tau_min)
    u = unit_sample("lhs", k, k, seed)
    lhs = tau_min ** (1.0 - u)  # log-uniform in [tau_min, 1]
    return np.vstack([tau_min, np.ones(k), oat, lhs])


def fit_budget(tau: np.ndarray, y: np.ndarray, form: str) -> tuple[float, np.ndarray, float]:
    """(r, c, largest relative residual) of the separable budget of ``form`` (rss | linear)
    fitted to metric ``y`` at ``tau`` by non-negative least squares."""
    from scipy.optimize import nnls

    power = 2 if form == "rss" else 1
    design = np.hstack([np.ones((len(tau), 1)), tau**power])
    coefficients, _ = nnls(design, y**power)
    r, c = coefficients[0] ** (1 / power), coefficients[1:] ** (1 / power)
    return float(r), c, float(np.max(np.abs(predict(tau, r, c, form) - y) / y))


def predict(tau: np.ndarray, r: float, c: np.ndarray, form: str) -> np.ndarray:
    """The budget's metric at normalised tolerances ``tau`` (..., k)."""
    if form == "rss":
        return np.sqrt(r**2 + np.sum((c * tau) ** 2, axis=-1))
    return r + np.sum(c * tau, axis=-1)


def allocate(
    r: float, c: np.ndarray, form: str, level: float, tau_min: np.ndarray, variables
) -> np.ndarray | None:
    """The cheapest normalised tolerances meeting ``predict <= level``, or None where even the
    tightest do not.

    The program (minimise sum b_j / tau_j subject to the budget, tau_min <= tau <= 1) is
    convex and separable: for a multiplier lambda each tau_j minimises its own
    ``b_j / tau_j + lambda g_j(tau_j)`` in closed form (linear: ``sqrt(b_j / (lambda c_j))``,
    rss: ``cbrt(b_j / (2 lambda c_j^2))``, clipped to its range), and the budget spent falls
    monotonically with lambda, so the KKT point is one root in log lambda
    (:func:`scipy.optimize.brentq`): the global optimum of the fitted budget.
    """
    from scipy.optimize import brentq

    b = np.array([v["b"] for v in variables], dtype=float)
    b = b / b.max()  # the allocation depends on the ratios of b only (lambda absorbs a scale)
    if form == "rss":
        room = level**2 - r**2

        def spend(tau):
            return float(np.sum((c * tau) ** 2))

        def best(lam, cj, bj):
            return np.cbrt(bj / (2.0 * lam * cj**2))
    else:
        room = level - r

        def spend(tau):
            return float(c @ tau)

        def best(lam, cj, bj):
            return np.sqrt(bj / (lam * cj))

    if room <= 0 or spend(tau_min) > room:
        return None
    loose = np.ones_like(tau_min)
    if spend(loose) <= room:
        return loose
    active = c > 0

    def tau_of(log_lam: float) -> np.ndarray:
        tau = loose.copy()
        tau[active] = best(math.exp(log_lam), c[active], b[active])
        return np.clip(tau, tau_min, 1.0)

    low, high = -1.0, 1.0
    while spend(tau_of(low)) <= room:  # the loosest allocation spends more than the room
        low *= 2.0
    while spend(tau_of(high)) > room:
        high *= 2.0
    root = brentq(lambda x: spend(tau_of(x)) - room, low, high, xtol=1e-13, rtol=1e-15)
    tau = tau_of(root)
    return tau if spend(tau) <= room * (1 + 1e-12) else tau_of(high)


# ---------------------------------------------------------------------------------------------
# the run


class _Budget:
    """The fitted budget of one run and the true model behind it."""

    def __init__(self, study, evaluator):
        options = study.options
        self.variables = options["variables"]
        self.bounds = study.bounds[: len(self.variables)]
        self.names = [b.parameter for b in self.bounds]
        self.metric, self.limit = options["metric"], options["limit"]
        self.evaluator = evaluator
        self.tau_min = np.array(
            [loosest(b, v["kind"])[1] for b, v in zip(self.bounds, self.variables, strict=True)]
        )
        self.doe = design_of_experiments(self.tau_min, options["seed"])
        self.y = self.evaluate("budget", self.doe)
        if not np.all(np.isfinite(self.y)) or np.any(self.y <= 0):
            raise StudyError(
                f"{study.name}: {self.metric} is not resolved (or not > 0) at"
                f" {int(np.count_nonzero(~(self.y > 0)))} of {len(self.y)} budget points (see"
                " points.csv); e.g. PSD1 needs a plate of three periods of 33 mm: choose another"
                " metric or a larger plate (machine.workpiece_size[i] in [base])"
            )
        self.fits = {form: fit_budget(self.doe, self.y, form) for form in ("rss", "linear")}
        form = options["budget"]
        self.form = min(self.fits, key=lambda f: self.fits[f][2]) if form == "auto" else form
        self.r, self.c, _ = self.fits[self.form]

    def evaluate(self, group: str, tau: np.ndarray) -> np.ndarray:
        """The true metric at normalised tolerances ``tau`` (n, k)."""
        values = values_of(np.atleast_2d(tau), self.bounds, self.variables)
        points = [dict(zip(self.names, map(float, row), strict=True)) for row in values]
        return self.evaluator.values(group, points, output=self.metric)

    def cheapest(self, group: str, level: float, corrections: int) -> list[dict]:
        """Model-checked allocations for ``level``: the first, then each corrected one."""
        rows, target = [], level
        for step in range(corrections + 1):
            tau = allocate(self.r, self.c, self.form, target, self.tau_min, self.variables)
            if tau is None:
                rows.append(
                    {"level": level, "step": step, "budget_level": target, "feasible": False}
                )
                break
            (y,) = self.evaluate(group, tau[None, :])
            row = {"level": level, "step": step, "budget_level": target, "feasible": True}
            row.update(
                cost=float(cost_of(tau, self.variables)),
                predicted=float(predict(tau, self.r, self.c, self.form)),
            )
            row.update(evaluated=float(y), meets=bool(y <= level * (1 + MEETS_RTOL)))
            values = values_of(tau, self.bounds, self.variables)
            row.update(zip(self.names, map(float, values), strict=True))
            rows.append(row)
            if row["meets"] or not np.isfinite(y):
                break
            target *= level / y
        return rows

    def cheapest_likely(self, study) -> list[dict]:
        """Model-checked allocations meeting the limit with the study's probability over the
        fixed sample of its uncertain bands: the first, then each corrected one."""
        options = study.options
        p, limit = options["probability"], self.limit
        samples = _uncertain_samples(study, len(self.variables))
        n, k = len(samples), len(self.variables)
        need = math.ceil(p * n - 1e-12)
        runs = chance.sample_points(self.tau_min)
        points = [{**self._design(tau), **sample} for sample in samples for tau in runs]
        y = self.evaluator.values("chance", points, output=self.metric).reshape(n, k + 1)
        r, c = chance.sample_budgets(y, self.tau_min, self.form)
        b = np.array([v["b"] for v in self.variables], dtype=float)
        rows, target = [], limit
        for step in range(options["corrections"] + 1):
            row = {"level": limit, "step": step, "budget_level": target, "probability": p}
            tau = chance.allocate_with_probability(r, c, self.form, target, p, self.tau_min, b)
            if tau is None:
                rows.append({**row, "feasible": False})
                break
            design = self._design(tau)
            values = self.evaluator.values(
                "interval", [{**design, **sample} for sample in samples], output=self.metric
            )
            hits = int(np.count_nonzero(values <= limit * (1 + MEETS_RTOL)))
            quantile = float(np.sort(np.where(np.isfinite(values), values, np.inf))[need - 1])
            predicted = np.sort(chance.predict_samples(tau, r, c, self.form))[need - 1]
            row.update(feasible=True, cost=float(cost_of(tau, self.variables)))
            row.update(predicted=float(predicted), evaluated=quantile, meets=hits >= need)
            row.update(p_meet=hits / n, **design)
            rows.append(row)
            if row["meets"] or not np.isfinite(quantile):
                break
            target *= limit / quantile
        return rows

    def _design(self, tau: np.ndarray) -> dict[str, float]:
        """The designed parameters' values [SI] of normalised tolerances ``tau``."""
        values = values_of(tau, self.bounds, self.variables)
        return dict(zip(self.names, map(float, values), strict=True))

    def table(self) -> pd.DataFrame:
        """``budget.csv``: per variable, then one row per fit."""
        rows = []
        for j, (bound, v) in enumerate(zip(self.bounds, self.variables, strict=True)):
            t_max, tau_min = loosest(bound, v["kind"])
            rows.append(
                {
                    "parameter": bound.parameter,
                    "kind": v["kind"],
                    "tight": bound.high if v["kind"] == "stiffness" else bound.low,
                    "loose": bound.low if v["kind"] == "stiffness" else bound.high,
                    "contribution_loose": float(self.c[j]),
                    "contribution_tight": float(self.c[j] * tau_min),
                    "cost_a": v["a"],
                    "cost_b": v["b"],
                    "reason": v["reason"],
                }
            )
        for form, (r, _, residual) in self.fits.items():
            used = " (used)" if form == self.form else ""
            rows.append(
                {
                    "parameter": f"fit:{form}{used}",
                    "contribution_loose": r,
                    "max_rel_residual": residual,
                }
            )
        return pd.DataFrame(rows)


def analyse(study, evaluator, baseline: Mapping, out_dir: Path) -> str:
    """Fit the budget, allocate at the limit and along the trade-off; write the tables."""
    options = study.options
    budget = _Budget(study, evaluator)
    outputs.write_table(budget.table(), out_dir / BUDGET)
    found = {NOMINAL: budget.cheapest("optimum", budget.limit, options["corrections"])}
    if options.get("probability") is not None:
        found[f"P >= {options['probability']:g}"] = budget.cheapest_likely(study)
    rows = [{"specification": spec, **row} for spec, checked in found.items() for row in checked]
    allocation = pd.DataFrame(rows)
    outputs.write_table(allocation, out_dir / ALLOCATION)
    tight, loose = float(budget.y[0]), float(budget.y[1])
    levels = np.geomspace(1.05 * tight, loose, options["levels"]) if loose > 1.05 * tight else []
    rows = []
    for level in levels:
        checked = budget.cheapest("tradeoff", float(level), options["corrections"])
        rows.append(checked[-1])
    columns = ["level", "step", "budget_level", "feasible", "cost", "predicted", "evaluated"]
    columns += ["meets", *budget.names]
    outputs.write_table(pd.DataFrame(rows, columns=columns), out_dir / TRADEOFF)
    intervals = [_interval(study, budget, checked[-1]) for checked in found.values()]
    interval = None
    if all(i is not None for i in intervals):
        interval = pd.concat(intervals, ignore_index=True)
        interval.insert(0, "specification", list(found))
        outputs.write_table(interval, out_dir / INTERVAL)
    return headline(budget, allocation, options, interval)


def _interval(study, budget: _Budget, final: Mapping) -> pd.DataFrame | None:
    """The metric at the optimum over a Latin hypercube of the uncertain bands (None without
    them or without an optimum)."""
    uncertain = study.bounds[len(budget.variables) :]
    if not uncertain or not final.get("feasible", False):
        return None
    samples = _uncertain_samples(study, len(budget.variables))
    design = {n: float(final[n]) for n in budget.names}
    points = [{**design, **row} for row in samples]
    y = budget.evaluator.values("interval", points, output=budget.metric)
    row = summarise(y, (0.05, 0.5, 0.95), budget.limit * (1 + MEETS_RTOL))  # as meets
    row["limit"] = budget.limit
    inputs = " ".join(b.parameter for b in uncertain)
    return pd.DataFrame([{"metric": budget.metric, "inputs": inputs, **row}])


def _uncertain_samples(study, n_variables: int) -> list[dict]:
    """The fixed Latin hypercube of the uncertain bands (the bounds after the variables): the
    interval's samples and the common random numbers of a probability."""
    options = study.options
    bands = {b.parameter: b for b in study.bounds[n_variables:]}
    samples = sample_designs(bands, options["uncertain_samples"], options["seed"])
    return samples.to_dict("records")


def headline(budget: _Budget, allocation: pd.DataFrame, options: Mapping, interval) -> str:
    """The cheapest allocation at the limit (or why there is none), the budget's fit and the
    interval at the optimum."""
    metric, limit, p = options["metric"], options["limit"], options.get("probability")
    fit = f"{budget.form} budget, largest fit residual {budget.fits[budget.form][2]:.1%}"
    spec = f"{metric} <= {short(limit)}"
    if p is not None:
        spec = f"P({spec}) >= {short(p)} over {options['uncertain_samples']} samples"
    final = allocation.iloc[-1]
    if not final.get("feasible", False):
        return (
            f"{spec}: not reachable inside the ranges (all tightest: {short(budget.y[0])}; {fit})."
        )
    values = ", ".join(f"{n} = {short(final[n])}" for n in budget.names)
    verdict = "meets it" if final["meets"] else "misses it after the corrections"
    gives = f"{short(final['evaluated'])}"
    if p is not None:
        gives = f"P = {short(final['p_meet'])} (its {short(p)} quantile {gives})"
    text = (
        f"Cheapest allocation for {spec}: {values}; cost {short(final['cost'])}"
        f" (all tightest {short(cost_of(budget.tau_min, budget.variables))}); the model gives"
        f" {gives} ({verdict}; {fit})"
    )
    if p is not None:
        nominal = allocation[allocation["specification"] == NOMINAL].iloc[-1]
        if nominal.get("feasible", False):
            text += f"; the nominal allocation (inputs at base) costs {short(nominal['cost'])}"
    if interval is None:
        return text + "."
    parts = []
    for r in interval.to_dict("records"):
        parts.append(
            f"{r['specification']}: 5-95 % {short(r['q05'])}-{short(r['q95'])}, P(meet)"
            f" {short(r['p_meet'])} [{short(r['p_meet_low'])}, {short(r['p_meet_high'])}]"
        )
    r = interval.iloc[-1]
    return f"{text}; over {r['samples']} samples of {r['inputs']}: " + "; ".join(parts) + "."


def planned_points(study) -> int:
    """Budget points, then per allocation (the limit and each level) its corrections."""
    options = study.options
    k = len(options["variables"])
    interval = options["uncertain_samples"] if options["uncertain"] else 0
    likely = 0
    if options.get("probability") is not None:  # per-sample budgets, then a check per step
        likely = interval * (k + 1 + options["corrections"] + 1)
    return 2 * k + 2 + (1 + options["levels"]) * (options["corrections"] + 1) + interval + likely


def figures(out_dir: Path) -> dict[str, Figure]:
    """Cost against the specification level."""
    tradeoff = outputs.read_table(out_dir / TRADEOFF)
    meta = outputs.read_meta(out_dir)
    options = meta.get("options", {})
    if not len(tradeoff) or "cost" not in tradeoff:
        return {}
    feasible = tradeoff[tradeoff["feasible"].astype(bool)]
    return {
        "tolerance-tradeoff.png": plot_tradeoff(
            feasible, options.get("limit", math.nan), options.get("metric", "")
        )
    }


OPTIMISE_TOLERANCES = StudyKind(
    name="optimise-tolerances",
    fields=(
        "variable",
        "metric",
        "limit",
        "budget",
        "levels",
        "corrections",
        "seed",
        "uncertain",
        "uncertain_samples",
        "probability",
    ),
    tables=(BUDGET, ALLOCATION, TRADEOFF, INTERVAL),
    parse=parse,
    planned_points=planned_points,
    analyse=analyse,
    figures=figures,
)
