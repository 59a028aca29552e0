"""The uncertainty study kind: Sobol indices against closed forms (Ishigami, a linear model),
interval coverage on a model whose distribution is known, null metrics, study-file mistakes,
and the runner's guarantees (resume after kill -9, the same tables with 1 or 2 workers and on
dask).

The study functions below are cheap closed forms with the study function's signature; their
inputs are the process parameters mapped linearly onto the unit interval (or [-pi, pi]).
"""

from __future__ import annotations

import fnmatch
import json
import math
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ufmt.cli import main
from ufmt.design import apply_design
from ufmt.errors import StudyError
from ufmt.machining.modal import modal_basis
from ufmt.machining.process import Process
from ufmt.model.load import load_model, load_model_text, packaged_path
from ufmt.simulate import simulate
from ufmt.studies.bands import documented_bands
from ufmt.studies.intervals import (
    headline_intervals,
    input_bands,
    sample_designs,
    scale_hinge_damping,
)
from ufmt.studies.load import parse_study
from ufmt.studies.outputs import read_meta, read_table
from ufmt.studies.parallel import Execution
from ufmt.studies.runner import run_study
from ufmt.studies.uncertainty import (
    distribute,
    independent_rows,
    sobol_indices,
    summarise,
    unit_sample,
)

HERE = Path(__file__).resolve()
REPO = HERE.parents[1]
RANGES = {"rpm": (100.0, 500.0), "feed_mm_min": (5.0, 25.0), "depth_um": (1.0, 7.0)}
ISHIGAMI_A, ISHIGAMI_B = 7.0, 0.1


def _unit(process) -> list[float]:
    return [(process[k] - lo) / (hi - lo) for k, (lo, hi) in RANGES.items()]


def ishigami(x1, x2, x3, a=ISHIGAMI_A, b=ISHIGAMI_B):
    """Ishigami & Homma (1990), inputs uniform on [-pi, pi]."""
    return np.sin(x1) + a * np.sin(x2) ** 2 + b * x3**4 * np.sin(x1)


def ishigami_indices(a=ISHIGAMI_A, b=ISHIGAMI_B):
    """Analytic (S1, ST) of the Ishigami function (Sobol' & Levitan 1999)."""
    v1 = 0.5 * (1 + b * math.pi**4 / 5) ** 2
    v2 = a**2 / 8
    v13 = b**2 * math.pi**8 * (1 / 18 - 1 / 50)
    v = v1 + v2 + v13
    return np.array([v1, v2, 0.0]) / v, np.array([v1 + v13, v2, v13]) / v


def ishigami_study(design, process, model=None):
    """Ishigami of the process mapped onto [-pi, pi]^3, as pv_measured_nm."""
    x = [-math.pi + 2 * math.pi * u for u in _unit(process)]
    return {"pv_measured_nm": float(ishigami(*x)), "psd1_rms_nm": math.nan}


def sum_study(design, process, model=None):
    """Y = u1 + u2 (u_i the first two process inputs on [0, 1]): triangular on [0, 2]; and
    2 u1 + u2 as zre_peak_nm (S1 = ST = 4/5, 1/5)."""
    u1, u2, _ = _unit(process)
    return {"pv_measured_nm": u1 + u2, "zre_peak_nm": 2 * u1 + u2, "psd1_rms_nm": math.nan}


def slow_sum_study(design, process, model=None):
    """sum_study after 50 ms (slow enough to be killed mid-way)."""
    time.sleep(0.05)
    return sum_study(design, process, model)


def machine_study(design, process, model=None):
    """A linear function of two [machine] inputs [nm]: the documented bands reach it."""
    return {
        "pv_measured_nm": 1e9 * design["machine.straightness_m"]
        + 10 * design["machine.force_scale"]
    }


def _inputs(names=("rpm", "feed_mm_min", "depth_um")) -> str:
    return "".join(
        f'[[input]]\nparameter = "{n}"\nrange = [{RANGES[n][0]}, {RANGES[n][1]}]\n' for n in names
    )


