"""``ufmt.simulate`` result API and the ``ufmt simulate --json`` contract."""

import json
import math
import subprocess
import sys

import numpy as np
import pytest
from matplotlib.figure import Figure
from synthetic import SMALL, packaged_text, synthetic_basis

import ufmt
from ufmt.errors import ModelError
from ufmt.machining.process import Process
from ufmt.model.machine import read_machine
from ufmt.model.schema import Model

CONTRACT = (
    "pv_nm",
    "pv_aperture_nm",
    "rms_nm",
    "force_peak_n",
    "pv_by_source_nm",
    "zre_peak_nm",
    "tip_acc_peak_mm_s2",
    "psd1_rms_nm",
    "psd2_rms_nm",
)


@pytest.fixture(scope="module")
def model_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("model") / "ufmt_unit.toml"
    path.write_text(packaged_text())
    return path


def test_json_contract_is_strict_and_complete(model_file):
    """Reference cut: every contract key, null where unresolved, no NaN/Infinity anywhere."""
    res = subprocess.run(
        [sys.executable, "-m", "ufmt.cli", "simulate", str(model_file), "--json"],
        capture_output=True,
        text=True,
        check=True,
    )
    out = json.loads(res.stdout, parse_constant=lambda c: pytest.fail(f"non-strict JSON: {c}"))
    for key in CONTRACT:
        assert key in out
    assert out["psd1_rms_nm"] is None  # the 52.4 mm plate spans 1.6 periods of 33 mm
    assert out["psd2_rms_nm"] > 0  # the line profiles at 0.03 mm resolve PSD2
    assert set(out["pv_by_source_nm"]) == {
        "dynamic",
        "feed_marks",
        "spindle_tilt",
        "error_motion",
        "straightness",
        "pressure_ripple",
        "workholding",
        "carriage_load",
    }
    # the reference cut's forces are of the measured size (0.1-1 N), not tens of newtons
    assert 0.1 < out["force_peak_n"] < 1.0
    # feed marks on by default: (v/f)^2 / (8 r_n) = (50 um)^2 / 40 mm = 62.5 nm
    assert out["pv_by_source_nm"]["feed_marks"] == pytest.approx(62.5, rel=0.03)
    assert out["pv_nm"] >= out["pv_aperture_nm"] > 0


def test_psd2_patch_resolves_psd2(model_file):
    model = ufmt.load_model(model_file)
    basis = synthetic_basis(n=6)
    grid = dict(basis=basis, static_correction=False, line_spacing=None)  # 1 mm steps
    assert math.isnan(ufmt.simulate(model, Process(300, 15, 4), **grid).metrics["psd2_rms_nm"])
    patched = ufmt.simulate(
        model, Process(300, 15, 4), basis=basis, static_correction=False, psd2_patch=10e-3
    )
    assert math.isfinite(patched.metrics["psd2_rms_nm"]) and patched.metrics["psd2_rms_nm"] >= 0


def test_result_api(tmp_path, model_file):
    """Path or model in; short repr, tidy frame, Figure, save."""
    model = Model("syn", (), (), machine=read_machine(SMALL), source="syn.toml")
    basis = synthetic_basis(n=6)
    r = ufmt.simulate(model, Process(300, 15, 4), basis=basis, static_correction=False)
    assert len(repr(r)) < 1000 and "pv_nm" in repr(r)
    frame = r.to_frame()
    assert len(frame) == 1
    assert {"pv_nm", "pv_aperture_nm", "pv_dynamic_nm", "pv_feed_marks_nm"} <= set(frame.columns)
    assert frame["pv_nm"].iloc[0] == r.metrics["pv_nm"]
    assert isinstance(r.plot(), Figure)
    paths = r.save(tmp_path / "out")
    assert all(p.exists() for p in paths)
    saved = json.loads((tmp_path / "out" / "metrics.json").read_text())
    assert saved["pv_nm"] == pytest.approx(r.metrics["pv_nm"])
    assert saved["psd2_rms_nm"] == pytest.approx(r.metrics["psd2_rms_nm"])  # the lines resolve it
    grid = np.load(tmp_path / "out" / "surface.npz")
    np.testing.assert_array_equal(grid["z_m"], r.surface.z)
    # a path works as well as a loaded model
    by_path = ufmt.simulate(
        str(model_file), Process(300, 15, 4), basis=basis, static_correction=False
    )
    assert by_path.metrics["pv_nm"] > 0


def test_model_without_machine_table_says_what_to_add():
    with pytest.raises(ModelError, match=r"syn.toml: no \[machine\] table: add one with tool_body"):
        ufmt.simulate(Model("syn", (), (), source="syn.toml"), Process(300, 15, 4))


def test_machine_table_is_validated_where_it_is_used(tmp_path):
    """The loader validates [machine] (tests/test_model_load.py), so every command that
    uses it (simulate, frf, calibrate, studies) stops on it: one line, did-you-mean, exit 2."""
    bad = packaged_text().replace("force_scale = 1.0", "force_scal = 1.0")
    path = tmp_path / "bad.toml"
    path.write_text(bad)
    res = subprocess.run(
        [sys.executable, "-m", "ufmt.cli", "simulate", str(path)], capture_output=True, text=True
    )
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "did you mean 'force_scale'" in lines[0] and "bad.toml" in lines[0]
