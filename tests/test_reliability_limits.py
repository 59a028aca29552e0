"""Reliability at the edges: planted links, a full disk, tampered cache records, resource
limits, the surface model's validity domain and the last one-line errors.

Oracles: the bytes of files a planted link points to (unchanged), the exit-status contract
(0 / 1 / 2), the closed-form cut width 2 sqrt(2 r_n a_p - a_p^2), the documented physical
ranges of a record, and byte-identical tables against an uninterrupted run.
"""

from __future__ import annotations

import dataclasses
import errno
import json
import math
import os
import re
from pathlib import Path

import joblib
import numpy as np
import pytest
from test_files import full_disk_after, on_disk
from test_reliability import (
    CACHE_FULL,
    RPM_SWEEP,
    _reference,
    _run,
    cli,
    one_line_error,
    study_file,
)

import ufmt
from ufmt import evaluate_cache, files
from ufmt.cli import main
from ufmt.cli.environment import matplotlib_config_dir
from ufmt.defaults import DEFAULT_SPACING
from ufmt.errors import OutputError, ProcessError, RunFailed, StudyError
from ufmt.evaluate import physical
from ufmt.fingerprint import model_sha256
from ufmt.machining.process import Process
from ufmt.machining.validity import (
    OutsideDomainError,
    check_bodies,
    check_cut,
    check_surface,
    cut_width,
)
from ufmt.model.machine import machine_of
from ufmt.studies import outputs
from ufmt.studies.load import load_study, parse_study
from ufmt.studies.locking import locked
from ufmt.studies.outputs import read_meta, read_table
from ufmt.studies.parallel import Execution, within_cores
from ufmt.studies.runner import run_study
from ufmt.tomlfile import read_toml


@pytest.fixture(autouse=True)
def _own_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("UFMT_CACHE_DIR", str(tmp_path / "cache"))
    evaluate_cache._usable.cache_clear()


# ---------------------------------------------------------------------------------------------
# planted links


@pytest.mark.parametrize("name", [".lock", "points.csv", "meta.json"])
def test_a_planted_link_in_the_results_is_refused_and_its_target_untouched(tmp_path, name):
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    out = tmp_path / "r" / "linked"
    out.mkdir(parents=True)
    (out / name).symlink_to(victim)
    study = study_file(tmp_path, "linked", RPM_SWEEP.format(n=3))
    with pytest.raises(StudyError, match="symbolic link") as info:
        _run(study, tmp_path / "r")
    assert "\n" not in str(info.value)
    assert victim.read_text() == "precious\n"


def test_a_hard_linked_lock_is_refused_and_never_truncated(tmp_path):
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    out = tmp_path / "r" / "hard"
    out.mkdir(parents=True)
    os.link(victim, out / ".lock")
    with pytest.raises(StudyError, match="not a plain file"):
        with locked(out):
            pass
    assert victim.read_text() == "precious\n"


def test_a_results_directory_that_is_a_link_is_refused(tmp_path):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (tmp_path / "r").mkdir()
    (tmp_path / "r" / "s").symlink_to(elsewhere, target_is_directory=True)
    with pytest.raises(StudyError, match="symbolic link"):
        _run(study_file(tmp_path, "s", RPM_SWEEP.format(n=3)), tmp_path / "r")
    assert list(elsewhere.iterdir()) == []


def test_the_lock_keeps_its_content_length_and_names_the_holder(tmp_path):
    out = tmp_path / "r" / "s"
    with locked(out):
        assert int((out / ".lock").read_text()) == os.getpid()
    with locked(out):  # a second lock rewrites the pid in place
        assert int((out / ".lock").read_text()) == os.getpid()


