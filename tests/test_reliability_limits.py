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

import pytest
from test_files import full_disk_after
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
from ufmt import evaluate_cache
from ufmt.cli import main
from ufmt.defaults import DEFAULT_SPACING
from ufmt.errors import OutputError, ProcessError, RunFailed, StudyError
from ufmt.evaluate import physical
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
from ufmt.studies.locking import locked
from ufmt.studies.outputs import read_meta, read_table


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
    full_disk_after_writes(monkeypatch, 5)
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


def full_disk_after_writes(monkeypatch, writes: int) -> None:
    """Make every ``os.write`` after the first ``writes`` raise ENOSPC."""
    real = os.write
    done = [0]

    def write(fd, data):
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
    full_disk_after(monkeypatch, 1000)
    assert main(["report", "--results", str(tmp_path / "r")]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "report.html: No space left" in error
    assert report.read_bytes() == good
    assert sorted(p.name for p in report.parent.iterdir()) == ["report.html"]


def test_a_full_cache_is_one_warning_and_no_temporary_file(tmp_path, monkeypatch):
    full_disk_after(monkeypatch, 0)
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
    study.write_text(study.read_text().replace('"first"', '"a better description"'))
    out = _run(study, tmp_path / "r")
    assert read_meta(out)["run"]["points_reused"] == 4
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
