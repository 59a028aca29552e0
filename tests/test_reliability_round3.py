"""Reliability round 3: every attack of the third round gives one line naming the file, the
field and the allowed range (exit 2) or the right result; every request is bounded before it
allocates (:mod:`ufmt.limits`); the public functions take their arguments one way.

Oracles: the exit-status contract (2 and one line on stderr, no traceback), the documented
budgets of :mod:`ufmt.limits` (a refused request allocates next to nothing: tracemalloc's
peak), the same call made with the documented argument form (a ``Process`` for a dict, the
packaged path for None), invariance of the loaded model under a rigid translation of the
whole file, scale invariance of the tolerance allocation in its cost coefficients, and the
quantiles written in ``distribution.csv`` for the headline and the report.
"""

from __future__ import annotations

import json
import os
import re
import threading
import tomllib
import tracemalloc
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from test_uncertainty import _inputs, run, write_study

import ufmt
from ufmt import evaluate_cache, limits
from ufmt.calibration.modal_test import read_modal_test
from ufmt.cli import main
from ufmt.errors import ModelError, ProcessError, StudyError, UfmtError
from ufmt.machining.process import Process
from ufmt.model.load import load_model, load_model_text, model_from_dict
from ufmt.report import _headline_intervals
from ufmt.studies.outputs import short
from ufmt.studies.tolerances import allocate
from ufmt.tomlfile import read_text

MODELS = Path(__file__).parent / "models"


@pytest.fixture(autouse=True)
def _own_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("UFMT_CACHE_DIR", str(tmp_path / "cache"))


def refused(capsys, *argv) -> str:
    """The one stderr line of ``ufmt argv`` exiting with status 2 (argparse exits too)."""
    try:
        status = main(list(argv))
    except SystemExit as exc:
        status = exc.code
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert status == 2, err
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def peak_mib(call) -> tuple[BaseException | None, float]:
    """(the exception ``call`` raised, the peak of Python allocations during it [MiB])."""
    tracemalloc.start()
    try:
        call()
        raised = None
    except Exception as exc:  # the caller asserts what it must be
        raised = exc
    peak = tracemalloc.get_traced_memory()[1] / 2**20
    tracemalloc.stop()
    return raised, peak


# ---------------------------------------------------------------------------------------------
# tracebacks that are now one line


@pytest.mark.parametrize(
    ("argv", "phrase"),
    [
        (["simulate", "--samples-per-rev", "9"], "--samples-per-rev: 9 must be even"),
        (["simulate", "--samples-per-rev", "6"], "--samples-per-rev: 6 must be >= 8"),
        (["simulate", "--feed", "1e-9"], "revolutions"),
        (["simulate", "--modes", "5000"], f"--modes: 5000 must be <= {limits.MAX_MODE_COUNT}"),
        (["modes", "--count", "100000"], "--count: 100000 must be <= "),
        (["frf", "--points", "1000000"], f"--points: 1000000 must be <= {limits.MAX_FRF_POINTS}"),
        (["simulate", "--uncertainty", "2", "--uncertainty-inputs", ""], "names no band"),
        (["simulate", "--uncertainty", "2", "--uncertainty-inputs", ","], "names no band"),
        (["simulate", "--uncertainty", "10000"], f"must be <= {limits.MAX_UNCERTAINTY_SAMPLES}"),
        (["frf", "--at", "head:nan,0,0.93", "head:0,0,0.93"], "must be finite"),
        (["frf", "--at", "head:1e6,0,0.93", "head:0,0,0.93"], "within 20 m"),
    ],
)
def test_each_attack_is_one_line_with_exit_2(capsys, tmp_path, argv, phrase):
    """Oracle: the exit-status contract; the line names the argument and its range."""
    if argv[0] == "frf":
        argv = [*argv, "--output-dir", str(tmp_path / "frf")]
    assert phrase in refused(capsys, *argv)


def test_the_revolution_limit_is_the_cut_length_over_the_feed_per_revolution(capsys):
    """Oracle: n_rev = (cut span) / (v / f); the message's count is that number."""
    machine = load_model().machine
    y0, y1 = machine.cut_span
    line = refused(capsys, "simulate", "--feed", "1e-9", "--rpm", "300")
    expected = (y1 - y0) / (1e-9 / 60e3 / 5.0)
    shown = float(re.search(r"needs ([0-9.e+]+) revolutions", line).group(1))
    assert shown == pytest.approx(expected, rel=1e-2)


