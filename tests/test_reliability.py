"""Reliability: inputs refused before any point runs, loud failures, safe concurrent
runs, a cache that cannot execute code, resume that keeps what it can, one-line errors.

Oracles: the loader's documented rules and LIMITS, byte-identical tables against an
uninterrupted reference run, the exit-status contract of ``ufmt run`` (0 / 1 / 2 / 130), and
RFC 8259 strict JSON (``json.loads`` with non-finite constants refused).
"""

from __future__ import annotations

import json
import math
import os
import pickle
import re
import signal
import subprocess
import sys
import textwrap
import threading
import time
import warnings
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import ufmt
from ufmt import evaluate_cache
from ufmt.cli import main
from ufmt.design import apply_design
from ufmt.errors import ModelError, StudyError
from ufmt.jsonout import dumps_strict
from ufmt.model.load import load_model, load_model_text, model_from_dict
from ufmt.model.rules import LIMITS
from ufmt.model.write import model_to_toml, toml_value
from ufmt.studies.kinds import KINDS
from ufmt.studies.load import load_study, parse_study
from ufmt.studies.locking import locked
from ufmt.studies.outputs import read_meta
from ufmt.studies.parallel import Execution
from ufmt.studies.runner import run_study

HERE = Path(__file__).resolve()
REPO = HERE.parents[1]
PY = [sys.executable, "-m", "ufmt.cli"]


def _run(study, results, jobs=1):
    """``run_study`` without progress bars or plots."""
    return run_study(study, Execution(jobs=jobs), results=results, progress=False, plots=False)


# ---------------------------------------------------------------------------------------------
# cheap study functions (signature of ufmt.evaluate)


def line_pv(design, process, model=None):
    """PV = rpm / 10 [nm] (a closed form: the reference table is known exactly)."""
    return {"pv_nm": process["rpm"] / 10.0}


def slow_line_pv(design, process, model=None):
    """line_pv after 0.2 s (slow enough to be interrupted mid-study)."""
    time.sleep(0.2)
    return line_pv(design, process, model)


def always_fails(design, process, model=None):
    raise RuntimeError("this point always fails")


def declared_k(design, process, model=None, parameters=None):
    """The h31 z stiffness that ``design`` sets through the study's own declarations."""
    changed = apply_design(load_model(model), design, parameters)
    return {"pv_nm": float(changed.hinge("h31").stiffness[2])}


CACHE_FULL = "cache directory /x is unusable (No space left on device); running without it"


def cache_warning_pv(design, process, model=None):
    """line_pv, warning on every point as a worker with a full cache does."""
    warnings.warn(CACHE_FULL, evaluate_cache.CacheWarning, stacklevel=1)
    return line_pv(design, process, model)


def domain_pv(design, process, model=None):
    """line_pv inside the validity domain of the packaged machine; raises outside it."""
    from ufmt.design import REFERENCE_PROCESS
    from ufmt.machining.process import Process
    from ufmt.machining.validity import check_cut
    from ufmt.model.machine import machine_of

    check_cut(Process(**{**REFERENCE_PROCESS, **process}), machine_of(load_model()))
    return line_pv(design, process, model)


def study_file(tmp_path: Path, name: str, body: str, function: str = "line_pv") -> Path:
    path = tmp_path / f"{name}.toml"
    text = f'function = "{HERE}:{function}"\n' + textwrap.dedent(body)
    path.write_text(text, encoding="utf-8")
    return path


RPM_SWEEP = """
kind = "sweep"
[[axis]]
parameter = "rpm"
range = [200.0, 400.0]
n = {n}
"""


def cli(*args, cwd=REPO, env=None, timeout=300):
    return subprocess.run(
        [*PY, *map(str, args)], capture_output=True, text=True, cwd=cwd, env=env, timeout=timeout
    )


def one_line_error(result, status=2) -> str:
    assert result.returncode == status, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    return lines[0]


@pytest.fixture(autouse=True)
def _own_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("UFMT_CACHE_DIR", str(tmp_path / "cache"))


# ---------------------------------------------------------------------------------------------
# design values validated before any point runs


