"""Modal-test files, the MAC and the pairing of model and test modes (ufmt validate --test)."""

import json
from pathlib import Path

import numpy as np
import pytest

import ufmt
from ufmt.calibration.correlation import (
    FREQUENCY_WINDOW,
    assembled_test,
    correlate,
    mac_matrix,
    pair_modes,
)
from ufmt.calibration.frequencies import read_reference
from ufmt.calibration.modal_test import Sensor, modal_test, read_modal_test
from ufmt.cli import main
from ufmt.errors import StudyError

ROOT = Path(__file__).resolve().parents[1]
BRIDGE = ROOT / "examples" / "bridge.toml"
SENSORS = [
    Sensor(body, point, d)
    for body, point in (
        ("head", (0.15, 0.0, 0.93)),
        ("bridge", (0.5, 0.2, 1.6)),
        ("table", (0.0, 0.05, 0.8)),
        ("shaft", (0.0, 0.0, 1.0)),  # a beam end: a node of the assembled mesh
    )
    for d in "xyz"
]


def test_mstmm_shapes_at_sensors_match_the_assembled_model():
    """Oracle: the independent assembled model. Its first 8 modes at rigid-body points and a
    beam end, taken as a test, pair one to one with the MSTMM's, MAC 1 and equal frequency."""
    model = ufmt.load_model(BRIDGE)
    result = correlate(model, assembled_test(model, SENSORS, count=8))
    table = result.table
    assert list(table["model_mode"]) == list(range(1, 9))
    assert (table["mac"] > 1 - 1e-6).all()
    assert result.summary()["max_abs_error_percent"] < 1e-3


def test_mac_is_blind_to_scale_and_sign_and_skips_unmeasured_components():
    rng = np.random.default_rng(1)
    model = rng.standard_normal((4, 6))
    test = -3.0 * model[[2, 0]]  # proportional to model modes 3 and 1
    mac = mac_matrix(test, model)
    assert mac[0, 2] == pytest.approx(1.0) and mac[1, 0] == pytest.approx(1.0)
    partial = test.copy()
    partial[0, :2] = np.nan  # only components 2..5 measured: the MAC over those
    sub = mac_matrix(partial[:1, 2:], model[:, 2:])
    np.testing.assert_allclose(mac_matrix(partial, model)[:1], sub)
    orthogonal = np.array([[1.0, 0, 0], [0, 1.0, 0]])
    np.testing.assert_allclose(mac_matrix(orthogonal, orthogonal), np.eye(2), atol=1e-15)


def test_pairing_follows_the_shapes_when_modes_swap_and_the_order_without_shapes():
    """Property: a test whose modes 2 and 3 are the model's 3 and 2 pairs crosswise by MAC;
    the frequency-only test pairs by order."""
    model = np.eye(4)
    test = modal_test([1, 2, 3], [10.0, 20.0, 30.0], sensors=SENSORS[:4], shapes=model[[0, 2, 1]])
    index, how = pair_modes(test, mac_matrix(test.shapes, model), 4)
    assert index.tolist() == [0, 2, 1] and how == ["mac"] * 3
    plain = modal_test([1, 3], [10.0, 30.0])
    index, how = pair_modes(plain, np.full((2, 4), np.nan), 4)
    assert index.tolist() == [0, 2] and how == ["order", "order"]


