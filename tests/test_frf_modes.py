"""Measured FRFs to modes (oracles: the bridge example's own FRFs, written as a universal file
(dataset 58) and a CSV FRF table and read back unchanged; the modes LSCF/LSFD extract from them
against the model's natural frequencies (0.5 %; 1 % with 1 % noise), its damping ratio and its
shapes by MAC; the modes whose FRF peaks are visible at the sensors, found from the model's
shapes at the sensors, all recovered)."""

import json
from dataclasses import replace

import numpy as np
import pytest

from ufmt.calibration.correlation import correlate, sensor_shapes
from ufmt.calibration.frf_file import is_frf_file, read_measured_frf, save_uff
from ufmt.calibration.frf_modes import extract_modes
from ufmt.calibration.frf_overlay import overlay, synthetic_frf
from ufmt.calibration.modal_test import Sensor, read_modal_test
from ufmt.calibration.test_file import read_test
from ufmt.cli import main
from ufmt.model.load import load_model
from ufmt.mstmm.solve import solve_modes

BRIDGE = "examples/bridge.toml"
POINTS = [("head", (0.15, 0.0, 0.93)), ("bridge", (0.3, 0.2, 1.9)), ("table", (0.1, 0.1, 0.85))]
BAND = (50.0, 650.0)
FREQ = np.arange(1.0, 701.0, 1.0)  # [Hz] evenly spaced lines, as an analyser writes them


@pytest.fixture(scope="module")
def bridge():
    return load_model(BRIDGE)


@pytest.fixture(scope="module")
def frfs(bridge):
    """The bridge's receptances at three points x three directions, driven at the head in
    x, y and z (27 FRFs)."""
    outputs = [Sensor(b, p, d) for b, p in POINTS for d in "xyz"]
    inputs = [Sensor("head", POINTS[0][1], d) for d in "xyz"]
    o = [s for _ in inputs for s in outputs]
    i = [r for r in inputs for _ in outputs]
    return synthetic_frf(bridge, o, i, FREQ)


@pytest.fixture(scope="module")
def files(frfs, tmp_path_factory):
    folder = tmp_path_factory.mktemp("frf")
    uff = save_uff(frfs, folder / "bridge-frf.uff")
    csv = frfs.save(folder / "bridge-frf.csv")
    return uff, csv


@pytest.fixture(scope="module")
def visible(bridge, frfs):
    """Natural frequencies [Hz] in the band of the modes whose peak in some FRF is at least
    ``share`` of the largest modal peak (|phi_out phi_in| / w^2 from the model's shapes)."""
    solution = solve_modes(bridge, fmax_hz=BAND[1])
    out = sensor_shapes(bridge, solution.shapes, frfs.outputs)
    inp = sensor_shapes(bridge, solution.shapes, frfs.inputs)
    w = 2 * np.pi * solution.frequencies_hz
    score = np.max(np.abs(out * inp), axis=1) / w**2
    score = score / score.max()
    f = solution.frequencies_hz

    def above(share: float) -> np.ndarray:
        return f[(score >= share) & (f >= BAND[0])]

    return above


def nearest_error_percent(found, reference) -> np.ndarray:
    """|100 (f / f_nearest reference - 1)| for every f found."""
    found, reference = np.asarray(found), np.asarray(reference)
    near = reference[np.argmin(np.abs(found[:, None] - reference[None, :]), axis=1)]
    return np.abs(100 * (found / near - 1))


def test_uff58_and_csv_table_read_back_unchanged(frfs, files):
    for path in files:
        assert is_frf_file(path)
        back = read_measured_frf(path)
        np.testing.assert_allclose(back.frequencies_hz, frfs.frequencies_hz, rtol=1e-12)
        scale = np.abs(frfs.values).max()
        np.testing.assert_allclose(back.values, frfs.values, rtol=0, atol=1e-10 * scale)
        assert back.outputs == frfs.outputs and back.inputs == frfs.inputs
        assert back.kind == "receptance"


def test_modes_from_the_bridges_frfs_within_half_a_percent(bridge, files, visible):
    result = extract_modes(files[0], *BAND)
    model_hz = solve_modes(bridge, fmax_hz=BAND[1] * 1.2).frequencies_hz
    found = result.test.frequencies_hz
    assert np.all(nearest_error_percent(found, model_hz) < 0.5)
    # every mode the sensors see is found (the table's modes are not driven from the head)
    assert np.all(nearest_error_percent(visible(1e-4), found) < 0.5)
    np.testing.assert_allclose(result.test.damping_ratio, 0.01, rtol=0.02)  # the model's zeta
    pairs = correlate(bridge, result.test).table
    assert (pairs["paired_by"] == "mac").all()
    assert pairs["mac"].min() > 0.99 and pairs["error_percent"].abs().max() < 0.5