@pytest.mark.parametrize(
    ("axis", "phrase"),
    [
        ('parameter = "head_radial_stiffness_N_m"\nrange = [-2e8, 2e8]', "is negative"),
        ('parameter = "head_radial_stiffness_N_m"\nvalues = [1e8, 1e300]', "allowed range"),
        ('parameter = "hinge.h31.rotational_stiffness[2]"\nscale = [0.5, 2.0]', "released"),
        ('parameter = "hinge.h24.stiffness[0]"\nscale = [0.5, 2.0]', "rigid"),
        ('parameter = "hinge.h99.stiffness[0]"\nrange = [1e8, 2e8]', "did you mean 'h29'"),
        (
            'parameter = "rpm"\nvalues = [0.0, 300.0]',
            "field 'rpm': 0 is not positive (allowed: > 0 [rpm])",
        ),
    ],
)
def test_bad_design_and_process_values_are_refused_at_load(tmp_path, axis, phrase):
    with pytest.raises(StudyError, match=r"study\.toml: ") as error:
        parse_study(f'kind = "sweep"\n[[axis]]\n{axis}\n', tmp_path / "study.toml")
    assert phrase in str(error.value)


def test_bad_inputs_exit_2_before_any_point_runs(tmp_path, capsys):
    bodies = {
        "rpm0": RPM_SWEEP.format(n=3) + "[base]\nrpm = 0.0\n",
        "missing-model": 'model = "nope.toml"\n' + RPM_SWEEP.format(n=3),
        "bad-model": 'model = "bad.toml"\n' + RPM_SWEEP.format(n=3),
        "hinge": RPM_SWEEP.format(n=3) + '[base]\n"hinge.h0.stiffness[0]" = 1e8\n',
    }
    (tmp_path / "bad.toml").write_text('name = "x"\n[[body]]\nname = "a"\n', encoding="utf-8")
    for name, body in bodies.items():
        path = study_file(tmp_path, name, body)
        assert main(["run", str(path), "--results", str(tmp_path / "r")]) == 2
        error = capsys.readouterr().err.strip()
        assert len(error.splitlines()) == 1 and f"{name}.toml" in error
        assert not (tmp_path / "r" / name).exists()  # refused before the results exist


def test_evaluate_refuses_a_design_value_the_model_file_could_not_hold():
    with pytest.raises(ModelError, match=r"stiffness\[0\]'.* is negative"):
        ufmt.evaluate({"head_radial_stiffness_N_m": -2e8}, {})


def test_evaluate_takes_a_process_object_and_load_model_defaults_to_the_packaged_model(
    monkeypatch,
):
    from records import same_record  # tests/ is not on the path of the study subprocesses

    monkeypatch.setenv("UFMT_CACHE_DIR", "")
    assert ufmt.load_model().source == str(ufmt.packaged_path())
    by_object = ufmt.evaluate({}, ufmt.Process(300.0, 15.0, 4.0))
    by_dict = ufmt.evaluate({}, {"rpm": 300.0, "feed_mm_min": 15.0, "depth_um": 4.0})
    assert same_record(by_object, by_dict)
    assert by_object["status"] == "ok"


# ---------------------------------------------------------------------------------------------
# physical magnitudes (LIMITS) and fuzzed model files

TWO_BODIES = {
    "name": "two",
    "body": [
        {
            "name": "a",
            "kind": "rigid",
            "mass": 2.0,
            "center_of_mass": [0.0, 0.0, 0.0],
            "inertia": [[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]],
        },
        {
            "name": "s",
            "kind": "beam",
            "start": [0.0, 0.0, 0.0],
            "end": [0.0, 0.0, 1.0],
            "density": 7800.0,
            "youngs_modulus": 2.1e11,
            "shear_modulus": 8e10,
            "diameter": 0.1,
        },
    ],
    "hinge": [
        {
            "name": "k",
            "between": ["ground", "a"],
            "at": [0.0, 0.0, 0.0],
            "stiffness": [1e6, 1e6, 1e6],
            "rotational_stiffness": [1e5, 1e5, 1e5],
        },
        {
            "name": "j",
            "between": ["a", "s"],
            "at": [0.0, 0.0, 0.0],
            "stiffness": [1e6, 1e6, 1e6],
            "rotational_stiffness": [1e5, 1e5, 1e5],
        },
    ],
}


