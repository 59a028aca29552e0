"""Study kind ``uncertainty``: every metric as a distribution over the model's documented
bands, with its quantiles, its Sobol indices and the probability of meeting a specification.

The documented bands are the study model's (:func:`ufmt.studies.bands.model_bands`: its file's
``[[uncertain]]`` tables, or the packaged machine's on the packaged machine); an input given
by its name with ``range`` or ``scale`` needs no documented band.

Fields::

    [[input]]                        # one per uncertain input (at least one)
    parameter = "machine.*"          # a parameter, or a shell pattern over the model's documented
                                     #   bands (ufmt.studies.bands.model_bands)
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

    [[contrast]]                     # optional: a sweep's finding with its interval
                                     #   (ufmt.studies.contrasts)

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
``convergence.csv`` (the estimates on the nested prefixes of N/2^j base samples),
``samples.csv`` (inputs and metrics of the independent points) and, with ``[[contrast]]``,
``contrast.csv`` (:mod:`ufmt.studies.contrasts`). A metric that is NaN (a band
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
from ufmt.studies import contrasts, outputs
from ufmt.studies.bands import matching, model_bands, no_bands
from ufmt.studies.contrasts import CONTRAST, evaluate_contrasts, parse_contrasts, sentence
from ufmt.studies.fields import MAX_POINTS, Parameters
from ufmt.studies.optimise import Space
from ufmt.studies.outputs import short
from ufmt.studies.spec import Bound, StudyKind
from ufmt.tables import Where

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


def parse(where: Where, data: Mapping, parameters: Parameters) -> dict:
    """The inputs (as bounds, with their distributions) and the options."""
    bounds, inputs = _inputs(where, data, parameters)
    for b in bounds:
        if b.parameter in parameters.base:
            where.sub("base").fail(b.parameter, "is an uncertain input of this study; remove it")
    method = where.choice("method", data.get("method", "saltelli"), METHODS, "method")
    samples = where.integer("samples", data.get("samples", 64), 2, MAX_POINTS)
    if method == "saltelli" and samples & (samples - 1):
        where.fail("samples", f"{samples} is not a power of two (Saltelli sampling)")
    options = {
        "inputs": inputs,
        "method": method,
        "samples": samples,
        "seed": where.integer("seed", data.get("seed", 1), 0),
        "metrics": _metrics(where, data.get("metrics", list(DEFAULT_METRICS))),
        "quantiles": _quantiles(where, data.get("quantiles", list(DEFAULT_QUANTILES))),
        "specification": _specification(where, data.get("specification", {})),
    }
    for metric in options["specification"]:
        if metric not in options["metrics"]:  # its limit would be dropped without a word
            where.sub("specification").fail(
                metric, f"is not one of this study's metrics ({', '.join(options['metrics'])})"
            )
    groups, options["contrasts"] = parse_contrasts(
        where, data, parameters, [b.parameter for b in bounds]
    )
    return {"bounds": bounds, "groups": groups, "options": options}


def _inputs(
    where: Where, data: Mapping, parameters: Parameters
) -> tuple[tuple[Bound, ...], list[dict]]:
    """The ``[[input]]`` tables: bounds (documented band or the file's) and distributions."""
    tables = where.tables("input", data.get("input", []), required=True)
    bands = model_bands(parameters.model, damping=False)
    found: dict[str, tuple[Bound, dict, bool]] = {}  # name -> (bound, input, from a pattern)
    for i, table in enumerate(tables):
        at = where.sub(f"input[{i}]")
        at.keys(table, _INPUT_FIELDS, required=("parameter",))
        pattern = at.string("parameter", table["parameter"])
        distribution = table.get("distribution", "uniform")
        distribution = at.choice("distribution", distribution, DISTRIBUTIONS, "distribution")
        is_pattern = any(c in pattern for c in "*?[") and not _is_name(pattern, bands, parameters)
        names = matching(pattern, bands) if is_pattern else [pattern]
        if not names and not bands:
            at.fail("parameter", str(no_bands(parameters.model)))
        if not names:
            at.fail("parameter", f"{pattern!r} matches no documented band ({', '.join(bands)})")
        for name in names:
            parameters.check(at, "parameter", name)
            if name in found and not found[name][2]:
                where.fail("input", f"{name!r} appears more than once")
            bound = _bound(where.sub(f"input {name!r}"), name, table, bands, distribution)
            if bound.relative:
                _check_scalable(where.sub(f"input {name!r}"), parameters, name)
            reason = "study file" if bound.relative or "range" in table else bands[name].reason
            entry = {"parameter": name, "distribution": distribution, "band": reason}
            found[name] = (bound, entry, is_pattern)
    return tuple(b for b, _, _ in found.values()), [e for _, e, _ in found.values()]


def _is_name(text: str, bands, parameters: Parameters) -> bool:
    """Whether ``text`` names one parameter (a band, or a parameter of the study's model such
    as ``hinge.h3.stiffness[0]``) rather than a shell pattern over the bands."""
    if text in bands or text in PROCESS_PARAMETERS:
        return True
    return unknown_design_parameter(text, parameters.model, parameters.declared) is None


def _bound(at: Where, name: str, table: Mapping, bands, distribution: str) -> Bound:
    """The sampled interval of ``name``: the file's range or scale, else its documented
    band."""
    log = distribution == "loguniform"
    rules = {"sign": "positive", "allowed": "> 0 for a log-uniform input"} if log else {}
    given = [key for key in ("range", "scale") if key in table]
    if len(given) > 1:
        at.fail_table("give at most one of range, scale")
    if given == ["range"]:
        return Bound(name, *at.interval("range", table["range"], **rules), log)
    if given == ["scale"]:
        low, high = at.interval("scale", table["scale"], sign="positive")
        return Bound(name, low, high, log, relative=True)
    if name not in bands:
        at.missing("range", "no documented band on this model: give range or scale")
    band = bands[name]
    if log and band.low <= 0:
        at.fail("distribution", f"loguniform needs a band > 0, not [{band.low:g}, {band.high:g}]")
    return Bound(name, band.low, band.high, log)


def _metrics(where: Where, value) -> list[str]:
    """A non-empty array of distinct record outputs."""
    items = where.items("metrics", value, "metric name", required=True)
    names = [where.choice(f"metrics[{i}]", m, METRICS, "metric") for i, m in enumerate(items)]
    return where.unique("metrics", names)


def _quantiles(where: Where, value) -> list[float]:
    """A non-empty array of probabilities in (0, 1), sorted, without repeats."""
    items = where.items("quantiles", value, "quantile", required=True)
    quantiles = []
    for i, q in enumerate(items):
        q = where.number(f"quantiles[{i}]", q, allowed="a probability in (0, 1)")
        if not 0.0 < q < 1.0:
            where.fail(f"quantiles[{i}]", f"{q:g} is outside (0, 1)")
        quantiles.append(q)
    return sorted(set(quantiles))


def _specification(where: Where, table) -> dict[str, float]:
    """``[specification]``: metric -> upper limit (> 0)."""
    table = where.mapping("specification", table, "[specification]")
    at = where.sub("specification")
    at.keys(table, METRICS)
    return {metric: at.number(metric, value, sign="positive") for metric, value in table.items()}


def _check_scalable(at: Where, parameters: Parameters, name: str) -> None:
    """A scale multiplies the calibrated value: refuse a released, rigid or absurd one."""
    value = parameters.baseline(name)
    if not (math.isfinite(value) and value > 0):
        at.fail(
            "scale",
            f"the calibrated value of {name} is {value!r}: a scale of it is meaningless;"
            " give range",
        )


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
    text = headline(distribution, sobol, options)
    if options["contrasts"]:
        draws = [dict(zip(space.names, map(float, row), strict=True)) for row in values[keep]]
        contrast = evaluate_contrasts(study, evaluator, baseline, draws)
        outputs.write_table(contrast, out_dir / CONTRAST)
        said = "; ".join(sentence(r) for r in contrast.to_dict("records"))
        text += f"; findings (point change, 5-95 % over the samples): {said}"
    return text


def headline(distribution: pd.DataFrame, sobol: pd.DataFrame, options: Mapping) -> str:
    """Each metric's 5-95 % interval (or why it has none), its leading input, and the
    probability of meeting the specification."""
    low, high = quantile_column(options["quantiles"][0]), quantile_column(options["quantiles"][-1])
    parts = []
    for r in distribution.to_dict("records"):  # by name: "q2.5" is no attribute name
        if r["resolved"] == 0:
            parts.append(f"{r['metric']} not resolved in any sample")
            continue
        text = f"{r['metric']} {short(r[low])}-{short(r[high])}"
        if r["resolved"] < r["samples"]:
            text += f" ({r['resolved']} of {r['samples']} samples resolved)"
        top = sobol[sobol["metric"] == r["metric"]].sort_values("ST", ascending=False)
        if len(top):
            text += f", led by {top.iloc[0]['parameter']} (ST {short(top.iloc[0]['ST'])})"
        if math.isfinite(r["p_meet"]):
            text += (
                f", P(<= {short(r['limit'])}) = {short(r['p_meet'])}"
                f" [{short(r['p_meet_low'])}, {short(r['p_meet_high'])}]"
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
    """Saltelli N (k + 2) for k inputs, Latin hypercube N; then the contrasts."""
    n, k = study.options["samples"], len(study.bounds)
    saltelli = study.options["method"] == "saltelli"
    independent = 2 * n if saltelli else n
    return (n * (k + 2) if saltelli else n) + contrasts.planned(study, independent)


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
    fields=(
        "input",
        "method",
        "samples",
        "seed",
        "metrics",
        "quantiles",
        "specification",
        "contrast",
    ),
    tables=(DISTRIBUTION, SOBOL, CONVERGENCE, SAMPLES, CONTRAST),
    parse=parse,
    planned_points=planned_points,
    analyse=analyse,
    figures=figures,
)