def test_file_round_trip(tmp_path):
    test = modal_test([2, 1], [20.0, 10.0], [0.01, np.nan], SENSORS[:2], [[1.0, np.nan], [0.5, 2]])
    back = read_modal_test(test.save(tmp_path / "t.csv"))
    assert back.modes.tolist() == [1, 2] and back.sensors == test.sensors[:2]
    np.testing.assert_array_equal(back.shapes, [[0.5, 2.0], [1.0, np.nan]])
    np.testing.assert_array_equal(back.damping_ratio, [np.nan, 0.01])


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("mode,freq\n1,2\n", "unknown field 'freq'"),
        ("mode,frequency_hz\n1,-2\n", "row 2: field 'frequency_hz': -2 is not positive"),
        ("mode,frequency_hz,body\n1,2,head\n", "field 'x_m': missing"),
        ("mode,frequency_hz\n1,2\n1,3\n", "row 3: field 'frequency_hz': 3 differs"),
        (
            "mode,frequency_hz,body,x_m,y_m,z_m,direction,shape\n1,2,head,0,0,0,rx,1\n",
            "row 2: field 'direction': unknown direction 'rx'",
        ),
        ("mode,frequency_hz,damping_ratio\n1,2,5\n", "field 'damping_ratio': 5 is outside"),
    ],
)
def test_file_mistakes_are_one_line(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(StudyError) as err:
        read_modal_test(path)
    assert str(err.value).startswith(str(path)) and message in str(err.value)
    assert "\n" not in str(err.value)


def test_table3_file_is_the_reference_data():
    """Oracle: paper_reference.toml (Table 3's modal-test column), mode numbers as printed."""
    test = read_modal_test(ufmt.packaged_path("table3-modal-test.csv"))
    column = read_reference(ufmt.packaged_path("paper_reference.toml")).column("modal_test_hz")
    assert dict(zip(test.modes.tolist(), test.frequencies_hz.tolist(), strict=True)) == column


def test_validate_test_cli_writes_the_users_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    test = ROOT / "examples" / "bridge-modal-test.csv"
    assert main(["validate", str(BRIDGE), "--test", str(test), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert {"paired", "max_abs_error_percent", "mean_abs_error_percent", "min_mac"} <= set(out)
    assert len(out["pairs"]) == read_modal_test(test).modes.size
    keys = {"test_mode", "model_mode", "paired_by", "mac", "error_percent"}
    assert all(keys <= set(pair) and pair["paired_by"] == "mac" for pair in out["pairs"])
    folder = tmp_path / "results" / "bridge" / "validation"
    assert {p.name for p in folder.iterdir()} == {"correlation.csv", "mac.csv", "mac.png"}


def test_validate_without_a_test_on_a_users_model_is_one_line(capsys):
    assert main(["validate", str(BRIDGE), "--output-dir", "/nonexistent/v"]) == 2
    err = capsys.readouterr().err.strip()
    assert "--test FILE" in err and "\n" not in err


def test_table3_tags_of_bodies_a_model_lacks_are_mismatches_not_a_crash():
    """The API's Table 3 validation of a user's model: tags naming absent bodies say so."""
    from ufmt.calibration.frequencies import modeset_from_mstmm, validation_table

    model = ufmt.load_model(BRIDGE)
    reference = read_reference(ufmt.packaged_path("paper_reference.toml"))
    solution = ufmt.solve_modes(model, count=3)
    modes = modeset_from_mstmm(model, solution.shapes)
    table = validation_table(model, reference, modes, solution.frequencies_hz)
    assert set(table["tag_check"]) == {"bodies"}
    assert table["tag_detail"].str.contains("not in the model").all()


def test_unreadable_test_files_are_one_line(tmp_path):
    with pytest.raises(StudyError, match="nothere.csv: file not found"):
        read_modal_test(tmp_path / "nothere.csv")
    (tmp_path / "empty.csv").write_text("")
    with pytest.raises(StudyError, match="empty.csv: not a readable CSV file"):
        read_modal_test(tmp_path / "empty.csv")
    with pytest.raises(StudyError, match="t.uff: file not found"):
        read_modal_test(tmp_path / "t.uff")


def test_a_model_mode_the_sensors_cannot_see_keeps_mac_pairing():
    """Property: a model mode with no motion at the sensors (a NaN MAC column) is MAC 0 there;
    the crossed test modes still pair by MAC (not by order)."""
    model = np.array([[1.0, 0, 0, 0], [0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 1.0, 0]])
    test = modal_test([1, 2, 3], [10.0, 20.0, 30.0], sensors=SENSORS[:4], shapes=model[[0, 3, 2]])
    mac = mac_matrix(test.shapes, model)
    assert np.isnan(mac[:, 1]).all()
    index, how = pair_modes(test, mac, 4)
    assert index.tolist() == [0, 3, 2] and how == ["mac"] * 3


def test_candidates_lie_in_the_tests_frequency_window():
    """Oracle: the window definition. A test numbered from 2000 pairs by MAC with the model's
    first modes, and no candidate lies above 2 x the highest test frequency; a frequency-only
    mode numbered 2000 has no candidate of that number and stays unpaired."""
    model = ufmt.load_model(BRIDGE)
    test = assembled_test(model, SENSORS, count=6)
    renumbered = modal_test(test.modes + 1999, test.frequencies_hz, None, SENSORS, test.shapes)
    result = correlate(model, renumbered)
    assert list(result.table["model_mode"]) == list(range(1, 7))
    assert set(result.table["paired_by"]) == {"mac"}
    assert result.model_hz.max() <= FREQUENCY_WINDOW * test.frequencies_hz.max()
    plain = correlate(model, modal_test([2000], [test.frequencies_hz[0]]))
    assert plain.table["model_mode"].isna().all() and plain.summary()["paired"] == 0


def _scaled_test(tmp_path, factor, name="mm.csv"):
    """The bridge example's test with every position times ``factor``."""
    frame = read_modal_test(ROOT / "examples" / "bridge-modal-test.csv").to_frame()
    frame[["x_m", "y_m", "z_m"]] *= factor
    path = tmp_path / name
    frame.to_csv(path, index=False)
    return path


def test_a_unit_slip_is_one_line_with_a_hint_and_the_declared_unit_fixes_it(
    tmp_path, monkeypatch, capsys
):
    """The bridge's test with positions in mm: exit 2, one line naming the file and a sensor,
    "did you mean --test-unit mm"; declared, the result equals the metre file's
    (invariance under the unit)."""
    monkeypatch.chdir(tmp_path)
    mm = _scaled_test(tmp_path, 1000.0)
    assert main(["validate", str(BRIDGE), "--test", str(mm), "--json"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and str(mm) in err and "did you mean --test-unit mm" in err
    assert main(["validate", str(BRIDGE), "--test", str(mm), "--test-unit", "mm", "--json"]) == 0
    declared = json.loads(capsys.readouterr().out)
    metres = ROOT / "examples" / "bridge-modal-test.csv"
    assert main(["validate", str(BRIDGE), "--test", str(metres), "--json"]) == 0
    reference = json.loads(capsys.readouterr().out)
    for a, b in zip(declared["pairs"], reference["pairs"], strict=True):
        assert a["model_mode"] == b["model_mode"] and a["mac"] == pytest.approx(b["mac"])


@pytest.mark.parametrize(
    ("sensor", "message"),
    [
        (Sensor("head", (0.0, 0.0, 0.965 + 1e6), "z"), "outside the machine"),
        (Sensor("shaft", (1.0, 0.0, 1.2), "x"), "from the axis of beam 'shaft'"),
        (Sensor("head", (0.9, 0.0, 0.965), "x"), "from the centre of mass of 'head'"),
        (Sensor("shaft", (0.0, 0.0, 1.5), "x"), "along beam 'shaft'"),
        (Sensor("joint", (0.0, 0.0, 1.3), "x"), "virtual"),
    ],
)
def test_a_sensor_off_its_body_or_outside_the_machine_is_refused(sensor, message):
    """Each rule of ufmt.calibration.sensors: 1000 km away, 1 m off the shaft's axis (section
    radius 0.06 m), 0.9 m from the head (radius 0.22 m), past the shaft's end, on a virtual
    body."""
    model = ufmt.load_model(BRIDGE)
    test = modal_test([1], [100.0], None, [sensor, SENSORS[0]], [[1.0, 0.5]], "t.csv")
    with pytest.raises(StudyError) as err:
        correlate(model, test)
    assert str(err.value).startswith("t.csv: field 'sensor ") and message in str(err.value)
    assert "did you mean" not in str(err.value)


def test_validate_test_honours_modes(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    test = ROOT / "examples" / "bridge-modal-test.csv"
    out = tmp_path / "v"
    args = [
        "validate",
        str(BRIDGE),
        "--test",
        str(test),
        "--modes",
        "1,3",
        "--output-dir",
        str(out),
    ]
    assert main(args) == 0
    assert {"mode-1.png", "mode-3.png"} <= {p.name for p in out.iterdir()}
    assert "mode-2.png" not in {p.name for p in out.iterdir()}