@pytest.mark.parametrize(
    ("where", "value", "limit"),
    [
        (("body", 0, "mass"), 1e308, "mass"),
        (("body", 0, "mass"), 1e-300, "mass"),
        (("body", 0, "inertia"), [[1e308, 0, 0], [0, 1e308, 0], [0, 0, 1e308]], "inertia_entry"),
        (("body", 0, "inertia"), [[1e-300, 0, 0], [0, 1e-300, 0], [0, 0, 1e-300]], "inertia"),
        (("body", 1, "youngs_modulus"), 1e-300, "modulus"),
        (("hinge", 0, "stiffness"), [1e308, 1e6, 1e6], "stiffness"),
        (("hinge", 0, "rotational_stiffness"), [1e-300, 1e5, 1e5], "rotational_stiffness"),
    ],
)
def test_absurd_magnitudes_are_refused_with_the_documented_band(where, value, limit):
    data = json.loads(json.dumps(TWO_BODIES))
    kind, index, field = where
    data[kind][index][field] = value
    low, high, unit = LIMITS[limit]
    with pytest.raises(ModelError, match="outside the allowed range") as error:
        model_from_dict(data, "m.toml")
    message = str(error.value)
    assert f"{high:g}" in message and unit in message and "\n" not in message


def test_the_limits_admit_the_packaged_models():
    for name in ("ufmt.toml", "ufmt-prior.toml"):
        model = load_model(ufmt.packaged_path(name))
        assert set(model.design) >= {
            "head_radial_stiffness_N_m",
            "spindle_angular_stiffness_Nm_rad",
        }


_VALUES = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(2**70), 2**70),
    st.text(max_size=5),
    st.booleans(),
    st.lists(st.floats(), max_size=4),
    st.dictionaries(st.text(max_size=3), st.integers(), max_size=2),
)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**31 - 1), data=st.data())
def test_fuzzed_model_files_load_or_give_one_model_error(seed, data):
    """Any model with one field replaced by an arbitrary value loads, or raises ModelError
    with one line: never another exception."""
    from strategies import random_model  # here: the study subprocesses import this file

    model = random_model(seed, 3, 1, 1, special=True)
    element = data.draw(st.sampled_from(["body", "hinge"]))
    table = data.draw(st.sampled_from(model[element]))
    field = data.draw(st.sampled_from(sorted(table) + ["unknown_field"]))
    table[field] = data.draw(_VALUES)
    try:
        model_from_dict(model, "fuzz.toml")
    except ModelError as exc:
        assert "\n" not in str(exc) and str(exc).startswith("fuzz.toml: ")


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    key=st.sampled_from(["kind", "name", "base", "axis", "n", "range", "design", "model", "x"]),
    value=_VALUES,
)
def test_fuzzed_study_files_parse_or_give_one_study_error(tmp_path_factory, key, value):
    table = {"kind": "sweep", "axis": [{"parameter": "rpm", "range": [200.0, 400.0], "n": 3}]}
    if key in ("n", "range"):
        table["axis"][0][key] = value
    else:
        table[key] = value
    text = "\n".join(f"{k} = {toml_value(v)}" for k, v in table.items())  # inline tables
    try:
        parse_study(text, tmp_path_factory.mktemp("s") / "fuzz.toml")
    except StudyError as exc:
        assert "\n" not in str(exc) and "fuzz.toml" in str(exc)


def test_deeply_nested_toml_is_one_line(tmp_path):
    nested = "x = " + "[" * 3000 + "]" * 3000 + "\n"
    with pytest.raises(ModelError, match="nested too deeply"):
        load_model_text(nested, "deep.toml")
    with pytest.raises(StudyError, match="nested too deeply"):
        parse_study(nested, tmp_path / "deep.toml")


# ---------------------------------------------------------------------------------------------
# design declarations


