"""Plots of study results, read from ``results/<study>/`` (never recomputed).

* sweeps: PV against each swept parameter (log axis for stiffnesses, the calibrated value
  marked), as the paper's Fig. 15 (bearing stiffness) and Fig. 16 (rpm, feed, depth);
  PV maps over 2-D grids;
* optimisers: convergence (best objective against evaluations, per stage) and, for cutting
  recipes, the Pareto front of PV against cutting time with the PV target;
* sensitivity: bar chart of the indices.

Figures are drawn with matplotlib's object API on the Agg canvas (no display, no pyplot state).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import LogNorm
from matplotlib.figure import Figure

from ufmt.studies.outputs import (
    CONVERGENCE,
    INDICES,
    META,
    OPTIMA,
    PARETO,
    POINTS,
    parameter_label,
    read_table,
)

DPI = 120
PANEL = (4.2, 3.2)  # inches per panel
MAX_LABELLED_CELLS = 64  # PV maps print each cell's value up to this many cells


def plot_study(out_dir: str | Path) -> list[Path]:
    """Draw every plot of the study in ``out_dir``; returns the PNG paths written."""
    out_dir = Path(out_dir)
    meta = json.loads((out_dir / META).read_text(encoding="utf-8"))
    points = read_table(out_dir / POINTS)
    kind = meta["kind"]
    if kind in ("sweep", "grid"):
        return plot_sweeps(points, meta, out_dir)
    if kind == "sensitivity":
        return [plot_sensitivity(read_table(out_dir / INDICES), out_dir / "sensitivity.png")]
    written = [plot_convergence(read_table(out_dir / CONVERGENCE), out_dir / "convergence.png")]
    if kind == "optimise-process":
        written.append(
            plot_pareto(
                points,
                read_table(out_dir / PARETO),
                read_table(out_dir / OPTIMA),
                out_dir / "pareto.png",
            )
        )
    return written


def _save(fig: Figure, path: Path) -> Path:
    FigureCanvasAgg(fig)
    fig.savefig(path, dpi=DPI)
    return path


def _ok(points: pd.DataFrame) -> pd.DataFrame:
    return points[points["status"] == "ok"] if "status" in points else points


def plot_sweeps(points: pd.DataFrame, meta: dict, out_dir: Path) -> list[Path]:
    """PV against each one-at-a-time axis (one figure) and a PV map per 2-D grid."""
    written = []
    lines = [g for g in meta["groups"] if len(g["axes"]) == 1]
    if lines:
        written.append(
            plot_pv_lines(points, lines, meta["baseline"], out_dir / "pv_vs_parameters.png")
        )
    for group in meta["groups"]:
        if len(group["axes"]) == 2:
            written.append(plot_pv_map(points, group, out_dir / f"pv_map_{group['name']}.png"))
    return written


def plot_pv_lines(points: pd.DataFrame, groups: list[dict], baseline: dict, path: Path) -> Path:
    """One panel per swept parameter: PV and PV with tilt removed [nm] against it."""
    n = len(groups)
    cols = min(n, 3)
    rows = -(-n // cols)
    fig = Figure(figsize=(PANEL[0] * cols, PANEL[1] * rows), layout="constrained")
    ok = _ok(points)
    for i, group in enumerate(groups):
        ax = fig.add_subplot(rows, cols, i + 1)
        axis = group["axes"][0]
        name = axis["parameter"]
        data = ok[ok["group"] == group["name"]].sort_values(name)
        ax.plot(data[name], data["pv_nm"], "o-", label="PV")
        if "pv_tilt_removed_nm" in data:
            ax.plot(data[name], data["pv_tilt_removed_nm"], "s--", ms=3, label="PV, tilt removed")
        if axis["log"]:
            ax.set_xscale("log")
        reference = baseline.get(name)
        if reference is not None and np.isfinite(reference):
            ax.axvline(reference, color="0.5", lw=0.8, ls=":", label="calibrated / base")
        ax.set_xlabel(parameter_label(name))
        ax.set_ylabel("surface PV [nm]")
        ax.grid(True, which="both", alpha=0.3)
        if i == 0:
            ax.legend(fontsize="small")
    fig.suptitle("Surface PV against each swept parameter (others at the base design)")
    return _save(fig, path)


def plot_pv_map(points: pd.DataFrame, group: dict, path: Path) -> Path:
    """PV [nm] over a 2-D grid (log axes for log-spaced parameters), lowest point marked."""
    x_axis, y_axis = group["axes"]
    x_name, y_name = x_axis["parameter"], y_axis["parameter"]
    data = points[points["group"] == group["name"]]
    table = data.pivot_table(index=y_name, columns=x_name, values="pv_nm", aggfunc="first")
    fig = Figure(figsize=(1.3 * PANEL[0], 1.2 * PANEL[1]), layout="constrained")
    ax = fig.add_subplot()
    pv = table.to_numpy(float)
    norm = LogNorm() if np.nanmin(pv) > 0 and np.nanmax(pv) > 10 * np.nanmin(pv) else None
    x, y = table.columns.to_numpy(float), table.index.to_numpy(float)
    mesh = ax.pcolormesh(_edges(x, x_axis["log"]), _edges(y, y_axis["log"]), pv, norm=norm)
    fig.colorbar(mesh, ax=ax, label="surface PV [nm]")
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
        best = ok.iloc[int(np.argmin(ok["pv_nm"].to_numpy(float)))]
        ax.plot(best[x_name], best[y_name], "o", ms=22, mfc="none", mec="r", mew=1.5)
    if x_axis["log"]:
        ax.set_xscale("log")
    if y_axis["log"]:
        ax.set_yscale("log")
    ax.set_xlabel(parameter_label(x_name))
    ax.set_ylabel(parameter_label(y_name))
    ax.set_title(f"Surface PV [nm] over grid {group['name']} (red ring: lowest)")
    return _save(fig, path)


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


def plot_convergence(convergence: pd.DataFrame, path: Path) -> Path:
    """Best objective so far [nm] against evaluations, one line per optimiser stage."""
    fig = Figure(figsize=(1.4 * PANEL[0], PANEL[1]), layout="constrained")
    ax = fig.add_subplot()
    for stage, data in convergence.groupby("stage", sort=False):
        (line,) = ax.plot(data["evaluation"], data["best_objective_nm"], label=stage)
        refine = data[data["phase"] == "trust-region"]
        ax.plot(
            refine["evaluation"], refine["best_objective_nm"], "o", ms=2, color=line.get_color()
        )
    ax.set_xlabel("evaluations")
    if (convergence["best_objective_nm"] > 0).all():
        ax.set_yscale("log")
    ax.set_ylabel("best objective so far [nm]")
    ax.grid(True, alpha=0.3)
    stages = convergence["stage"].nunique()
    ax.legend(fontsize="x-small", ncol=1 + stages // 6)
    ax.set_title("Optimiser convergence (dots: convex trust-region steps)")
    return _save(fig, path)


def plot_pareto(
    points: pd.DataFrame, front: pd.DataFrame, optima: pd.DataFrame, path: Path
) -> Path:
    """Every evaluated recipe, the non-dominated front and the optima: PV against time."""
    fig = Figure(figsize=(1.4 * PANEL[0], 1.2 * PANEL[1]), layout="constrained")
    ax = fig.add_subplot()
    ok = _ok(points)
    travel = optima["travel_mm"].iloc[0]
    ax.scatter(travel / ok["feed_mm_min"], ok["pv_nm"], s=4, c="0.75", label="evaluated")
    ax.step(
        front["cutting_time_min"], front["pv_nm"], "o-", where="post", ms=3, label="Pareto front"
    )
    for row in optima.itertuples():
        ax.plot(row.cutting_time_min, row.pv_nm, "*", ms=12, label=row.optimum)
    target = optima["target_pv_nm"].iloc[0]
    ax.axhline(target, color="r", lw=0.8, ls="--", label=f"target {target:g} nm")
    ax.set_yscale("log")
    ax.set_xlabel("cutting time of one pass [min]")
    ax.set_ylabel("surface PV [nm]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize="small")
    ax.set_title("PV against cutting time")
    return _save(fig, path)


def plot_sensitivity(indices: pd.DataFrame, path: Path) -> Path:
    """Horizontal bars of the sensitivity indices with their confidence intervals."""
    morris = "mu_star_nm" in indices
    bars = (
        [("mu_star_nm", "mu_star_conf_nm", "mu* (mean |effect|)"), ("sigma_nm", None, "sigma")]
        if morris
        else [("ST", "ST_conf", "total ST"), ("S1", "S1_conf", "first-order S1")]
    )
    n = len(indices)
    fig = Figure(figsize=(1.6 * PANEL[0], 0.6 + 0.35 * n), layout="constrained")
    ax = fig.add_subplot()
    y = np.arange(n)
    height = 0.38
    for k, (value, conf, label) in enumerate(bars):
        err = indices[conf] if conf else None
        ax.barh(y + (k - 0.5) * height, indices[value], height, xerr=err, label=label, capsize=2)
    ax.set_yticks(y, [parameter_label(p) for p in indices["parameter"]], fontsize="small")
    ax.invert_yaxis()
    ax.set_xlabel("PV effect per full range [nm]" if morris else "share of PV variance")
    ax.grid(True, axis="x", alpha=0.3)
    ax.legend(fontsize="small")
    ax.set_title("Sensitivity of surface PV" + (" (Morris)" if morris else " (Sobol)"))
    return _save(fig, path)
