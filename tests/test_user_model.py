"""A user's own model through the public API: paths or loaded models everywhere, the record of
evaluate, one mode numbering, lengths that cannot slip a unit, study values checked as simulate
checks them."""

import pickle
from pathlib import Path

import numpy as np
import pytest

import ufmt
from ufmt.errors import ModelError, UfmtError
from ufmt.model.load import load_model_text
from ufmt.studies.load import load_study
from ufmt.studies.ranges import process_warnings
from ufmt.studies.runner import default_results

ROOT = Path(__file__).resolve().parents[1]
BRIDGE = ROOT / "examples" / "bridge.toml"
TEXT = BRIDGE.read_text()


def test_a_path_works_wherever_a_model_does():
    """Property: each entry point gives the same answer for the path and the loaded model."""
    model = ufmt.load_model(BRIDGE)
    by_path = ufmt.solve_modes(str(BRIDGE), count=5)
    by_model = ufmt.solve_modes(model, count=5)
    np.testing.assert_array_equal(by_path.frequencies_hz, by_model.frequencies_hz)
    assert by_path.to_frame(BRIDGE).equals(by_model.to_frame(model))
    assert by_path.plot(model=BRIDGE) is not None


def test_modes_are_numbered_from_one_and_out_of_range_is_one_clear_error():
    solution = ufmt.solve_modes(BRIDGE, count=5)
    assert solution.plot(model=BRIDGE, mode=5) is not None
    for bad in (0, 6):
        with pytest.raises(UfmtError, match=f"mode {bad}: cannot draw it \\(1..5"):
            solution.plot(model=BRIDGE, mode=bad)
    from ufmt.plots.modes import plot_mode

    with pytest.raises(UfmtError, match="mode index 30: outside 0..4"):
        plot_mode(ufmt.load_model(BRIDGE), solution.shapes, 30)


def test_evaluate_returns_a_record_that_reads_as_the_dict_the_studies_keep():
    record = ufmt.evaluate({}, {"rpm": 300.0}, BRIDGE)
    plain = record.to_dict()
    assert type(plain) is dict and dict(record) == plain and record == plain
    assert record["status"] == record.status == "ok"
    assert list(record.to_frame().columns) == list(plain)
    again = pickle.loads(pickle.dumps(record))
    assert list(again) == list(record) and again.status == "ok"
    assert repr(record).startswith("EvaluationRecord(rpm=300") and "\n" not in repr(record)


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        (
            "tool_radius = 0.15 ",
            "tool_radius = 150 ",
            "'tool_radius': 150 m .* did you mean 0.15 m",
        ),
        ("tool_radius = 0.15 ", "tool_radius = 15 ", "'tool_radius': 15 m is larger than the mac"),
        (
            "workpiece_size = [0.10, 0.10]",
            "workpiece_size = [200, 200]",
            "field 'workpiece_size': 200 m .* did you mean 0.2 m",
        ),
        ("cutting_plane_z = 0.93 ", "cutting_plane_z = 5.0 ", "'cutting_plane_z': 5 m is 4.04 m"),
        ("cutting_plane_z = 0.93 ", "cutting_plane_z = 930 ", "did you mean 0.93 m \\(930 mm\\)"),
    ],
)
def test_a_length_in_the_wrong_unit_names_its_field_and_the_likely_unit(old, new, message):
    assert old in TEXT
    with pytest.raises(ModelError, match=message):
        load_model_text(TEXT.replace(old, new), "bridge.toml")


def test_the_shipped_models_pass_the_plausibility_bounds():
    for path in [None, BRIDGE, *sorted((ROOT / "tests" / "models").glob("good*.toml"))]:
        ufmt.load_model(path)


STUDY = """
kind = "sweep"
name = "slip"
model = "{model}"
[base]
rpm = 300.0
[[axis]]
parameter = "feed_mm_min"
values = [0.05, 8.0, 20.0]
"""


def test_study_process_values_get_simulates_range_warnings(tmp_path):
    """Oracle: the warnings ufmt.Process (what simulate checks) gives for the same values."""
    path = tmp_path / "slip.toml"
    path.write_text(STUDY.format(model=BRIDGE))
    study = load_study(path)
    found = process_warnings(study)
    expected = []
    for feed in (0.05, 20.0):
        with pytest.warns(ufmt.machining.process.ProcessRangeWarning) as caught:
            ufmt.Process(300.0, feed, 4.0)
        expected.append(f"{path}: {caught[0].message}")
    assert found == expected
    assert default_results(study) == Path("results") / "bridge"


def test_report_of_a_users_model_goes_to_its_own_folder(tmp_path, monkeypatch):
    from ufmt.cli import main

    monkeypatch.chdir(tmp_path)
    assert main(["report", str(BRIDGE)]) == 2  # nothing computed yet: no page of nothing
    (tmp_path / "results" / "bridge").mkdir(parents=True)  # e.g. made by `ufmt frf`
    assert main(["report", str(BRIDGE)]) == 0
    assert (tmp_path / "results" / "bridge" / "report.html").exists()
    assert not (tmp_path / "results" / "report.html").exists()