def test_a_study_declares_its_own_design_parameter_with_did_you_mean(tmp_path):
    body = """
    kind = "sweep"
    [design.head_z_N_m]
    hinge = "h31"
    field = "stiffness"
    components = [2]
    [[axis]]
    parameter = "head_z_N_m"
    values = [1e8, 3e8]
    """
    out = _run(study_file(tmp_path, "declared", body, "declared_k"), tmp_path / "r")
    table = (out / "points.csv").read_text(encoding="utf-8").splitlines()
    assert [float(line.split(",")[3]) for line in table[1:]] == [1e8, 3e8]  # pv = set value
    typo = body.replace('field = "stiffness"', 'field = "stifness"')
    with pytest.raises(StudyError, match="did you mean 'stiffness'"):
        parse_study(textwrap.dedent(typo), tmp_path / "typo.toml")
    bad = body.replace("components = [2]", "components = [2, 3]")
    with pytest.raises(StudyError, match=r"components\[1\]'.*not 0, 1 or 2"):
        parse_study(textwrap.dedent(bad), tmp_path / "bad.toml")


def test_design_declarations_survive_the_model_writer():
    """The calibration writes ufmt.toml from the prior with model_to_toml: the [design] table
    must come through unchanged."""
    prior = load_model(ufmt.packaged_path("ufmt-prior.toml"))
    again = load_model_text(model_to_toml(prior), "again.toml")
    assert again.design == prior.design == load_model().design
    assert again.design["head_angular_stiffness_Nm_rad"].components == (0, 1)


# ---------------------------------------------------------------------------------------------
# exit statuses, plots of an all-failed study


def test_failed_points_exit_1_with_a_summary_and_no_plot_traceback(tmp_path):
    body = (
        'kind = "grid"\n[[axis]]\nparameter = "rpm"\nvalues = [200.0, 300.0]\n'
        '[[axis]]\nparameter = "depth_um"\nvalues = [2.0, 4.0]\n'
    )
    result = cli(
        "run", study_file(tmp_path, "fails", body, "always_fails"), "--results", tmp_path / "r"
    )
    assert result.returncode == 1 and "Traceback" not in result.stderr
    assert "4 of 4 points failed" in result.stderr
    assert "grid: no successful points" in result.stdout and "grid grid" not in result.stdout


# ---------------------------------------------------------------------------------------------
# results folder: lock, keyed by study, validated rows, content fingerprint


def test_a_second_run_into_locked_results_refuses_with_one_line(tmp_path):
    study = study_file(tmp_path, "locked", RPM_SWEEP.format(n=3))
    with locked(tmp_path / "r" / "locked"):
        with pytest.raises(StudyError, match="another ufmt run .* is writing these results"):
            run_study(study, Execution(jobs=1), results=tmp_path / "r", progress=False)
    _run(study, tmp_path / "r")


@pytest.mark.slow
def test_concurrent_starts_never_interleave(tmp_path):
    study = study_file(tmp_path, "both", RPM_SWEEP.format(n=12), "slow_line_pv")
    reference = _reference(tmp_path, "both", RPM_SWEEP.format(n=12))
    args = [*PY, "run", str(study), "--jobs", "1", "--results", str(tmp_path / "r"), "--no-plots"]
    procs = [subprocess.Popen(args, cwd=REPO, stderr=subprocess.PIPE, text=True) for _ in "ab"]
    statuses = sorted(p.wait(timeout=300) for p in procs)
    assert statuses in ([0, 0], [0, 2])
    assert (tmp_path / "r" / "both" / "points.csv").read_bytes() == reference


def _reference(tmp_path: Path, name: str, body: str) -> bytes:
    """points.csv of an uninterrupted run of the fast twin (line_pv)."""
    twin = tmp_path / "reference"
    twin.mkdir(exist_ok=True)
    out = _run(study_file(twin, name, body), twin / "r")
    return (out / "points.csv").read_bytes()


def test_two_study_files_with_one_name_cannot_share_results(tmp_path):
    first = study_file(tmp_path, "a", 'name = "same"\n' + RPM_SWEEP.format(n=3))
    second = study_file(tmp_path, "b", 'name = "same"\n' + RPM_SWEEP.format(n=4))
    _run(first, tmp_path / "r")
    with pytest.raises(StudyError, match=r"another study file with the name 'same' \(a.toml\)"):
        run_study(second, Execution(jobs=1), results=tmp_path / "r", progress=False)


