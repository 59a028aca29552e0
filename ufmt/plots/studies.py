"""Plots of study results, drawn from the tables of ``results/<study>/`` (never recomputed).

* sweeps: PV against each swept parameter (log axis for stiffnesses, the calibrated value
  marked, the region outside the paper's Table 1 shaded for process parameters), as the
  paper's Fig. 15 (bearing stiffness) and Fig. 16 (rpm, feed, depth); PV maps over 2-D grids
  with the lowest point and the calibrated design / base recipe marked. The metric drawn and
  ranked is the study's (``metric``, :mod:`ufmt.studies.metric`; by default the
  interferometer's PV, ``pv_measured_nm``, what a shop reads and Table 4 reports), the
  whole-plate PV (``pv_nm``) beside it on its own axis;
* optimisers: convergence (best objective against evaluations, per stage); for cutting
  recipes the Pareto front of PV against cutting time with the PV target, each front point
  labelled with its recipe; for designs the trade-off of PV against stiffness cost;
* sensitivity: bar chart of the indices with their 95 % confidence intervals.

Each ``plot_*`` takes tables (and an optional ``ax``) and returns the Figure; each study
kind's module (:mod:`ufmt.studies.kinds`) reads its tables and picks its figures.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.colors import LogNorm
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

from ufmt.design import SOURCE_METRICS
from ufmt.machining.process import TABLE1_RANGE
from ufmt.metric_names import metric_axis_label, metric_label, metric_unit, metric_words
from ufmt.plots import new_axes, new_figure

PANEL = (4.2, 3.2)  # inches per panel
DENSE_TICK_SPAN = 30.0  # log axes spanning less than this ratio label every 1-9 x 10^k
MAX_LABELLED_CELLS = 64  # PV maps print each cell's value up to this many cells
MAX_RECIPE_LABELS = 10  # Pareto points labelled with their recipe (evenly picked)
OUTSIDE_TABLE1 = {"color": "0.85", "hatch": "//", "alpha": 0.5, "lw": 0}
CONSTANT_SHARE = 1e-3  # a source whose PV moves less than this share is drawn as constant
OPTIMUM_LABELS = {
    "min-pv": "minimum",
    "fastest-under-target": "fastest recipe under the target",
    "calibrated": "calibrated design",
    "optimum": "optimum design",
}
_UNITS = (  # column-name suffix -> unit of an axis label
    ("_Nm_rad", "N m/rad"),
    ("_N_m", "N/m"),
    ("_mm_min", "mm/min"),
    ("_um", "µm"),
    ("_nm", "nm"),
    ("_hz", "Hz"),
    ("_mm", "mm"),
    ("_min", "min"),
)


def parameter_label(name: str) -> str:
    """Axis label of a column: ``head_angular_stiffness_Nm_rad`` -> "head angular stiffness
    [N m/rad]", ``rpm`` -> "spindle speed [rpm]"."""
    if name == "rpm":
        return "spindle speed [rpm]"
    for suffix, unit in _UNITS:
        if name.endswith(suffix):
            return f"{name[: -len(suffix)].replace('_', ' ')} [{unit}]"
    return name.replace("_", " ")


def _ok(points: pd.DataFrame) -> pd.DataFrame:
    return points[points["status"] == "ok"] if "status" in points else points


def _plain_log(axis, values=None) -> None:
    """Log axis with plain numbers ("200", not "2x10^2") at 1, 2, 5 x 10^k, or at every
    1-9 x 10^k where ``values`` span less than :data:`DENSE_TICK_SPAN` (so that a narrow
    range, e.g. 70-200 nm, has its numbers read)."""
    subs = (1.0, 2.0, 5.0)
    if values is not None:
        v = np.asarray(values, dtype=float)
        v = v[np.isfinite(v) & (v > 0)]
        if v.size and v.max() / v.min() < DENSE_TICK_SPAN:
            subs = tuple(float(k) for k in range(1, 10))
    axis.set_major_locator(LogLocator(subs=subs))
    axis.set_major_formatter(FuncFormatter(lambda v, _: _plain(v)))
    axis.set_minor_formatter(NullFormatter())