def test_a_test_mode_number_of_40_digits_names_the_field(tmp_path):
    """Oracle: the reader's documented range of ``mode`` (1 to MAX_TEST_MODE)."""
    path = tmp_path / "test.csv"
    path.write_text("mode,frequency_hz\n" + "9" * 40 + ",100.0\n", encoding="utf-8")
    with pytest.raises(StudyError, match=r"test\.csv.*mode.*\[1, 1e\+06\]"):
        read_modal_test(path)


def test_an_empty_cell_reads_as_empty_not_nonetype(tmp_path):
    path = tmp_path / "test.csv"
    path.write_text("mode,frequency_hz\n1,\n", encoding="utf-8")
    with pytest.raises(StudyError, match="frequency_hz") as info:
        read_modal_test(path)
    assert "NoneType" not in str(info.value) and "empty" in str(info.value)


def test_tolerance_costs_are_bounded_and_the_allocation_is_scale_free():
    """Oracle: the allocation minimises sum b_j / tau_j, so multiplying every b_j by one
    factor (1e300: beyond float range once squared) leaves it unchanged."""
    c = np.array([2.0, 1.0, 0.5])
    tau_min = np.full(3, 0.05)
    base = [{"a": 1.0, "b": b} for b in (1.0, 3.0, 0.5)]
    huge = [{"a": 1.0, "b": 1e300 * v["b"]} for v in base]
    for form in ("linear", "rss"):
        level = 1.2 if form == "linear" else 1.0
        expected = allocate(0.1, c, form, level, tau_min, base)
        np.testing.assert_allclose(allocate(0.1, c, form, level, tau_min, huge), expected)


def test_a_calibration_band_that_holds_its_parameter_is_refused():
    from ufmt.calibration.settings import _parameters
    from ufmt.tables import Where

    table = {"name": "bearing", "hinges": ["h25"], "field": "stiffness", "components": [0]}
    top = Where("settings.toml", error=StudyError)
    with pytest.raises(StudyError, match=r"settings\.toml.*band.*empty range"):
        _parameters(top, [{**table, "band": [1.0, 1.0]}], load_model())


# ---------------------------------------------------------------------------------------------
# uncertainty quantiles other than 5 and 95 %


def test_uncertainty_study_with_2_5_and_97_5_percent_quantiles_finishes(tmp_path):
    """Oracle: the headline quotes the q2.5 and q97.5 columns of distribution.csv."""
    body = "samples = 16\nquantiles = [0.025, 0.5, 0.975]\nmetrics = ['zre_peak_nm']\n"
    out = run(write_study(tmp_path, "q", body + _inputs(), "sum_study"), tmp_path / "r")
    meta = json.loads((out / "meta.json").read_text(encoding="utf-8"))
    assert meta["status"] == "complete"
    row = pd.read_csv(out / "distribution.csv").iloc[0]
    assert f"zre_peak_nm {short(row['q2.5'])}-{short(row['q97.5'])}" in meta["headline"]


def test_the_report_shows_a_study_run_with_10_and_90_percent(tmp_path):
    """Oracle: the report's columns are the study's quantiles, with their values."""
    body = "samples = 16\nquantiles = [0.1, 0.9]\nmetrics = ['zre_peak_nm']\n"
    out = run(write_study(tmp_path, "q", body + _inputs(), "sum_study"), tmp_path / "r")
    html = _headline_intervals(tmp_path / "no-cut", out)
    row = pd.read_csv(out / "distribution.csv").iloc[0]
    assert "10 %" in html and "90 %" in html
    assert f"{row['q10']:.4g}" in html and f"{row['q90']:.4g}" in html


def test_a_specification_for_a_metric_the_study_does_not_compute_is_refused(tmp_path):
    body = "samples = 16\nmetrics = ['zre_peak_nm']\n[specification]\npv_measured_nm = 1.0\n"
    with pytest.raises(StudyError, match=r"specification.*pv_measured_nm.*zre_peak_nm"):
        run(write_study(tmp_path, "s", body + _inputs(), "sum_study"), tmp_path / "r")


# ---------------------------------------------------------------------------------------------
# one API


@pytest.fixture(scope="module")
def packaged():
    return load_model()


def test_simulate_takes_a_dict_and_none_as_evaluate_does(packaged):
    """Oracle: the same call with a Process and the loaded packaged model."""
    process = {"rpm": 300.0, "feed_mm_min": 15.0, "depth_um": 4.0}
    as_dict = ufmt.simulate(None, process, n_modes=20)
    as_object = ufmt.simulate(packaged, Process(**process), n_modes=20)
    np.testing.assert_equal(as_dict.metrics, as_object.metrics)  # NaN: an unresolved band


