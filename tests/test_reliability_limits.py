"""Reliability at the edges: planted links, a full disk, tampered cache records, resource
limits, the surface model's validity domain and the last one-line errors.

Oracles: the bytes of files a planted link points to (unchanged), the exit-status contract
(0 / 1 / 2), the closed-form cut width 2 sqrt(2 r_n a_p - a_p^2), the documented physical
ranges of a record, and byte-identical tables against an uninterrupted run.
"""

from __future__ import annotations

import os

import pytest
from test_reliability import RPM_SWEEP, _run, study_file

from ufmt import evaluate_cache
from ufmt.errors import StudyError
from ufmt.studies.locking import locked


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
