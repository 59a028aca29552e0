"""evaluate_batch and the study runner's chunks against their oracle: ufmt.evaluate called
point by point (its modal basis from machining.modal.modal_basis, one design at a time).

The points are cut on a 20 mm plate (``machine.workpiece_size``) so that each costs a fraction
of a second; the modal basis, the part a batch solves differently, is the full one.
"""

from __future__ import annotations

import importlib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from records import same_record

import ufmt
from ufmt.design import FREQUENCIES, METRICS
from ufmt.errors import StudyError
from ufmt.recent import Recent
from ufmt.studies.outputs import read_table
from ufmt.studies.parallel import CHUNKS_PER_WORKER, MAX_CHUNK, Execution, chunk_size
from ufmt.studies.runner import run_study

evaluate_module = importlib.import_module("ufmt.evaluate")  # ufmt.evaluate is the function
BRIDGE = Path(__file__).resolve().parents[1] / "examples" / "bridge.toml"
SMALL_PLATE = {"machine.workpiece_size[0]": 0.02, "machine.workpiece_size[1]": 0.02}


def bridge_design(axial_scale: float) -> dict:
    return {"spindle_axial_stiffness_N_m": 3e8 * axial_scale, **SMALL_PLATE}


@pytest.fixture
def batch_solves(monkeypatch):
    """The models of every batch solve, in calls; a fresh memo of modal bases."""
    monkeypatch.setattr(evaluate_module, "_BASES", Recent(evaluate_module.BASIS_CACHE))
    calls = []
    real = evaluate_module.solve_modes_batch

    def counting(models, **kwargs):
        calls.append(list(models))
        return real(models, **kwargs)

    monkeypatch.setattr(evaluate_module, "solve_modes_batch", counting)
    return calls


def one_by_one(designs, processes, model, monkeypatch):
    """The oracle: evaluate point by point, without the disk cache or remembered bases."""
    monkeypatch.setenv("UFMT_CACHE_DIR", "")
    monkeypatch.setattr(evaluate_module, "_BASES", Recent(evaluate_module.BASIS_CACHE))
    return [ufmt.evaluate(d, p, model) for d, p in zip(designs, processes, strict=True)]


def test_batch_equals_one_by_one_with_cache_hits_misses_and_failures(
    tmp_path, monkeypatch, batch_solves
):
    monkeypatch.setenv("UFMT_CACHE_DIR", str(tmp_path / "cache"))
    known = bridge_design(0.5)
    reference = {"rpm": 300.0, "feed_mm_min": 15.0, "depth_um": 4.0}
    ufmt.evaluate(known, reference, BRIDGE)  # in the disk cache from now on
    designs = [bridge_design(s) for s in (1.0, 2.0, 1.0, 4.0)] + [known, bridge_design(3.0)]
    processes = [reference] * 6
    processes[2] = {"rpm": 250.0}  # a process change on the first design
    processes[5] = {"rpm": -5.0}  # not a cut: a recorded error, no basis
    evaluate_module._BASES.clear()
    batch = ufmt.evaluate_batch(designs, processes, BRIDGE)
    # one solve of the three new designs: the cached point and the failed one need none
    assert [len(models) for models in batch_solves] == [3]
    assert batch[4].status == "ok" and batch[5].status == "error"
    oracle = one_by_one(designs, processes, BRIDGE, monkeypatch)
    assert all(same_record(b, o) for b, o in zip(batch, oracle, strict=True))


def test_a_record_does_not_depend_on_its_batch_companions(monkeypatch, batch_solves):
    monkeypatch.setenv("UFMT_CACHE_DIR", "")
    a, b, c = (bridge_design(s) for s in (0.7, 1.3, 2.6))
    first = ufmt.evaluate_batch([a, b], {}, BRIDGE)
    evaluate_module._BASES.clear()
    second = ufmt.evaluate_batch([c, b, a], {}, BRIDGE)
    assert [len(models) for models in batch_solves] == [2, 3]
    assert same_record(first[0], second[2]) and same_record(first[1], second[1])


def test_batch_bases_on_the_packaged_model_are_modal_basis_exactly(monkeypatch, batch_solves):
    """The packaged model cuts with its slide moved (the carried bodies' centres are moved
    back): the bases a batch builds are those of modal_basis, array for array."""
    monkeypatch.setenv("UFMT_CACHE_DIR", "")
    used = []
    real = evaluate_module.simulate

    def recording(model, process, basis):
        used.append(basis)
        return real(model, process, basis=basis)

    monkeypatch.setattr(evaluate_module, "simulate", recording)
    designs = [{"head_angular_stiffness_Nm_rad": 1e5 * s, **SMALL_PLATE} for s in (1.0, 2.0)]
    batch = ufmt.evaluate_batch(designs, {})
    assert [len(models) for models in batch_solves] == [2]
    batched, used[:] = list(used), []
    oracle = one_by_one(designs, [{}, {}], None, monkeypatch)
    assert all(same_record(b, o) for b, o in zip(batch, oracle, strict=True))
    for mine, theirs in zip(batched, used, strict=True):
        assert mine.slide_y == theirs.slide_y != 0.0
        np.testing.assert_array_equal(mine.omega, theirs.omega)
        np.testing.assert_array_equal(mine.hinge_damping, theirs.hinge_damping)
        for name, shape in theirs.body_shapes.items():
            np.testing.assert_array_equal(mine.body_shapes[name], shape)
        for name, center in theirs.body_centers.items():
            np.testing.assert_array_equal(mine.body_centers[name], center)