def test_a_linked_cache_subdirectory_is_one_warning_and_receives_nothing(tmp_path):
    cache = tmp_path / "cache"
    key = {"case": 1}
    digest = evaluate_cache.key_digest(key)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    cache.mkdir()
    (cache / digest[:2]).symlink_to(elsewhere, target_is_directory=True)
    with pytest.warns(evaluate_cache.CacheWarning, match="symbolic link"):
        evaluate_cache.store(key, {"pv_nm": 1.0, "message": ""})
    assert list(elsewhere.iterdir()) == []
    evaluate_cache._broken.clear()


# ---------------------------------------------------------------------------------------------
# a full disk


def test_a_full_disk_mid_study_is_one_line_exit_1_and_the_resume_is_identical(
    tmp_path, monkeypatch, capsys
):
    body = RPM_SWEEP.format(n=8)
    reference = _reference(tmp_path, "full", body)
    study = study_file(tmp_path, "full", body)
    results = tmp_path / "r"
    # room for five writes (meta.json, the header, three rows): then every write fails
    full_disk_after_writes(monkeypatch, 5, results)
    args = ["--results", str(results), "--jobs", "1", "--no-plots", "--no-progress"]
    status = main(["run", str(study), *args])
    error = capsys.readouterr().err.strip()
    assert status == 1 and len(error.splitlines()) == 1, error
    assert "No space left on device" in error and "points.csv" in error
    out = results / "full"
    assert not [p.name for p in out.iterdir() if p.name.endswith(".tmp")]
    kept = (out / "points.csv").read_bytes().count(b"\n") - 1
    assert kept == 3
    monkeypatch.undo()  # room again
    monkeypatch.setenv("UFMT_CACHE_DIR", str(tmp_path / "cache"))
    out = _run(study, results)
    assert (out / "points.csv").read_bytes() == reference
    assert read_meta(out)["run"]["points_reused"] >= kept - 1


def full_disk_after_writes(monkeypatch, writes: int, where: Path) -> None:
    """Make every ``os.write`` to a file below ``where`` after the first ``writes`` raise
    ENOSPC."""
    real = os.write
    done = [0]

    def write(fd, data):
        if not on_disk(fd, where):
            return real(fd, data)
        done[0] += 1
        if done[0] > writes:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(fd, data)

    monkeypatch.setattr(os, "write", write)


def test_a_transient_write_failure_records_meta_failed_with_the_reason(tmp_path, monkeypatch):
    study = study_file(tmp_path, "once", RPM_SWEEP.format(n=4))
    results = tmp_path / "r"
    real = outputs.PointLog.append
    calls = []

    def append(self, row):
        calls.append(row)
        if len(calls) == 2:
            raise OutputError(errno.ENOSPC, f"cannot write {self.path}: No space left on device")
        real(self, row)

    monkeypatch.setattr(outputs.PointLog, "append", append)
    with pytest.raises(RunFailed, match="No space left on device.*rows are kept"):
        _run(study, results)
    meta = read_meta(results / "once")
    assert meta["status"] == "failed" and "No space left on device" in meta["reason"]