def _plain(value: float) -> str:
    """A tick label: "200", "0.5", or "2e8" for large and small numbers (never "2x10^8")."""
    if value == 0 or 1e-3 <= abs(value) < 1e5:
        return f"{value:g}"
    mantissa, exponent = f"{value:.0e}".split("e")
    return f"{mantissa}e{int(exponent)}"


def _label(name: str) -> str:
    """Legend text of an optimum or optimiser stage ("min-pv" -> "minimum PV")."""
    if name in OPTIMUM_LABELS:
        return OPTIMUM_LABELS[name]
    if name.startswith("feed-"):
        return f"feed {name[5:]} mm/min"
    return name.replace("-", " ").replace("_", " ")


def _shade_outside_table1(ax, name: str, values, axis: str = "x") -> bool:
    """Shade where process parameter ``name`` leaves the paper's Table 1 range, when some of
    ``values`` lie there; True if shaded."""
    if name not in TABLE1_RANGE:
        return False
    low, high, _ = TABLE1_RANGE[name]
    values = np.asarray(values, dtype=float)
    if np.all((values >= low) & (values <= high)):
        return False
    lo, hi = ax.get_xlim() if axis == "x" else ax.get_ylim()
    span = ax.axvspan if axis == "x" else ax.axhspan
    labelled = "outside Table 1" in ax.get_legend_handles_labels()[1]
    for a, b in ((lo, min(low, hi)), (max(high, lo), hi)):
        if b > a:
            span(a, b, label=None if labelled else "outside Table 1", **OUTSIDE_TABLE1)
            labelled = True
    (ax.set_xlim if axis == "x" else ax.set_ylim)(lo, hi)
    return True


def sweep_figures(points: pd.DataFrame, meta: dict) -> dict[str, Figure]:
    """The study's metric against each one-at-a-time axis (one figure) and a map of it per
    2-D grid (the metric of ``meta["options"]``, else :func:`_main_metric`)."""
    figures = {}
    metric = meta.get("options", {}).get("metric") or _main_metric(points)
    lines = [g for g in meta["groups"] if len(g["axes"]) == 1]
    if lines:
        figures["pv_vs_parameters.png"] = plot_pv_lines(points, lines, meta["baseline"], metric)
    for group in meta["groups"]:
        if len(group["axes"]) == 2:
            figures[f"pv_map_{group['name']}.png"] = plot_pv_map(
                points, group, meta["baseline"], metric=metric
            )
    return figures


