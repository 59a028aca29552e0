"""Study layer: spec validation, runner (resume, failures, dask), optimisers, sensitivity.

Most tests run studies of the cheap analytic functions below (closed forms are the oracles);
study files point at them with ``function = "<this file>:<name>"``. The physics-backed tests
(``ufmt.evaluate`` on the packaged model) check the paper's trends with small budgets.
"""

from __future__ import annotations

import json
import math
import os
import re
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ufmt.design import apply_design, design_value
from ufmt.errors import StudyError
from ufmt.evaluate import evaluate
from ufmt.fingerprint import PACKAGE, PHYSICS, physics_sources
from ufmt.model.load import load_model, packaged_path
from ufmt.model.write import design_lines
from ufmt.recent import Recent
from ufmt.studies.load import load_study, parse_study
from ufmt.studies.optimise import (
    Space,
    fit_convex_quadratic,
    global_search,
    minimise,
    minimise_quadratic,
    pareto_mask,
    trust_region_refine,
)
from ufmt.studies.outputs import read_meta, read_table
from ufmt.studies.parallel import Execution
from ufmt.studies.runner import run_study

HERE = Path(__file__).resolve()
REPO = HERE.parents[1]

# ---------------------------------------------------------------------------------------------
# cheap analytic study functions (same signature as ufmt.evaluate.evaluate)

K_REF = 3.0e6  # reference angular stiffness of the analytic PV [N m/rad]


def analytic_pv(design, process, model=None):
    """PV [nm] = 100 sqrt(K_REF / k_angular) (depth / 4) (feed / 15) (300 / rpm)."""
    k = design.get("head_angular_stiffness_Nm_rad", K_REF)
    pv = (
        100.0
        * math.sqrt(K_REF / k)
        * (process["depth_um"] / 4.0)
        * (process["feed_mm_min"] / 15.0)
        * (300.0 / process["rpm"])
    )
    return {"pv_nm": pv, "rms_nm": pv / 4.0}


def slow_pv(design, process, model=None):
    """analytic_pv after 50 ms (a study slow enough to be killed mid-way)."""
    time.sleep(0.05)
    return analytic_pv(design, process, model)


def failing_pv(design, process, model=None):
    """analytic_pv, but raises above 350 rpm unless $UFMT_TEST_FAST_SPINDLE is "ok"."""
    if process["rpm"] > 350.0 and os.environ.get("UFMT_TEST_FAST_SPINDLE") != "ok":
        raise RuntimeError("spindle too fast for this test")
    return analytic_pv(design, process, model)


def recipe_pv(design, process, model=None):
    """PV = 5 (1 + ((rpm - 330) / 60)^2) feed depth: minimum 40 nm at (330, 4, 2); the
    fastest recipe under 100 nm has feed 100 / (5 * 2) = 10 mm/min (rpm 330, depth 2)."""
    a = 5.0 * (1.0 + ((process["rpm"] - 330.0) / 60.0) ** 2)
    return {"pv_nm": a * process["feed_mm_min"] * process["depth_um"]}


DESIGN_A = 40.0  # [nm] PV of the design function at the calibrated angular stiffness


def design_pv(design, process, model=None):
    """PV = A k0 / k_ang + 50 log10(k_rad / 4e8)^2 (k0 = 3e6, the tiny model's value).

    With cost w k_ang / k0 the optimum is k_ang / k0 = sqrt(A / w) and k_rad = 4e8.
    """
    ratio = design["head_angular_stiffness_Nm_rad"] / 3.0e6
    radial = math.log10(design["head_radial_stiffness_N_m"] / 4.0e8)
    return {"pv_nm": DESIGN_A / ratio + 50.0 * radial**2}


def linear_pv(design, process, model=None):
    """PV = 30 log10(k_angular) + 0.5 rpm (depth has no effect)."""
    return {
        "pv_nm": 30.0 * math.log10(design["head_angular_stiffness_Nm_rad"]) + 0.5 * process["rpm"]
    }


TINY_MODEL = """\
name = "spindle and head on two air bearings"

[[body]]
name = "spindle"
kind = "rigid"
mass = 80.0
center_of_mass = [0.0, 0.0, 0.3]
inertia = [[2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 1.0]]

[[body]]
name = "head"
kind = "rigid"
mass = 40.0
center_of_mass = [0.0, 0.0, 0.05]
inertia = [[1.5, 0.0, 0.0], [0.0, 1.5, 0.0], [0.0, 0.0, 2.8]]

[[hinge]]
name = "h25"
between = ["ground", "spindle"]
at = [0.0, 0.0, 0.4]
stiffness = [1.0e8, 1.1e8, 3.0e8]
rotational_stiffness = [2.0e6, 2.1e6, 0.0]

[[hinge]]
name = "h31"
between = ["spindle", "head"]
at = [0.0, 0.0, 0.1]
stiffness = [2.0e8, 2.0e8, 5.0e8]
rotational_stiffness = [3.0e6, 3.0e6, 0.0]
""" + "\n".join(  # the packaged model's declarations: head_* on h31, spindle_* on h25
    line for p in load_model().design.values() for line in design_lines(p)
)