@pytest.mark.parametrize(
    "corrupt",
    [
        b"rpm,3,300.0,30.0,ok,,extra\n",  # a field too many
        b"rpm,3,300.0,3\xff\xfe,ok,\n",  # not UTF-8
        b"rpm,3,300.0,thirty,ok,\n",  # a number that does not parse
        b"rpm,3,300.0\n",  # truncated, yet ending in a newline
        b"rpm,3,300.0,30.0,o",  # cut mid-write
    ],
)
def test_corrupt_rows_are_recomputed_to_the_same_table(tmp_path, corrupt):
    body = RPM_SWEEP.format(n=5)
    reference = _reference(tmp_path, "rows", body)
    study = study_file(tmp_path, "rows", body)
    out = _run(study, tmp_path / "r")
    lines = reference.splitlines(keepends=True)
    (out / "points.csv").write_bytes(b"".join(lines[:4]) + corrupt)
    out = _run(study, tmp_path / "r")
    assert (out / "points.csv").read_bytes() == reference
    run = read_meta(out)["run"]
    assert run["points_reused"] == 3 and run["points_new"] == 2


def test_comments_and_another_clone_keep_the_rows(tmp_path):
    clone_a, clone_b = tmp_path / "a", tmp_path / "b"
    for clone in (clone_a, clone_b):
        (clone / "studies").mkdir(parents=True)
        (clone / "model.toml").write_bytes(ufmt.packaged_path().read_bytes())
    body = 'model = "../model.toml"\n' + RPM_SWEEP.format(n=3)
    study_a = study_file(clone_a / "studies", "s", body)
    first = read_meta(_run(study_a, clone_a / "r"))["run"]
    # the same study in another place, with comments added to the study and the model file
    study_b = study_file(clone_b / "studies", "s", "# a comment\n" + body + "# another\n")
    with (clone_b / "model.toml").open("a", encoding="utf-8") as f:
        f.write("\n# a comment on the model\n")
    (clone_b / "r").mkdir()
    os.replace(clone_a / "r" / "s", clone_b / "r" / "s")  # committed results, new clone
    out = _run(study_b, clone_b / "r")
    # every row reused: the record stays that of the run that computed them
    assert read_meta(out)["run"] == first and first["points_new"] == 3
    assert load_study(study_a).content_sha256 != ""


# ---------------------------------------------------------------------------------------------
# the cache: unusable directories, planted and tampered entries


@pytest.mark.parametrize("kind", ["file", "others-writable"])
def test_an_unusable_cache_is_one_warning_and_the_run_goes_on(tmp_path, monkeypatch, kind):
    where = tmp_path / "bad-cache"
    if kind == "file":
        where.write_text("not a directory")
    else:
        where.mkdir()
        where.chmod(0o777)
    monkeypatch.setenv("UFMT_CACHE_DIR", str(where))
    evaluate_cache._usable.cache_clear()
    with pytest.warns(evaluate_cache.CacheWarning, match="running without the evaluation cache"):
        assert evaluate_cache.directory() is None
    study = study_file(tmp_path, "nocache", RPM_SWEEP.format(n=3))
    args = ("--results", tmp_path / "r", "--no-plots", "--no-progress", "--jobs", "1")
    result = cli("run", study, *args)
    assert result.returncode == 0, result.stderr
    warnings_ = result.stderr.splitlines()
    assert len(warnings_) == 1 and warnings_[0].startswith("warning: cache directory")


