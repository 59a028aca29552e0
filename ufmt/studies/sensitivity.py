"""Study kind ``sensitivity``: global sensitivity of a record metric (default the
interferometer's PV, :mod:`ufmt.studies.metric`) to bearing stiffnesses and process
parameters (SALib).

Fields: ``[[bound]]`` over any parameters (at least two), ``metric``, ``method`` (morris | sobol),
``samples`` (Morris trajectories or Sobol base samples, default 16), ``levels`` (Morris,
default 4), ``seed`` (default 1). Each ``[[bound]]`` is a factor sampled uniformly in its
value, or in log10 of it for ``spacing = "log"`` (stiffnesses spanning decades). Methods:

* ``morris`` (default): elementary effects on ``levels``-level trajectories (Morris 1991; the
  radial-free design of Campolongo et al. 2007 as SALib samples it), ``samples`` trajectories,
  ``samples * (factors + 1)`` evaluations. ``mu_star_nm`` is the mean absolute change of the
  metric (in its unit: nm for the PV and RMS metrics) per full range of the factor (SALib's
  unit-hypercube effect), ``sigma_nm`` its spread (interactions and non-linearity).
* ``sobol``: Saltelli's estimator on a scrambled Sobol sequence, ``samples * (factors + 2)``
  evaluations; first-order ``S1`` and total ``ST`` shares of the metric's variance with
  bootstrap 95 % confidence half-widths.

The whole sample is one request to the runner: its workers evaluate it in chunks, each as one
batch (:mod:`ufmt.studies.parallel`).

Writes ``indices.csv`` (one row per factor, most influential first); its figure is a bar chart
of the indices.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from ufmt.errors import StudyError
from ufmt.plots.studies import plot_sensitivity
from ufmt.studies import outputs
from ufmt.studies.fields import MAX_POINTS, Parameters, read_bounds
from ufmt.studies.metric import metric_words, read_metric
from ufmt.studies.optimise import Space
from ufmt.studies.outputs import short
from ufmt.studies.spec import StudyKind
from ufmt.tables import Where

INDICES = "indices.csv"  # one row per factor, most influential first
METHODS = ("morris", "sobol")


def parse(where: Where, data: Mapping, parameters: Parameters) -> dict:
    """The sampled bounds and the method's options."""
    bounds = read_bounds(where, data, parameters, required=True)
    if len(bounds) < 2:
        where.fail("bound", "sensitivity needs at least two [[bound]] parameters")
    for b in bounds:
        if b.parameter in parameters.base:
            where.sub("base").fail(b.parameter, "is sampled by the sensitivity study; remove it")
    options = {
        "metric": read_metric(where, data, "metric"),
        "method": where.choice("method", data.get("method", "morris"), METHODS, "method"),
        "samples": where.integer("samples", data.get("samples", 16), 2, MAX_POINTS),
        "levels": where.integer("levels", data.get("levels", 4), 2),
        "seed": where.integer("seed", data.get("seed", 1), 0),
    }
    method = options["method"]
    if method == "sobol" and options["samples"] & (options["samples"] - 1):
        where.fail("samples", f"{options['samples']} is not a power of two (Sobol sampling)")
    return {"bounds": bounds, "options": options}


def sensitivity_problem(space: Space) -> dict:
    """SALib problem over the unit coordinates of ``space`` (linear, or log10 for log bounds)."""
    return {"num_vars": space.dim, "names": list(space.names), "bounds": [[0.0, 1.0]] * space.dim}


def morris_indices(problem: dict, X: np.ndarray, Y: np.ndarray, levels: int, seed: int):
    """Morris indices table (mu_star_nm, mu_star_conf_nm, sigma_nm, mu_nm)."""
    from SALib.analyze import morris

    Si = morris.analyze(problem, X, Y, num_levels=levels, seed=seed)
    table = pd.DataFrame(
        {
            "parameter": problem["names"],
            "mu_star_nm": Si["mu_star"],
            "mu_star_conf_nm": Si["mu_star_conf"],
            "sigma_nm": Si["sigma"],
            "mu_nm": Si["mu"],
        }
    )
    return table.sort_values("mu_star_nm", ascending=False, kind="stable")


def sobol_indices(problem: dict, Y: np.ndarray, seed: int):
    """Sobol indices table (S1, S1_conf, ST, ST_conf)."""
    from SALib.analyze import sobol

    Si = sobol.analyze(problem, Y, calc_second_order=False, seed=seed)
    table = pd.DataFrame(
        {
            "parameter": problem["names"],
            "S1": Si["S1"],
            "S1_conf": Si["S1_conf"],
            "ST": Si["ST"],
            "ST_conf": Si["ST_conf"],
        }
    )
    return table.sort_values("ST", ascending=False, kind="stable")


def sample(problem: dict, method: str, samples: int, levels: int, seed: int) -> np.ndarray:
    """Sample matrix (evaluations x factors) in the problem's coordinates."""
    if method == "morris":
        from SALib.sample import morris

        return morris.sample(problem, N=samples, num_levels=levels, seed=seed)
    from SALib.sample import sobol

    return sobol.sample(problem, N=samples, calc_second_order=False, seed=seed)


def sample_count(study) -> int:
    """Points a sensitivity study evaluates: Morris N (k + 1), Sobol (first order) N (k + 2)
    for N samples of k parameters."""
    k = len(study.bounds)
    per_sample = k + 1 if study.options["method"] == "morris" else k + 2
    return study.options["samples"] * per_sample


def analyse(study, evaluator, baseline: Mapping, out_dir: Path) -> str:
    """Sample, evaluate, analyse; write ``indices.csv``; return the headline."""
    options = study.options
    method = options["method"]
    space = Space.from_bounds(study.bounds, baseline)
    problem = sensitivity_problem(space)
    X = sample(problem, method, options["samples"], options["levels"], options["seed"])
    metric = options.get("metric", "pv_nm")
    Y = evaluator.values(method, space.points(X), metric)
    failed = int(np.count_nonzero(~np.isfinite(Y)))
    if failed:
        raise StudyError(
            f"{study.name}: {failed} of {len(Y)} points failed (see points.csv); sensitivity"
            " indices need every point"
        )
    if method == "morris":
        table = morris_indices(problem, X, Y, options["levels"], options["seed"])
        key, unit = "mu_star_nm", " nm"
    else:
        table = sobol_indices(problem, Y, options["seed"])
        key, unit = "ST", ""
    outputs.write_table(table.reset_index(drop=True), out_dir / INDICES)
    ranked = ", ".join(
        f"{r.parameter} ({short(getattr(r, key))}{unit})" for r in table.itertuples()
    )
    what = "mean |elementary effect| per full range" if method == "morris" else "total Sobol index"
    return f"{metric_words(metric)} ({metric}) sensitivity ranking ({method}, {what}): {ranked}."


def figures(out_dir: Path) -> dict[str, Figure]:
    """Bar chart of the indices."""
    return {"sensitivity.png": plot_sensitivity(outputs.read_table(out_dir / INDICES))}


SENSITIVITY = StudyKind(
    name="sensitivity",
    fields=("bound", "metric", "method", "samples", "levels", "seed"),
    tables=(INDICES,),
    parse=parse,
    planned_points=sample_count,
    analyse=analyse,
    figures=figures,
)