def write_study(tmp_path: Path, name: str, body: str, function: str) -> Path:
    path = tmp_path / f"{name}.toml"
    text = f'kind = "uncertainty"\nfunction = "{HERE}:{function}"\n' + textwrap.dedent(body)
    path.write_text(text, encoding="utf-8")
    return path


def run(path, results, jobs=1, **kwargs):
    return run_study(path, Execution(jobs=jobs, **kwargs), results=results, progress=False)


# ---------------------------------------------------------------------------------------------
# estimators against closed forms


def test_sobol_indices_of_the_ishigami_function_converge_to_the_analytic_values():
    """Oracle: the Ishigami function's analytic indices; the error shrinks with N (property:
    Saltelli's estimator converges) and is inside 0.03 at N = 4096."""
    s1, st = ishigami_indices()
    errors = []
    for n in (256, 4096):
        u = unit_sample("saltelli", 3, n, seed=2)
        y = ishigami(*(-math.pi + 2 * math.pi * u.T))
        table = sobol_indices(["x1", "x2", "x3"], y, seed=2)
        errors.append(max(np.abs(table["S1"] - s1).max(), np.abs(table["ST"] - st).max()))
    assert errors[1] < errors[0]
    assert errors[1] < 0.03, errors


def test_interval_coverage_on_a_triangular_distribution():
    """Oracle: u1 + u2 of two uniforms is triangular on [0, 2], F(y) = y^2 / 2 below 1; the
    estimated 5-95 % interval covers 90 % of it, P(Y <= 1) = 1/2 lies in its interval."""
    for method, n in (("saltelli", 512), ("lhs", 1024)):
        u = unit_sample(method, 2, n, seed=4)
        y = u[independent_rows(method, len(u), 2)].sum(axis=1)
        row = summarise(y, (0.05, 0.95), limit=1.0)

        def cdf(v):
            return np.where(v <= 1, v**2 / 2, 1 - (2 - v) ** 2 / 2)

        coverage = cdf(row["q95"]) - cdf(row["q05"])
        assert abs(coverage - 0.90) < 0.01, (method, coverage)
        assert row["p_meet_low"] <= 0.5 <= row["p_meet_high"]


def test_distributions_map_the_unit_interval_onto_their_laws():
    """Oracles: the truncated normal is symmetric (median at the band's middle) and stays in
    the band; the triangular law with mode c has F(c) = c."""
    u = np.linspace(0.001, 0.999, 999)[:, None].repeat(2, axis=1)
    out = distribute(u, ["normal", "triangular"], [0.5, 0.3])
    assert out[499, 0] == pytest.approx(0.5, abs=1e-9)  # median of the symmetric normal
    assert out[299, 1] == pytest.approx(0.3, abs=2e-3)  # F(mode) = mode for triangular(0, 1, c)
    assert out[:, 0].min() >= 0.0 and out[:, 0].max() <= 1.0


# ---------------------------------------------------------------------------------------------
# the study kind through the runner


def test_uncertainty_study_gives_linear_sobol_indices_and_the_distribution(tmp_path):
    """Oracle: for Y = 2 u1 + u2 (uniform u) S1 = ST = 4/5 and 1/5, the third input 0."""
    body = 'samples = 256\nmetrics = ["pv_measured_nm", "zre_peak_nm", "psd1_rms_nm"]\n'
    body += "[specification]\npv_measured_nm = 1.0\n" + _inputs()
    out = run(write_study(tmp_path, "lin", body, "sum_study"), tmp_path / "r")
    sobol = read_table(out / "sobol.csv")
    zre = sobol[sobol["metric"] == "zre_peak_nm"].set_index("parameter")
    np.testing.assert_allclose(zre["S1"], [0.8, 0.2, 0.0], atol=0.02)
    np.testing.assert_allclose(zre["ST"], [0.8, 0.2, 0.0], atol=0.02)
    dist = read_table(out / "distribution.csv").set_index("metric")
    assert dist.loc["pv_measured_nm", "resolved"] == 512  # A and B of N = 256
    assert dist.loc["pv_measured_nm", "q50"] == pytest.approx(1.0, abs=0.01)
    assert (
        dist.loc["pv_measured_nm", "p_meet_low"] <= 0.5 <= dist.loc["pv_measured_nm", "p_meet_high"]
    )
    # PSD1 not resolved: a row that says so, no indices, no failure
    assert dist.loc["psd1_rms_nm", "resolved"] == 0
    assert "psd1_rms_nm" not in set(sobol["metric"])
    meta = read_meta(out)
    assert "psd1_rms_nm not resolved" in meta["headline"]
    assert {"uncertainty-distributions.png", "uncertainty-sobol.png"} <= set(meta["plots"])
    conv = read_table(out / "convergence.csv")
    assert sorted(set(conv["samples"])) == [8, 16, 32, 64, 128, 256]


