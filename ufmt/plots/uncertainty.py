"""Plots of the uncertainty and tolerance-allocation studies, drawn from their tables:

* the distribution of each metric (histogram of the independent samples, its quantiles and
  the specification), a panel per metric, "not resolved" where no sample is;
* the first-order and total Sobol indices with their 95 % confidence half-widths, a panel per
  metric;
* the convergence of the estimates with the number of base samples;
* the trade-off of the cheapest tolerance allocation's cost against the specification level.

Each ``plot_*`` takes tables (and an optional ``ax`` for one-panel plots) and returns the
Figure.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from ufmt.metric_names import metric_axis_label
from ufmt.plots import new_axes, new_figure
from ufmt.plots.studies import PANEL, parameter_label


def _grid(n: int, columns: int = 3) -> tuple[Figure, list]:
    """A figure with ``n`` panels in rows of ``columns``."""
    cols = min(columns, max(n, 1))
    rows = math.ceil(max(n, 1) / cols)
    fig = new_figure((PANEL[0] * cols, PANEL[1] * rows))
    return fig, [fig.add_subplot(rows, cols, i + 1) for i in range(max(n, 1))]


def plot_distributions(distribution: pd.DataFrame, samples: pd.DataFrame) -> Figure:
    """Histogram of each metric's samples with its quantiles (dashed; outermost labelled) and
    its specification (red), the probability of meeting it in the title."""
    fig, axes = _grid(len(distribution))
    quantiles = [c for c in distribution.columns if c.startswith("q")]
    for ax, row in zip(axes, distribution.to_dict("records"), strict=False):  # "q2.5": by name
        values = samples[row["metric"]].to_numpy(dtype=float)
        values = values[np.isfinite(values)]
        ax.set_xlabel(metric_axis_label(row["metric"]), fontsize="small")
        if not len(values):
            ax.text(0.5, 0.5, "not resolved\nin any sample", ha="center", va="center")
            ax.set_yticks([])
            continue
        ax.hist(values, bins=min(40, max(8, len(values) // 8)), color="0.6")
        for q in quantiles:
            ax.axvline(row[q], color="C0", ls="--", lw=0.8)
        title = f"{quantiles[0]}-{quantiles[-1]}: {row[quantiles[0]]:.3g}"
        title += f"-{row[quantiles[-1]]:.3g}"
        if math.isfinite(row["limit"]):
            ax.axvline(row["limit"], color="C3", lw=1.5, label="specification")
            title += (
                f"\nP(meet) = {row['p_meet']:.2f} [{row['p_meet_low']:.2f},"
                f" {row['p_meet_high']:.2f}]"
            )
        if row["resolved"] < row["samples"]:
            title += f"\n{row['resolved']} of {row['samples']} resolved"
        ax.set_title(title, fontsize="small")
        ax.set_ylabel("samples", fontsize="small")
    return fig


#: Inputs drawn per Sobol or convergence panel: those of the largest total index (the rest
#: are listed in sobol.csv / convergence.csv).
TOP_INPUTS = 8
_COMPONENTS = "xyz"
_HINGE_FIELDS = {
    "stiffness": ("stiffness", "N/m"),
    "rotational_stiffness": ("rotational stiffness", "N m/rad"),
}
_SUFFIX_UNITS = (
    ("_m_per_N", "m/N"),
    ("_rad", "rad"),
    ("_deg", "deg"),
    ("_hz", "Hz"),
    ("_kg", "kg"),
    ("_m", "m"),
)


def input_label(name: str) -> str:
    """An uncertain input in words with its unit: ``machine.tool_compliance_m_per_N`` ->
    "tool compliance [m/N]", ``hinge.h31.rotational_stiffness[0]`` -> "hinge h31 rotational
    stiffness x [N m/rad]", ``machine.force_scale`` -> "force scale [-]"."""
    from ufmt.model.machine import OPTIONAL_FIELDS

    if name.startswith("hinge.") and name.count(".") == 2 and name.endswith("]"):
        _, hinge, rest = name.split(".")
        field, index = rest[:-1].split("[")
        words, unit = _HINGE_FIELDS.get(field, (field.replace("_", " "), ""))
        component = _COMPONENTS[int(index)] if index.isdigit() and int(index) < 3 else index
        return f"hinge {hinge} {words} {component}" + (f" [{unit}]" if unit else "")
    key = name.removeprefix("machine.")
    unit = OPTIONAL_FIELDS[key][3] if key in OPTIONAL_FIELDS else ""
    words = key
    for suffix, u in _SUFFIX_UNITS:
        if key.endswith(suffix) and (not unit or u == unit):
            words, unit = key[: -len(suffix)], unit or u
            break
    return f"{words.replace('_', ' ')} [{unit or '-'}]"


