"""Study kinds ``sweep`` and ``grid``: points on axes of values, all known before the run.

* ``sweep``: every ``[[axis]]`` is varied alone about the base (one-at-a-time); each
  ``[[grid]]`` (``name`` plus its own ``[[grid.axis]]`` list) adds a full-factorial grid.
* ``grid``: the ``[[axis]]`` entries are crossed into one full-factorial grid.

Field ``findings`` (default false): also judge the paper's statements like for like from
the points (``findings.csv``, :mod:`ufmt.studies.findings`).

Field ``metric`` (default the interferometer's PV, :mod:`ufmt.studies.metric`): the record
metric the headline and the figures rank. The headline says how it responds along each axis
and over each grid; the figures draw it against each one-at-a-time axis and map it over each
2-D grid; the PSD figure's best and worst points are its lowest and highest. Along each
one-at-a-time stiffness or speed axis the modes are followed by MAC (``modes.csv``,
:mod:`ufmt.studies.tracking`). With ``intervals``, each group's best point is compared with its
worst over the documented bands (``decisions.csv``, :mod:`ufmt.studies.decisions`).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from ufmt.defaults import REFERENCE_PROCESS
from ufmt.design import PROCESS_PARAMETERS, apply_design
from ufmt.errors import UfmtError
from ufmt.evaluate import resolve_model
from ufmt.plots.psd import plot_psd_extremes
from ufmt.plots.studies import plot_tracked_modes, sweep_figures
from ufmt.simulate import Process, simulate
from ufmt.studies import outputs
from ufmt.studies.decisions import (
    BAND_POINTS,
    DECISIONS,
    compare_logged,
    draws,
    read_decisions,
    sentences,
)
from ufmt.studies.decisions import FIELDS as DECISION_FIELDS
from ufmt.studies.fields import DEFAULT_FUNCTION, Parameters, read_axes, read_grids
from ufmt.studies.findings import FINDINGS, findings_headline, findings_table
from ufmt.studies.metric import metric_unit, metric_words, read_metric
from ufmt.studies.outputs import short
from ufmt.studies.spec import Group, StudyKind
from ufmt.studies.tracking import moved, tracked_modes
from ufmt.tables import Where


def parse_sweep(where: Where, data: Mapping, parameters: Parameters) -> dict:
    """The axes (one group each) and grids of a sweep."""
    axes = read_axes(where, data, parameters, required=False)
    groups = [Group(a.parameter, (a,)) for a in axes]
    groups += read_grids(where, data, parameters)
    if not groups:
        where.fail("axis", "a sweep needs at least one [[axis]] or [[grid]]")
    where.unique("axis", [g.name for g in groups])
    parts = _with_decisions(where, data, parameters, tuple(groups))
    if "findings" in data:
        parts["options"]["findings"] = where.boolean("findings", data["findings"])
    return parts


def parse_grid(where: Where, data: Mapping, parameters: Parameters) -> dict:
    """The axes of a grid, crossed into one group."""
    axes = read_axes(where, data, parameters, required=True)
    return _with_decisions(where, data, parameters, (Group("grid", tuple(axes)),))


def _with_decisions(where: Where, data: Mapping, parameters: Parameters, groups) -> dict:
    """The kind's parts: its groups, its metric and its decisions' options
    (:mod:`ufmt.studies.decisions`: each group's best point against its worst)."""
    swept = [a.parameter for g in groups for a in g.axes]
    decisions, inputs = read_decisions(where, data, parameters, swept)
    options = {"metric": read_metric(where, data, "metric"), **decisions}
    return {"groups": groups, "options": options, "inputs": inputs}


def planned_points(study) -> int:
    """Points of every axis and grid (the decisions' band samples are logged apart)."""
    return sum(math.prod(len(a.values) for a in g.axes) for g in study.groups)


def analyse(study, evaluator, baseline: Mapping[str, float], out_dir: Path) -> str:
    """Evaluate every point of every group, follow the modes along the stiffness and speed
    axes (``modes.csv``); returns the headline."""
    evaluator.evaluate([(g.name, p) for g in study.groups for p in g.points(baseline)])
    table = evaluator.table()
    headline = sweep_headline(table, study)
    if study.options.get("findings"):  # the statements are the study's answer; the axes'
        found = findings_table(table, baseline)  # trends are in findings.csv and the figures
        outputs.write_table(found, out_dir / FINDINGS)
        headline = findings_headline(found)
    said = best_against_worst(study, evaluator, table, out_dir)
    if said:
        headline += f" Decisions: {said}."
    modes = mode_tracks(study, baseline)
    if modes is not None:
        outputs.write_table(modes, out_dir / MODES)
        headline += modes_headline(modes)
    return headline


def best_against_worst(study, evaluator, table: pd.DataFrame, out_dir: Path) -> str:
    """Each group's best point (lowest metric) against its worst, with the difference's
    interval over the bands (``decisions.csv``); '' without ``intervals``."""
    metric, n = study.options["metric"], study.options.get("intervals", 0)
    if not n:
        return ""
    comparisons = []
    for group in study.groups:
        rows = table[(table["group"] == group.name) & (table["status"] == "ok")]
        values = pd.to_numeric(rows[metric], errors="coerce") if metric in rows else None
        if values is None or values.notna().sum() < 2:
            continue
        names = [a.parameter for a in group.axes]
        best, worst = rows.loc[values.idxmin(), names], rows.loc[values.idxmax(), names]
        point = {"best": best.astype(float).to_dict(), "worst": worst.astype(float).to_dict()}
        comparisons.append((group.name, point["worst"], point["best"]))
    samples = draws(study.inputs, n, study.options["interval_seed"])
    decisions = compare_logged(evaluator, comparisons, [metric], samples)
    outputs.write_table(decisions, out_dir / DECISIONS)
    return f"each axis's best against its worst: {sentences(decisions)}"


#: Modes followed by MAC along each stiffness or speed axis (:mod:`ufmt.studies.tracking`).
MODES = "modes.csv"


def _tracked_axis(name: str) -> bool:
    """Whether the modes are followed along an axis of ``name``: a design parameter (a
    stiffness) or the spindle speed (a Campbell diagram); not feed, depth or machine keys,
    which change no mode."""
    return name == "rpm" or not (name in PROCESS_PARAMETERS or name.startswith("machine."))


def mode_tracks(study, baseline: Mapping[str, float]) -> pd.DataFrame | None:
    """The modes along every one-at-a-time stiffness or speed axis, followed by MAC
    (:func:`ufmt.studies.tracking.tracked_modes`), as one table; None when the study's
    function is not ``ufmt.evaluate`` or no axis changes or drives the modes."""
    if study.function != DEFAULT_FUNCTION:
        return None
    base, _ = resolve_model(study.model)
    fixed = {k: v for k, v in study.base.items() if not _not_design(k)}
    frames = []
    for group in study.groups:
        if len(group.axes) != 1 or not _tracked_axis(group.axes[0].parameter):
            continue
        axis = group.axes[0]
        name = axis.parameter

        def model_at(value, name=name):
            design = fixed if name == "rpm" else {**fixed, name: value}
            return apply_design(base, design, study.design)

        frames.append(tracked_modes(model_at, axis.resolved(baseline), name))
    return pd.concat(frames, ignore_index=True) if frames else None


def _not_design(name: str) -> bool:
    """A process parameter or a ``machine.`` key (applied elsewhere than the hinges)."""
    return name in PROCESS_PARAMETERS or name.startswith("machine.")


def modes_headline(modes: pd.DataFrame) -> str:
    """ " Modes: ..." naming, per stiffness axis, the mode whose frequency moves most."""
    parts = []
    for name, table in modes.groupby("parameter", sort=False):
        if name == "rpm":
            continue
        track, ratio = next(iter(moved(table, top=1).items()))
        first = table[table["track_name"] == track]["frequency_hz"]
        parts.append(
            f"{name}: the {track} mode moves most ({short(first.iloc[0])} ->"
            f" {short(first.iloc[-1])} Hz)"
        )
    return f" Modes followed by MAC: {'; '.join(parts)}." if parts else ""


def figures(out_dir: Path) -> dict[str, Figure]:
    """The metric against each one-at-a-time axis, a map of it per 2-D grid, and the modes
    followed along the stiffness and speed axes (where ``modes.csv`` was written)."""
    meta = outputs.read_meta(out_dir)
    out = sweep_figures(outputs.read_table(out_dir / outputs.POINTS), meta)
    if (out_dir / MODES).is_file():
        out["modes_tracked.png"] = plot_tracked_modes(outputs.read_table(out_dir / MODES), meta)
    return out


EXTREMES_FIGURE = "psd_best_worst.png"


def extreme_psd_figures(study, out_dir: Path) -> dict[str, Figure]:
    """PSDs of the sweep's best and worst points (lowest and highest value of the study's
    ``metric`` in points.csv) in one figure (:func:`ufmt.plots.psd.plot_psd_extremes`).

    The surfaces are not in the tables, so the two points are simulated again here, through
    :func:`ufmt.simulate` on the study's model with the point's design applied: two
    simulations, part of the study's outputs step (run only when plots are drawn); the plot
    function reads their results. Empty when the study function is not ``ufmt.evaluate``
    (its points are not ufmt simulations) or fewer than two points succeeded.
    """
    if study.function != DEFAULT_FUNCTION:
        return {}
    metric = study.options["metric"]
    table = outputs.read_table(out_dir / outputs.POINTS)
    table = table[table["group"].isin([g.name for g in study.groups])]
    values = pd.to_numeric(table.get(metric), errors="coerce")
    ok = table[(table["status"] == "ok") & np.isfinite(values)]
    if len(ok) < 2:
        return {}
    ranked = values[ok.index]
    rows = {"best": ok.loc[ranked.idxmin()], "worst": ok.loc[ranked.idxmax()]}
    try:
        results = {label: simulate_point(study, row) for label, row in rows.items()}
    except UfmtError as exc:  # the points are saved; only this figure is missing
        warnings.warn(f"{study.name}: no {EXTREMES_FIGURE}: {exc}", stacklevel=2)
        return {}
    return {EXTREMES_FIGURE: plot_psd_extremes(results, metric)}


def simulate_point(study, row: Mapping):
    """:func:`ufmt.simulate` of one study point (``row``: the values of the study's
    parameters): the model with the point's design applied, cut with its process."""
    values = {p: float(row[p]) for p in study.parameters}
    design = {k: v for k, v in values.items() if k not in PROCESS_PARAMETERS}
    process = {**REFERENCE_PROCESS, **{k: v for k, v in values.items() if k in PROCESS_PARAMETERS}}
    base, _ = resolve_model(study.model)
    return simulate(apply_design(base, design, study.design), Process(**process))


def trend(x, y) -> str:
    """How ``y`` changes as ``x`` rises: "falls" or "rises" (monotonically), else "falls
    overall (not monotonically)" or "rises overall (not monotonically)" by the end points."""
    y = np.asarray(y, dtype=float)[np.argsort(x)]
    steps = np.diff(y)
    if np.all(steps <= 0):
        return "falls"
    if np.all(steps >= 0):
        return "rises"
    return f"{'falls' if y[-1] < y[0] else 'rises'} overall (not monotonically)"


def sweep_headline(table: pd.DataFrame, study) -> str:
    """One sentence per sweep axis or grid: how the study's metric responds, with its range
    (and, where the table has it, the PV of the cutting-force vibration alone at the axis
    ends); the metric is named once, first."""
    metric = study.options.get("metric", "pv_nm")
    words, unit = metric_words(metric), metric_unit(metric)
    ok = table[table["status"] == "ok"] if "status" in table else table
    parts = []
    for group in study.groups:
        rows = ok[ok["group"] == group.name]
        if rows.empty or metric not in rows or not rows[metric].notna().any():
            parts.append(f"{group.name}: no successful points")
            continue
        rows = rows[rows[metric].notna()]
        pv = rows[metric].to_numpy(float)
        if len(group.axes) == 1:
            name = group.axes[0].parameter
            x = rows[name].to_numpy(float)
            lo, hi = x.min(), x.max()
            vibration = ""
            if "pv_dynamic_nm" in rows and rows["pv_dynamic_nm"].notna().all():
                dyn = rows["pv_dynamic_nm"].to_numpy(float)
                vibration = (
                    f"; vibration's PV {short(dyn[np.argmin(x)])} -> {short(dyn[np.argmax(x)])} nm"
                )
            if lo == hi:  # one value: nothing rises or falls
                parts.append(f"{short(pv.min())} {unit} at {name} = {short(lo)} (one point)")
                continue
            parts.append(
                f"{trend(x, pv)} as {name} rises from {short(lo)} to {short(hi)}"
                f" ({short(pv[np.argmin(x)])} -> {short(pv[np.argmax(x)])} {unit},"
                f" range {short(pv.min())}-{short(pv.max())} {unit}{vibration})"
            )
        else:
            best = rows.iloc[int(np.argmin(pv))]
            at = ", ".join(f"{a.parameter} = {short(best[a.parameter])}" for a in group.axes)
            label = "grid" if group.name == "grid" else f"grid {group.name}"
            parts.append(f"{label}: {short(pv.min())}-{short(pv.max())} {unit}, lowest at {at}")
    return f"{words} ({metric}): " + "; ".join(parts) + "."


SWEEP = StudyKind(
    name="sweep",
    fields=("axis", "grid", "metric", "findings", *DECISION_FIELDS),
    tables=(MODES, FINDINGS, DECISIONS, BAND_POINTS),
    parse=parse_sweep,
    planned_points=planned_points,
    analyse=analyse,
    figures=figures,
    simulated_figures=extreme_psd_figures,
)
GRID = StudyKind(
    name="grid",
    fields=("axis", "metric", *DECISION_FIELDS),
    tables=(MODES, DECISIONS, BAND_POINTS),
    parse=parse_grid,
    planned_points=planned_points,
    analyse=analyse,
    figures=figures,
    simulated_figures=extreme_psd_figures,
)
