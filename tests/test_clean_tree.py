"""A rerun that computes nothing new rewrites nothing: every file of a study's results (and the
results index) has the same bytes after a second run that reuses every point. The oracle is
the first run's own bytes."""

from __future__ import annotations

from pathlib import Path

from test_studies import SWEEP, run, write_study

from ufmt.studies.outputs import read_meta, settled_meta


def snapshot(root: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()
    }


def test_rerun_of_a_finished_study_leaves_every_file_byte_identical(tmp_path):
    study = write_study(tmp_path, "clean", SWEEP)
    results = tmp_path / "results"
    run(study, results)
    first = snapshot(results)
    assert {"README.md", "clean/meta.json", "clean/points.csv"} <= set(first)
    assert any(name.endswith(".png") for name in first)
    out = run(study, results)
    assert snapshot(results) == first
    assert read_meta(out)["run"]["points_new"] == 20  # the computing run's figures, kept


def test_a_run_that_computes_keeps_its_own_timings():
    previous = {"fingerprint": "a", "status": "complete", "run": {"points_new": 5}}
    computed = {"fingerprint": "a", "status": "complete", "run": {"points_new": 1}}
    assert settled_meta(computed, previous)["run"]["points_new"] == 1
    changed = {"fingerprint": "b", "status": "complete", "run": {"points_new": 0}}
    assert settled_meta(changed, previous)["run"]["points_new"] == 0
    reused = {"fingerprint": "a", "status": "complete", "run": {"points_new": 0}}
    assert settled_meta(reused, previous)["run"]["points_new"] == 5


def test_cli_says_when_a_rerun_reused_every_point(tmp_path, capsys):
    from ufmt.cli import main

    study = write_study(tmp_path, "said", SWEEP)
    command = ["run", str(study), "--results", str(tmp_path / "r"), "--jobs", "1", "--no-progress"]
    assert main(command) == 0
    assert "20 points (20 new, 0 reused, 0 failed)" in capsys.readouterr().out
    assert main(command) == 0
    assert "20 points, every one reused from the run of" in capsys.readouterr().out