def test_a_full_disk_keeps_the_previous_report(tmp_path, monkeypatch, capsys):
    (tmp_path / "r").mkdir()
    report = tmp_path / "r" / "report.html"
    assert main(["report", "--results", str(tmp_path / "r")]) == 0
    good = report.read_bytes()
    capsys.readouterr()
    full_disk_after(monkeypatch, 1000, tmp_path)
    assert main(["report", "--results", str(tmp_path / "r")]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "report.html: No space left" in error
    assert report.read_bytes() == good
    assert sorted(p.name for p in report.parent.iterdir()) == ["report.html"]


def test_a_full_cache_is_one_warning_and_no_temporary_file(tmp_path, monkeypatch):
    full_disk_after(monkeypatch, 0, tmp_path)
    with pytest.warns(evaluate_cache.CacheWarning, match="No space left") as caught:
        evaluate_cache.store({"case": 1}, {"pv_nm": 1.0, "message": ""})
        evaluate_cache.store({"case": 2}, {"pv_nm": 2.0, "message": ""})
    assert len(caught) == 1
    assert not [p for p in (tmp_path / "cache").rglob("*") if p.is_file()]
    evaluate_cache._broken.clear()


def test_a_worker_cache_warning_is_reported_once_by_the_run(tmp_path):
    study = study_file(tmp_path, "warned", RPM_SWEEP.format(n=4), "cache_warning_pv")
    args = ("--results", tmp_path / "r", "--no-plots", "--no-progress", "--jobs", "1")
    result = cli("run", study, *args)
    assert result.returncode == 0, result.stderr
    assert result.stderr.strip().splitlines() == [f"warning: {CACHE_FULL}"]


# ---------------------------------------------------------------------------------------------
# the validity domain of the surface model


def test_the_cut_width_is_the_chord_of_the_nose_circle():
    """2 sqrt(2 r a - a^2) against the chord of a circle of radius r cut a below its lowest
    point, computed from Pythagoras: 2 sqrt(r^2 - (r - a)^2)."""
    for r, a in [(5e-3, 4e-6), (1e-3, 1e-9), (2e-3, 2e-3)]:
        assert cut_width(r, a) == pytest.approx(2 * math.sqrt(r**2 - (r - a) ** 2), rel=1e-6)


@pytest.mark.filterwarnings("ignore::ufmt.machining.process.ProcessRangeWarning")
def test_the_scallop_limit_sits_at_the_cut_width():
    machine = machine_of(ufmt.load_model())
    depth_um = 4.0
    width = cut_width(machine.nose_radius, depth_um * 1e-6)
    rpm = 300.0
    at_limit = width * 1e3 * rpm  # feed [mm/min] that makes feed/rev = width
    check_cut(Process(rpm, at_limit * (1 - 1e-9), depth_um), machine)
    with pytest.raises(OutsideDomainError, match="exceeds the width") as info:
        check_cut(Process(rpm, at_limit * (1 + 1e-6), depth_um), machine)
    assert f"{rpm:g} rpm" in str(info.value) and "\n" not in str(info.value)
    with pytest.raises(OutsideDomainError, match="exceeds the nose radius"):
        check_cut(Process(rpm, 1.0, machine.nose_radius * 1e6 * 1.01), machine)


@pytest.mark.parametrize(
    ("change", "phrase"),
    [
        ({"tool_body": "slider"}, "same body"),
        ({"workpiece_size": (0.0524, 1e-9)}, "fewer than 2 grid steps"),
        ({"workpiece_size": (1e6, 0.0524)}, "surface nodes"),
    ],
)
def test_impossible_machines_are_outside_the_domain(change, phrase):
    machine = dataclasses.replace(machine_of(ufmt.load_model()), **change)
    with pytest.raises(OutsideDomainError, match=phrase):
        check_bodies(machine)
        check_surface(machine, DEFAULT_SPACING, 5e-3)


@pytest.mark.parametrize(
    ("args", "phrase"),
    [
        (["--rpm", "20"], "exceeds the width"),
        (["--depth", "1e-12"], "exceeds the width"),
        (["--depth", "1e9"], "nose radius"),
        (["--rpm", "1e-9"], "exceeds the width"),
        (["--aperture-margin", "100"], "no clear aperture"),
        (["--psd2-patch", "1e6"], "does not fit"),
        (["--sources", ","], "names no source"),
    ],
)
def test_simulate_outside_the_domain_is_one_line_with_exit_2(args, phrase):
    line = one_line_error(cli("simulate", *args))
    assert phrase in line


@pytest.mark.filterwarnings("ignore::ufmt.machining.process.ProcessRangeWarning")
def test_evaluate_raises_outside_the_domain_and_refuses_non_numbers():
    with pytest.raises(OutsideDomainError, match="exceeds the width"):
        ufmt.evaluate({}, {"rpm": 20.0})
    for value in (None, "300", True):
        with pytest.raises(ProcessError, match="is not a number"):
            ufmt.evaluate({}, {"rpm": value})
        with pytest.raises(ProcessError, match="is not a number"):
            Process(value, 15.0, 4.0)


def test_a_study_records_points_outside_the_domain_as_invalid_and_goes_on(tmp_path):
    body = 'kind = "sweep"\n[[axis]]\nparameter = "rpm"\nvalues = [10.0, 20.0, 300.0, 400.0]\n'
    study = study_file(tmp_path, "domain", body, "domain_pv")
    args = ("--results", tmp_path / "r", "--no-plots", "--no-progress", "--jobs", "1")
    result = cli("run", study, *args)
    assert result.returncode == 0, result.stderr
    assert "2 of 4 points lie outside" in result.stderr
    table = read_table(tmp_path / "r" / "domain" / "points.csv")
    assert list(table["status"]) == ["invalid", "invalid", "ok", "ok"]
    assert table["message"][0].startswith("process: feed per revolution")
    run = read_meta(tmp_path / "r" / "domain")["run"]
    assert run["points_invalid"] == 2 and run["points_failed"] == 0
    assert "300" in result.stdout  # the sweep's best point is a valid one (lowest pv: 300 rpm)


def soft_model(tmp_path: Path, factor: float = 2e-5) -> Path:
    """The packaged model with every hinge stiffness times ``factor``: a machine whose tool
    vibrates by micrometres under the reference cut."""
    text = ufmt.packaged_path().read_text(encoding="utf-8")

    def scaled(match):
        values = ", ".join(repr(float(v) * factor) for v in match.group(2).split(","))
        return f"{match.group(1)}[{values}]"

    pattern = r"^((?:rotational_)?stiffness = )\[([^\]]*)\]"
    path = tmp_path / "soft.toml"
    path.write_text(re.sub(pattern, scaled, text, flags=re.M), encoding="utf-8")
    return path


@pytest.mark.filterwarnings("ignore::ufmt.machining.process.ProcessRangeWarning")
def test_the_contact_limit_sits_where_z_re_reaches_the_depth_of_cut():
    """Oracle: linearity. z_re is linear in the force scale, so one run at scale f1 with
    peak p1 places the limit at f* = f1 a_p / p1: a run at 0.9 f* has the peak 0.9 a_p (the
    linearity itself) and is inside the domain, one at 1.1 f* is refused naming both values."""
    model, process = ufmt.load_model(), Process(300.0, 15.0, 4.0)
    options = {"n_modes": 12, "spacing": 2e-3}
    f1 = 1.0
    p1 = float(np.abs(ufmt.simulate(model, process, force_scale=f1, **options).response.z_re).max())
    limit = f1 * process.depth_m / p1
    inside = ufmt.simulate(model, process, force_scale=0.9 * limit, **options)
    assert np.abs(inside.response.z_re).max() == pytest.approx(0.9 * process.depth_m, rel=1e-9)
    with pytest.raises(OutsideDomainError, match="z_re reaches 4400 nm") as info:
        ufmt.simulate(model, process, force_scale=1.1 * limit, **options)
    assert "depth of cut 4000 nm" in str(info.value) and "\n" not in str(info.value)


def test_simulate_on_a_soft_machine_whose_tool_leaves_the_cut_is_exit_2(tmp_path, capsys):
    model = soft_model(tmp_path)
    assert main(["simulate", str(model), "--feed", "45"]) == 2
    error = capsys.readouterr().err.strip()  # a warning (45 mm/min: outside Table 1) first
    last = error.splitlines()[-1]
    assert last.startswith("ufmt simulate: error: process: the relative vibration z_re reaches")
    assert "depth of cut 4000 nm" in last and "Traceback" not in error, error


@pytest.mark.filterwarnings("ignore::ufmt.machining.process.ProcessRangeWarning")
def test_a_study_records_a_cut_that_loses_contact_as_invalid(tmp_path):
    soft_model(tmp_path)
    study = tmp_path / "contact.toml"
    study.write_text(
        'model = "soft.toml"\nkind = "sweep"\n[[axis]]\nparameter = "feed_mm_min"\n'
        "values = [15.0, 45.0]\n",
        encoding="utf-8",
    )
    out = run_study(study, Execution(jobs=1), results=tmp_path / "r", progress=False, plots=False)
    table = read_table(out / "points.csv")
    assert list(table["status"]) == ["ok", "invalid"]
    assert "z_re reaches" in table["message"][1]


# ---------------------------------------------------------------------------------------------
# cache records checked before use


NAMES = ("pv_nm", "psd2_rms_nm", "f1_hz")


@pytest.mark.parametrize(
    ("outputs_", "used"),
    [
        ({"pv_nm": 12.5, "psd2_rms_nm": "nan", "f1_hz": 20.0}, True),  # PSD2 unresolved: NaN
        ({"pv_nm": -1.0, "psd2_rms_nm": 1.0, "f1_hz": 20.0}, False),  # a negative PV
        ({"pv_nm": 1.0, "psd2_rms_nm": 1.0, "f1_hz": -5.0}, False),  # a negative frequency
        ({"pv_nm": 1.0, "psd2_rms_nm": 1.0, "f1_hz": 0.0}, False),  # a zero frequency
        ({"pv_nm": "nan", "psd2_rms_nm": 1.0, "f1_hz": 20.0}, False),  # PV is always a number
        ({"pv_nm": "inf", "psd2_rms_nm": 1.0, "f1_hz": 20.0}, False),  # never infinite
    ],
)
def test_cache_records_outside_their_physical_ranges_are_not_used(outputs_, used):
    key = {"case": 1}
    record = {"format": 1, "key": key, "outputs": {**outputs_, "message": ""}}
    path = evaluate_cache._file(evaluate_cache.directory(), key)
    path.parent.mkdir(parents=True)
    path.write_text(json.dumps(record))
    loaded = evaluate_cache.load(key, NAMES, physical)
    assert (loaded is not None) == used


def test_a_non_strict_nan_literal_in_a_cache_record_is_not_used():
    key = {"case": 1}
    path = evaluate_cache._file(evaluate_cache.directory(), key)
    path.parent.mkdir(parents=True)
    text = '{"format": 1, "key": {"case": 1}, "outputs": {"pv_nm": NaN, "psd2_rms_nm": 1.0,'
    path.write_text(text + ' "f1_hz": 20.0, "message": ""}}')
    assert evaluate_cache.load(key, NAMES) is None


# ---------------------------------------------------------------------------------------------
# resume that keeps data


def test_a_new_description_keeps_the_rows(tmp_path):
    body = RPM_SWEEP.format(n=4)
    study = study_file(tmp_path, "desc", 'description = "first"\n' + body)
    out = _run(study, tmp_path / "r")
    rows, fingerprint = (out / "points.csv").read_bytes(), read_meta(out)["fingerprint"]
    study.write_text(study.read_text().replace('"first"', '"a better description"'))
    out = _run(study, tmp_path / "r")
    assert read_meta(out)["fingerprint"] == fingerprint  # the rows were reused, not set aside
    assert (out / "points.csv").read_bytes() == rows and not list(out.glob("points.*.csv"))
    assert read_meta(out)["description"] == "a better description"


def test_a_change_of_results_sets_the_old_table_aside(tmp_path):
    study = study_file(tmp_path, "aside", RPM_SWEEP.format(n=4))
    out = _run(study, tmp_path / "r")
    old_rows = (out / "points.csv").read_bytes()
    old_fingerprint = read_meta(out)["fingerprint"]
    study.write_text(study.read_text().replace("n = 4", "n = 3") + "[base]\ndepth_um = 3.0\n")
    out = _run(study, tmp_path / "r")
    assert (out / f"points.{old_fingerprint[:16]}.csv").read_bytes() == old_rows
    assert read_meta(out)["run"]["points_new"] == 3


def test_stale_plot_names_from_an_untrusted_meta_never_delete_outside(tmp_path):
    victim = tmp_path / "victim.png"
    victim.write_text("precious")
    study = study_file(tmp_path, "plots", RPM_SWEEP.format(n=3))
    out = _run(study, tmp_path / "r")
    meta = read_meta(out)
    meta.update(fingerprint="0" * 64, plots=["../../victim.png"])
    (out / "meta.json").write_text(json.dumps(meta))
    _run(study, tmp_path / "r")
    assert victim.read_text() == "precious"


# ---------------------------------------------------------------------------------------------
# resource limits


def test_jobs_beyond_the_cores_are_capped_with_one_warning(tmp_path):
    cores = joblib.cpu_count()
    with pytest.warns(UserWarning, match=f"only {cores} cores") as caught:
        capped = within_cores(Execution(jobs=100_000))
    assert capped.n_jobs == cores and len(caught) == 1
    assert within_cores(Execution(jobs=1)).n_jobs == 1
    remote = Execution(jobs=64, backend="dask", scheduler="tcp://10.0.0.5:8786")
    assert within_cores(remote) is remote  # a remote cluster's size is its own
    study = study_file(tmp_path, "many", RPM_SWEEP.format(n=3))
    with pytest.warns(UserWarning, match="cores are available"):
        out = run_study(study, Execution(jobs=10_000), results=tmp_path / "r", progress=False)
    assert read_meta(out)["run"]["jobs"] == cores


def test_an_oversized_study_file_is_one_line(tmp_path):
    path = study_file(tmp_path, "huge", RPM_SWEEP.format(n=3))
    with path.open("a", encoding="utf-8") as f:
        f.write(("# " + "x" * 1000 + "\n") * 5000)
    with pytest.raises(StudyError, match="a study file holds at most") as info:
        load_study(path)
    assert "huge.toml" in str(info.value)


def test_meta_json_holds_the_study_text_once(tmp_path):
    body = 'description = "a unique phrase"\n' + RPM_SWEEP.format(n=3)
    study = study_file(tmp_path, "once", body)
    out = _run(study, tmp_path / "r")
    text = (out / "meta.json").read_text(encoding="utf-8")
    assert text.count("range = [200.0, 400.0]") == 1


# ---------------------------------------------------------------------------------------------
# the last tracebacks: one line, exit 2


def test_a_deep_dotted_key_names_the_file(tmp_path):
    deep = "kind = 'sweep'\n" + ".".join(["a"] * 3000) + " = 1\n"
    with pytest.raises(StudyError, match="nested too deeply") as info:
        parse_study(deep, tmp_path / "deep.toml")
    assert "deep.toml" in str(info.value)


def test_a_utf8_byte_order_mark_is_accepted(tmp_path):
    packaged = ufmt.packaged_path()
    bom = tmp_path / "bom.toml"
    bom.write_bytes(b"\xef\xbb\xbf" + packaged.read_bytes())
    assert model_sha256(ufmt.load_model(bom)) == model_sha256(ufmt.load_model(packaged))
    study = study_file(tmp_path, "bomstudy", RPM_SWEEP.format(n=3))
    study.write_bytes(b"\xef\xbb\xbf" + study.read_bytes())
    assert load_study(study).kind == "sweep"
    assert read_toml(bom)["name"] == read_toml(packaged)["name"]


@pytest.mark.parametrize(
    "command",
    [
        ["simulate", "--save", "{file}"],
        ["simulate", "--plot", "{file}"],
        ["frf", "--output-dir", "{file}"],
        ["validate", "--output-dir", "{file}"],
        ["report", "--results", "{dir}", "--output", "{dir}"],
        ["report", "--results", "{dir}/missing"],
    ],
)
def test_outputs_in_the_way_are_one_line_with_exit_2(tmp_path, capsys, command):
    (tmp_path / "file").write_text("keep")
    (tmp_path / "dir").mkdir()
    args = [a.format(file=tmp_path / "file", dir=tmp_path / "dir") for a in command]
    assert main(args) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "Traceback" not in error, error
    assert (tmp_path / "file").read_text() == "keep"


def test_a_study_that_cannot_write_its_results_is_one_line_exit_2(tmp_path, monkeypatch, capsys):
    def refuse(path, data):
        raise PermissionError(errno.EACCES, os.strerror(errno.EACCES))

    monkeypatch.setattr(files, "_atomic_write", refuse)
    study = study_file(tmp_path, "ro", RPM_SWEEP.format(n=3))
    assert main(["run", str(study), "--results", str(tmp_path / "r"), "--no-progress"]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "meta.json: Permission denied" in error, error


@pytest.mark.parametrize(
    ("old", "new", "phrase"),
    [
        ("workpiece_size = [0.0524, 0.0524]", "workpiece_size = [0.0524, 1e-9]", "grid steps"),
        ('tool_body = "head"', 'tool_body = "slider"', "same body"),
        ('tool_body = "head"', 'tool_body = "spindle_joint"', "no mode shapes"),
    ],
)
def test_impossible_machines_in_a_model_file_are_one_line(tmp_path, capsys, old, new, phrase):
    text = ufmt.packaged_path().read_text(encoding="utf-8")
    assert old in text
    model = tmp_path / "m.toml"
    model.write_text(text.replace(old, new), encoding="utf-8")
    assert main(["simulate", str(model)]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and phrase in error, error


def test_plot_mode_into_a_directory_writes_the_named_file(tmp_path, capsys):
    assert main(["plot-mode", "1", "--output", str(tmp_path)]) == 0
    assert (tmp_path / "mode-1.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert str(tmp_path / "mode-1.png") in capsys.readouterr().out


def test_an_unwritable_matplotlib_config_dir_is_replaced_quietly(tmp_path, monkeypatch):
    blocker = tmp_path / "not-a-dir"
    blocker.write_text("")
    monkeypatch.delenv("MPLCONFIGDIR", raising=False)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(blocker))  # matplotlib/ cannot exist below it
    matplotlib_config_dir()
    private = Path(os.environ["MPLCONFIGDIR"])
    assert private.is_dir() and private.stat().st_uid == os.getuid()
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path))  # writable: left alone
    monkeypatch.delenv("MPLCONFIGDIR")
    matplotlib_config_dir()
    assert "MPLCONFIGDIR" not in os.environ


@pytest.mark.parametrize(
    "body",
    [
        'kind = "grid"\n'
        '[[axis]]\nparameter = "rpm"\nrange = [200.0, 400.0]\nn = 1000\n'
        '[[axis]]\nparameter = "feed_mm_min"\nrange = [4.0, 16.0]\nn = 1000\n',
        'kind = "sweep"\n'
        + "".join(
            f'[[grid]]\nname = "g{i}"\n'
            '[[grid.axis]]\nparameter = "rpm"\nrange = [200.0, 400.0]\nn = 100\n'
            '[[grid.axis]]\nparameter = "feed_mm_min"\nrange = [4.0, 16.0]\nn = 100\n'
            for i in range(20)
        ),
        'kind = "sweep"\n[[axis]]\nparameter = "rpm"\nvalues = ['
        + ", ".join(str(200.0 + i * 1e-3) for i in range(100_001))
        + "]\n",
    ],
    ids=["grid-kind", "twenty-grids", "values-list"],
)
def test_one_cap_on_the_total_points_of_a_study(tmp_path, body):
    """2,000 points of 20 grids or 10^6 of a grid kind: each group alone may be under the cap,
    the study is not (the count is the kind's planned points, made before any point list)."""
    with pytest.raises(StudyError, match="more than the allowed 100,000") as info:
        parse_study(body, tmp_path / "big.toml")
    assert "\n" not in str(info.value) and "big.toml" in str(info.value)