def test_modes_from_noisy_frfs_within_one_percent(bridge, frfs, visible):
    rng = np.random.default_rng(7)
    noise = rng.standard_normal(frfs.values.shape) + 1j * rng.standard_normal(frfs.values.shape)
    noisy = replace(frfs, values=frfs.values * (1 + 0.01 * noise / np.sqrt(2)))
    result = extract_modes(noisy, *BAND)
    model_hz = solve_modes(bridge, fmax_hz=BAND[1] * 1.2).frequencies_hz
    assert np.all(nearest_error_percent(result.test.frequencies_hz, model_hz) < 1.0)
    # the strongly visible modes are all found
    assert np.all(nearest_error_percent(visible(0.05), result.test.frequencies_hz) < 1.0)
    pairs = correlate(bridge, result.test).table
    assert pairs["mac"].min() > 0.9 and pairs["error_percent"].abs().max() < 1.0


def test_given_approximate_frequencies_pick_their_poles(files):
    result = extract_modes(files[0], *BAND, approx_hz=[160.0, 350.0])
    np.testing.assert_allclose(result.test.frequencies_hz, [162.435, 345.425], rtol=5e-4)
    assert set(result.chart.loc[result.chart["selected"], "frequency_hz"].round(3)) == set(
        result.test.frequencies_hz.round(3)
    )


def test_overlay_of_the_model_on_its_own_frfs_is_exact(bridge, frfs):
    both = overlay(bridge, frfs)
    np.testing.assert_allclose(both.model, frfs.values, rtol=1e-9, atol=0)
    assert both.log_ratio() < 1e-9


def test_a_modal_test_file_is_read_as_before():
    path = "examples/bridge-modal-test.csv"
    assert not is_frf_file(path)
    a, b = read_test(path), read_modal_test(path)
    np.testing.assert_array_equal(a.frequencies_hz, b.frequencies_hz)
    np.testing.assert_array_equal(a.shapes, b.shapes)


def test_validate_with_measured_frfs(frfs, tmp_path, capsys):
    z = [
        p
        for p, (o, i) in enumerate(zip(frfs.outputs, frfs.inputs, strict=True))
        if i.direction == "z"
    ]
    small = replace(
        frfs,
        values=frfs.values[z],
        outputs=tuple(frfs.outputs[p] for p in z),
        inputs=tuple(frfs.inputs[p] for p in z),
    )  # 9 FRFs, driven in z
    path = save_uff(small, tmp_path / "z.uff")
    out = tmp_path / "v"
    code = main(
        ["validate", BRIDGE, "--test", str(path), "--frf-band", "50,650"]
        + ["--output-dir", str(out), "--json"]
    )
    assert code == 0
    data = json.loads(capsys.readouterr().out)
    for key in ("paired", "max_abs_error_percent", "mean_abs_error_percent", "min_mac", "pairs"):
        assert key in data
    assert data["max_abs_error_percent"] < 0.5 and data["frf"]["modes"] == data["paired"]
    for name in ("frf-modes.csv", "stabilisation.png", "frf-overlay.csv", "frf-overlay.png"):
        assert (out / name).is_file()
    # the extracted modes, written as a modal-test CSV, read back as the same test
    again = read_modal_test(out / "frf-modes.csv")
    np.testing.assert_allclose(again.frequencies_hz, data["frf"]["frequencies_hz"], rtol=1e-9)


def test_accelerance_gives_the_same_modes(frfs, files):
    iw = 2j * np.pi * frfs.frequencies_hz
    accel = replace(frfs, values=frfs.values * iw**2, kind="accelerance")
    a = extract_modes(accel, *BAND).test
    r = extract_modes(files[0], *BAND).test
    assert a.frequencies_hz.size == r.frequencies_hz.size
    np.testing.assert_allclose(a.frequencies_hz, r.frequencies_hz, rtol=1e-4)
    np.testing.assert_allclose(a.damping_ratio, r.damping_ratio, rtol=2e-2)


def test_calibration_on_frfs_recovers_the_air_bearing_factor(bridge, frfs, tmp_path):
    """FRFs of the bridge with its air bearing 0.8 x as stiff: calibrating the example against
    the modes extracted from them finds the factor 0.8."""
    from ufmt.calibration.model_update import update_model
    from ufmt.calibration.reduced import apply_parameters
    from ufmt.calibration.settings import Parameter

    bearing = Parameter("bearing", ("air_bearing",), "stiffness", (0, 1, 2), (0.5, 2.0), "")
    truth = apply_parameters(bridge, [bearing], np.array([np.log(0.8)]))
    measured = synthetic_frf(truth, frfs.outputs, frfs.inputs, FREQ)
    test = extract_modes(measured, *BAND).test
    update = update_model(bridge, test, [bearing])
    assert update.scales[0] == pytest.approx(0.8, rel=5e-3)
