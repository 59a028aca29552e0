"""The metric a study ranks: an optimiser's objective and a sweep's metric are any record
metric, and a study's headline, tables and figures rank the same one.

Oracle: closed-form study functions with two metrics whose minima lie at different recipes;
the reported optimum must be the lowest value of the chosen metric among the points evaluated.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import pytest

from ufmt.errors import StudyError
from ufmt.plots.studies import plot_pv_map
from ufmt.studies.load import load_study
from ufmt.studies.outputs import read_meta, read_table
from ufmt.studies.parallel import Execution
from ufmt.studies.runner import run_study

HERE = Path(__file__).resolve()


def two_metrics(design, process, model=None):
    """pv_nm lowest at 330 rpm, pv_measured_nm lowest at 250 rpm (both lowest at the
    smallest feed and depth)."""
    rpm, feed, depth = process["rpm"], process["feed_mm_min"], process["depth_um"]
    return {
        "pv_nm": 5.0 * (1.0 + ((rpm - 330.0) / 60.0) ** 2) * feed * depth,
        "pv_measured_nm": 3.0 * (1.0 + ((rpm - 250.0) / 40.0) ** 2) * feed * depth,
    }


def _study(tmp_path: Path, name: str, body: str) -> Path:
    path = tmp_path / f"{name}.toml"
    text = f'function = "{HERE}:two_metrics"\n' + textwrap.dedent(body)
    path.write_text(text, encoding="utf-8")
    return path


def _run(path: Path, results: Path) -> Path:
    return run_study(path, Execution(jobs=1), results=results, progress=False)


@pytest.mark.parametrize("objective", ["pv_nm", "pv_measured_nm"])
def test_optimise_process_reports_the_lowest_value_of_its_objective(tmp_path, objective):
    body = f"""
    kind = "optimise-process"
    objective = "{objective}"
    target = 100.0
    workpiece_length_mm = 100.0
    tool_radius_mm = 150.0
    pareto_levels = 3
    [optimiser]
    popsize = 6
    maxiter = 8
    refine_steps = 2
    """
    out = _run(_study(tmp_path, "recipes", body), tmp_path / "r")
    optima = read_table(out / "optima.csv").set_index("optimum")
    points = read_table(out / "points.csv")
    best = optima.loc["min-pv"]
    assert best[objective] == points[objective].min()
    assert best["objective"] == objective
    expected_rpm = 330.0 if objective == "pv_nm" else 250.0
    assert best["rpm"] == pytest.approx(expected_rpm, rel=2e-2)
    meta = read_meta(out)
    assert f"({objective})" in meta["headline"]
    if "fastest-under-target" in optima.index:
        assert optima.loc["fastest-under-target", objective] <= 100.0
    index = (tmp_path / "r" / "README.md").read_text(encoding="utf-8")
    assert objective in index  # the results index names the metric


def test_a_grid_headline_and_its_map_mark_the_same_lowest_point(tmp_path):
    body = """
    kind = "grid"
    metric = "pv_measured_nm"
    [base]
    depth_um = 4.0
    [[axis]]
    parameter = "rpm"
    values = [200.0, 250.0, 300.0, 350.0, 400.0]
    [[axis]]
    parameter = "feed_mm_min"
    values = [4.0, 8.0]
    """
    out = _run(_study(tmp_path, "grid", body), tmp_path / "r")
    meta = read_meta(out)
    assert meta["headline"].startswith("interferometer PV (pv_measured_nm):")
    assert "lowest at rpm = 250, feed_mm_min = 4" in meta["headline"]
    points = read_table(out / "points.csv")
    fig = plot_pv_map(points, meta["groups"][0], meta["baseline"], metric="pv_measured_nm")
    marked = [line for line in fig.axes[0].lines if line.get_label().startswith("lowest")]
    assert len(marked) == 1
    assert (marked[0].get_xdata()[0], marked[0].get_ydata()[0]) == (250.0, 4.0)
    # the whole-plate PV would have ranked another point lowest: the choice matters here
    whole = points.loc[points["pv_nm"].idxmin()]
    assert whole["rpm"] != 250.0


def test_a_sweep_ranks_its_metric_in_the_headline(tmp_path):
    body = """
    kind = "sweep"
    metric = "pv_nm"
    [base]
    feed_mm_min = 4.0
    depth_um = 2.0
    [[axis]]
    parameter = "rpm"
    values = [200.0, 330.0]
    """
    out = _run(_study(tmp_path, "sweep", body), tmp_path / "r")
    headline = read_meta(out)["headline"]
    points = read_table(out / "points.csv")
    pv = points.sort_values("rpm")["pv_nm"].to_numpy(float)
    assert headline.startswith("whole-plate PV (pv_nm): falls as rpm rises")
    assert np.all(np.diff(pv) < 0)


def test_an_unknown_metric_is_one_line_with_a_suggestion(tmp_path):
    body = """
    kind = "optimise-process"
    objective = "pv_mesured_nm"
    """
    with pytest.raises(StudyError, match=r"objective.*did you mean 'pv_measured_nm'"):
        load_study(_study(tmp_path, "bad", body))


def test_target_and_its_older_name_together_are_refused(tmp_path):
    body = """
    kind = "optimise-process"
    target = 50.0
    target_pv_nm = 60.0
    """
    with pytest.raises(StudyError, match="older name"):
        load_study(_study(tmp_path, "both", body))


def test_the_packaged_default_is_the_interferometer_pv(tmp_path):
    path = tmp_path / "default.toml"
    path.write_text('kind = "optimise-process"\n', encoding="utf-8")
    assert load_study(path).options["objective"] == "pv_measured_nm"