BASE = """
[base]
rpm = 300.0
feed_mm_min = 15.0
depth_um = 4.0
"""


def write_study(tmp_path: Path, name: str, body: str, function: str = "analytic_pv") -> Path:
    path = tmp_path / f"{name}.toml"
    text = f'function = "{HERE}:{function}"\n' + textwrap.dedent(body)
    path.write_text(text, encoding="utf-8")
    return path


SWEEP = (
    """
kind = "sweep"
"""
    + BASE
    + f"head_angular_stiffness_Nm_rad = {K_REF}\n"
    + """
[[axis]]
parameter = "head_angular_stiffness_Nm_rad"
range = [1e5, 1e7]
n = 5
spacing = "log"

[[axis]]
parameter = "rpm"
values = [200.0, 300.0, 400.0]

[[grid]]
name = "feed_x_depth"
[[grid.axis]]
parameter = "feed_mm_min"
range = [4.0, 16.0]
n = 3
[[grid.axis]]
parameter = "depth_um"
range = [2.0, 8.0]
n = 4
"""
)


def run(path, results, jobs=1, **kwargs):
    return run_study(path, Execution(jobs=jobs, **kwargs), results=results, progress=False)


# ---------------------------------------------------------------------------------------------
# study files


@pytest.mark.parametrize(
    ("body", "problem"),
    [
        (
            'kind = "sweep"\n[[axis]]\nparameter = "head_angular_stifness_Nm_rad"\nvalues = [1.0]',
            "axis[0]: field 'parameter': unknown parameter 'head_angular_stifness_Nm_rad' (did you"
            " mean 'head_angular_stiffness_Nm_rad'?; or hinge.<name>.stiffness[i]; declare others"
            " in a [design] table)",
        ),
        (
            'kind = "sweep"\n[[axis]]\nparameter = "rpm"\nvalues = []',
            "axis 'rpm': field 'values': empty (at least one value is required)",
        ),
        (
            'kind = "sweep"\n[[axis]]\nparameter = "rpm"\nrange = [300, 300]',
            "axis 'rpm': field 'range': empty range [300, 300] (allowed: lower < upper)",
        ),
        (
            'kind = "grid"\n[[axis]]\nparameter = "rpm"\nrange = [400, 200]',
            "axis 'rpm': field 'range': reversed bounds [400, 200] (allowed: lower < upper)",
        ),
        (
            'kind = "optimise-design"\n[[bound]]\nparameter = "head_axial_stiffness_N_m"\n'
            "scale = [5.0, 0.5]",
            "bound 'head_axial_stiffness_N_m': field 'scale': reversed bounds [5, 0.5]"
            " (allowed: lower < upper)",
        ),
        ('kind = "sweeep"', "field 'kind': unknown study kind 'sweeep' (did you mean 'sweep'?)"),
        (
            'kind = "sweep"\nbogus = 1',
            "unknown field 'bogus' (valid fields: kind, name, description, function, model, base,"
            " design, axis, grid, metric, findings, intervals, interval_inputs, interval_seed)",
        ),
        (
            'kind = "sensitivity"\n[[bound]]\nparameter = "rpm"\nrange = [200, 400]',
            "field 'bound': sensitivity needs at least two [[bound]] parameters",
        ),
        (
            'kind = "optimise-process"\n[[bound]]\nparameter = "head_axial_stiffness_N_m"\n'
            "range = [1e8, 1e9]",
            "bound 'head_axial_stiffness_N_m': field 'parameter': optimise-process searches"
            " process parameters only (rpm, feed_mm_min, depth_um)",
        ),
        (
            'kind = "sweep"\n[[grid]]\nname = "g"\n[[grid.axis]]\nparameter = "rpm"\n'
            'range = [200.0, 400.0]\nspacing = "lg"',
            "grid 'g'.axis 'rpm': field 'spacing': unknown spacing 'lg' (did you mean 'log'?)",
        ),
        (
            'kind = "sweep"\n[base]\nrpm = -3\n[[axis]]\nparameter = "feed_mm_min"\nvalues = [4.0]',
            "field 'rpm': -3 is not positive (allowed: > 0 [rpm])",
        ),
        (
            'kind = "sweep"\n[[axis]]\nparameter = "rpm"\nvalues = [-1.0]\nspacing = "log"',
            "axis 'rpm': field 'values[0]': -1 is not positive (allowed: > 0 for log spacing or a"
            " scale)",
        ),
        (
            'kind = "optimise-design"\n[[bound]]\nparameter = "head_axial_stiffness_N_m"\n'
            "scale = [0.5, 2.0]\n[optimiser]\npopsiz = 3",
            "optimiser: unknown field 'popsiz' (did you mean 'popsize'?)",
        ),
        (
            'kind = "optimise-process"\n[base]\nrpm = 300.0',
            "base: field 'rpm': is searched by optimise-process; remove it",
        ),
    ],
)
def test_bad_study_files_give_one_line_naming_file_table_and_field(tmp_path, body, problem):
    """Oracle: the one wording of ufmt.tables (<file>: <table>: field '<field>': <problem>)."""
    path = tmp_path / "bad.toml"
    path.write_text(body, encoding="utf-8")
    with pytest.raises(StudyError) as info:
        load_study(path)
    assert str(info.value) == f"{path}: {problem}"