def _bounded(value: np.ndarray, conf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper error-bar lengths of an index in [0, 1] with half-width ``conf``,
    clipped to [0, 1] (an index cannot leave it; the bootstrap's symmetric band can)."""
    value = np.clip(value, 0.0, 1.0)
    return value - np.clip(value - conf, 0.0, 1.0), np.clip(value + conf, 0.0, 1.0) - value


def plot_sobol(sobol: pd.DataFrame) -> Figure:
    """Horizontal bars of S1 and ST per input with 95 % bootstrap half-widths clipped to
    [0, 1], the TOP_INPUTS inputs of largest ST per metric, a panel per metric."""
    metrics = list(dict.fromkeys(sobol["metric"]))
    fig, axes = _grid(len(metrics), columns=2)
    height = 0.38
    for ax, metric in zip(axes, metrics, strict=False):
        table = sobol[sobol["metric"] == metric].sort_values("ST", ascending=False)
        table = table.head(TOP_INPUTS)
        y = np.arange(len(table))
        for shift, column, label in (
            (-height / 2, "ST", "total ST"),
            (height / 2, "S1", "first-order S1"),
        ):
            value = np.clip(table[column].to_numpy(float), 0.0, 1.0)
            errors = _bounded(value, table[f"{column}_conf"].to_numpy(float))
            ax.barh(y + shift, value, height, xerr=np.vstack(errors), label=label)
        ax.set_yticks(y, [input_label(p) for p in table["parameter"]], fontsize="x-small")
        ax.invert_yaxis()
        ax.set_xlim(0.0, 1.0)
        left = len(sobol[sobol["metric"] == metric]) - len(table)
        more = f"\n({left} inputs of smaller ST in sobol.csv)" if left > 0 else ""
        ax.set_xlabel(f"share of variance (an index in [0, 1]){more}", fontsize="small")
        ax.set_title(metric_axis_label(metric), fontsize="small")
        ax.grid(True, axis="x", alpha=0.3)
    axes[0].legend(fontsize="x-small", loc="lower right")
    return fig


def plot_convergence(convergence: pd.DataFrame) -> Figure:
    """Total Sobol indices (with their half-widths, clipped to [0, 1]) of the TOP_INPUTS
    inputs of largest final ST or, without indices, the quantiles against the number of base
    samples, a panel per metric; one legend per panel, right of its axes."""
    metrics = list(dict.fromkeys(convergence["metric"]))
    fig, axes = _grid(len(metrics), columns=2)
    fig.set_size_inches(2.4 * PANEL[0], fig.get_size_inches()[1])
    for ax, metric in zip(axes, metrics, strict=False):
        table = convergence[convergence["metric"] == metric]
        total = table[table["statistic"] == "ST"]
        if len(total):
            last = total[total["samples"] == total["samples"].max()]
            top = last.sort_values("value", ascending=False)["parameter"].head(TOP_INPUTS)
            lines = total[total["parameter"].isin(top)].groupby("parameter", sort=False)
            ax.set_ylabel("total Sobol index ST", fontsize="small")
            ax.set_ylim(0.0, 1.0)
        elif not np.isfinite(table["value"].to_numpy(float)).any():
            ax.text(0.5, 0.5, "not resolved\nin any sample", ha="center", va="center")
            ax.set_yticks([])
            lines = []
        else:
            lines = table.groupby("statistic", sort=False)
            ax.set_ylabel(f"quantile of {metric_axis_label(metric)}", fontsize="small")
        for label, line in lines:
            value = line["value"].to_numpy(float)
            shown = input_label(str(label)) if len(total) else str(label)
            ax.plot(line["samples"], value, marker="o", ms=3, label=shown)
            conf = line["conf"].to_numpy(dtype=float)
            if len(total) and np.isfinite(conf).any():
                low, high = _bounded(value, conf)
                ax.fill_between(
                    line["samples"],
                    np.clip(value, 0, 1) - low,
                    np.clip(value, 0, 1) + high,
                    alpha=0.15,
                )
        ax.set_xscale("log", base=2)
        ax.set_xlabel("base samples N", fontsize="small")
        ax.set_title(metric_axis_label(metric), fontsize="small")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize="xx-small", loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return fig


def plot_tradeoff(tradeoff: pd.DataFrame, limit: float, metric: str, ax=None) -> Figure:
    """Cost of the cheapest allocation against the specification level (evaluated with the
    model; open markers: the allocation missed the level), the study's level marked."""
    fig, ax = new_axes(ax, (1.5 * PANEL[0], PANEL[1] * 1.2))
    ok = tradeoff["meets"].astype(bool)
    ax.plot(tradeoff["level"], tradeoff["cost"], color="C0", lw=1)
    ax.plot(tradeoff["level"][ok], tradeoff["cost"][ok], "o", color="C0", label="meets (model)")
    if (~ok).any():
        ax.plot(
            tradeoff["level"][~ok],
            tradeoff["cost"][~ok],
            "o",
            mfc="none",
            color="C3",
            label="missed",
        )
    ax.axvline(limit, color="0.4", ls="--", label="specification")
    ax.set_xscale("log")
    ax.set_xlabel(f"specification: {parameter_label(metric)} <=", fontsize="small")
    ax.set_ylabel("cost [relative units]", fontsize="small")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="x-small")
    ax.set_title("Cheapest tolerances against the specification", fontsize="small")
    return fig
