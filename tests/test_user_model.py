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


# ---------------------------------------------------------------------------------------------
# a model's own uncertain inputs ([[uncertain]])

#: the bridge without the uncertain inputs its example file declares
PLAIN = TEXT.split("\n[[uncertain]]")[0]
UNCERTAIN = """
[[uncertain]]
name = "machine.force_scale"
band = [0.8, 1.25]
distribution = "loguniform"
source = "assumed: the cutting coefficient of another tool, within 25 %"

[[uncertain]]
name = "hinge.air_bearing.stiffness[2]"
scale = [0.5, 2.0]
source = "assumed: an air bearing's axial stiffness known to a factor of two"

[[uncertain]]
name = "spindle_radial_stiffness_N_m"
scale = [0.8, 1.2]
distribution = "loguniform"
source = "assumed"
"""


def test_uncertain_tables_read_scale_against_the_files_own_value_and_write_back():
    """Oracles: a scale is the file's own value times the factors (the air bearing's axial
    4e8 N/m; a [design] name's value is the mean of its components, 2e8 N/m); writing the
    model and reading the text back gives the same inputs (the writer is the loader's
    inverse)."""
    from ufmt.model.write import model_to_toml

    model = load_model_text(PLAIN + UNCERTAIN, "bridge.toml")
    force, axial, radial = model.uncertain
    assert (force.low, force.high, force.log) == (0.8, 1.25, True)
    axial_k = model.hinge("air_bearing").stiffness[2]
    assert (axial.low, axial.high, axial.log) == (0.5 * axial_k, 2.0 * axial_k, False)
    radial_k = np.mean(model.hinge("air_bearing").stiffness[:2])
    assert (radial.low, radial.high) == pytest.approx((0.8 * radial_k, 1.2 * radial_k))
    assert load_model_text(model_to_toml(model)).uncertain == model.uncertain
    assert load_model_text(PLAIN).uncertain == ()


@pytest.mark.parametrize(
    ("entry", "field", "phrase"),
    [
        ('name = "hinge.h31.stiffness[0]"\nband = [1e8, 2e8]', "name", "no hinge 'h31'"),
        ('name = "machine.force_scal"\nband = [1, 2]', "name", "did you mean"),
        ('name = "rpm"\nband = [200, 400]', "name", "process parameter"),
        ('name = "machine.force_scale"\nband = [nan, 2]', "band[0]", "nan is not a number"),
        ('name = "machine.force_scale"\nband = [2, 1]', "band", "reversed bounds"),
        ('name = "machine.force_scale"\nband = [1, 1]', "band", "empty range"),
        ('name = "machine.force_scale"\nband = [0.1, 2]', "band", "outside the allowed range"),
        ('name = "hinge.air_bearing.stiffness[0]"\nband = [1e8, 1e16]', "band", "outside"),
        ('name = "machine.workpiece_size[0]"\nband = [0.05, 0.5]', "band", "tool circle"),
        ('name = "hinge.shaft_top.stiffness[0]"\nscale = [0.5, 2]', "scale", "meaningless"),
        ('name = "machine.force_scale"\nscale = [0.1, 2]', "scale", "outside the allowed range"),
        ('name = "machine.force_scale"\nband = [-1, 2]\ndistribution = "loguniform"', "band", ">"),
        (
            'name = "machine.force_scale"\nband = [1, 2]\ndistribution = "normal"',
            "distribution",
            "",
        ),
    ],
)
def test_uncertain_table_mistakes_are_one_line_naming_the_entry_and_field(entry, field, phrase):
    text = f'{PLAIN}\n[[uncertain]]\n{entry}\nsource = "test"\n'
    with pytest.raises(ModelError) as err:
        load_model_text(text, "bridge.toml")
    message = str(err.value)
    assert "\n" not in message and message.startswith("bridge.toml: uncertain '")
    assert f"field '{field}'" in message and phrase in message


@pytest.mark.parametrize(
    ("entry", "phrase"),
    [
        ('name = "machine.force_scale"\nband = [1, 2]', "field 'source': missing"),
        ('name = "machine.force_scale"\nband = [1, 2]\nscale = [1, 2]\nsource = "x"', "exactly"),
        ('name = "machine.force_scale"\nrange = [1, 2]\nsource = "x"', "unknown field 'range'"),
    ],
)
def test_uncertain_table_shape_mistakes_are_one_line(entry, phrase):
    with pytest.raises(ModelError) as err:
        load_model_text(f"{PLAIN}\n[[uncertain]]\n{entry}\n", "bridge.toml")
    assert "\n" not in str(err.value) and phrase in str(err.value)


def test_an_uncertain_input_given_twice_is_refused():
    entry = '\n[[uncertain]]\nname = "machine.force_scale"\nband = [1, 2]\nsource = "x"\n'
    with pytest.raises(ModelError, match="appears more than once"):
        load_model_text(PLAIN + entry + entry, "bridge.toml")
