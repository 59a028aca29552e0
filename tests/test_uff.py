"""Universal files (UFF) of a modal test as vendors write them: nodes (15, 2411), units (164 or
declared), unmeasured directions, complex modes and their MPC, malformed files."""

import json
from pathlib import Path

import numpy as np
import pytest

import ufmt
from ufmt.calibration.correlation import assembled_test, correlate
from ufmt.calibration.modal_test import Sensor
from ufmt.calibration.uff import modal_phase_collinearity, uff_nodes
from ufmt.errors import StudyError
from ufmt.tables import Where

ROOT = Path(__file__).resolve().parents[1]
BRIDGE = ROOT / "examples" / "bridge.toml"
DATA = Path(__file__).parent / "data" / "uff"
POINTS = [("head", (0.15, 0.0, 0.93)), ("bridge", (0.5, 0.2, 1.6)), ("table", (0, 0.05, 0.8))]
COMMON = {"id1": "t", "id2": "t", "id3": "t", "id4": "t", "id5": "t", "load_case": 1}
COMMON |= {"model_type": 1, "data_ch": 2, "spec_data_type": 8, "n_data_per_node": 3}


def write_uff(
    path, test, points, *, complex_modes=False, nodes_set=15, length=None, mode_n=None, eig=None
):
    """``test`` (3 sensors x y z per point) as a universal file written by pyuff: node
    positions in dataset ``nodes_set`` in file units of ``length`` per metre (dataset 164; None:
    no dataset 164, positions in metres), one dataset 55 per mode; and its node map."""
    import pyuff

    uff = pyuff.UFF(str(path))
    xyz = np.array([p for _, p in points]) * (length or 1.0)
    nodes = np.arange(1, len(points) + 1)
    zeros = [0] * len(nodes)
    if length is not None:
        uff.write_sets(pyuff.prepare_164(1, "file", 2, length, 1.0, 1.0, 273.15), "overwrite")
    if nodes_set == 15:
        uff.write_sets(pyuff.prepare_15(nodes, zeros, zeros, [1] * len(nodes), *xyz.T), "add")
    else:
        uff.write_sets(pyuff.prepare_2411(nodes, zeros, zeros, [1] * len(nodes), *xyz.T), "add")
    for k, (f, shape) in enumerate(zip(test.frequencies_hz, test.shapes, strict=True)):
        r = np.nan_to_num(shape.reshape(len(points), 3))  # unmeasured: 0, as vendors write
        if complex_modes:
            w, zeta = 2 * np.pi * f, 0.02
            lam = complex(-zeta * w, w * np.sqrt(1 - zeta**2)) if eig is None else eig
            r = r * np.exp(0.7j)  # an arbitrary complex scaling of a real mode
            extra = {"analysis_type": 3, "data_type": 5, "eig": lam, "modal_a": 0j, "modal_b": 0j}
        else:
            extra = {"analysis_type": 2, "data_type": 2, "freq": f, "modal_m": 1.0}
            extra |= {"modal_damp_vis": 0.01, "modal_damp_his": 0.0}
        number = k + 1 if mode_n is None else mode_n[k]
        data = pyuff.prepare_55(
            **COMMON, **extra, mode_n=number, node_nums=nodes, r1=r[:, 0], r2=r[:, 1], r3=r[:, 2]
        )
        uff.write_sets(data, mode="add")
    Path(path).with_suffix(".nodes.csv").write_text(
        "node,body\n" + "".join(f"{n},{b}\n" for n, (b, _) in zip(nodes, points, strict=True))
    )
    return Path(path)


def bridge_test(count=6, axes="xyz", points=POINTS):
    model = ufmt.load_model(BRIDGE)
    sensors = [Sensor(b, p, d) for b, p in points for d in axes]
    return model, assembled_test(model, sensors, count=count)


def moving(test):
    """The sensors of ``test`` that move in some mode (a direction exactly 0 in every mode is
    written as an unmeasured one is, and read as no sensor)."""
    return [s for j, s in enumerate(test.sensors) if np.any(test.shapes[:, j] != 0.0)]