def test_the_cache_never_executes_code_and_ignores_tampered_entries(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    monkeypatch.setenv("UFMT_CACHE_DIR", str(cache))
    evaluate_cache._usable.cache_clear()
    key = {"case": 1}
    names = ("pv_nm", "f1_hz")
    evaluate_cache.store(key, {"pv_nm": 12.5, "f1_hz": math.nan, "message": ""})
    loaded = evaluate_cache.load(key, names)
    assert loaded["pv_nm"] == 12.5 and math.isnan(loaded["f1_hz"])
    entry = next(cache.glob("*/*.json"))

    class Planted:
        def __reduce__(self):
            return (Path(tmp_path / "pwned").write_text, ("ran",))

    entry.write_bytes(pickle.dumps(Planted()))  # a pickle planted where an entry was
    assert evaluate_cache.load(key, names) is None and not (tmp_path / "pwned").exists()
    record = json.loads(json.dumps({"format": 1, "key": {"case": 2}, "outputs": {}}))
    entry.write_text(json.dumps(record))  # an entry of another key
    assert evaluate_cache.load(key, names) is None
    entry.write_text('{"format": 1, "key": {"case": 1}, "outputs": {"pv_nm": "x", "f1_hz": 1}}')
    assert evaluate_cache.load(key, names) is None  # wrong types and fields


# ---------------------------------------------------------------------------------------------
# interruption, strict JSON, progress totals


@pytest.mark.slow
def test_sigterm_stops_the_workers_and_leaves_meta_interrupted(tmp_path):
    from synthetic import child_pids, still_running  # the study subprocesses import this file

    body = RPM_SWEEP.format(n=40)
    study = study_file(tmp_path, "term", body, "slow_line_pv")
    results = tmp_path / "r"
    args = [*PY, "run", str(study), "--jobs", "2", "--results", str(results), "--no-progress"]
    proc = subprocess.Popen(args, cwd=REPO, stderr=subprocess.PIPE, text=True)
    log = results / "term" / "points.csv"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not (log.exists() and log.read_bytes().count(b"\n") > 4):
        time.sleep(0.05)
    children = child_pids(proc.pid)
    assert children, "no worker processes"
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=60) == 130
    assert "interrupted" in proc.stderr.read()
    assert read_meta(results / "term")["status"] == "interrupted"
    assert still_running(children, 20.0) == []
    out = _run(study, results, jobs=2)
    assert (out / "points.csv").read_bytes() == _reference(tmp_path, "term", body)


def _sigterm_once_rows_exist(folder: Path, timeout: float = 60.0) -> None:
    """SIGTERM to this process as soon as the study in ``folder`` has written its first chunk
    of rows (the runner writes a chunk at a time, so a fixed delay may fall before it; the
    table's header alone does not count)."""
    end = time.monotonic() + timeout
    while _rows_written(folder / "points.csv") < 1 and time.monotonic() < end:
        time.sleep(0.01)
    os.kill(os.getpid(), signal.SIGTERM)


def _rows_written(table: Path) -> int:
    """Data rows in ``table`` so far (the header may be written before any row)."""
    try:
        return max(table.read_bytes().count(b"\n") - 1, 0)
    except FileNotFoundError:
        return 0


def test_sigterm_in_process_interrupts_and_a_rerun_resumes(tmp_path):
    """Small version of the test above: SIGTERM to this process mid-study."""
    body = RPM_SWEEP.format(n=12)
    study = study_file(tmp_path, "term", body, "slow_line_pv")
    results = tmp_path / "r"
    timer = threading.Thread(target=_sigterm_once_rows_exist, args=(results / "term",))
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        _run(study, results)
    timer.join()
    assert read_meta(results / "term")["status"] == "interrupted"
    assert signal.getsignal(signal.SIGTERM) == signal.SIG_DFL  # the handler is restored
    saved = (results / "term" / "points.csv").read_bytes().count(b"\n") - 1
    assert 1 <= saved < 12
    out = _run(study, results)
    assert read_meta(out)["run"]["points_reused"] == saved
    assert (out / "points.csv").read_bytes() == _reference(tmp_path, "term", body)


def test_meta_json_is_strict_json(tmp_path):
    text = dumps_strict({"a": math.nan, "b": [math.inf, 1.5], "c": {"d": -math.inf}})
    assert json.loads(text, parse_constant=_refuse) == {
        "a": None,
        "b": [None, 1.5],
        "c": {"d": None},
    }
    body = RPM_SWEEP.format(n=3)
    out = _run(study_file(tmp_path, "strict", body, "always_fails"), tmp_path / "r")
    json.loads((out / "meta.json").read_text(encoding="utf-8"), parse_constant=_refuse)


def _refuse(name):
    raise ValueError(f"non-standard JSON constant {name}")