def product_study(design, process, model=None):
    """Y = (1 + u1) depth_um, u1 the rpm on [0, 1]; a missing process value takes the
    reference case (300 rpm, 4 um), as the study function does."""
    low, high = RANGES["rpm"]
    u1 = (process.get("rpm", 300.0) - low) / (high - low)
    return {"pv_measured_nm": (1.0 + u1) * process.get("depth_um", 4.0)}


def test_contrast_interval_is_the_change_at_the_uncertain_samples(tmp_path):
    """Oracle: for Y = (1 + u1) d with u1 uniform on [0, 1], the change from d = 2 to d = 6 is
    4 (1 + u1), uniform on [4, 8] (5-95 %: 4.2-7.8), +200 % in every sample, 6 at the
    calibrated u1 = 1/2 (300 rpm); a contrast of the uncertain input itself (rpm 100 -> 500)
    overrides its samples: the change is d = 4 (the reference depth) in every sample."""
    body = 'method = "lhs"\nsamples = 400\nmetrics = ["pv_measured_nm"]\n' + _inputs(["rpm"])
    body += '[[contrast]]\nname = "depth"\nstudy = "sweep-process"\nparameter = "depth_um"\n'
    body += 'values = [2.0, 6.0]\nmetric = "pv_measured_nm"\n'
    body += '[[contrast]]\nname = "rpm"\nparameter = "rpm"\nvalues = [100.0, 500.0]\n'
    body += 'metric = "pv_measured_nm"\nsamples = 10\n'
    path = write_study(tmp_path, "contrast", body, "product_study")
    assert parse_study(path.read_text(), path).options["contrasts"][1]["samples"] == 10
    out = run(path, tmp_path / "r")
    table = read_table(out / "contrast.csv").set_index("name")
    depth = table.loc["depth"]
    assert depth["samples"] == depth["resolved"] == 400
    assert depth["point_change"] == pytest.approx(6.0, rel=1e-12)
    assert depth["change_q05"] == pytest.approx(4.2, abs=0.02)
    assert depth["change_q95"] == pytest.approx(7.8, abs=0.02)
    assert depth["change_pct_q05"] == pytest.approx(200.0, rel=1e-9)
    assert depth["change_pct_q95"] == pytest.approx(200.0, rel=1e-9)
    assert depth["p_falls"] == 0.0 and depth["study"] == "sweep-process"
    headline = read_meta(out)["headline"]
    assert "depth: pv_measured_nm 3 -> 9, +200.0 % [+200.0, +200.0], falls in 0/400" in headline
    rpm = table.loc["rpm"]
    assert rpm["samples"] == 10
    assert rpm["change_q05"] == pytest.approx(4.0, rel=1e-12)
    assert rpm["change_q95"] == pytest.approx(4.0, rel=1e-12)
    points = read_table(out / "points.csv")
    # the rpm contrast's points are the same two in every sample (rpm is its only input):
    # the journal computes each once
    assert len(points) == 400 + (2 * 400 + 2) + 2


def test_contrast_mistakes_are_one_line_each(tmp_path):
    base = 'method = "lhs"\nsamples = 4\n' + _inputs(["rpm"])
    cases = {
        'parameter = "rpm"\nmetric = "pv_nm"\n': "scale, values",
        'parameter = "rpm"\nvalues = [2.0, 2.0]\nmetric = "pv_nm"\n': "equal",
        'parameter = "rpm"\nvalues = [2.0, 3.0]\nmetric = "nothing"\n': "metric",
        'parameter = "nothing"\nvalues = [2.0, 3.0]\nmetric = "pv_nm"\n': "nothing",
    }
    for body, words in cases.items():
        text = base + '[[contrast]]\nname = "x"\n' + body
        path = write_study(tmp_path, "bad", text, "sum_study")
        with pytest.raises(StudyError, match=words) as err:
            parse_study(path.read_text(), path)
        assert "\n" not in str(err.value) and "contrast[0]" in str(err.value)


