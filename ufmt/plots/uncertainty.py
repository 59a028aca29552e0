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
        ax.set_xlabel(parameter_label(row["metric"]), fontsize="small")
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


def plot_sobol(sobol: pd.DataFrame) -> Figure:
    """Horizontal bars of S1 and ST per input with 95 % bootstrap half-widths, a panel per
    metric."""
    metrics = list(dict.fromkeys(sobol["metric"]))
    fig, axes = _grid(len(metrics), columns=2)
    height = 0.38
    for ax, metric in zip(axes, metrics, strict=False):
        table = sobol[sobol["metric"] == metric].sort_values("ST", ascending=False)
        y = np.arange(len(table))
        ax.barh(y - height / 2, table["ST"], height, xerr=table["ST_conf"], label="total ST")
        ax.barh(y + height / 2, table["S1"], height, xerr=table["S1_conf"], label="first-order S1")
        ax.set_yticks(y, list(table["parameter"]), fontsize="x-small")
        ax.invert_yaxis()
        ax.set_xlabel("share of variance", fontsize="small")
        ax.set_title(parameter_label(metric), fontsize="small")
        ax.grid(True, axis="x", alpha=0.3)
    axes[0].legend(fontsize="x-small", loc="lower right")
    return fig


def plot_convergence(convergence: pd.DataFrame) -> Figure:
    """Total Sobol indices (with their half-widths) or, without them, the quantiles against
    the number of base samples, a panel per metric."""
    metrics = list(dict.fromkeys(convergence["metric"]))
    fig, axes = _grid(len(metrics))
    for ax, metric in zip(axes, metrics, strict=False):
        table = convergence[convergence["metric"] == metric]
        total = table[table["statistic"] == "ST"]
        lines = total.groupby("parameter", sort=False) if len(total) else None
        if lines is None:
            lines = table.groupby("statistic", sort=False)
            ax.set_ylabel("quantile", fontsize="small")
        else:
            ax.set_ylabel("total Sobol index ST", fontsize="small")
        for label, line in lines:
            ax.plot(line["samples"], line["value"], marker="o", ms=3, label=str(label))
            conf = line["conf"].to_numpy(dtype=float)
            if np.isfinite(conf).any():
                low, high = line["value"] - conf, line["value"] + conf
                ax.fill_between(line["samples"], low, high, alpha=0.15)
        ax.set_xscale("log", base=2)
        ax.set_xlabel("base samples N", fontsize="small")
        ax.set_title(parameter_label(metric), fontsize="small")
        ax.legend(fontsize="xx-small")
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