def test_a_failing_or_warning_batch_solve_leaves_each_design_to_its_own(monkeypatch):
    monkeypatch.setenv("UFMT_CACHE_DIR", "")
    designs = [bridge_design(s) for s in (0.6, 1.6)]
    oracle = one_by_one(designs, [{}, {}], BRIDGE, monkeypatch)

    def failing(models, **kwargs):
        raise RuntimeError("one design of the batch has no roots")

    def warning(models, **kwargs):
        import warnings

        warnings.warn("a warning the batch cannot attribute to one design", stacklevel=1)
        return [ufmt.solve_modes(m, fmax_hz=kwargs["fmax_hz"]) for m in models]

    for stand_in in (failing, warning):
        monkeypatch.setattr(evaluate_module, "solve_modes_batch", stand_in)
        monkeypatch.setattr(evaluate_module, "_BASES", Recent(evaluate_module.BASIS_CACHE))
        batch = ufmt.evaluate_batch(designs, {}, BRIDGE)
        assert all(same_record(b, o) for b, o in zip(batch, oracle, strict=True))


def test_batch_raises_what_evaluate_raises_and_evaluate_each_keeps_it_per_point():
    good, bad = bridge_design(1.0), {"spindle_axial": 1e8}
    with pytest.raises(StudyError, match="spindle_axial"):
        ufmt.evaluate(bad, {}, BRIDGE)
    with pytest.raises(StudyError, match="spindle_axial"):
        ufmt.evaluate_batch([good, bad], {}, BRIDGE)
    with pytest.raises(StudyError, match="2 designs but 1 processes"):
        ufmt.evaluate_batch([good, good], [{}], BRIDGE)
    outcomes = evaluate_module.evaluate_each([bad, {"spindle_axial": 2e8}], {}, BRIDGE)
    assert all(isinstance(o, StudyError) for o in outcomes)


@pytest.mark.parametrize("jobs", [1, 2, 4])
def test_chunks_give_each_worker_several_and_stay_bounded(jobs):
    few = CHUNKS_PER_WORKER * jobs
    for points in (1, 5, 17, 64, 1000, 5000):
        size = chunk_size(points, jobs)
        chunks = -(-points // size)
        assert 1 <= size <= MAX_CHUNK
        if points >= few:
            assert chunks >= 2 * jobs  # every worker gets several chunks
        # the smallest size giving at most CHUNKS_PER_WORKER chunks a worker, unless capped
        assert size == MAX_CHUNK or chunks <= few
        assert size == 1 or size == MAX_CHUNK or -(-points // (size - 1)) > few


def test_a_study_of_evaluate_hands_its_worker_batches(tmp_path, monkeypatch, batch_solves):
    """jobs 1 runs the chunks in this process, where the batch solves can be counted; the
    table is the point-by-point oracle's, and --jobs 2's."""
    monkeypatch.setenv("UFMT_CACHE_DIR", "")
    values = [1.5e8 * (1.25**k) for k in range(8)]
    study = tmp_path / "batches.toml"
    study.write_text(
        f'kind = "sweep"\nname = "batches"\nmodel = "{BRIDGE}"\n[base]\n'
        + "".join(f'"{k}" = {v!r}\n' for k, v in SMALL_PLATE.items())
        + '[[axis]]\nparameter = "spindle_axial_stiffness_N_m"\n'
        + f"values = [{', '.join(map(repr, values))}]\n",
        encoding="utf-8",
    )
    out = run_study(study, Execution(jobs=1), results=tmp_path / "r", progress=False, plots=False)
    assert [len(models) for models in batch_solves] == [2, 2, 2, 2]  # chunk_size(8, 1) = 2
    table = pd.read_csv(out / "points.csv")
    table = table.set_index("spindle_axial_stiffness_N_m").loc[values]
    designs = [{"spindle_axial_stiffness_N_m": v, **SMALL_PLATE} for v in values]
    oracle = one_by_one(designs, [{}] * 8, BRIDGE, monkeypatch)
    assert (table["status"] == "ok").all()
    for name in (*METRICS, *FREQUENCIES):
        expected = [record[name] for record in oracle]
        np.testing.assert_array_equal(table[name].to_numpy(), expected, err_msg=name)
    # --jobs 2: one point per chunk (chunk_size(8, 2) = 1) in worker processes, the same table
    two = run_study(study, Execution(jobs=2), results=tmp_path / "r2", progress=False, plots=False)
    pd.testing.assert_frame_equal(read_table(two / "points.csv"), read_table(out / "points.csv"))
