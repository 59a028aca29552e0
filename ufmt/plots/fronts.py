"""The Pareto front of an optimiser study with several objectives: the first objective against
the second, coloured by the third where there is one; each objective's optimum starred."""

from __future__ import annotations

from collections.abc import Sequence

import pandas as pd
from matplotlib.figure import Figure

from ufmt.metric_names import metric_axis_label, metric_words
from ufmt.plots import new_axes

FIGSIZE = (8.0, 5.0)  # [in]


def plot_front(
    front: pd.DataFrame, optima: pd.DataFrame, objectives: Sequence[str], ax=None
) -> Figure:
    """The non-dominated recipes or designs (``pareto.csv``) in the plane of the first two
    ``objectives`` (axes in words with units), the third as colour, the optima (``optima.csv``
    rows named ``min-<metric>``) starred; the legend sits outside the data."""
    fig, ax = new_axes(ax, FIGSIZE)
    x, y = objectives[0], objectives[1]
    if len(objectives) > 2:
        z = objectives[2]
        dots = ax.scatter(front[x], front[y], c=front[z], cmap="viridis", s=18, label="front")
        fig.colorbar(dots, ax=ax, label=metric_axis_label(z))
    else:
        ax.plot(front[x], front[y], "o", ms=4, label="front")
    for row in optima.to_dict("records"):
        name = str(row.get("optimum", row.get("design", "")))
        words = metric_words(name.removeprefix("min-"))
        ax.plot(row[x], row[y], "*", ms=12, label=f"lowest {words}")
    ax.set_xlabel(metric_axis_label(x))
    ax.set_ylabel(metric_axis_label(y))
    ax.set_title(f"Pareto front of {len(front)} points ({len(objectives)} objectives)")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper left", bbox_to_anchor=(1.25 if len(objectives) > 2 else 1.02, 1.0))
    return fig
