"""Calibration of a user's model against its modal test (ufmt calibrate --prior --test)."""

import json
from pathlib import Path

import numpy as np
import pytest

import ufmt
from ufmt.calibration.correlation import assembled_test, correlate
from ufmt.calibration.modal_test import Sensor, modal_test, read_modal_test
from ufmt.calibration.model_update import (
    UpdateSettings,
    default_parameters,
    read_update_settings,
    update_model,
)
from ufmt.calibration.reduced import apply_parameters
from ufmt.cli import main
from ufmt.errors import StudyError

ROOT = Path(__file__).resolve().parents[1]
BRIDGE = ROOT / "examples" / "bridge.toml"
POINTS = [
    ("head", (0.15, 0.0, 0.93)),
    ("head", (0.0, 0.15, 0.93)),
    ("bridge", (0.5, 0.0, 2.0)),
    ("bridge", (0.0, 0.5, 2.0)),
    ("table", (0.05, 0.0, 0.8)),
    ("table", (0.0, 0.05, 0.8)),
]
TRUE_SCALES = [0.8, 1.0, 1.2, 1.0, 1.1, 0.9]  # one per default parameter of the bridge


def test_a_stiffness_perturbation_is_recovered_within_its_identifiability():
    """Oracle: the independent assembled model of the perturbed bridge gives the "measured"
    frequencies and shapes (12 modes, 18 sensors); the MSTMM fit recovers every factor this
    test identifies (relative deviation at 0.5 % frequency error < 5 %) to 0.1 %, and holds
    the one it does not (the table guide's tilt stiffness) at its prior: the data's rank is 5.
    The fit is optimal: its squared log residual is no larger than at the feasible point "every
    fitted factor at its truth, the held one at 1"."""
    model = ufmt.load_model(BRIDGE)
    parameters = default_parameters(model)
    truth = apply_parameters(model, parameters, np.log(TRUE_SCALES))
    sensors = [Sensor(b, p, d) for b, p in POINTS for d in "xyz"]
    test = assembled_test(truth, sensors, count=12)
    update = update_model(model, test, settings=UpdateSettings(regularisation=1e-3))
    identified = update.deviation < 0.05
    assert identified.sum() == 5 and not identified[5]
    assert update.held == (parameters[5].name,) and update.rank == 5
    assert update.scales[5] == 1.0
    np.testing.assert_allclose(
        update.scales[identified], np.array(TRUE_SCALES)[identified], rtol=1e-3
    )
    feasible = apply_parameters(model, parameters, np.log([*TRUE_SCALES[:5], 1.0]))

    def squares(table):
        return float(np.sum(np.log(table["model_hz"] / table["test_hz"]) ** 2))

    assert squares(update.after.table) <= squares(correlate(feasible, test).table) * (1 + 1e-6)
    assert update.before.summary()["max_abs_error_percent"] > 5.0


SETTINGS = """
[settings]
regularisation = 0.02
[[parameter]]
name = "bearing"
hinges = ["air_bearing"]
field = "stiffness"
components = [0, 1, 2]
band = [0.5, 2.0]
reason = "air-bearing film stiffness, known to a factor of two"
"""


def test_settings_file_declares_parameters_and_is_checked(tmp_path):
    path = tmp_path / "update.toml"
    path.write_text(SETTINGS)
    settings, parameters = read_update_settings(path, ufmt.load_model(BRIDGE))
    assert settings.regularisation == 0.02 and [p.name for p in parameters] == ["bearing"]
    path.write_text(SETTINGS.replace("[0.5, 2.0]", "[2.0, 0.5]"))
    with pytest.raises(StudyError, match="field 'band': reversed bounds"):
        read_update_settings(path, ufmt.load_model(BRIDGE))
    path.write_text(SETTINGS.replace("regularisation", "regularization"))
    with pytest.raises(StudyError, match="did you mean 'regularisation'"):
        read_update_settings(path, ufmt.load_model(BRIDGE))


def test_calibrate_test_cli_writes_the_calibrated_model_in_the_users_folder(
    tmp_path, monkeypatch, capsys
):
    monkeypatch.chdir(tmp_path)
    settings = tmp_path / "update.toml"
    settings.write_text(SETTINGS)
    test = ROOT / "examples" / "bridge-modal-test.csv"
    args = ["calibrate", "--prior", str(BRIDGE), "--test", str(test), "--settings", str(settings)]
    assert main(args) == 0
    folder = tmp_path / "results" / "bridge" / "calibration"
    calibrated = folder / "bridge-calibrated.toml"
    assert calibrated.read_text().startswith("# GENERATED FILE")
    assert ufmt.load_model(calibrated).hinge("air_bearing").stiffness[2] < 4e8  # softer
    assert {"parameters.csv", "residuals.csv", "mac.png"} <= {p.name for p in folder.iterdir()}
    assert main(["validate", str(calibrated), "--test", str(test), "--json"]) == 0
    out = json.loads(capsys.readouterr().out.splitlines()[-1])
    prior = correlate(BRIDGE, test).summary()["mean_abs_error_percent"]
    assert out["mean_abs_error_percent"] < prior  # the bearing alone: better, not exact


def test_factors_a_frequency_only_test_cannot_identify_are_held_and_named(
    tmp_path, monkeypatch, capsys
):
    """Property: the data's rank is at most the number of paired modes (3 frequencies, 6
    factors), so at least 3 factors are held at their prior (scale exactly 1), named on one
    line of the CLI's output and flagged in parameters.csv."""
    monkeypatch.chdir(tmp_path)
    full = read_modal_test(ROOT / "examples" / "bridge-modal-test.csv")
    test = modal_test(full.modes[:3], full.frequencies_hz[:3], source=str(tmp_path / "f.csv"))
    test.save(tmp_path / "f.csv")
    update = update_model(ufmt.load_model(BRIDGE), test)
    n = len(update.parameters)
    assert update.rank <= 3 and update.singular_values.size == 3
    assert len(update.held) >= n - 3
    held = [p.name in update.held for p in update.parameters]
    np.testing.assert_array_equal(update.scales[held], 1.0)
    args = ["calibrate", "--prior", str(BRIDGE), "--test", str(tmp_path / "f.csv")]
    args += ["--output", str(tmp_path / "c.toml")]
    assert main(args) == 0
    lines = [x for x in capsys.readouterr().out.splitlines() if x.startswith("held at the prior")]
    assert len(lines) == 1 and all(name in lines[0] for name in update.held)
    assert "HELD" in (tmp_path / "c.toml").read_text()


def test_calibrate_never_overwrites_its_prior(tmp_path, capsys):
    """Contract: --output equal to --prior (in any spelling) exits 2, prior unchanged."""
    prior = tmp_path / "p.toml"
    prior.write_text(BRIDGE.read_text())
    before = prior.read_bytes()
    test = ROOT / "examples" / "bridge-modal-test.csv"
    for output in (prior, tmp_path / "sub" / ".." / "p.toml"):
        args = ["calibrate", "--prior", str(prior), "--test", str(test), "--output", str(output)]
        assert main(args) == 2
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and "--output" in err and "prior" in err
    assert prior.read_bytes() == before