def test_progress_totals_are_fixed_in_advance(tmp_path):
    sweep = parse_study(
        RPM_SWEEP.format(n=7) + "[[grid]]\nname = 'g'\n[[grid.axis]]\n"
        "parameter = 'feed_mm_min'\nvalues = [4.0, 8.0]\n[[grid.axis]]\n"
        "parameter = 'depth_um'\nvalues = [2.0, 4.0, 6.0]\n",
        tmp_path / "p.toml",
    )
    assert KINDS[sweep.kind].planned_points(sweep) == 7 + 2 * 3
    body = """
    kind = "optimise-process"
    [optimiser]
    popsize = 2
    maxiter = 2
    refine_steps = 1
    """
    study = study_file(tmp_path, "opt", body, "line_pv")
    out = _run(study, tmp_path / "r")
    requested = read_meta(out)["run"]
    parsed = load_study(study)
    budget = KINDS[parsed.kind].planned_points(parsed)
    assert requested["points_new"] + requested["points_reused"] <= budget


def test_a_first_run_reuses_nothing_and_its_bar_total_never_moves(tmp_path, capsys):
    """Oracle: counting. A first run has no earlier rows, so every requested row is new
    (new == total, reused == 0), though its optimiser requests some points twice; a rerun
    computes nothing (meta.json unchanged); every total the bar prints is the kind's budget,
    fixed before the first point."""
    body = """
    kind = "optimise-process"
    [optimiser]
    popsize = 2
    maxiter = 2
    refine_steps = 2
    """
    study = study_file(tmp_path, "opt", body, "line_pv")
    parsed = load_study(study)
    budget = KINDS[parsed.kind].planned_points(parsed)
    out = run_study(study, Execution(jobs=1), results=tmp_path / "r", progress=True, plots=False)
    first = read_meta(out)["run"]
    assert first["points_reused"] == 0
    assert first["points_new"] == first["points_total"] > 0
    totals = set(re.findall(r"\d+/(\d+) \[", capsys.readouterr().err))
    assert totals == {str(budget)}
    before = (out / "meta.json").read_bytes()
    _run(study, tmp_path / "r")  # computes nothing, so it keeps the first run's record
    assert (out / "meta.json").read_bytes() == before


# ---------------------------------------------------------------------------------------------
# one-line errors of the CLI


@pytest.mark.parametrize(
    "args",
    [
        ["modes", "--fmax", "1e5"],
        ["simulate", "--zeta", "1e9"],
        ["frf", "--points", "1000000000"],
        ["run", "studies/sweep-stiffness.toml", "--backend", "dask", "--scheduler", "garbage"],
        ["run", "studies/sweep-stiffness.toml", "--backend", "dask", "--scheduler", "127.0.0.1"],
        ["run", "studies/sweep-stiffness.toml", "--backend", "dask", "--scheduler", "http://h:1"],
        ["run", "studies/sweep-stiffness.toml", "--results", "README.md"],
    ],
)
def test_listed_tracebacks_are_one_line_with_exit_2(args):
    one_line_error(cli(*args))


@pytest.mark.parametrize(
    ("axes", "problem"),
    [
        (
            '[[axis]]\nparameter = "rpm"\nrange = [200.0, 400.0]\nn = 36339061537\n',
            "axis 'rpm': field 'n': 36339061537 is outside the allowed range [1, 100000]",
        ),
        (
            '[[grid]]\nname = "g"\n[[grid.axis]]\nparameter = "rpm"\nrange = [200.0, 400.0]\n'
            'n = 1000\n[[grid.axis]]\nparameter = "feed_mm_min"\nrange = [4.0, 16.0]\nn = 1000\n',
            "grid 'g': field 'axis': 1,000,000 points is more than the allowed 100,000",
        ),
    ],
)
def test_a_study_larger_than_the_point_limit_is_one_line_before_any_allocation(
    tmp_path, axes, problem
):
    """A typo like n = 36339061537 once allocated 271 GiB (found by the fuzz test above)."""
    path = tmp_path / "big.toml"
    with pytest.raises(StudyError) as info:
        parse_study(f'kind = "sweep"\n{axes}', path)
    assert str(info.value) == f"{path}: {problem}"