def test_documented_bands_reach_the_study_function(tmp_path):
    """The machine.* pattern takes the bands of calibration.toml (read, not restated)."""
    bands = documented_bands()
    body = 'method = "lhs"\nsamples = 64\nmetrics = ["pv_measured_nm"]\n'
    body += '[[input]]\nparameter = "machine.straightness_m"\n'
    body += '[[input]]\nparameter = "machine.force_scale"\ndistribution = "loguniform"\n'
    out = run(write_study(tmp_path, "mach", body, "machine_study"), tmp_path / "r")
    samples = read_table(out / "samples.csv")
    for name in ("machine.straightness_m", "machine.force_scale"):
        assert bands[name].low <= samples[name].min() < samples[name].max() <= bands[name].high
    # Latin hypercube: exactly one sample per stratum of each input's (log) band
    low, high = bands["machine.force_scale"].low, bands["machine.force_scale"].high
    fs = np.log(samples["machine.force_scale"] / low) / np.log(high / low)
    assert sorted(np.floor(fs * 64).astype(int)) == list(range(64))


@pytest.mark.parametrize(
    ("body", "where", "phrase"),
    [
        (
            '[[input]]\nparameter = "machine.zzz*"\n',
            "input[0]: field 'parameter'",
            "matches no documented band",
        ),
        (
            '[[input]]\nparameter = "rpm"\n',
            "input 'rpm': field 'range'",
            "missing \\(no documented band",
        ),
        (
            _inputs(["rpm"]) + 'distribution = "cauchy"\n',
            "input[0]: field 'distribution'",
            "unknown distribution 'cauchy'",
        ),
        ("samples = 12\n" + _inputs(["rpm"]), "field 'samples'", "power of two"),
        ('metrics = ["pv_nn"]\n' + _inputs(["rpm"]), "field 'metrics[0]'", "unknown metric"),
        (
            "[specification]\npv_nm = -1.0\n" + _inputs(["rpm"]),
            "specification: field 'pv_nm'",
            "not positive",
        ),
        ("quantiles = [0.05, 1.0]\n" + _inputs(["rpm"]), "field 'quantiles[1]'", "outside"),
        ("[base]\nrpm = 300.0\n" + _inputs(["rpm"]), "base: field 'rpm'", "uncertain input"),
        (
            _inputs(["rpm"]).replace("range = [100.0, 500.0]", "range = [500.0, 100.0]"),
            "input 'rpm': field 'range'",
            "reversed bounds",
        ),
    ],
)
def test_study_file_mistakes_are_one_line(tmp_path, body, where, phrase):
    path = write_study(tmp_path, "bad", body, "sum_study")
    with pytest.raises(StudyError, match=phrase) as info:
        parse_study(path.read_text(), path)
    assert f"bad.toml: {where}:" in str(info.value) and "\n" not in str(info.value)


TINY = 'samples = 8\nmetrics = ["pv_measured_nm", "zre_peak_nm"]\n' + _inputs()
TABLES = ("points.csv", "distribution.csv", "sobol.csv", "convergence.csv", "samples.csv")


def test_one_and_two_workers_give_identical_tables(tmp_path):
    study = write_study(tmp_path, "tiny", TINY, "sum_study")
    one = run(study, tmp_path / "one", jobs=1)
    two = run(study, tmp_path / "two", jobs=2)
    for table in TABLES:
        assert (one / table).read_bytes() == (two / table).read_bytes(), table