@pytest.mark.parametrize(
    ("complex_modes", "nodes_set", "length", "unit"),
    [(False, 15, None, "m"), (True, 15, None, "m"), (False, 2411, 1000.0, None)],
)
def test_a_universal_file_reads_as_the_same_test(tmp_path, complex_modes, nodes_set, length, unit):
    """Oracle: the test written to UFF by pyuff and read back pairs with the MSTMM as the test
    itself: the same sensors [m] (dataset 2411 in mm by dataset 164, or 15 in a declared
    metre), frequencies, damping (complex: from the eigenvalue) and MAC 1; a complex scaling of
    a real mode has MPC 1. A direction that is exactly 0 in every mode is no sensor."""
    model, test = bridge_test()
    path = write_uff(
        tmp_path / "t.uff",
        test,
        POINTS,
        complex_modes=complex_modes,
        nodes_set=nodes_set,
        length=length,
    )
    back = ufmt.read_modal_test(path, unit=unit)
    # the table does not move in the bridge's first 6 modes: no sensor (module rule)
    expected = moving(test)
    assert [(s.body, s.direction) for s in back.sensors] == [
        (s.body, s.direction) for s in expected
    ]
    positions = [s.position for s in back.sensors]
    np.testing.assert_allclose(positions, [s.position for s in expected], atol=1e-9)
    digits = 1e-5  # UFF's E13.5 fields hold 6 significant digits
    np.testing.assert_allclose(back.frequencies_hz, test.frequencies_hz, rtol=digits)
    np.testing.assert_allclose(back.damping_ratio, 0.02 if complex_modes else 0.01, rtol=digits)
    if complex_modes:
        np.testing.assert_allclose(back.mpc, 1.0, atol=1e-9)
    else:
        assert np.isnan(back.mpc).all()
    result = correlate(model, back)
    assert (result.table["mac"] > 1 - 1e-6).all()
    assert list(result.table["model_mode"]) == list(range(1, 7))


def test_no_units_and_none_declared_is_refused_and_a_declared_unit_scales(tmp_path):
    """Never a guess: dataset 15 without 164 asks for the unit; declared mm divides by 1000;
    a declared unit that contradicts dataset 164 is refused."""
    _, test = bridge_test(count=2)
    mm = [(b, tuple(1000 * c for c in p)) for b, p in POINTS]
    path = write_uff(tmp_path / "t.uff", test, mm)
    with pytest.raises(StudyError) as err:
        ufmt.read_modal_test(path)
    message = str(err.value)
    assert message.startswith(str(path)) and "dataset 164" in message and "\n" not in message
    back = ufmt.read_modal_test(path, unit="mm")
    np.testing.assert_allclose(
        [s.position for s in back.sensors], [s.position for s in moving(test)], atol=1e-12
    )
    declared = write_uff(tmp_path / "u.uff", test, POINTS, length=1000.0)
    with pytest.raises(StudyError, match=r"dataset 164: field 'length': .* differs"):
        ufmt.read_modal_test(declared, unit="m")
    with pytest.raises(StudyError, match="unknown length unit 'furlong'"):
        ufmt.read_modal_test(declared, unit="furlong")


def test_unmeasured_directions_are_absent_not_zero(tmp_path):
    """Oracle: a test measured in x only, written with 0 in y and z as vendors do, reads back
    with one sensor per point (x), and its MAC against the model equals the x-only test's."""
    points = POINTS[:2]  # the head and the bridge: both move in x in the first 4 modes
    model, test = bridge_test(count=4, points=points)
    x_only = test.shapes.copy()
    x_only[:, [j for j, s in enumerate(test.sensors) if s.direction != "x"]] = np.nan
    written = type(test)(
        test.source, test.modes, test.frequencies_hz, test.damping_ratio, test.sensors, x_only
    )
    back = ufmt.read_modal_test(write_uff(tmp_path / "t.uff", written, points), unit="m")
    assert [s.direction for s in back.sensors] == ["x"] * len(points)
    _, reference = bridge_test(count=4, axes="x", points=points)
    np.testing.assert_allclose(
        correlate(model, back).mac, correlate(model, reference).mac, atol=1e-6
    )


