"""Modal-test files, the MAC and the pairing of model and test modes (ufmt validate --test)."""

import json
from pathlib import Path

import numpy as np
import pytest

import ufmt
from ufmt.calibration.correlation import assembled_test, correlate, mac_matrix, pair_modes
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
    assert index.tolist() == [0, 2, 1] and how == ["MAC"] * 3
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
    assert {"max_abs_error_percent", "mean_abs_error_percent", "pairs"} <= set(out)
    assert len(out["pairs"]) == read_modal_test(test).modes.size
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