@pytest.mark.slow
def test_dask_gives_identical_tables(tmp_path):
    from dask.distributed import LocalCluster

    study = write_study(tmp_path, "tiny", TINY, "sum_study")
    one = run(study, tmp_path / "one", jobs=1)
    with LocalCluster(
        n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None
    ) as cluster:
        dask = run(study, tmp_path / "dask", backend="dask", scheduler=cluster.scheduler_address)
    for table in TABLES:
        assert (one / table).read_bytes() == (dask / table).read_bytes(), table


def test_killed_run_resumes_to_the_same_tables(tmp_path):
    body = 'samples = 16\nmetrics = ["pv_measured_nm"]\n' + _inputs()  # 80 points
    study = write_study(tmp_path, "killed", body, "slow_sum_study")
    (tmp_path / "ref").mkdir()
    reference = run(write_study(tmp_path / "ref", "killed", body, "sum_study"), tmp_path / "ref")
    results = tmp_path / "results"
    log = results / "killed" / "points.csv"
    command = [sys.executable, "-m", "ufmt.cli", "run", str(study), "--jobs", "2"]
    command += ["--results", str(results), "--no-progress"]
    proc = subprocess.Popen(command, cwd=REPO, start_new_session=True, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and proc.poll() is None:
            if log.exists() and log.read_bytes().count(b"\n") > 10:
                break
            time.sleep(0.01)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)  # the run and its workers, mid-study
        proc.wait()
    saved = log.read_bytes().count(b"\n") - 1
    assert 10 <= saved < 80, "the run was not killed mid-study"
    out = run(study, results, jobs=2)
    assert read_meta(out)["run"]["points_reused"] >= saved
    for table in TABLES[1:]:
        pd.testing.assert_frame_equal(read_table(out / table), read_table(reference / table))
    resumed, fresh = read_table(out / "points.csv"), read_table(reference / "points.csv")
    pd.testing.assert_frame_equal(resumed, fresh)


# ---------------------------------------------------------------------------------------------
# intervals on the headline numbers (ufmt simulate --uncertainty N)


def test_latin_hypercube_interval_covers_ninety_percent_of_a_log_uniform_band():
    """Oracle: force_scale is log-uniform on its band, F(x) = ln(x / lo) / ln(hi / lo); the
    5-95 % interval of the samples covers 90 % of it (a Latin hypercube: within 1 / n)."""
    bands = input_bands(["machine.force_scale"])
    band = bands["machine.force_scale"]
    x = sample_designs(bands, 1000, seed=5)["machine.force_scale"].to_numpy()
    row = summarise(x, (0.05, 0.95))

    def cdf(v):
        return np.log(v / band.low) / np.log(band.high / band.low)

    assert abs(cdf(row["q95"]) - cdf(row["q05"]) - 0.90) < 2e-3


def test_headline_interval_of_a_linear_source_is_its_amplitude_interval_scaled():
    """Oracle: the PV of the straightness alone is linear in its amplitude, so the interval of
    PV is the interval of the sampled amplitudes times PV per metre of the point value."""
    model = load_model()
    process = Process(300.0, 15.0, 4.0)
    options = {"sources": ["straightness"]}
    point = simulate(model, process, **options)
    per_metre = point.metrics["pv_nm"] / model.machine.straightness_m
    intervals = headline_intervals(model, process, 6, ["machine.straightness_m"], **options)
    amplitude = intervals.samples["machine.straightness_m"].to_numpy()
    got = intervals.to_dict()["metrics"]["pv_nm"]
    expected = per_metre * np.quantile(amplitude, [0.05, 0.95])
    np.testing.assert_allclose([got["q05"], got["q95"]], expected, rtol=1e-9)


def test_hinge_damping_factor_on_the_shared_basis_equals_the_basis_of_the_scaled_model():
    """Oracle: an independent assembly. The projected hinge damping Phi_rel^T C Phi_rel is
    linear in C, so the shared basis' matrix times the factor equals the basis solved again
    from the model whose hinge dampers carry the factor (same modes: damping does not enter
    them)."""
    model = load_model()
    factor = 1.7
    shared = modal_basis(model)
    again = modal_basis(scale_hinge_damping(model, factor))
    np.testing.assert_allclose(again.omega, shared.omega, rtol=1e-12)
    # the two solves agree to rounding: entries far below the largest carry its absolute
    # rounding, so the absolute floor is relative to the matrix's scale (entries up to ~10)
    scale = np.abs(shared.hinge_damping).max()
    np.testing.assert_allclose(
        again.hinge_damping, factor * shared.hinge_damping, rtol=1e-9, atol=1e-12 * scale
    )