def test_bad_study_through_cli_exits_2_with_one_line(tmp_path, capsys):
    from ufmt.cli import main

    path = tmp_path / "bad.toml"
    path.write_text('kind = "sweep"\n[[axis]]\nparameter = "rpm"\nvalues = []', encoding="utf-8")
    assert main(["run", str(path), "--results", str(tmp_path / "r"), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and str(path) in err and "field 'values': empty" in err


def test_sweep_points_are_one_at_a_time_and_grids_full_factorial(tmp_path):
    study = load_study(write_study(tmp_path, "s", SWEEP))
    sizes = [len(g.points({})) for g in study.groups]
    assert sizes == [5, 3, 12]
    angular = study.groups[0].points({})
    assert np.allclose(
        [p["head_angular_stiffness_Nm_rad"] for p in angular], np.geomspace(1e5, 1e7, 5)
    )


def test_relative_scale_uses_the_baseline():
    study = parse_study(
        'kind = "sweep"\n[[axis]]\nparameter = "head_axial_stiffness_N_m"\nscale = [0.5, 2.0]\n'
        'n = 3\nspacing = "log"'
    )
    values = study.groups[0].points({"head_axial_stiffness_N_m": 4e8})
    assert [p["head_axial_stiffness_N_m"] for p in values] == pytest.approx([2e8, 4e8, 8e8])


# ---------------------------------------------------------------------------------------------
# runner


def expected_pv(table: pd.DataFrame) -> np.ndarray:
    return np.array(
        [
            analytic_pv(
                {"head_angular_stiffness_Nm_rad": r.head_angular_stiffness_Nm_rad},
                {"rpm": r.rpm, "feed_mm_min": r.feed_mm_min, "depth_um": r.depth_um},
            )["pv_nm"]
            for r in table.itertuples()
        ]
    )


def test_tiny_sweep_end_to_end(tmp_path):
    out = run(write_study(tmp_path, "tiny-sweep", SWEEP), tmp_path / "results", jobs=2)
    table = read_table(out / "points.csv")
    assert len(table) == 20
    assert list(table.columns[:2]) == ["group", "index"]
    for column in ("rpm", "feed_mm_min", "depth_um", "head_angular_stiffness_Nm_rad", "pv_nm"):
        assert column in table
    # non-varied parameters sit at the base; the outputs are the closed form
    angular = table[table["group"] == "head_angular_stiffness_Nm_rad"]
    assert (angular["rpm"] == 300.0).all() and (angular["index"] == list(range(5))).all()
    assert np.allclose(table["pv_nm"], expected_pv(table), rtol=1e-12)
    assert (table["status"] == "ok").all()

    meta = read_meta(out)
    assert meta["status"] == "complete" and meta["run"]["points_new"] == 20
    for key in ("model_sha256", "code_sha256", "versions", "git", "study_text", "headline"):
        assert key in meta
    assert meta["headline"].startswith(
        "whole-plate PV (pv_nm): falls as head_angular_stiffness_Nm_rad rises"
    )
    assert {"pv_vs_parameters.png", "pv_map_feed_x_depth.png"} <= set(meta["plots"])
    index = (tmp_path / "results" / "README.md").read_text()
    assert "[tiny-sweep](tiny-sweep/)" in index and meta["headline"] in index


def test_failing_points_are_recorded_not_fatal_and_retried_on_rerun(tmp_path, monkeypatch):
    body = (
        'kind = "grid"\n'
        + BASE.replace("rpm = 300.0\n", "")
        + ('[[axis]]\nparameter = "rpm"\nvalues = [300.0, 400.0]\n')
    )
    study = write_study(tmp_path, "fails", body, "failing_pv")
    out = run(study, tmp_path / "results")
    table = read_table(out / "points.csv").set_index("rpm")
    assert table.loc[300.0, "status"] == "ok" and table.loc[300.0, "pv_nm"] > 0
    assert table.loc[400.0, "status"] == "error"
    assert "RuntimeError: spindle too fast" in table.loc[400.0, "message"]
    assert math.isnan(table.loc[400.0, "pv_nm"])
    assert read_meta(out)["run"]["points_failed"] == 1

    monkeypatch.setenv("UFMT_TEST_FAST_SPINDLE", "ok")  # the failure was transient
    out = run(study, tmp_path / "results")
    table = read_table(out / "points.csv").set_index("rpm")
    assert (table["status"] == "ok").all() and len(table) == 2
    assert read_meta(out)["run"]["points_new"] == 1  # only the failed point ran again


def test_killed_run_resumes_to_the_same_table(tmp_path):
    body = (
        'kind = "grid"\n'
        + BASE
        + (
            '[[axis]]\nparameter = "rpm"\nrange = [200.0, 400.0]\nn = 8\n'
            '[[axis]]\nparameter = "depth_um"\nrange = [2.0, 8.0]\nn = 5\n'
        )
    )
    study = write_study(tmp_path, "killed", body, "slow_pv")
    (tmp_path / "ref").mkdir()
    fast_twin = write_study(tmp_path / "ref", "killed", body, "analytic_pv")
    reference = read_table(run(fast_twin, tmp_path / "reference") / "points.csv")

    results = tmp_path / "results"
    log = results / "killed" / "points.csv"
    command = [sys.executable, "-m", "ufmt.cli", "run", str(study), "--jobs", "2"]
    command += ["--results", str(results), "--no-progress"]
    proc = subprocess.Popen(command, cwd=REPO, start_new_session=True, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and proc.poll() is None:
            if log.exists() and log.read_bytes().count(b"\n") > 10:  # header + 10 rows
                break
            time.sleep(0.01)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)  # the run and its workers, mid-study
        proc.wait()
    saved = log.read_bytes().count(b"\n") - 1  # complete rows (a kill may cut the last one)
    assert 10 <= saved < 40, "the run was not killed mid-study"

    out = run(study, results, jobs=2)
    resumed = read_table(out / "points.csv")
    pd.testing.assert_frame_equal(resumed, reference)
    assert read_meta(out)["run"]["points_reused"] >= saved


def test_rerun_of_a_finished_study_evaluates_nothing(tmp_path):
    study = write_study(tmp_path, "again", SWEEP)
    out = run(study, tmp_path / "r")
    first, first_run = read_table(out / "points.csv"), read_meta(out)["run"]
    out = run(study, tmp_path / "r")
    # a rerun that computes nothing keeps the computing run's record (a computing rerun
    # would record its own points and times)
    assert read_meta(out)["run"] == first_run and first_run["points_new"] == 20
    pd.testing.assert_frame_equal(read_table(out / "points.csv"), first)


def test_dask_local_cluster_backend_gives_the_same_table(tmp_path):
    from dask.distributed import LocalCluster

    study = write_study(tmp_path, "dask", SWEEP)
    reference = read_table(run(study, tmp_path / "loky") / "points.csv")
    with LocalCluster(
        n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None
    ) as cluster:
        out = run(study, tmp_path / "dask", backend="dask", scheduler=cluster.scheduler_address)
    pd.testing.assert_frame_equal(read_table(out / "points.csv"), reference)
    assert read_meta(out)["run"]["backend"] == "dask"


def test_execution_rejects_bad_arguments():
    with pytest.raises(StudyError, match="--backend"):
        Execution(backend="spark")
    with pytest.raises(StudyError, match="--jobs"):
        Execution(jobs=0)
    with pytest.raises(StudyError, match="--scheduler"):
        Execution(scheduler="tcp://127.0.0.1:8786")


# ---------------------------------------------------------------------------------------------
# optimisers on functions with known optima

OPTIONS = {"seed": 3, "popsize": 10, "maxiter": 40, "tol": 1e-8, "refine_steps": 6}


def test_global_search_finds_the_global_minimum_of_a_multimodal_function():
    # Rastrigin in [-5.12, 5.12]^2 shifted to (1, -2): global minimum 0, many local minima
    centre = np.array([1.0, -2.0])

    def rastrigin(u):
        x = -5.12 + 10.24 * u - centre
        return 20 + np.sum(x**2 - 10 * np.cos(2 * np.pi * x), axis=1)

    found = minimise(rastrigin, 2, OPTIONS)
    assert found.value < 1e-4
    assert np.allclose(-5.12 + 10.24 * found.u, centre, atol=1e-3)
    assert found.history and min(found.history) == pytest.approx(found.value)


def test_convex_quadratic_fit_recovers_an_exact_quadratic():
    rng = np.random.default_rng(0)
    H = np.array([[4.0, 1.0, 0.0], [1.0, 3.0, -0.5], [0.0, -0.5, 2.0]])
    g = np.array([0.3, -0.2, 0.1])
    d = rng.uniform(-0.1, 0.1, size=(25, 3))
    y = 7.0 + d @ g + 0.5 * np.einsum("ni,ij,nj->n", d, H, d)
    c_fit, g_fit, H_fit = fit_convex_quadratic(d, y)
    assert c_fit == pytest.approx(7.0, abs=1e-6)
    assert np.allclose(g_fit, g, atol=1e-5) and np.allclose(H_fit, H, atol=1e-3)


def test_quadratic_step_is_the_box_constrained_minimiser():
    H, g = np.diag([2.0, 4.0]), np.array([-1.0, 8.0])  # unconstrained minimiser (0.5, -2)
    step, predicted = minimise_quadratic(g, H, np.array([-1.0, -1.0]), np.array([1.0, 1.0]))
    assert np.allclose(step, [0.5, -1.0], atol=1e-6)  # second coordinate clipped at the box
    assert predicted == pytest.approx(-1.0 * 0.5 + 0.5 * 2 * 0.25 + 8 * -1.0 + 0.5 * 4, abs=1e-6)


def test_trust_region_refine_converges_on_a_convex_function():
    target = np.array([0.62, 0.31, 0.47])

    def bowl(u):
        return (
            3.0
            + np.sum((u - target) ** 2 * [1.0, 5.0, 2.0], axis=1)
            + np.sum((u - target) ** 4, axis=1)
        )

    start = np.array([0.5, 0.5, 0.5])
    found = trust_region_refine(bowl, start, float(bowl(start[None])[0]), steps=8, seed=0)
    assert np.allclose(found.u, target, atol=2e-3) and found.value == pytest.approx(3.0, abs=1e-5)


def test_global_search_with_the_default_budget_on_a_smooth_bowl():
    found = global_search(lambda u: np.sum((u - 0.25) ** 2, axis=1), 3, OPTIONS)
    assert np.allclose(found.u, 0.25, atol=0.02)


def test_pareto_mask_matches_the_definition():
    rng = np.random.default_rng(1)
    a, b = rng.integers(0, 20, 200).astype(float), rng.integers(0, 20, 200).astype(float)
    mask = pareto_mask(a, b)
    dominated = [
        np.any((a <= a[i]) & (b <= b[i]) & ((a < a[i]) | (b < b[i]))) for i in range(len(a))
    ]
    on_front = ~np.array(dominated)
    # the mask keeps one of each tied pair of non-dominated points and nothing else
    assert not np.any(mask & ~on_front)
    assert set(zip(a[mask], b[mask], strict=True)) == set(
        zip(a[on_front], b[on_front], strict=True)
    )


def test_space_maps_log_and_linear_bounds():
    space = Space(
        ("k", "rpm"), np.array([1e6, 200.0]), np.array([1e8, 400.0]), np.array([True, False])
    )
    values = space.values(np.array([[0.5, 0.25]]))
    assert values[0] == pytest.approx([1e7, 250.0])
    assert space.unit(values)[0] == pytest.approx([0.5, 0.25])


def test_optimise_process_finds_the_known_recipes(tmp_path):
    body = """
    kind = "optimise-process"
    target_pv_nm = 100.0
    workpiece_length_mm = 100.0
    tool_radius_mm = 150.0
    pareto_levels = 7
    [optimiser]
    popsize = 8
    maxiter = 15
    """
    out = run(write_study(tmp_path, "recipes", body, "recipe_pv"), tmp_path / "r")
    optima = read_table(out / "optima.csv").set_index("optimum")
    best = optima.loc["min-pv"]
    assert best["pv_nm"] == pytest.approx(40.0, rel=1e-4)
    assert (best["rpm"], best["feed_mm_min"], best["depth_um"]) == pytest.approx(
        (330, 4, 2), rel=1e-3
    )
    fast = optima.loc["fastest-under-target"]
    # re-evaluated with the true function, under the target, within one bisection step of 10
    assert fast["pv_nm"] == pytest.approx(recipe_pv({}, fast)["pv_nm"], rel=1e-12)
    assert fast["pv_nm"] <= 100.0
    assert 10.0 - 2.0 / 2**4 - 1e-9 <= fast["feed_mm_min"] <= 10.0
    assert fast["cutting_time_min"] == pytest.approx(400.0 / fast["feed_mm_min"])
    front = read_table(out / "pareto.csv")
    assert np.all(np.diff(front["cutting_time_min"]) > 0) and np.all(np.diff(front["pv_nm"]) < 0)
    # the front's fastest point is the upper feed bound, its slowest the minimum-PV recipe
    assert front["cutting_time_min"].iloc[0] == pytest.approx(400.0 / 16.0)
    assert front["pv_nm"].iloc[-1] == pytest.approx(40.0, rel=1e-3)
    assert {"convergence.png", "pareto.png"} <= set(read_meta(out)["plots"])


def test_optimise_design_finds_the_known_stiffnesses(tmp_path):
    (tmp_path / "tiny.toml").write_text(TINY_MODEL, encoding="utf-8")
    weight = 10.0  # optimum angular ratio sqrt(40 / 10) = 2
    body = f"""
    kind = "optimise-design"
    model = "tiny.toml"
    [base]
    rpm = 300.0
    [[bound]]
    parameter = "head_angular_stiffness_Nm_rad"
    scale = [0.2, 10.0]
    spacing = "log"
    [[bound]]
    parameter = "head_radial_stiffness_N_m"
    range = [1e8, 1e9]
    spacing = "log"
    [cost]
    head_angular_stiffness_Nm_rad = {weight}
    [optimiser]
    popsize = 8
    maxiter = 15
    """
    out = run(write_study(tmp_path, "design", body, "design_pv"), tmp_path / "r")
    optima = read_table(out / "optima.csv").set_index("design")
    best, calibrated = optima.loc["optimum"], optima.loc["calibrated"]
    assert best["head_angular_stiffness_Nm_rad"] == pytest.approx(2 * 3.0e6, rel=2e-3)
    assert best["head_radial_stiffness_N_m"] == pytest.approx(4.0e8, rel=2e-3)
    assert best["objective_nm"] == pytest.approx(2 * math.sqrt(DESIGN_A * weight), rel=1e-5)
    assert calibrated["head_angular_stiffness_Nm_rad"] == 3.0e6  # read from the model file
    assert calibrated["objective_nm"] > best["objective_nm"]


# ---------------------------------------------------------------------------------------------
# sensitivity


SENSITIVITY = """
kind = "sensitivity"
method = "{method}"
samples = {samples}
[base]
feed_mm_min = 15.0
[[bound]]
parameter = "head_angular_stiffness_Nm_rad"
range = [1e5, 1e7]
spacing = "log"
[[bound]]
parameter = "rpm"
range = [200.0, 400.0]
[[bound]]
parameter = "depth_um"
range = [2.0, 8.0]
"""


def test_morris_indices_of_a_linear_function_are_its_slopes_times_ranges(tmp_path):
    body = SENSITIVITY.format(method="morris", samples=10)
    out = run(write_study(tmp_path, "morris", body, "linear_pv"), tmp_path / "r")
    mu = read_table(out / "indices.csv").set_index("parameter")["mu_star_nm"]
    # 30 nm per decade over 2 decades, 0.5 nm/rpm over 200 rpm, no depth effect
    assert mu.to_dict() == pytest.approx(
        {"rpm": 100.0, "head_angular_stiffness_Nm_rad": 60.0, "depth_um": 0.0}, abs=1e-9
    )
    assert "sensitivity.png" in read_meta(out)["plots"]


def test_sobol_indices_of_a_linear_function_are_variance_shares(tmp_path):
    body = SENSITIVITY.format(method="sobol", samples=512)
    out = run(write_study(tmp_path, "sobol", body, "linear_pv"), tmp_path / "r")
    table = read_table(out / "indices.csv").set_index("parameter")
    var_rpm, var_k = (0.5 * 200) ** 2 / 12, (30 * 2) ** 2 / 12  # uniform: range^2 / 12
    share = var_rpm / (var_rpm + var_k)
    assert table.loc["rpm", "S1"] == pytest.approx(share, abs=table.loc["rpm", "S1_conf"])
    assert table.loc["rpm", "ST"] == pytest.approx(share, abs=table.loc["rpm", "ST_conf"])
    assert table.loc["depth_um", "ST"] == 0.0


# ---------------------------------------------------------------------------------------------
# evaluate


def test_design_parameters_set_the_documented_hinge_components():
    from ufmt.model.load import load_model_text

    model = load_model_text(TINY_MODEL)
    design = {
        "head_radial_stiffness_N_m": 7e8,
        "head_angular_stiffness_Nm_rad": 4e6,
        "spindle_axial_stiffness_N_m": 9e8,
        "spindle_radial_stiffness_N_m": 2.1e8,  # calibrated x, y = 1e8, 1.1e8: mean 1.05e8
        "hinge.h25.rotational_stiffness[1]": 5e6,
    }
    changed = apply_design(model, design)
    assert list(changed.hinge("h31").stiffness) == [7e8, 7e8, 5e8]
    assert list(changed.hinge("h31").rotational_stiffness) == [4e6, 4e6, 0.0]
    # a mean over unequal components scales them in proportion (anisotropy kept)
    assert list(changed.hinge("h25").stiffness) == pytest.approx([2e8, 2.2e8, 9e8], rel=1e-15)
    assert list(changed.hinge("h25").rotational_stiffness) == [2e6, 5e6, 0.0]
    assert list(model.hinge("h31").stiffness) == [2e8, 2e8, 5e8]  # the original is untouched
    assert design_value(model, "spindle_radial_stiffness_N_m") == pytest.approx(1.05e8, rel=1e-15)
    # restating the calibrated value gives back the calibrated hinge exactly
    same = apply_design(model, {"spindle_radial_stiffness_N_m": 1.05e8})
    assert list(same.hinge("h25").stiffness) == list(model.hinge("h25").stiffness)


def test_evaluate_rejects_unknown_names_and_records_physics_failures(tmp_path, monkeypatch):
    monkeypatch.setenv("UFMT_CACHE_DIR", str(tmp_path / "cache"))
    with pytest.raises(StudyError, match="head_radial"):
        evaluate({"head_radial": 1e8}, {})
    path = tmp_path / "tiny.toml"
    path.write_text(TINY_MODEL, encoding="utf-8")
    record = evaluate({}, {"rpm": -5.0}, model=path)  # non-physical rpm: recorded, not raised
    assert record["status"] == "error" and record["message"]
    assert math.isnan(record["pv_nm"]) and record["rpm"] == -5.0
    assert record == evaluate({}, {"rpm": -5.0}, model=path)  # deterministic


# ---------------------------------------------------------------------------------------------
# the packaged UFMT model


def packaged_study(tmp_path: Path, name: str, body: str) -> Path:
    """A study of ufmt.evaluate on the packaged model (no function line)."""
    path = tmp_path / f"{name}.toml"
    path.write_text(textwrap.dedent(body), encoding="utf-8")
    return path


def test_paper_trends_hold_in_a_small_sweep_of_the_model(tmp_path, monkeypatch):
    monkeypatch.setenv("UFMT_CACHE_DIR", "")
    body = """
    kind = "sweep"
    [base]
    rpm = 300.0
    feed_mm_min = 15.0
    depth_um = 4.0
    [[axis]]
    parameter = "head_angular_stiffness_Nm_rad"
    scale = [0.3, 3.0]
    n = 3
    spacing = "log"
    [[axis]]
    parameter = "rpm"
    values = [250.0, 300.0, 350.0]
    [[axis]]
    parameter = "feed_mm_min"
    values = [8.0, 12.0, 16.0]
    [[axis]]
    parameter = "depth_um"
    values = [2.0, 4.0, 6.0]
    """
    out = run(packaged_study(tmp_path, "trends", body), tmp_path / "r", jobs=2)
    table = read_table(out / "points.csv")
    assert (table["status"] == "ok").all(), table["message"].tolist()

    def pv(group):
        rows = table[table["group"] == group].sort_values(group)
        return rows["pv_nm"].to_numpy()

    # paper section 4.3: faster spindle, lower feed, smaller depth of cut each give a smoother
    # surface; and Fig. 15: a stiffer angular head bearing too (0.3x/1x/3x: 99.1/96.8/94.1 nm
    # whole plate, now that no fitted straightness wave dilutes the vibration; its vibration
    # part alone does not fall: tests/test_paper_findings.py, a strict expected failure).
    assert np.all(np.diff(pv("head_angular_stiffness_Nm_rad")) < 0)
    assert np.all(np.diff(pv("rpm")) < 0)
    assert np.all(np.diff(pv("feed_mm_min")) > 0)
    assert np.all(np.diff(pv("depth_um")) > 0)


@pytest.mark.slow
def test_optimise_process_on_the_model_with_a_small_budget(tmp_path, monkeypatch):
    monkeypatch.setenv("UFMT_CACHE_DIR", "")
    body = """
    kind = "optimise-process"
    target_pv_nm = 100.0
    pareto_levels = 2
    [optimiser]
    popsize = 4
    maxiter = 3
    refine_steps = 1
    """
    out = run(packaged_study(tmp_path, "opt-process", body), tmp_path / "r", jobs=2)
    optima = read_table(out / "optima.csv").set_index("optimum")
    points = read_table(out / "points.csv")
    best = optima.loc["min-pv"]
    # the reported optimum is the true model's value there (to the last digits, which depend
    # on the BLAS thread count: workers run one thread) and the best of every evaluation
    again = evaluate({}, {p: best[p] for p in ("rpm", "feed_mm_min", "depth_um")})
    assert best["pv_nm"] == pytest.approx(again["pv_nm"], rel=1e-9)
    # the default objective is the interferometer's PV: the optimum is its lowest value
    assert best["objective"] == "pv_measured_nm"
    assert best["pv_measured_nm"] == points["pv_measured_nm"].min()
    assert (
        200 <= best["rpm"] <= 400 and 4 <= best["feed_mm_min"] <= 16 and 2 <= best["depth_um"] <= 8
    )
    if "fastest-under-target" in optima.index:
        assert optima.loc["fastest-under-target", "pv_measured_nm"] <= 100.0


@pytest.mark.slow
def test_optimise_design_on_the_model_with_a_small_budget(tmp_path, monkeypatch):
    monkeypatch.setenv("UFMT_CACHE_DIR", "")
    body = """
    kind = "optimise-design"
    [base]
    rpm = 300.0
    feed_mm_min = 15.0
    depth_um = 4.0
    [[bound]]
    parameter = "head_angular_stiffness_Nm_rad"
    scale = [0.5, 2.0]
    spacing = "log"
    [[bound]]
    parameter = "head_radial_stiffness_N_m"
    scale = [0.5, 2.0]
    spacing = "log"
    [cost]
    head_angular_stiffness_Nm_rad = 5.0
    head_radial_stiffness_N_m = 5.0
    [optimiser]
    popsize = 3
    maxiter = 2
    refine_steps = 1
    """
    out = run(packaged_study(tmp_path, "opt-design", body), tmp_path / "r", jobs=2)
    optima = read_table(out / "optima.csv").set_index("design")
    best, calibrated = optima.loc["optimum"], optima.loc["calibrated"]
    names = ("head_angular_stiffness_Nm_rad", "head_radial_stiffness_N_m")
    again = evaluate(
        {n: best[n] for n in names}, {"rpm": 300.0, "feed_mm_min": 15.0, "depth_um": 4.0}
    )
    assert best["pv_nm"] == pytest.approx(again["pv_nm"], rel=1e-9)  # BLAS threads: see above
    assert best["objective_nm"] <= calibrated["objective_nm"] + 1e-9
    assert calibrated["cost_nm"] == pytest.approx(10.0)  # 5 nm per calibrated multiple, twice


def test_evaluate_reuses_the_basis_and_caches_on_the_model_content(tmp_path, monkeypatch):
    import importlib

    from records import same_record  # tests/ is not on the path of the study subprocesses

    evaluate_module = importlib.import_module("ufmt.evaluate")  # ufmt.evaluate is the function
    monkeypatch.setenv("UFMT_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(evaluate_module, "_BASES", Recent(evaluate_module.BASIS_CACHE))
    model = tmp_path / "ufmt.toml"
    model.write_bytes(packaged_path().read_bytes())
    computed = []
    real = evaluate_module.modal_basis

    def counting(*args):
        computed.append(args)
        return real(*args)

    monkeypatch.setattr(evaluate_module, "modal_basis", counting)
    first = evaluate({}, {}, model)
    slower = evaluate({}, {"rpm": 250.0}, model)
    assert first["status"] == slower["status"] == "ok"
    assert slower["pv_nm"] != first["pv_nm"]
    assert len(computed) == 1  # the process change reused the design's modal basis

    def broken(*args):
        raise RuntimeError("modal basis must not be recomputed")

    monkeypatch.setattr(evaluate_module, "modal_basis", broken)
    monkeypatch.setattr(evaluate_module, "_BASES", Recent(evaluate_module.BASIS_CACHE))
    cached = evaluate({}, {}, model)  # served from the disk cache
    assert same_record(cached, first)  # psd2_rms_nm is NaN (unresolved band) in both
    with model.open("a", encoding="utf-8") as f:
        f.write("\n# a comment does not change the model's content\n")
    assert same_record(evaluate({}, {}, model), first)
    text = model.read_text(encoding="utf-8")
    model.write_text(re.sub(r"force_scale = .*", "force_scale = 1.5", text), encoding="utf-8")
    changed = evaluate({}, {}, model)
    assert changed["status"] == "error" and "must not be recomputed" in changed["message"]


#: ufmt modules an evaluation loads that cannot change its record, with the reason; every
#: other one must be in the physics allow-list of the code fingerprint.
NOT_PHYSICS = {
    "ufmt": "the package root only binds the public entry points",
    "ufmt.evaluate_cache": "stores records under the key the fingerprint is part of",
    "ufmt.files": "writes the cache's records atomically: how they are written, not what",
    "ufmt.fingerprint": "computes that key",
    "ufmt.recent": "a bounded memo of recent results: what it keeps, not what they are",
}
EVALUATION_FOOTPRINT = """
import json, os, sys
import ufmt

opened = []
sys.addaudithook(lambda event, args: opened.append(args[0]) if event == "open" else None)
assert ufmt.evaluate({}, {})["status"] == "ok"
modules = {m: getattr(sys.modules[m], "__file__", None) for m in list(sys.modules)}
files = sorted({os.path.realpath(p) for p in opened if isinstance(p, str)})
print(json.dumps({"modules": modules, "files": files}))
"""


def test_the_code_fingerprint_covers_every_physics_module_an_evaluation_loads(tmp_path):
    """Oracle: ``sys.modules`` and the files opened in a fresh interpreter after one evaluation
    (disk cache off, so the physics runs): every ufmt module loaded is in the allow-list of
    ``ufmt.fingerprint.PHYSICS`` or in NOT_PHYSICS, and the only packaged data file read is
    the model, whose content keys the cache on its own."""
    assert all((PACKAGE / entry).exists() for entry in PHYSICS)
    tops = {path.relative_to(PACKAGE).parts[0] for path in physics_sources()}
    assert not tops & {"studies", "plots", "report.py", "cli", "calibration"}  # not physics
    env = {**os.environ, "UFMT_CACHE_DIR": "", "MPLBACKEND": "Agg"}
    result = subprocess.run(
        [sys.executable, "-c", EVALUATION_FOOTPRINT],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    footprint = json.loads(result.stdout)
    covered = {path.resolve() for path in physics_sources()}
    loaded = {
        name: Path(file).resolve()
        for name, file in footprint["modules"].items()
        if name == "ufmt" or name.startswith("ufmt.")
    }
    assert PACKAGE == Path(footprint["modules"]["ufmt"]).resolve().parent
    outside = sorted(n for n, f in loaded.items() if f not in covered and n not in NOT_PHYSICS)
    assert not outside, (
        f"add to ufmt.fingerprint.PHYSICS (or NOT_PHYSICS, with a reason): {outside}"
    )
    assert "ufmt.machining.modal" in loaded  # the physics ran (loaded on the first basis)
    data = [f for f in footprint["files"] if Path(f).suffix not in (".py", ".pyc")]
    data = [f for f in data if Path(f).is_relative_to(PACKAGE)]
    assert data == [str(packaged_path().resolve())]