def test_simulate_with_a_partial_dict_takes_the_reference_case(packaged):
    """Oracle: missing names are the reference case, as ``evaluate`` fills them."""
    partial = ufmt.simulate(packaged, {"rpm": 300.0}, n_modes=20)
    full = ufmt.simulate(packaged, Process(300.0, 15.0, 4.0), n_modes=20)
    np.testing.assert_equal(partial.metrics, full.metrics)


@pytest.mark.parametrize(
    ("call", "error", "phrase"),
    [
        (lambda m: ufmt.simulate({"rpm": 300}, m), ProcessError, "the model comes first"),
        (lambda m: ufmt.simulate(m, {"rpm": True}), ProcessError, "'rpm': True is not a number"),
        (lambda m: ufmt.simulate(m, {"rmp": 300}), ProcessError, "did you mean 'rpm'"),
        (lambda m: ufmt.simulate(m, {}, sources=[]), ProcessError, "no error source"),
        (lambda m: ufmt.evaluate(m, {"rpm": 300}), StudyError, "the design comes first"),
        (
            lambda m: ufmt.evaluate({"head_axial_stiffness_N_m": True}, {}, m),
            StudyError,
            "True is not a number",
        ),
        (lambda m: ufmt.evaluate({"x": "1e8"}, {}, m), StudyError, "'1e8' is not a number"),
    ],
)
def test_a_mistaken_argument_is_a_clear_message(packaged, call, error, phrase):
    with pytest.raises(error, match=re.escape(phrase)):
        call(packaged)


def test_evaluate_takes_none_as_the_model_as_it_is(tmp_path):
    """Oracle: None and {} are the same (empty) design."""
    none, empty = ufmt.evaluate(None, {"rpm": 300.0}), ufmt.evaluate({}, {"rpm": 300.0})
    np.testing.assert_equal(none.to_dict(), empty.to_dict())


def test_library_messages_name_parameters_not_options():
    for call in (
        lambda: ufmt.solve_modes(None, fmax_hz=-5.0),
        lambda: ufmt.solve_modes(None, method="nope"),
    ):
        with pytest.raises(UfmtError) as info:
            call()
        assert "--" not in str(info.value)


# ---------------------------------------------------------------------------------------------
# every request bounded before it allocates


def _many_modes():
    """A slender cantilever (0.5 m long, 0.3 mm thick): far more than MAX_MODE_COUNT modes
    below 1 MHz (bending modes grow as the square of their number)."""
    return load_model_text(_beam_model(0.0003), "slender.toml")


@pytest.mark.parametrize(
    ("call", "phrase"),
    [
        (lambda: ufmt.solve_modes(None, fmax_hz=1e300, count=3), "fmax_hz: 1e+300"),
        (lambda: ufmt.solve_modes(_many_modes(), fmax_hz=1e6), "modes below fmax_hz = 1e+06"),
        (lambda: ufmt.solve_modes(None, count=100000), "count: 100,000"),
        (lambda: ufmt.simulate(None, {}, n_modes=1e9), "n_modes: 1,000,000,000"),
        (lambda: ufmt.simulate(None, {}, table_rows=10**8), "table_rows: 100,000,000"),
        (lambda: ufmt.simulate(None, {}, n_phi=9), "n_phi: 9 must be even"),
        (lambda: ufmt.frf(None, points=1e9), "points: 1,000,000,000"),
        (lambda: ufmt.frf(None, points=True), "points: True is not an integer"),
        (lambda: ufmt.frf(None, fmax_hz=float("inf")), "fmax_hz: inf"),
        (lambda: ufmt.frf(None, tool_angle=float("nan")), "tool_angle: nan"),
    ],
)
def test_an_oversized_api_request_is_refused_before_it_allocates(call, phrase):
    """Oracle: the documented budgets; the refusal allocates less than 64 MiB (the requests
    would need gigabytes)."""
    raised, peak = peak_mib(call)
    assert isinstance(raised, UfmtError) and phrase in str(raised), raised
    assert peak < 64, peak