def test_damping_samples_are_simulations_at_the_sampled_ratio_and_factor():
    """Oracle: each sample of the damping bands equals a simulation called directly with that
    zeta on the model whose hinge dampers carry that factor; the bands are the assumed ones."""
    model = load_model()
    process = Process(300.0, 15.0, 4.0)
    inputs = ["machine.modal_damping_ratio", "damping.*"]
    bands = input_bands(inputs)
    zeta = bands["machine.modal_damping_ratio"]
    assert (zeta.low, zeta.high) == (0.005, 0.02)
    assert (bands["damping.hinge_factor"].low, bands["damping.hinge_factor"].high) == (0.5, 2.0)
    intervals = headline_intervals(model, process, 2, inputs, zeta=0.05)  # the sample's wins
    for row in intervals.samples.to_dict("records"):
        direct = simulate(
            scale_hinge_damping(model, row["damping.hinge_factor"]),
            process,
            zeta=row["machine.modal_damping_ratio"],
        )
        assert row["zre_peak_nm"] == pytest.approx(direct.metrics["zre_peak_nm"], rel=1e-9)
    zre = intervals.samples["zre_peak_nm"].to_numpy()
    assert np.ptp(zre) > 0  # the damping moves the vibration


def test_simulate_uncertainty_json_keeps_every_key_and_adds_intervals(capsys):
    argv = ["simulate", "--json", "--uncertainty-inputs", "machine.error_motion_m"]
    assert main(argv) == 0
    plain = json.loads(capsys.readouterr().out)
    assert main([*argv, "--uncertainty", "3"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert {k: v for k, v in out.items() if k != "uncertainty"} == plain
    metrics = out["uncertainty"]["metrics"]
    assert out["uncertainty"]["inputs"] == ["machine.error_motion_m"]
    assert metrics["pv_measured_nm"]["q05"] <= metrics["pv_measured_nm"]["q95"]
    assert metrics["psd1_rms_nm"]["q05"] is None  # not resolved on the 52.4 mm plate: null


def test_simulate_uncertainty_rejects_an_unknown_band_in_one_line():
    res = subprocess.run(
        [sys.executable, "-m", "ufmt.cli", "simulate", "--uncertainty", "2"]
        + ["--uncertainty-inputs", "machine.nothing*"],
        cwd=REPO,
        capture_output=True,
        text=True,
    )
    assert res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1
    assert "matches no documented band" in res.stderr and "Traceback" not in res.stderr


def test_a_band_added_to_the_calibration_file_is_an_input_at_once(tmp_path):
    """The bands are read, not restated: a [[response.parameter]] added to a copy of the
    calibration file (here the nose radius, a loader key without a documented band) appears
    with its band and scale; a stiffness factor's band is the prior's value times the factor."""
    packaged = packaged_path("calibration.toml")
    text = packaged.read_text(encoding="utf-8")
    for key, file in (("prior", "ufmt-prior.toml"), ("reference", "paper_reference.toml")):
        assert f'{key} = "{file}"' in text  # relative to the file: made absolute for the copy
        text = text.replace(f'{key} = "{file}"', f'{key} = "{packaged.parent / file}"')
    text += (
        '\n[[response.parameter]]\nkey = "nose_radius"\nfit = false\nband = [1e-3, 8e-3]\n'
        'start = 5e-3\nscale = "log"\nunit = "m"\nreason = "test"\n'
    )
    path = tmp_path / "calibration.toml"
    path.write_text(text, encoding="utf-8")
    bands = documented_bands(path)
    assert "machine.nose_radius" not in documented_bands()
    band = bands["machine.nose_radius"]
    assert (band.low, band.high, band.log, band.unit) == (1e-3, 8e-3, True, "m")
    prior = load_model(packaged.parent / "ufmt-prior.toml")
    axial = bands["hinge.h31.stiffness[2]"]
    k = prior.hinge("h31").stiffness[2]
    assert (axial.low, axial.high) == pytest.approx((0.5 * k, 2.0 * k), rel=1e-12)


def test_rerun_that_computes_nothing_rewrites_nothing(tmp_path):
    """Oracle: the first run's own bytes (every table, meta.json, figure, the index)."""
    study = write_study(tmp_path, "clean", TINY, "sum_study")
    results = tmp_path / "results"
    run(study, results)
    first = {p: p.read_bytes() for p in sorted(results.rglob("*")) if p.is_file()}
    run(study, results)
    assert {p: p.read_bytes() for p in sorted(results.rglob("*")) if p.is_file()} == first


# ---------------------------------------------------------------------------------------------
# a model's own bands: declared in its file, the packaged machine's for the packaged machine

BRIDGE = REPO / "examples" / "bridge.toml"
FORCE_BAND = """
[[uncertain]]
name = "machine.force_scale"
band = [{low!r}, {high!r}]
distribution = "loguniform"
source = "test"
"""


def plain_bridge() -> str:
    """The bridge example's text without the [[uncertain]] tables it declares."""
    return BRIDGE.read_text(encoding="utf-8").split("\n[[uncertain]]")[0]


def bridge_with(text: str):
    """The bridge example with ``text`` as its only [[uncertain]] tables."""
    return load_model_text(plain_bridge() + text, str(BRIDGE))


def test_bridge_interval_over_its_own_band_contains_the_nominal_and_widens_with_the_band():
    """Oracles: the dynamic surface is linear in the force factor (each sample's PV is its
    factor times the nominal PV, the bridge's force_scale being 1); the Latin hypercube puts
    one sample on each side of the log-centre 1 of a band log-symmetric about it, so the 5-95 %
    interval contains the nominal; with the same seed a wider band gives a wider interval."""
    process = Process(300.0, 15.0, 4.0)
    options = {"sources": ["dynamic"], "n_phi": 512}
    nominal = simulate(bridge_with(""), process, **options).metrics["pv_dynamic_nm"]
    widths = []
    for low, high in ((0.8, 1.25), (0.5, 2.0)):
        model = bridge_with(FORCE_BAND.format(low=low, high=high))
        intervals = headline_intervals(model, process, 4, **options)
        assert intervals.inputs == ("machine.force_scale",)
        samples = intervals.samples
        np.testing.assert_allclose(
            samples["pv_dynamic_nm"], samples["machine.force_scale"] * nominal, rtol=1e-9
        )
        band = intervals.to_dict()["metrics"]["pv_dynamic_nm"]
        assert band["q05"] < nominal < band["q95"]
        widths.append(band["q95"] - band["q05"])
    assert widths[1] > widths[0]


def test_the_packaged_machine_keeps_its_bands_and_samples_wherever_its_file_lies(tmp_path):
    """Oracle: the code path before models declared bands, rebuilt here: the calibration
    file's bands and the assumed damping bands matching DEFAULT_INPUTS, in that order; the
    packaged model, loaded or copied elsewhere, samples them bitwise alike."""
    from ufmt.studies.bands import damping_bands
    from ufmt.studies.intervals import DEFAULT_INPUTS

    everything = {**documented_bands(), **damping_bands()}
    names = [n for p in DEFAULT_INPUTS for n in everything if fnmatch.fnmatchcase(n, p)]
    before = sample_designs({n: everything[n] for n in dict.fromkeys(names)}, 5, seed=3)
    copy = tmp_path / "ufmt.toml"
    copy.write_bytes(packaged_path().read_bytes())
    for model in (None, load_model(), load_model(copy)):
        pd.testing.assert_frame_equal(sample_designs(input_bands(None, model), 5, 3), before)


def test_another_model_never_borrows_the_packaged_machines_bands():
    """The bridge without tables has no bands (one line saying how to declare them); with
    tables exactly its own; a packaged model with a stiffness changed is another machine."""
    with pytest.raises(StudyError, match="declares no uncertain inputs") as err:
        input_bands(["machine.*"], bridge_with(""))
    assert "[[uncertain]]" in str(err.value) and "\n" not in str(err.value)
    own = input_bands(None, bridge_with(FORCE_BAND.format(low=0.8, high=1.25)))
    assert list(own) == ["machine.force_scale"] and (own["machine.force_scale"].low) == 0.8
    changed = apply_design(load_model(), {"hinge.h31.stiffness[2]": 1e9})
    with pytest.raises(StudyError, match="declares no uncertain inputs"):
        input_bands(None, changed)


@pytest.mark.parametrize(
    "extra", [["--uncertainty", "8"], ["--uncertainty", "2", "--uncertainty-inputs", "machine.*"]]
)
def test_simulate_uncertainty_on_a_model_without_bands_is_one_line_before_the_cut(
    extra, tmp_path, capsys
):
    plain = tmp_path / "bridge.toml"
    plain.write_text(plain_bridge(), encoding="utf-8")
    assert main(["simulate", str(plain), *extra]) == 2
    out, err = capsys.readouterr()
    assert out == "" and len(err.strip().splitlines()) == 1
    assert "declares no uncertain inputs" in err and "h31" not in err


def bridge_stiffness_study(design, process, model=None):
    """The sampled axial stiffness of the bridge's air bearing [N/m] as pv_measured_nm."""
    return {"pv_measured_nm": design["hinge.air_bearing.stiffness[2]"]}


def test_uncertainty_study_scale_on_a_users_hinge_is_its_own_value_times_the_scale(tmp_path):
    """Oracle: the model's own value (4e8 N/m) times scale = [0.5, 2]: every sample inside,
    both halves of the band sampled; a pattern over a model without bands is one line."""
    (tmp_path / "bridge.toml").write_text(plain_bridge(), encoding="utf-8")
    body = """\
        model = "bridge.toml"
        samples = 4
        metrics = ["pv_measured_nm"]
        [[input]]
        parameter = "hinge.air_bearing.stiffness[2]"
        scale = [0.5, 2.0]
        """
    out = run(write_study(tmp_path, "scaled", body, "bridge_stiffness_study"), tmp_path / "r")
    values = read_table(out / "samples.csv")["pv_measured_nm"].to_numpy()
    assert np.all((values >= 2e8) & (values <= 8e8)) and values.min() < 4e8 < values.max()
    bad = write_study(
        tmp_path,
        "bad",
        'model = "bridge.toml"\n[[input]]\nparameter = "machine.*"\n',
        "bridge_stiffness_study",
    )
    with pytest.raises(StudyError, match="declares no uncertain inputs") as err:
        parse_study(bad.read_text(), bad)
    assert "\n" not in str(err.value)


def test_uncertainty_study_patterns_match_the_models_own_bands(tmp_path):
    """A pattern over a model with [[uncertain]] tables gives its bands (the damping factor,
    outside what a study sets, left out)."""
    damping = '\n[[uncertain]]\nname = "damping.hinge_factor"\nband = [0.5, 2.0]\nsource = "t"\n'
    text = plain_bridge() + FORCE_BAND.format(low=0.8, high=1.25) + damping
    (tmp_path / "bridge.toml").write_text(text, encoding="utf-8")
    body = 'model = "bridge.toml"\n[[input]]\nparameter = "*"\n'
    path = write_study(tmp_path, "own", body, "bridge_stiffness_study")
    study = parse_study(path.read_text(), path)
    assert [(b.parameter, b.low, b.high) for b in study.bounds] == [
        ("machine.force_scale", 0.8, 1.25)
    ]


def test_the_bridge_example_samples_its_own_declared_bands(capsys):
    """The example's ``machine.*`` is its own force band (log-symmetric about its nominal 1):
    the interval brackets the point value; none of the packaged machine's bands appears."""
    argv = ["simulate", str(BRIDGE), "--json", "--sources", "dynamic", "--uncertainty", "2"]
    assert main([*argv, "--uncertainty-inputs", "machine.*"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["uncertainty"]["inputs"] == ["machine.force_scale"]
    band = out["uncertainty"]["metrics"]["pv_dynamic_nm"]
    assert band["q05"] < out["pv_dynamic_nm"] < band["q95"]