def test_any_mode_numbering_and_malformed_modes(tmp_path):
    """Mode numbers 101, 205, ... are kept; mode_n 0, a duplicate number, a zero or NaN
    eigenvalue are refused with one line naming the file and the dataset."""
    _, test = bridge_test(count=3)
    path = write_uff(tmp_path / "t.uff", test, POINTS, mode_n=[101, 205, 999], length=1.0)
    assert ufmt.read_modal_test(path).modes.tolist() == [101, 205, 999]
    for numbers, match in (([0, 1, 2], "mode_n': 0 is too small"), ([1, 2, 1], "appears more")):
        path = write_uff(tmp_path / "t.uff", test, POINTS, mode_n=numbers, length=1.0)
        with pytest.raises(StudyError, match=f"dataset 55.*{match}"):
            ufmt.read_modal_test(path)
    for bad in (complex(np.nan, np.nan), 0j, complex(3.0, 100.0)):
        path = write_uff(tmp_path / "c.uff", test, POINTS, complex_modes=True, length=1.0, eig=bad)
        with pytest.raises(StudyError) as err:
            ufmt.read_modal_test(path)
        assert "dataset 55 [0]: field 'eig'" in str(err.value) and "\n" not in str(err.value)


def test_duplicate_nodes_and_a_truncated_file_are_refused(tmp_path):
    _, test = bridge_test(count=8)
    path = write_uff(tmp_path / "t.uff", test, POINTS, length=1.0)
    text = path.read_text()
    cut = tmp_path / "cut.uff"
    cut.write_text(text[: len(text) // 2])
    cut.with_suffix(".nodes.csv").write_text(path.with_suffix(".nodes.csv").read_text())
    with pytest.raises(StudyError, match="cut.uff: truncated"):
        ufmt.read_modal_test(cut)
    import pyuff

    where = Where("t.uff", error=StudyError)
    nodes = pyuff.prepare_15(
        [1, 2, 1], [0] * 3, [0] * 3, [1] * 3, [0.0, 1.0, 2.0], [0.0] * 3, [0.0] * 3
    )
    with pytest.raises(StudyError, match="dataset 15: field 'node_nums': node 1 is listed more"):
        uff_nodes(where, [nodes], "m")


def test_real_export_nodes_and_units():
    """A public export (tests/data/uff/SOURCE.md): dataset 2411 with 10 nodes, dataset 164 in
    mm: the positions are the file's numbers / 1000 [m]."""
    import pyuff

    sets = pyuff.UFF(str(DATA / "heat_engine_housing.uff")).read_sets()
    nodes = uff_nodes(Where("heat", error=StudyError), sets, None)
    raw = next(d for d in sets if d["type"] == 2411)
    assert sorted(nodes) == list(range(1, 11))
    np.testing.assert_allclose(
        nodes[1], [raw["x"][0] / 1000, raw["y"][0] / 1000, raw["z"][0] / 1000]
    )
    with pytest.raises(StudyError, match="no mode shapes"):
        ufmt.read_modal_test(DATA / "heat_engine_housing.uff")


def test_real_complex_mode_measured_directions_and_mpc(tmp_path):
    """A public complex-mode export (dataset 55, analysis type 3; tests/data/uff/SOURCE.md)
    with node positions added: its 3 measured directions (111111 y z, 60101 z), frequency
    |λ|/2π, damping -Re λ/|λ|, and MPC against the covariance eigenvalue form
    ((λ1 - λ2)/(λ1 + λ2))² of its shape."""
    import pyuff

    path = tmp_path / "real.uff"
    nodes = pyuff.prepare_15(
        [111111, 60101], [0, 0], [0, 0], [1, 1], [0.1, 0.2], [0.0, 0.0], [1.0, 1.0]
    )
    pyuff.UFF(str(path)).write_sets(nodes, "overwrite")
    path.write_text(path.read_text() + (DATA / "complex-mode-record10.uff").read_text())
    path.with_suffix(".nodes.csv").write_text("node,body\n111111,head\n60101,table\n")
    test = ufmt.read_modal_test(path, unit="m")
    assert [(s.body, s.direction) for s in test.sensors] == [
        ("table", "z"),  # node 60101 first: sensors in node order
        ("head", "y"),
        ("head", "z"),
    ]
    raw = pyuff.UFF(str(DATA / "complex-mode-record10.uff")).read_sets()
    lam = raw["eig"]
    assert test.frequencies_hz[0] == pytest.approx(abs(lam) / (2 * np.pi))
    assert test.damping_ratio[0] == pytest.approx(-lam.real / abs(lam))
    phi = np.concatenate([raw["r1"], raw["r2"], raw["r3"]])
    pair = np.array([phi.real, phi.imag])
    eig = np.linalg.eigvalsh(pair @ pair.T)
    assert test.mpc[0] == pytest.approx(((eig[1] - eig[0]) / eig.sum()) ** 2)
    assert 0.0 < test.mpc[0] < 1.0


def test_mpc_properties():
    """MPC 1 for any complex scaling of a real shape, 0 for equal-norm quadrature parts."""
    rng = np.random.default_rng(3)
    real = rng.standard_normal(9)
    assert modal_phase_collinearity(real * np.exp(1.1j)) == pytest.approx(1.0)
    assert modal_phase_collinearity(np.array([1.0, 1j])) == pytest.approx(0.0)


def test_validate_reads_a_uff_with_the_declared_unit(tmp_path, monkeypatch, capsys):
    """CLI: a UFF in mm without dataset 164 exits 2 with one line asking for the unit; with
    --test-unit mm it pairs every mode by MAC (MAC 1: the assembled model's own shapes)."""
    from ufmt.cli import main

    monkeypatch.chdir(tmp_path)
    _, test = bridge_test(count=4)
    mm = [(b, tuple(1000 * c for c in p)) for b, p in POINTS]
    path = write_uff(tmp_path / "t.uff", test, mm)
    assert main(["validate", str(BRIDGE), "--test", str(path), "--json"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "--test-unit" in err and str(path) in err
    args = ["validate", str(BRIDGE), "--test", str(path), "--test-unit", "mm", "--json"]
    assert main(args) == 0
    out = json.loads(capsys.readouterr().out)
    assert [p["paired_by"] for p in out["pairs"]] == ["mac"] * 4
    assert out["min_mac"] > 1 - 1e-6


def test_real_exports_without_units_or_in_local_systems():
    """Public exports (tests/data/uff/SOURCE.md): ARTeMIS geometry (dataset 15, 74 nodes, no
    dataset 164) asks for the unit and reads 74 nodes when it is declared; Test.Lab (dataset
    164 in metres, 36 nodes each measuring in a local system of dataset 18) is refused."""
    import pyuff

    artemis = pyuff.UFF(str(DATA / "artemis-geometry.uff")).read_sets()
    where = Where("artemis-geometry.uff", error=StudyError)
    with pytest.raises(StudyError, match="no units \\(dataset 164\\)"):
        uff_nodes(where, artemis, None)
    raw = next(d for d in artemis if d["type"] == 15)
    nodes = uff_nodes(where, artemis, "cm")
    assert len(nodes) == 74
    first = int(raw["node_nums"][0])
    np.testing.assert_allclose(nodes[first], np.array([raw[k][0] for k in "xyz"]) / 100)
    testlab = pyuff.UFF(str(DATA / "testlab-164-18-15.uff")).read_sets()
    with pytest.raises(StudyError, match="dataset 15: field 'disp_cs': node 1 measures in"):
        uff_nodes(Where("testlab", error=StudyError), testlab, None)