def test_a_20_mb_model_file_is_refused_from_its_size(tmp_path):
    """Oracle: MAX_INPUT_BYTES; a sparse 20 MB file is refused without being read."""
    path = tmp_path / "big.toml"
    with path.open("wb") as fh:
        fh.truncate(20 << 20)
    raised, peak = peak_mib(lambda: load_model(path))
    assert isinstance(raised, ModelError) and "20,971,520 bytes" in str(raised)
    assert str(path) in str(raised) and peak < 4


def test_ufmt_modes_refuses_a_20_mb_model_in_one_line(capsys, tmp_path):
    path = tmp_path / "big.toml"
    with path.open("wb") as fh:
        fh.truncate(20 << 20)
    line = refused(capsys, "modes", str(path))
    assert str(path) in line and f"at most {limits.MAX_INPUT_BYTES:,}" in line


def test_a_device_is_read_up_to_the_budget_only():
    """Oracle: /dev/zero never ends; it is refused after MAX_INPUT_BYTES."""
    with pytest.raises(StudyError, match=r"/dev/zero: more than [0-9,]+ bytes"):
        read_text("/dev/zero")


def test_a_model_with_more_bodies_than_the_budget_is_refused_before_it_is_built():
    body = {"kind": "rigid", "mass": 1.0, "center_of_mass": [0, 0, 0], "inertia": np.eye(3)}
    data = {
        "name": "many",
        "body": [{**body, "name": f"b{i}"} for i in range(limits.MAX_BODIES + 1)],
    }
    raised, peak = peak_mib(lambda: model_from_dict(data, "many.toml"))
    assert isinstance(raised, ModelError), raised
    assert f"{limits.MAX_BODIES + 1:,} [[body]] tables" in str(raised) and "many.toml" in str(
        raised
    )


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs")
def test_a_fifo_planted_as_a_cache_record_does_not_block(tmp_path):
    """Oracle: the read returns (a miss) while nobody ever writes to the FIFO."""
    key = {"case": "fifo"}
    digest = evaluate_cache.key_digest(key)
    folder = tmp_path / "cache" / digest[:2]
    folder.mkdir(parents=True, mode=0o700)
    (tmp_path / "cache").chmod(0o700)
    os.mkfifo(folder / f"{digest}.json")
    result = []
    reader = threading.Thread(target=lambda: result.append(evaluate_cache.load(key, ("a",))))
    reader.daemon = True
    reader.start()
    reader.join(10.0)
    assert not reader.is_alive() and result == [None]
    evaluate_cache.store(key, {"a": 1.0, "message": ""})  # the record replaces the FIFO
    assert evaluate_cache.load(key, ("a",)) == {"a": 1.0, "message": ""}


# ---------------------------------------------------------------------------------------------
# lengths in metres without a [machine] table


def _beam_model(diameter: float, shift: float = 0.0) -> str:
    return f"""
name = "shaft"
[[body]]
name = "shaft"
kind = "beam"
start = [{shift}, {shift}, {shift}]
end = [{shift}, {shift}, {shift + 0.5}]
density = 7850.0
youngs_modulus = 2.1e11
shear_modulus = 8.1e10
diameter = {diameter}
[[hinge]]
name = "root"
between = ["ground", "shaft"]
at = [{shift}, {shift}, {shift}]
stiffness = [inf, inf, inf]
rotational_stiffness = [inf, inf, inf]
"""


def test_a_shaft_diameter_typed_in_mm_is_refused_with_a_hint():
    with pytest.raises(ModelError, match=r"shaft.*'diameter'.*did you mean 0\.1 m"):
        load_model_text(_beam_model(100.0), "shaft.toml")


def _moved(scale: float, shift: float) -> dict:
    """good_mixed.toml without its [machine] table, every point (centres of mass, beam ends,
    hinge points) times ``scale`` plus ``shift`` [m] along x, y and z."""
    data = tomllib.loads((MODELS / "good_mixed.toml").read_text(encoding="utf-8"))
    data.pop("machine", None)  # the model alone, as a file without [machine]
    for table in [*data["body"], *data["hinge"]]:
        for key in ("center_of_mass", "start", "end", "at"):
            if key in table:
                table[key] = [scale * v + shift for v in table[key]]
    return data


