"""Study kind ``uncertainty``: every metric as a distribution over the model's documented
bands, with its quantiles, its Sobol indices and the probability of meeting a specification.

Fields::

    [[input]]                        # one per uncertain input (at least one)
    parameter = "machine.*"          # a parameter, or a shell pattern over the documented bands
                                     #   (ufmt.studies.bands: [machine] keys, bearing stiffnesses)
    distribution = "uniform"         # uniform (default) | loguniform | normal | triangular
    range = [0.0, 1e-7]              # optional: the band [SI] (default: the documented one);
                                     #   or scale = [lo, hi] times the calibrated value

    method = "saltelli"              # saltelli (default) | lhs
    samples = 64                     # base samples N (saltelli: a power of two)
    seed = 1
    metrics = ["pv_measured_nm", ...]  # record outputs (default: DEFAULT_METRICS)
    quantiles = [0.05, 0.25, 0.5, 0.75, 0.95]

    [specification]                  # optional: upper limits of metrics
    pv_measured_nm = 100.0

Distributions act on the unit coordinate of the band (0 at its low end, 1 at its high end):
``uniform`` over the band, ``loguniform`` uniform in log10 of the value, ``normal`` a normal
truncated to the band with the band = mean +- 2 sigma, ``triangular`` with its mode at the
calibrated value (the band's middle when that lies outside). A later ``[[input]]`` naming a
parameter replaces one a pattern gave.

Sampling: ``saltelli`` is Saltelli's scheme on a scrambled Sobol sequence as SALib draws it
(``N (k + 2)`` evaluations for k inputs; the base matrices A and B, 2N independent points,
give the distribution; all of them the first-order and total Sobol indices, Jansen/Saltelli
estimators with bootstrap 95 % confidence half-widths). ``lhs`` is a Latin hypercube
(:class:`scipy.stats.qmc.LatinHypercube`, N evaluations): the distribution only.

Tables: ``distribution.csv`` (per metric: valid samples, mean, standard deviation, the
quantiles, the specification and the probability of meeting it with its 95 % Clopper-Pearson
interval), ``sobol.csv`` (per metric and input: S1, ST and their confidence half-widths),
``convergence.csv`` (the estimates on the nested prefixes of N/2^j base samples) and
``samples.csv`` (inputs and metrics of the independent points). A metric that is NaN (a band
the plate does not resolve, e.g. PSD1 on a plate shorter than three periods of 33 mm, or a
failed point) counts as not resolved: its row says how many samples were, and it gets Sobol
indices only where every sample is resolved.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from ufmt.design import METRICS, PROCESS_PARAMETERS, unknown_design_parameter
from ufmt.plots.uncertainty import plot_convergence, plot_distributions, plot_sobol
from ufmt.studies import outputs
from ufmt.studies.bands import documented_bands, matching
from ufmt.studies.optimise import Space
from ufmt.studies.outputs import short
from ufmt.studies.spec import (
    MAX_POINTS,
    Bound,
    StudyKind,
    check_keys,
    read_bounds,
    read_count,
    read_real,
)

DISTRIBUTIONS = ("uniform", "loguniform", "normal", "triangular")
METHODS = ("saltelli", "lhs")
DEFAULT_METRICS = (
    "pv_measured_nm",
    "psd1_rms_nm",
    "waviness_rms_nm",
    "zre_peak_nm",
    "tip_acc_measured_mm_s2",
)
DEFAULT_QUANTILES = (0.05, 0.25, 0.5, 0.75, 0.95)
NORMAL_SIGMAS = 2.0  # the band is mean +- 2 sigma of a normal input (truncated to it)
MIN_CONVERGENCE_SAMPLES = 8  # smallest prefix of the convergence table
GROUP = "uncertainty"
DISTRIBUTION = "distribution.csv"
SOBOL = "sobol.csv"
CONVERGENCE = "convergence.csv"
SAMPLES = "samples.csv"
_INPUT_FIELDS = ("parameter", "distribution", "range", "scale")


# ---------------------------------------------------------------------------------------------
# the study file


def parse(where, data: Mapping, base: Mapping[str, float]) -> dict:
    """The inputs (as bounds, with their distributions) and the options."""
    bounds, inputs = _inputs(where, data.get("input", []))
    for b in bounds:
        if b.parameter in base:
            where.fail(f"base.{b.parameter}", "is an uncertain input of this study; remove it")
    method = data.get("method", "saltelli")
    if method not in METHODS:
        where.fail("method", f"unknown method {method!r} ({' or '.join(METHODS)})")
    samples = read_count(where, "samples", data.get("samples", 64), 2, MAX_POINTS)
    if method == "saltelli" and samples & (samples - 1):
        where.fail("samples", f"{samples} is not a power of two (Saltelli sampling)")
    metrics = _names(where, "metrics", data.get("metrics", list(DEFAULT_METRICS)), METRICS)
    quantiles = data.get("quantiles", list(DEFAULT_QUANTILES))
    if not isinstance(quantiles, list) or not quantiles:
        where.fail(
            "quantiles", f"expected a non-empty array of numbers in (0, 1), got {quantiles!r}"
        )
    quantiles = [read_real(where, "quantiles", q) for q in quantiles]
    if any(not 0.0 < q < 1.0 for q in quantiles):
        where.fail("quantiles", f"{quantiles!r}: every quantile must lie in (0, 1)")
    options = {
        "inputs": inputs,
        "method": method,
        "samples": samples,
        "seed": read_count(where, "seed", data.get("seed", 1), 0),
        "metrics": metrics,
        "quantiles": sorted(set(quantiles)),
        "specification": _specification(where, data.get("specification", {})),
    }
    return {"bounds": bounds, "options": options}


def _inputs(where, tables) -> tuple[tuple[Bound, ...], list[dict]]:
    """The ``[[input]]`` tables: bounds (documented band or the file's) and distributions."""
    if (
        not isinstance(tables, list)
        or not tables
        or not all(isinstance(t, Mapping) for t in tables)
    ):
        where.fail("input", "expected at least one [[input]] table")
    bands = documented_bands()
    found: dict[str, tuple[Bound, dict, bool]] = {}  # name -> (bound, input, from a pattern)
    for i, table in enumerate(tables):
        check_keys(where, f"input[{i}].", table, _INPUT_FIELDS)
        pattern = table.get("parameter")
        if not isinstance(pattern, str) or not pattern:
            where.fail(f"input[{i}].parameter", f"expected a parameter name, got {pattern!r}")
        distribution = table.get("distribution", "uniform")
        if distribution not in DISTRIBUTIONS:
            where.fail(
                f"input[{i}].distribution",
                f"unknown distribution {distribution!r} ({', '.join(DISTRIBUTIONS)})",
            )
        is_pattern = any(c in pattern for c in "*?[") and pattern not in bands
        names = matching(pattern, bands) if is_pattern else [pattern]
        if not names:
            where.fail(f"input[{i}].parameter", f"{pattern!r} matches no documented band")
        for name in names:
            if name in found and not found[name][2]:
                where.fail("input", f"{name!r} appears more than once")
            bound = _bound(where, f"input[{name}]", name, table, bands, distribution)
            reason = bands[name].reason if name in bands and "range" not in table else "study file"
            entry = {"parameter": name, "distribution": distribution, "band": reason}
            found[name] = (bound, entry, is_pattern)
    return tuple(b for b, _, _ in found.values()), [e for _, e, _ in found.values()]


def _bound(where, label: str, name: str, table: Mapping, bands, distribution: str) -> Bound:
    """The sampled interval of ``name``: the file's range/scale, else its documented band."""
    log = distribution == "loguniform"
    if "range" in table or "scale" in table:
        given = {k: table[k] for k in ("range", "scale") if k in table}
        spacing = {"spacing": "log"} if log else {}
        (bound,) = read_bounds(where, [{"parameter": name, **given, **spacing}], required=True)
        return bound
    problem = (
        None
        if name in PROCESS_PARAMETERS
        else unknown_design_parameter(name, where.model, where.declared)
    )
    if problem:
        where.fail(f"{label}.parameter", problem)
    if name not in bands:
        where.fail(f"{label}.range", "has no documented band: give range or scale")
    band = bands[name]
    if log and band.low <= 0:
        where.fail(f"{label}.distribution", f"loguniform needs a band > 0, not {band.low!r}")
    return Bound(name, band.low, band.high, log)


def _names(where, field: str, value, allowed: Sequence[str]) -> list[str]:
    """A non-empty array of distinct names out of ``allowed``."""
    if not isinstance(value, list) or not value or not all(isinstance(v, str) for v in value):
        where.fail(field, f"expected a non-empty array of names, got {value!r}")
    for v in value:
        if v not in allowed:
            where.fail(field, f"unknown metric {v!r} (metrics: {', '.join(allowed)})")
    if len(set(value)) != len(value):
        where.fail(field, "a metric appears more than once")
    return list(value)


def _specification(where, table) -> dict[str, float]:
    """``[specification]``: metric -> upper limit."""
    if not isinstance(table, Mapping):
        where.fail("specification", "expected a table of metric = upper limit")
    check_keys(where, "specification.", table, METRICS)
    limits = {}
    for metric, value in table.items():
        limits[metric] = read_real(where, f"specification.{metric}", value)
        if limits[metric] <= 0:
            where.fail(f"specification.{metric}", f"{value!r} must be > 0")
    return limits


# ---------------------------------------------------------------------------------------------
# sampling


def unit_sample(method: str, dim: int, samples: int, seed: int) -> np.ndarray:
    """Uniform points in the unit cube (evaluations x dim): Saltelli's N (dim + 2) rows (A,
    the dim AB_i, B for each base sample) or a Latin hypercube of N."""
    if method == "lhs":
        from scipy.stats import qmc

        return qmc.LatinHypercube(d=dim, rng=np.random.default_rng(seed)).random(samples)
    from SALib.sample import sobol

    problem = {"num_vars": dim, "names": [f"x{i}" for i in range(dim)], "bounds": [[0, 1]] * dim}
    return sobol.sample(problem, N=samples, calc_second_order=False, seed=seed)


def independent_rows(method: str, n_rows: int, dim: int) -> np.ndarray:
    """Indices of the rows that are independent draws: A and B of Saltelli's scheme, every
    row of a Latin hypercube."""
    if method == "lhs":
        return np.arange(n_rows)
    step = dim + 2
    starts = np.arange(0, n_rows, step)
    return np.sort(np.concatenate([starts, starts + step - 1]))


def distribute(u: np.ndarray, distributions: Sequence[str], modes: Sequence[float]) -> np.ndarray:
    """Unit coordinates of the inputs' distributions from uniform ``u`` (n, dim) by inverse
    CDFs on [0, 1] (``modes``: the triangular modes in unit coordinates)."""
    from scipy import stats

    out = np.array(u, dtype=float, copy=True)
    edge = NORMAL_SIGMAS
    for j, (name, mode) in enumerate(zip(distributions, modes, strict=True)):
        if name == "normal":
            sigma = 0.5 / NORMAL_SIGMAS  # the band [0, 1] is 0.5 +- NORMAL_SIGMAS sigma
            out[:, j] = stats.truncnorm.ppf(u[:, j], -edge, edge, loc=0.5, scale=sigma)
        elif name == "triangular":
            out[:, j] = stats.triang.ppf(u[:, j], float(np.clip(mode, 0.0, 1.0)))
    return np.clip(out, 0.0, 1.0)


def draw_points(study, baseline: Mapping) -> tuple[Space, np.ndarray]:
    """The study's input box and its sample (evaluations x inputs, parameter values [SI])."""
    options = study.options
    space = Space.from_bounds(study.bounds, baseline)
    u = unit_sample(options["method"], space.dim, options["samples"], options["seed"])
    distributions = [i["distribution"] for i in options["inputs"]]
    modes = space.unit([baseline.get(n, math.nan) for n in space.names])
    modes = np.where(np.isfinite(modes) & (modes >= 0) & (modes <= 1), modes, 0.5)
    return space, space.values(distribute(u, distributions, modes))


# ---------------------------------------------------------------------------------------------
# analysis


def summarise(
    values: np.ndarray, quantiles: Sequence[float], limit: float | None = None
) -> dict[str, float]:
    """Samples, mean, standard deviation, quantiles of the finite ``values``, and the
    probability that a value is <= ``limit`` with its 95 % Clopper-Pearson interval."""
    from scipy.stats import binomtest

    values = np.asarray(values, dtype=float)
    valid = values[np.isfinite(values)]
    row = {"samples": len(values), "resolved": len(valid)}
    row["mean"] = float(np.mean(valid)) if len(valid) else math.nan
    row["std"] = float(np.std(valid, ddof=1)) if len(valid) > 1 else math.nan
    for q in quantiles:
        row[quantile_column(q)] = float(np.quantile(valid, q)) if len(valid) else math.nan
    row["limit"] = math.nan if limit is None else float(limit)
    row["p_meet"] = row["p_meet_low"] = row["p_meet_high"] = math.nan
    if limit is not None and len(valid):
        hits = int(np.count_nonzero(valid <= limit))
        interval = binomtest(hits, len(valid)).proportion_ci(0.95, method="exact")
        row.update(p_meet=hits / len(valid), p_meet_low=interval.low, p_meet_high=interval.high)
    return row


def quantile_column(q: float) -> str:
    """Column name of quantile ``q``: 0.05 -> "q05", 0.5 -> "q50", 0.975 -> "q97.5"."""
    return f"q{100 * q:02.0f}" if float(100 * q).is_integer() else f"q{100 * q:g}"


def sobol_indices(names: Sequence[str], y: np.ndarray, seed: int) -> pd.DataFrame:
    """First-order and total Sobol indices of Saltelli-sampled outputs ``y`` (SALib), with
    bootstrap 95 % confidence half-widths."""
    from SALib.analyze import sobol

    problem = {"num_vars": len(names), "names": list(names), "bounds": [[0, 1]] * len(names)}
    si = sobol.analyze(problem, np.asarray(y, dtype=float), calc_second_order=False, seed=seed)
    return pd.DataFrame(
        {
            "parameter": list(names),
            "S1": si["S1"],
            "S1_conf": si["S1_conf"],
            "ST": si["ST"],
            "ST_conf": si["ST_conf"],
        }
    )


def indices_of(metric: str, names, y: np.ndarray, seed: int) -> pd.DataFrame | None:
    """The Sobol table of one metric, or None where a sample is not resolved or the metric
    does not vary (its variance shares are undefined)."""
    if not np.all(np.isfinite(y)) or np.ptp(y) == 0.0:
        return None
    table = sobol_indices(names, y, seed)
    table.insert(0, "metric", metric)
    return table


def convergence(study, names, outputs_: Mapping[str, np.ndarray]) -> pd.DataFrame:
    """Estimates on the nested prefixes of N / 2^j base samples (Sobol prefixes are the
    smaller designs): the quantiles of every metric and the Sobol indices of the resolved
    ones."""
    options = study.options
    method, dim, seed = options["method"], len(names), options["seed"]
    per_sample = dim + 2 if method == "saltelli" else 1
    sizes = [options["samples"]]
    while sizes[-1] // 2 >= MIN_CONVERGENCE_SAMPLES:
        sizes.append(sizes[-1] // 2)
    rows = []
    for n in sorted(sizes):
        for metric, y in outputs_.items():
            prefix = y[: n * per_sample]
            draws = prefix[independent_rows(method, len(prefix), dim)]
            summary = summarise(draws, options["quantiles"])
            for q in options["quantiles"]:
                column = quantile_column(q)
                rows.append((n, len(prefix), metric, column, "", summary[column], math.nan))
            table = indices_of(metric, names, prefix, seed) if method == "saltelli" else None
            for r in [] if table is None else table.itertuples():
                rows.append((n, len(prefix), metric, "S1", r.parameter, r.S1, r.S1_conf))
                rows.append((n, len(prefix), metric, "ST", r.parameter, r.ST, r.ST_conf))
    columns = ["samples", "evaluations", "metric", "statistic", "parameter", "value", "conf"]
    return pd.DataFrame(rows, columns=columns)


def analyse(study, evaluator, baseline: Mapping, out_dir: Path) -> str:
    """Sample, evaluate, write the four tables; return the headline."""
    options = study.options
    space, values = draw_points(study, baseline)
    points = [dict(zip(space.names, map(float, row), strict=True)) for row in values]
    rows = evaluator.evaluate([(GROUP, p) for p in points])
    outputs_ = {m: np.array([_number(r.get(m)) for r in rows]) for m in options["metrics"]}
    keep = independent_rows(options["method"], len(points), space.dim)
    limits = options["specification"]
    distribution = pd.DataFrame(
        [
            {"metric": m, **summarise(y[keep], options["quantiles"], limits.get(m))}
            for m, y in outputs_.items()
        ]
    )
    tables = []
    if options["method"] == "saltelli":
        tables = [indices_of(m, space.names, y, options["seed"]) for m, y in outputs_.items()]
    tables = [t for t in tables if t is not None]
    columns = ["metric", "parameter", "S1", "S1_conf", "ST", "ST_conf"]
    sobol = pd.concat(tables, ignore_index=True) if tables else pd.DataFrame(columns=columns)
    samples = pd.DataFrame(values[keep], columns=list(space.names))
    for m, y in outputs_.items():
        samples[m] = y[keep]
    outputs.write_table(distribution, out_dir / DISTRIBUTION)
    outputs.write_table(sobol, out_dir / SOBOL)
    outputs.write_table(convergence(study, space.names, outputs_), out_dir / CONVERGENCE)
    outputs.write_table(samples, out_dir / SAMPLES)
    return headline(distribution, sobol, options)


def headline(distribution: pd.DataFrame, sobol: pd.DataFrame, options: Mapping) -> str:
    """Each metric's 5-95 % interval (or why it has none), its leading input, and the
    probability of meeting the specification."""
    low, high = quantile_column(options["quantiles"][0]), quantile_column(options["quantiles"][-1])
    parts = []
    for r in distribution.itertuples():
        if r.resolved == 0:
            parts.append(f"{r.metric} not resolved in any sample")
            continue
        text = f"{r.metric} {short(getattr(r, low))}-{short(getattr(r, high))}"
        if r.resolved < r.samples:
            text += f" ({r.resolved} of {r.samples} samples resolved)"
        top = sobol[sobol["metric"] == r.metric].sort_values("ST", ascending=False)
        if len(top):
            text += f", led by {top.iloc[0]['parameter']} (ST {short(top.iloc[0]['ST'])})"
        if math.isfinite(r.p_meet):
            text += (
                f", P(<= {short(r.limit)}) = {short(r.p_meet)}"
                f" [{short(r.p_meet_low)}, {short(r.p_meet_high)}]"
            )
        parts.append(text)
    span = f"{options['quantiles'][0]:.0%}-{options['quantiles'][-1]:.0%}"
    return f"Uncertainty over {len(options['inputs'])} inputs ({span} intervals): " + "; ".join(
        parts
    )


def _number(value) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def planned_points(study) -> int:
    """Saltelli N (k + 2) for k inputs, Latin hypercube N."""
    n, k = study.options["samples"], len(study.bounds)
    return n * (k + 2) if study.options["method"] == "saltelli" else n


def figures(out_dir: Path) -> dict[str, Figure]:
    """Distributions, Sobol indices (if any) and convergence."""
    distribution = outputs.read_table(out_dir / DISTRIBUTION)
    samples = outputs.read_table(out_dir / SAMPLES)
    sobol = outputs.read_table(out_dir / SOBOL)
    figs = {"uncertainty-distributions.png": plot_distributions(distribution, samples)}
    if len(sobol):
        figs["uncertainty-sobol.png"] = plot_sobol(sobol)
    figs["uncertainty-convergence.png"] = plot_convergence(
        outputs.read_table(out_dir / CONVERGENCE)
    )
    return figs


UNCERTAINTY = StudyKind(
    name="uncertainty",
    fields=("input", "method", "samples", "seed", "metrics", "quantiles", "specification"),
    tables=(DISTRIBUTION, SOBOL, CONVERGENCE, SAMPLES),
    parse=parse,
    planned_points=planned_points,
    analyse=analyse,
    figures=figures,
)
