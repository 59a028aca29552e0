"""Measured-FRF files refused with one line naming the file, the dataset or column and what
is allowed (oracle: the message text and exit 2, no traceback); a declared or written unit
scales the node positions (oracle: the same nodes in metres)."""

import numpy as np
import pytest
import pyuff

from ufmt.calibration.frf_file import MeasuredFrf, read_measured_frf, save_uff
from ufmt.calibration.modal_test import Sensor
from ufmt.cli import main
from ufmt.errors import StudyError

FREQ = np.arange(1.0, 9.0)
HEAD = Sensor("head", (0.15, 0.0, 0.93), "z")
TABLE = Sensor("table", (0.1, 0.1, 0.85), "x")


def small(kind="receptance") -> MeasuredFrf:
    values = np.array([1.0 / (100.0 - FREQ**2 + 1j * FREQ), 2.0 / (50.0 - FREQ**2 + 1j)])
    return MeasuredFrf("small", FREQ, values, (HEAD, TABLE), (HEAD, HEAD), kind)


def written(tmp_path, **change):
    """A universal file of ``small()`` with the dataset 58 fields ``change``d."""
    path = save_uff(small(), tmp_path / "t.uff")
    sets = pyuff.UFF(str(path)).read_sets()
    for d in sets:
        if d["type"] == 58:
            d.update(change)
    path.unlink()
    pyuff.UFF(str(path), "w").write_sets(sets, mode="overwrite")
    return path


def refused(path, match, capsys=None):
    with pytest.raises(StudyError, match=match) as info:
        read_measured_frf(path)
    assert "\n" not in str(info.value) and str(path.with_suffix("")) in str(info.value)
    if capsys is not None:  # the CLI: one line, exit 2
        assert main(["validate", "examples/bridge.toml", "--test", str(path)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "Traceback" not in err[0]


def test_not_an_frf_function_is_refused(tmp_path, capsys):
    refused(written(tmp_path, func_type=1), r"dataset 58 \[0\]: field 'func_type'", capsys)


def test_a_rotation_is_refused(tmp_path):
    refused(written(tmp_path, rsp_dir=5), r"field 'rsp_dir': 5 is not a translation")


def test_uneven_lines_are_refused(tmp_path):
    path = save_uff(small(), tmp_path / "t.uff")
    sets = pyuff.UFF(str(path)).read_sets()
    for d in sets:
        if d["type"] == 58:
            d["x"] = FREQ**1.1
            d["abscissa_spacing"] = 0
    path.unlink()
    pyuff.UFF(str(path), "w").write_sets(sets, mode="overwrite")
    refused(path, "not evenly spaced")


def test_missing_node_map_is_refused(tmp_path):
    path = save_uff(small(), tmp_path / "t.uff")
    path.with_suffix(".nodes.csv").unlink()
    refused(path, r"t\.nodes\.csv: file not found")


def test_nodes_without_units_ask_for_the_unit(tmp_path):
    path = save_uff(small(), tmp_path / "t.uff")
    sets = [d for d in pyuff.UFF(str(path)).read_sets() if d["type"] != 164]
    for d in sets:
        if d["type"] == 2411:  # the same nodes in mm
            d["x"], d["y"], d["z"] = (np.asarray(d[k]) * 1000 for k in "xyz")
    path.unlink()
    pyuff.UFF(str(path), "w").write_sets(sets, mode="overwrite")
    refused(path, "declare their unit")
    back = read_measured_frf(path, unit="mm")
    assert back.outputs[0].position == pytest.approx(HEAD.position, rel=1e-12)
    assert back.outputs[1].position == pytest.approx(TABLE.position, rel=1e-12)


def test_negative_directions_flip_the_sign(tmp_path):
    plain = read_measured_frf(save_uff(small(), tmp_path / "a.uff"))
    flipped = read_measured_frf(written(tmp_path, ref_dir=-3))
    np.testing.assert_allclose(flipped.values, -plain.values, rtol=1e-11)


def test_csv_table_mistakes_are_one_line(tmp_path):
    path = small().save(tmp_path / "t.csv")
    text = path.read_text().replace("1z/1z", "1q/1z", 1)
    path.write_text(text)
    refused(path, r"field '1q/1z': expected a column name")
    path.write_text(small().save(tmp_path / "u.csv").read_text().replace("j)", "k)", 1))
    refused(path, r"row 2: field '1z/1z'.*is not a finite complex")


def test_csv_table_kind_comment(tmp_path):
    path = small("accelerance").save(tmp_path / "t.csv")
    assert read_measured_frf(path).kind == "accelerance"
    path.write_text(path.read_text().replace("accelerance", "compliance"))
    refused(path, "unknown kind 'compliance'")


def test_a_zero_hz_line_is_dropped(tmp_path):
    lines = np.arange(0.0, 9.0)
    values = np.vstack([np.full(lines.size, 1 + 1j), np.full(lines.size, 2 - 1j)])
    with_dc = MeasuredFrf("dc", lines, values, (HEAD, TABLE), (HEAD, HEAD), "receptance")
    back = read_measured_frf(save_uff(with_dc, tmp_path / "t.uff"))
    np.testing.assert_array_equal(back.frequencies_hz, FREQ)
    np.testing.assert_allclose(back.values, values[:, 1:], rtol=1e-11)


def test_positions_from_the_node_map_without_units(tmp_path):
    path = save_uff(small(), tmp_path / "t.uff")
    sets = [d for d in pyuff.UFF(str(path)).read_sets() if d["type"] == 58]
    path.unlink()
    pyuff.UFF(str(path), "w").write_sets(sets, mode="overwrite")
    refused(path, "field 'x_m': missing")  # the map names bodies only
    small().save(tmp_path / "t.csv")  # writes t.nodes.csv with x_m, y_m, z_m
    back = read_measured_frf(path)
    assert back.outputs == small().outputs
    np.testing.assert_allclose(back.values, small().values, rtol=1e-11)