def test_a_model_typed_in_mm_is_refused_and_a_translated_one_is_not():
    """Oracles: the model with its points in mm spans 700 m, more than any machine; the same
    model moved rigidly by 100 m along x, y, z loads and keeps its natural frequencies (only
    spans are checked)."""
    with pytest.raises(ModelError, match=r"mm\.toml.*spans 700 m along z.*did you mean 0\.7 m"):
        model_from_dict(_moved(1000.0, 0.0), "mm.toml")
    here = ufmt.solve_modes(model_from_dict(_moved(1.0, 0.0)), count=4)
    moved = ufmt.solve_modes(model_from_dict(_moved(1.0, 100.0)), count=4)
    np.testing.assert_allclose(moved.frequencies_hz, here.frequencies_hz, rtol=1e-6)


# ---------------------------------------------------------------------------------------------
# the SDF reader


def _sdf(points="4", profiles="3", scales=("1e-4", "1e-4", "1.0e-09"), heights=None) -> str:
    heights = heights or [" ".join(["1.0"] * 4)] * 3
    header = [
        "aISO-1.0",
        f"NumPoints = {points}",
        f"NumProfiles = {profiles}",
        f"Xscale = {scales[0]}",
        f"Yscale = {scales[1]}",
        f"Zscale = {scales[2]}",
        "DataType = 7",
    ]
    return "\r\n".join([*header, "*", *heights, "*", "Origin = x 0.0 m, y 0.0 m", "*"]) + "\r\n"


def test_a_well_formed_sdf_reads_back(tmp_path):
    """Oracle: the closed-form grid of the header (x = i Xscale, z = height Zscale)."""
    from ufmt.exports import read_sdf

    path = tmp_path / "ok.sdf"
    path.write_text(_sdf(), encoding="ascii")
    x, y, z = read_sdf(path)
    np.testing.assert_allclose(x, 1e-4 * np.arange(4))
    assert y.shape == (3,) and z.shape == (3, 4)
    np.testing.assert_allclose(z, 1e-9)


@pytest.mark.parametrize(
    ("text", "field"),
    [
        (_sdf(points="-1"), "NumPoints"),
        (_sdf(points="0"), "NumPoints"),
        (_sdf(profiles="-3"), "NumProfiles"),
        (_sdf(points="1e3"), "NumPoints"),
        (_sdf(scales=("nan", "1e-4", "1e-9")), "Xscale"),
        (_sdf(scales=("1e-4", "0", "1e-9")), "Yscale"),
        (_sdf(scales=("1e-4", "1e-4", "inf")), "Zscale"),
        (_sdf(heights=["1 2 3 nan"] * 3), "data"),
        (_sdf(heights=["1 2 3 inf"] * 3), "data"),
        (_sdf(heights=["1 2 3"] * 3), "data"),
        (_sdf(heights=["1 2 3 x"] * 3), "data"),
        (_sdf().replace("NumPoints = 4\r\n", ""), "NumPoints"),
        ("aISO-1.0\r\nNumPoints 4\r\n*\r\n*\r\n", "header line"),
        ("not an sdf", "ISO 25178-71"),
        (_sdf().replace("Origin = x 0.0 m", "Origin = x nan m"), "Origin"),
    ],
)
def test_a_malformed_sdf_names_the_file_and_the_field(tmp_path, text, field):
    from ufmt.exports import read_sdf

    path = tmp_path / "bad.sdf"
    path.write_text(text, encoding="ascii")
    with pytest.raises(ModelError) as info:
        read_sdf(path)
    assert str(path) in str(info.value) and field in str(info.value), info.value


# ---------------------------------------------------------------------------------------------
# warnings


FULL_CACHE = "cache directory /round3 is unusable (No space left on device); running without"


def warn_once_pv(design, process, model=None):
    """PV = rpm / 10 [nm]; reports a failed cache write as ufmt.evaluate does (warn_once)."""
    evaluate_cache.warn_once(FULL_CACHE)
    return {"pv_nm": process["rpm"] / 10.0}


def test_a_failed_cache_write_is_reported_with_one_job(tmp_path):
    """Oracle: the same warning ``--jobs 2`` shows (the main process reports a worker's)."""
    from ufmt.studies.parallel import Execution
    from ufmt.studies.runner import run_study

    study = tmp_path / "w.toml"
    study.write_text(
        f'function = "{Path(__file__).resolve()}:warn_once_pv"\nkind = "sweep"\n'
        '[[axis]]\nparameter = "rpm"\nrange = [200.0, 400.0]\nn = 2\n',
        encoding="utf-8",
    )
    with pytest.warns(evaluate_cache.CacheWarning, match="No space left on device"):
        run_study(study, Execution(jobs=1), results=tmp_path / "r", progress=False, plots=False)