def plot_pv_lines(
    points: pd.DataFrame, groups: list[dict], baseline: dict, metric: str | None = None, ax=None
) -> Figure:
    """Two panels per swept parameter. Above: ``metric`` (default :func:`_main_metric`: the
    interferometer's PV where the table has it) with the whole-plate PV (``pv_nm``) on its own
    right-hand axis. Below: the PV of each error source alone that
    changes over the sweep (the cutting-force vibration first); sources that are zero, or
    constant over every axis, are named in the legend instead of drawn. One legend for all.

    ax : two axes per group (above, below); default a new figure, up to three groups a row.
    """
    n = len(groups)
    cols = min(n, 3)
    rows = -(-n // cols)
    if ax is None:
        fig = new_figure((PANEL[0] * cols, 1.55 * PANEL[1] * rows + 0.9))
        grid = fig.add_gridspec(2 * rows, cols, height_ratios=[3, 2] * rows)
        panels = [
            (
                fig.add_subplot(grid[2 * (i // cols), i % cols]),
                fig.add_subplot(grid[2 * (i // cols) + 1, i % cols]),
            )
            for i in range(n)
        ]
    else:
        panels = [tuple(ax[2 * i : 2 * i + 2]) for i in range(n)]
        fig = panels[0][0].figure
    ok = _ok(points)
    metric = metric or _main_metric(ok)
    sources, constant = _varying_sources(ok)
    roles = [
        _pv_panels(top, bot, ok, group, baseline, sources, metric)
        for (top, bot), group in zip(panels, groups, strict=True)
    ]
    for role in ("metric", "whole", "vibration", "others"):  # compared panels: one scale
        common_scale([r[role] for r in roles if r.get(role) is not None])
    handles, labels = _unique_legend(fig)
    for column, value in constant.items():
        handles.append(Line2D([], [], ls="none"))
        labels.append(f"{_source(column)} alone: {value:.3g} nm at every point (not drawn)")
    fig.legend(handles, labels, loc="outside lower center", ncols=cols, fontsize="small")
    fig.suptitle(f"{metric_words(metric)} against each swept parameter (others at the base design)")
    return fig


def _source(column: str) -> str:
    """Legend name of a ``pv_<source>_nm`` column."""
    if column == "pv_dynamic_nm":
        return "cutting-force vibration"
    return column.removeprefix("pv_").removesuffix("_nm").replace("_", " ")


def _varying_sources(ok: pd.DataFrame) -> tuple[list[str], dict[str, float]]:
    """The ``pv_<source>_nm`` columns that change over the table (vibration first) and the
    non-zero constant ones with their value; zero or empty ones are left out."""
    varying, constant = [], {}
    for column in SOURCE_METRICS:
        if column not in ok or not ok[column].notna().any():
            continue
        values = ok[column].to_numpy(float)
        spread = np.nanmax(values) - np.nanmin(values)
        if spread > CONSTANT_SHARE * max(np.nanmax(np.abs(values)), 1e-12):
            varying.append(column)
        elif np.nanmax(np.abs(values)) > 0:
            constant[column] = float(np.nanmean(values))
    varying.sort(key=lambda c: c != "pv_dynamic_nm")
    return varying, constant


def _pv_panels(top, bottom, ok, group, baseline, sources, metric) -> dict:
    """One parameter's two panels (see :func:`plot_pv_lines`); returns their y axes by role
    ("metric", "whole", "vibration", "others"; absent where not drawn)."""
    roles = {"metric": top}
    axis = group["axes"][0]
    name = axis["parameter"]
    data = ok[ok["group"] == group["name"]].sort_values(name)
    x = data[name]
    top.plot(x, data[metric], "o-", color="C0", label=metric_label(metric))
    if metric != "pv_nm" and "pv_nm" in data:
        whole = roles["whole"] = top.twinx()
        label = "whole-plate PV (every point of the cut, right axis)"
        whole.plot(x, data["pv_nm"], "s--", ms=3, color="0.45", label=label)
        whole.set_ylabel("whole-plate PV [nm]", color="0.45", fontsize="small")
        whole.tick_params(axis="y", colors="0.45", labelsize="small")
    others = [c for c in sources if c != "pv_dynamic_nm"]
    if "pv_dynamic_nm" in sources:
        bottom.plot(
            x,
            data["pv_dynamic_nm"],
            "o-",
            ms=2.5,
            color="C3",
            lw=1.6,
            label=f"{_source('pv_dynamic_nm')} alone",
        )
        bottom.set_ylabel("vibration alone [nm]", color="C3", fontsize="small")
        roles["vibration"] = bottom
    if others:  # on their own axis, so that the vibration's change stays visible
        right = roles["others"] = bottom.twinx()
        for k, column in enumerate(others):
            right.plot(
                x,
                data[column],
                "^:",
                ms=2.5,
                lw=1.0,
                color=f"C{4 + k}",
                label=f"{_source(column)} alone (right axis, lower panel)",
            )
        right.set_ylabel("other sources alone [nm]", fontsize="small", color="C4")
        right.tick_params(axis="y", labelsize="small")
        right.margins(y=0.15)
    top.set_ylabel(metric_axis_label(metric), color="C0")
    bottom.set_xlabel(parameter_label(name))
    for a in (top, bottom):
        if axis["log"]:
            a.set_xscale("log")
        reference = baseline.get(name)
        if reference is not None and np.isfinite(reference):
            a.axvline(reference, color="0.5", lw=0.8, ls=":", label="calibrated / base")
        _shade_outside_table1(a, name, x)
        a.grid(True, which="both", alpha=0.3)
        a.margins(y=0.15)
    top.tick_params(labelbottom=False)
    top.sharex(bottom)
    return roles


#: The smallest y range of a compared sweep panel, as a share of its largest |value|: a
#: change smaller than this share is drawn flat, not stretched over the panel's height.
MIN_SPAN_SHARE = 0.2


def common_scale(axes: list, share: float = MIN_SPAN_SHARE) -> None:
    """One y range for ``axes`` (panels compared with each other): their data's joint range,
    widened about its middle to at least ``share`` of the largest |value|, plus 10 %."""
    limits = [a.dataLim for a in axes if np.isfinite(a.dataLim.y0) and a.dataLim.height >= 0]
    if not limits:
        return
    low = min(b.y0 for b in limits)
    high = max(b.y1 for b in limits)
    if not (np.isfinite(low) and np.isfinite(high)):
        return
    span = max(high - low, share * max(abs(low), abs(high)), 1e-12)
    middle = 0.5 * (low + high)
    low, high = middle - 0.55 * span, middle + 0.55 * span
    if low < 0 <= min(b.y0 for b in limits):  # a non-negative quantity keeps a non-negative axis
        low, high = 0.0, high - low
    for a in axes:
        a.set_ylim(low, high)


def _unique_legend(fig) -> tuple[list, list[str]]:
    """Every labelled artist of the figure's axes, each label once."""
    seen = {}
    for a in fig.axes:
        for handle, label in zip(*a.get_legend_handles_labels(), strict=True):
            seen.setdefault(label, handle)
    return list(seen.values()), list(seen)


def plot_pv_map(
    points: pd.DataFrame,
    group: dict,
    baseline: dict | None = None,
    ax=None,
    metric: str | None = None,
) -> Figure:
    """``metric`` over a 2-D grid (log axes for log-spaced parameters), its lowest point and
    the calibrated design / base recipe marked (default :func:`_main_metric`: the
    interferometer's PV where the table has it; the whole-plate PV's range in the title)."""
    x_axis, y_axis = group["axes"]
    x_name, y_name = x_axis["parameter"], y_axis["parameter"]
    data = points[points["group"] == group["name"]]
    metric = metric or _main_metric(data)
    words = metric_words(metric)
    label = metric_axis_label(metric)
    table = data.pivot_table(index=y_name, columns=x_name, values=metric, aggfunc="first")
    fig, ax = new_axes(ax, (1.5 * PANEL[0], 1.35 * PANEL[1]))
    pv = table.to_numpy(float)
    norm = LogNorm() if np.nanmin(pv) > 0 and np.nanmax(pv) > 10 * np.nanmin(pv) else None
    x, y = table.columns.to_numpy(float), table.index.to_numpy(float)
    mesh = ax.pcolormesh(_edges(x, x_axis["log"]), _edges(y, y_axis["log"]), pv, norm=norm)
    fig.colorbar(mesh, ax=ax, label=label)
    if pv.size <= MAX_LABELLED_CELLS:
        for (i, j), value in np.ndenumerate(pv):
            colour = "w" if mesh.norm(value) < 0.5 else "k"  # viridis is dark at the low end
            ax.text(
                x[j],
                y[i],
                f"{value:.3g}",
                ha="center",
                va="center",
                fontsize="x-small",
                color=colour,
            )
    ok = _ok(data)
    if not ok.empty:
        best = ok.iloc[int(np.argmin(ok[metric].to_numpy(float)))]
        ax.plot(
            best[x_name],
            best[y_name],
            "o",
            ms=22,
            mfc="none",
            mec="r",
            mew=1.5,
            label=f"lowest {words}",
        )
    base = baseline or {}
    if x_name in base and y_name in base:
        kind = "base recipe" if x_name in TABLE1_RANGE else "calibrated design"
        ax.plot(base[x_name], base[y_name], "*", ms=14, mfc="w", mec="k", label=kind)
    for name, axis_name, spec in ((x_name, "x", x_axis), (y_name, "y", y_axis)):
        if spec["log"]:
            getattr(ax, f"set_{axis_name}scale")("log")
            _plain_log(getattr(ax, f"{axis_name}axis"))
        _shade_outside_table1(ax, name, data[name], axis_name)
    ax.set_xlabel(parameter_label(x_name))
    ax.set_ylabel(parameter_label(y_name))
    ax.legend(
        fontsize="x-small",
        loc="upper center",
        bbox_to_anchor=(0.5, -0.18),
        ncols=3,
        markerscale=0.5,
    )
    short = [parameter_label(n).split(" [")[0] for n in (y_name, x_name)]
    title = f"{label}: {short[0]} against {short[1]}"
    if metric != "pv_nm" and "pv_nm" in ok and not ok.empty:
        title += f"\n(whole-plate PV {ok['pv_nm'].min():.0f}-{ok['pv_nm'].max():.0f} nm)"
    ax.set_title(title, fontsize="medium")
    return fig


def _main_metric(data: pd.DataFrame) -> str:
    """The PV a study figure shows: the interferometer's where the table has it."""
    if "pv_measured_nm" in data and data["pv_measured_nm"].notna().any():
        return "pv_measured_nm"
    return "pv_nm"


def _edges(centres: np.ndarray, log: bool) -> np.ndarray:
    """Cell edges around sorted cell centres: midpoints (geometric on a log axis)."""
    t = np.log10(centres) if log else centres
    if t.size == 1:
        inner, outer = np.array([]), np.array([t[0] - 0.5, t[0] + 0.5])
    else:
        inner = 0.5 * (t[1:] + t[:-1])
        outer = np.array([1.5 * t[0] - 0.5 * t[1], 1.5 * t[-1] - 0.5 * t[-2]])
    edges = np.concatenate([[outer[0]], inner, [outer[1]]])
    return 10.0**edges if log else edges


def plot_convergence(convergence: pd.DataFrame, ax=None) -> Figure:
    """Best objective so far [nm] against evaluations, one line per optimiser stage."""
    fig, ax = new_axes(ax, (1.4 * PANEL[0], PANEL[1]))
    for stage, data in convergence.groupby("stage", sort=False):
        (line,) = ax.plot(data["evaluation"], data["best_objective_nm"], label=_label(stage))
        refine = data[data["phase"] == "trust-region"]
        ax.plot(
            refine["evaluation"], refine["best_objective_nm"], "o", ms=2, color=line.get_color()
        )
    ax.set_xlabel("evaluations")
    if (convergence["best_objective_nm"] > 0).all():
        ax.set_yscale("log")
        _plain_log(ax.yaxis, convergence["best_objective_nm"])
    for _, data in convergence.groupby("stage", sort=False):
        best = data["best_objective_nm"].min()
        ax.annotate(
            f"{best:.3g}",
            (data["evaluation"].max(), best),
            xytext=(3, 0),
            textcoords="offset points",
            va="center",
            fontsize="x-small",
        )
    ax.set_ylabel("best objective so far [nm]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize="x-small", loc="upper left", bbox_to_anchor=(1.02, 1.0))
    ax.set_title("Optimiser convergence (dots: convex trust-region steps)", fontsize="medium")
    return fig


def _recipe(row) -> str:
    return f"{row.rpm:.0f} rpm, {row.feed_mm_min:.3g} mm/min, {row.depth_um:.2g} µm"


def plot_pareto(
    points: pd.DataFrame,
    front: pd.DataFrame,
    optima: pd.DataFrame,
    ax=None,
    bounds: list[dict] | None = None,
) -> Figure:
    """Every evaluated recipe, the non-dominated front and the optima: the study's objective
    (``optima["objective"]``, a record metric; ``pv_nm`` for tables that predate it) against
    cutting time, with the interferometer's PV of the front's recipes beside it where the
    objective is another metric. Front points are numbered and their recipes listed beside the
    axes (no label sits on a marker). ``bounds`` (meta.json's): the title says "Table 1
    ranges" only when they are the paper's Table 1 ranges."""
    metric = optima["objective"].iloc[0] if "objective" in optima else "pv_nm"
    target = optima["target"].iloc[0] if "target" in optima else optima["target_pv_nm"].iloc[0]
    words, unit = metric_words(metric), metric_axis_label(metric)
    fig, ax = new_axes(ax, (2.4 * PANEL[0], 1.6 * PANEL[1]))
    ok = _ok(points)
    travel = optima["travel_mm"].iloc[0]
    ax.scatter(travel / ok["feed_mm_min"], ok[metric], s=4, c="0.75", label="evaluated recipes")
    front = front.sort_values("cutting_time_min")
    ax.step(
        front["cutting_time_min"],
        front[metric],
        "o-",
        where="post",
        ms=3,
        label=f"Pareto front ({words})",
    )
    shown = [front[metric]]
    if metric != "pv_measured_nm" and "pv_measured_nm" in front:
        if front["pv_measured_nm"].notna().any():
            ax.plot(
                front["cutting_time_min"],
                front["pv_measured_nm"],
                "o",
                mfc="none",
                ms=5,
                color="C2",
                label="interferometer PV of the front's recipes",
            )
            shown.append(front["pv_measured_nm"])
    recipes = _number_front(ax, front, metric)
    for row in optima.itertuples():
        value = getattr(row, metric)
        name = f"minimum {words}" if row.optimum == "min-pv" else _label(row.optimum)
        ax.plot(
            row.cutting_time_min,
            value,
            "*",
            ms=13,
            label=f"{name}: {value:.3g} {metric_unit(metric)}, {_recipe(row)}",
        )
        shown.append(pd.Series([value]))
    ax.axhline(
        target,
        color="r",
        lw=0.8,
        ls="--",
        label=f"target: {words} ≤ {target:g} {metric_unit(metric)}",
    )
    ax.set_yscale("log")
    _plain_log(ax.yaxis, pd.concat([*shown, pd.Series([target])]))
    ax.set_xlabel("cutting time of one pass [min]")
    ax.set_ylabel(f"{unit} (the objective)")
    ax.grid(True, which="both", alpha=0.3)
    handles, labels = ax.get_legend_handles_labels()
    handles.append(Line2D([], [], ls="none"))
    labels.append("front recipes:\n" + "\n".join(recipes))
    ax.legend(handles, labels, fontsize="x-small", loc="upper left", bbox_to_anchor=(1.02, 1.0))
    ranges = " (Table 1 ranges)" if _table1_bounds(bounds) else ""
    ax.set_title(f"Cutting recipes: {words} against cutting time{ranges}")
    return fig


def _number_front(ax, front: pd.DataFrame, metric: str = "pv_nm") -> list[str]:
    """Number up to MAX_RECIPE_LABELS front points, evenly over the cutting time, above their
    markers; returns the "k: recipe" lines."""
    gap = np.ptp(front["cutting_time_min"].to_numpy(float)) / MAX_RECIPE_LABELS
    last, lines = -np.inf, []
    for row in front.itertuples():
        if row.cutting_time_min - last < gap:
            continue
        last = row.cutting_time_min
        k = len(lines) + 1
        value = getattr(row, metric)
        ax.annotate(
            str(k),
            (row.cutting_time_min, value),
            xytext=(0, 6),
            textcoords="offset points",
            ha="center",
            fontsize=7,
            color="C0",
        )
        lines.append(f"{k}: {_recipe(row)}, {row.cutting_time_min:.3g} min, {value:.3g}")
    return lines


def _table1_bounds(bounds: list[dict] | None) -> bool:
    """True if ``bounds`` are exactly the paper's Table 1 ranges of rpm, feed and depth."""
    if not bounds:
        return False
    ranges = {b["parameter"]: tuple(map(float, b["range"])) for b in bounds}
    table1 = {name: (low, high) for name, (low, high, _) in TABLE1_RANGE.items()}
    return ranges == table1


def design_cost(points: pd.DataFrame, meta: dict) -> np.ndarray:
    """Stiffness cost [nm] of each design of an optimise-design study: the sum over the costed
    parameters of weight [nm] x stiffness / calibrated stiffness (ufmt.studies.optimise_design).
    """
    weights = meta["options"]["cost"]
    return sum(w * points[k].to_numpy(float) / meta["baseline"][k] for k, w in weights.items())


def plot_design_tradeoff(points: pd.DataFrame, optima: pd.DataFrame, meta: dict, ax=None) -> Figure:
    """The study's objective metric (``optima["objective"]``; ``pv_nm`` for tables that
    predate it) against stiffness cost of every evaluated bearing design, lines of equal
    objective (metric + cost), the calibrated design and the optimum."""
    metric = optima["objective"].iloc[0] if "objective" in optima else "pv_nm"
    words, label = metric_words(metric), metric_axis_label(metric)
    unit = label[label.index("[") :] if "[" in label else ""
    fig, ax = new_axes(ax, (1.6 * PANEL[0], 1.4 * PANEL[1]))
    ok = _ok(points)
    cost, value = design_cost(ok, meta), ok[metric].to_numpy(float)
    ax.scatter(cost, value, s=6, c="0.6", label="evaluated designs")
    order = np.argsort(cost)
    front = order[value[order] <= np.minimum.accumulate(value[order])]
    ax.step(
        cost[front], value[front], where="post", color="C0", label=f"lowest {words} for its cost"
    )
    best = optima.loc[optima["objective_nm"].idxmin()]
    span = np.array([cost.min(), cost.max()])
    for level in best["objective_nm"] * np.array([1.0, 1.25, 1.5]):
        ax.plot(span, level - span, color="0.4", ls=":", lw=0.8)
    ax.plot([], [], color="0.4", ls=":", lw=0.8, label=f"equal {words} + cost")
    for row in optima.itertuples():
        mark = getattr(row, metric)
        text = f"{_label(row.design)}: {mark:.3g} + cost {row.cost_nm:.3g}"
        ax.plot(row.cost_nm, mark, "*", ms=13, label=text)
    ax.set_ylim(0.9 * np.nanmin(value), 1.05 * np.nanmax(value))
    ax.set_xlabel(f"stiffness cost {unit} (weights x stiffness / calibrated)")
    ax.set_ylabel(f"{label} (the objective)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="x-small")
    ax.set_title(f"Bearing design: {words} against stiffness cost", fontsize="medium")
    return fig


def plot_sensitivity(indices: pd.DataFrame, ax=None) -> Figure:
    """Horizontal bars of the sensitivity indices with their 95 % confidence intervals."""
    morris = "mu_star_nm" in indices
    bars = (
        [
            ("mu_star_nm", "mu_star_conf_nm", "μ* (mean |effect|), error bar: 95 % bootstrap CI"),
            ("sigma_nm", None, "σ (spread of the effect)"),
        ]
        if morris
        else [
            ("ST", "ST_conf", "total ST, error bar: 95 % bootstrap CI"),
            ("S1", "S1_conf", "first-order S1, error bar: 95 % bootstrap CI"),
        ]
    )
    n = len(indices)
    fig, ax = new_axes(ax, (1.6 * PANEL[0], 1.0 + 0.35 * n))
    y = np.arange(n)
    height = 0.38
    for k, (value, conf, label) in enumerate(bars):
        err = indices[conf] if conf else None
        ax.barh(y + (k - 0.5) * height, indices[value], height, xerr=err, label=label, capsize=2)
    ax.set_yticks(y, [parameter_label(p) for p in indices["parameter"]], fontsize="small")
    ax.invert_yaxis()
    ax.set_xlabel("PV effect per full range [nm]" if morris else "share of PV variance")
    ax.grid(True, axis="x", alpha=0.3)
    ax.legend(fontsize="x-small", loc="lower right")
    ax.set_title("Sensitivity of surface PV" + (" (Morris)" if morris else " (Sobol)"))
    return fig


#: Tracks named in the legend of a tracked-modes panel: those whose frequency moves most.
NAMED_TRACKS = 8
#: Distinct colours of the named tracks (tab10 without its grey, which marks the others).
TRACK_COLOURS = ("C0", "C1", "C2", "C3", "C4", "C5", "C6", "C9")


def plot_tracked_modes(modes: pd.DataFrame, meta: dict | None = None, ax=None) -> Figure:
    """Natural frequencies along each stiffness or speed axis, each mode followed by MAC
    (``modes.csv``, :mod:`ufmt.studies.tracking`): one panel per axis, a line per track, the
    tracks that move most named, the others grey; a pairing with MAC < 0.5 ringed. Along the
    spindle speed the modes are flat and the spindle harmonics k rpm / 60 fan out over them (a
    Campbell diagram): where a harmonic crosses a mode the cut drives it at resonance."""
    names = list(dict.fromkeys(modes["parameter"]))
    baseline = (meta or {}).get("baseline", {})
    if ax is None:
        fig = new_figure((PANEL[0] * 1.25 * len(names), PANEL[1] * 1.45))
        axes = fig.subplots(1, len(names), squeeze=False)[0]
    else:
        axes = np.atleast_1d(ax)
        fig = axes[0].figure
    for a, name in zip(axes, names, strict=True):
        table = modes[modes["parameter"] == name]
        ratio = table.groupby("track_name", sort=False)["track_ratio"].first()
        ranked = ratio.sort_values(key=lambda r: -np.abs(np.log(r)), kind="stable")
        named = list(ranked.index[:NAMED_TRACKS]) if name != "rpm" else []
        for track, rows in table.groupby("track_name", sort=False):
            rows = rows.sort_values("value")
            k = named.index(track) if track in named else -1
            a.plot(
                rows["value"],
                rows["frequency_hz"],
                "-",
                color=TRACK_COLOURS[k] if k >= 0 else "0.75",
                lw=1.6 if k >= 0 else 0.7,
                label=track if k >= 0 else None,
                zorder=2 if k >= 0 else 1,
            )
            weak = rows[rows["weak_pairing"].astype(bool)]
            a.plot(weak["value"], weak["frequency_hz"], "o", mfc="none", mec="r", ms=6)
        if name == "rpm":
            _spindle_harmonics(a, table)
        else:
            a.set_xscale("log")
        reference = baseline.get(name)
        if reference is not None and np.isfinite(reference):
            a.axvline(reference, color="0.5", lw=0.8, ls=":")
        a.set_yscale("log")
        a.set_xlabel(parameter_label(name))
        a.set_ylabel("natural frequency [Hz]")
        a.grid(True, which="both", alpha=0.3)
        if named:
            a.legend(
                fontsize="x-small",
                loc="upper center",
                bbox_to_anchor=(0.5, -0.16),
                title="moves most",
                ncols=4,
            )
    fig.suptitle(
        "Modes followed by MAC along each axis (grey: tracks that move little;"
        " red rings: MAC < 0.5 to the previous point)",
        fontsize="medium",
    )
    return fig


def _spindle_harmonics(ax, table: pd.DataFrame) -> None:
    """The spindle harmonics k rpm / 60 [Hz] across the speed axis, every tenth labelled."""
    rpm = np.linspace(table["value"].min(), table["value"].max(), 2)
    top = table["frequency_hz"].max()
    count = int(np.ceil(top / (rpm.min() / 60.0)))
    for k in range(1, count + 1):
        f = k * rpm / 60.0
        if f[0] > top:
            break
        labelled = k == 1 or k % 10 == 0
        ax.plot(rpm, f, color="k" if labelled else "0.85", lw=0.6 if labelled else 0.4, zorder=0)
        if labelled and f[-1] <= top:
            ax.annotate(
                f"{k}x", (rpm[-1], f[-1]), fontsize=6, xytext=(2, 0), textcoords="offset points"
            )
    ax.set_ylim(table["frequency_hz"].min() * 0.8, top * 1.2)