def test_an_all_zero_frf_plots_without_a_warning():
    """Oracle: an identically zero receptance (no coupling) plots on a linear axis at 0."""
    import warnings

    from ufmt.plots.response import plot_frf

    freq = np.geomspace(1.0, 100.0, 50)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fig = plot_frf(freq, np.zeros(50, complex), natural_hz=[10.0])
    assert fig.axes[0].get_yscale() == "linear"
    np.testing.assert_array_equal(fig.axes[0].lines[0].get_ydata(), 0.0)


# ---------------------------------------------------------------------------------------------
# every result has .plot() and .save()


def test_an_evaluation_record_plots_and_saves_its_own_values(tmp_path):
    """Oracle: record.json holds the record's values (NaN as null), the bars its finite
    [nm] values."""
    record = ufmt.evaluate(None, {"rpm": 300.0})
    paths = record.save(tmp_path)
    assert [p.name for p in paths] == ["record.json", "record.csv", "record.png"]
    saved = json.loads((tmp_path / "record.json").read_text(encoding="utf-8"))
    for key, value in record.items():
        expected = None if isinstance(value, float) and np.isnan(value) else value
        assert saved[key] == expected, key
    bars = record.plot().axes[0].patches
    finite = [v for k, v in record.items() if k.endswith("_nm") and np.isfinite(v)]
    assert sorted(b.get_width() for b in bars) == sorted(finite)


def test_a_modal_solution_keeps_the_model_it_was_solved_for(tmp_path):
    """Oracle: the same table as with the model passed again."""
    model = model_from_dict(_moved(1.0, 0.0))
    modes = ufmt.solve_modes(model, count=3)
    pd.testing.assert_frame_equal(modes.to_frame(), modes.to_frame(model))
    assert "body" in modes.to_frame()
    assert [p.name for p in modes.save(tmp_path)] == ["modes.csv", "modes.png"]
    assert modes.plot(mode=1) is not None


# ---------------------------------------------------------------------------------------------
# messages


def test_a_5_mb_body_name_is_not_echoed():
    """Oracle: the message names the field and the budget, in one short line."""
    data = tomllib.loads((MODELS / "good_mixed.toml").read_text(encoding="utf-8"))
    data["body"][0]["name"] = "b" * 5_000_000
    with pytest.raises(ModelError) as info:
        model_from_dict(data, "long.toml")
    assert "long.toml" in str(info.value) and "'name'" in str(info.value)
    assert f"at most {limits.MAX_NAME_CHARS}" in str(info.value) and len(str(info.value)) < 300


def test_an_unknown_long_name_is_cut_in_the_message():
    data = tomllib.loads((MODELS / "good_mixed.toml").read_text(encoding="utf-8"))
    data["hinge"][0]["between"] = ["ground", "x" * 100_000]
    with pytest.raises(ModelError) as info:
        model_from_dict(data, "long.toml")
    assert len(str(info.value)) < 1000


def test_a_memory_error_names_the_model_file(capsys, monkeypatch, tmp_path):
    """Oracle: the last guard's line names the file the command was given."""
    import ufmt.solvers

    def exhausted(*args, **kwargs):
        raise MemoryError

    monkeypatch.setattr(ufmt.solvers, "solve_modes", exhausted)
    path = MODELS / "good_mixed.toml"
    line = refused(capsys, "modes", str(path))
    assert str(path) in line and "MemoryError" in line


def test_evaluate_refuses_a_20_mb_model_without_holding_it(tmp_path):
    """Oracle: MAX_INPUT_BYTES; the content hash streams the file (peak far below 20 MiB)."""
    path = tmp_path / "big.toml"
    with path.open("wb") as fh:
        fh.truncate(20 << 20)
    raised, peak = peak_mib(lambda: ufmt.evaluate(None, {}, path))
    assert isinstance(raised, ModelError) and str(path) in str(raised), raised
    assert peak < 4, peak


def test_a_tolerance_cost_of_1e308_is_one_line(tmp_path):
    """Oracle: the documented bound of a cost coefficient (MAX_COST, relative units)."""
    from test_tolerances import study_text

    from ufmt.studies.load import parse_study
    from ufmt.studies.tolerances import MAX_COST

    text = study_text("linear_budget", 50.0).replace("cost = [1.0, 2.0]", "cost = [1e308, 1e308]")
    with pytest.raises(StudyError, match=rf"field .cost.*at most {re.escape(f'{MAX_COST:g}')}"):
        parse_study(text, tmp_path / "bad.toml")
