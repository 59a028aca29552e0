"""CLI contracts relied on from outside (DESIGN.md): JSON output and one-line errors."""

import json
import subprocess
import sys

import numpy as np
import pytest

from ufmt.cli import main

TWO_MASS = """
name = "two masses"
[[body]]
name = "a"
kind = "rigid"
mass = 2.0
center_of_mass = [0.0, 0.0, 0.0]
inertia = [[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]]
[[body]]
name = "b"
kind = "rigid"
mass = 1.0
center_of_mass = [0.0, 0.0, 1.0]
inertia = [[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]]
[[hinge]]
name = "ka"
between = ["ground", "a"]
at = [0.0, 0.0, 0.0]
stiffness = [1e6, 1e6, 1e6]
rotational_stiffness = [1e5, 1e5, 1e5]
[[hinge]]
name = "kb"
between = ["a", "b"]
at = [0.0, 0.0, 1.0]
stiffness = [1e6, 1e6, 1e6]
rotational_stiffness = [1e5, 1e5, 1e5]
"""


def run(*args):
    return subprocess.run(
        [sys.executable, "-m", "ufmt.cli", *args], capture_output=True, text=True, timeout=300
    )


@pytest.fixture
def model_file(tmp_path):
    path = tmp_path / "two.toml"
    path.write_text(TWO_MASS)
    return path


def test_modes_json_contract_and_methods_agree(model_file, capsys):
    assert main(["modes", str(model_file), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["order"] == 6 + 6  # ground reactions of the root + free tip of body b
    f = out["frequencies_hz"]
    assert f == sorted(f) and len(f) == 12
    assert main(["modes", str(model_file), "--json", "--method", "assembled"]) == 0
    asm = json.loads(capsys.readouterr().out)["frequencies_hz"]
    assert np.allclose(f, asm, rtol=1e-9)


def test_modes_count_and_fmax(model_file, capsys):
    assert main(["modes", str(model_file), "--json", "--count", "3"]) == 0
    three = json.loads(capsys.readouterr().out)["frequencies_hz"]
    assert main(["modes", str(model_file), "--json", "--fmax", str(three[2] * 1.0001)]) == 0
    below = json.loads(capsys.readouterr().out)["frequencies_hz"]
    assert len(three) == 3 and np.allclose(three, below[:3])


@pytest.mark.parametrize(
    "text, needle",
    [
        ("name = 'x'\n[[body]\n", "line"),
        (TWO_MASS.replace('kind = "rigid"', 'kind = "rigd"', 1), "kind"),
        (
            TWO_MASS.replace("stiffness = [1e6, 1e6, 1e6]", "stiffness = [1e6, nan, 1e6]", 1),
            "stiffness",
        ),
        (TWO_MASS.replace('between = ["a", "b"]', 'between = ["a", "c"]'), "between"),
    ],
)
def test_bad_model_gives_one_line_and_exit_2(tmp_path, text, needle):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    res = run("modes", str(path), "--json")
    assert res.returncode == 2
    assert res.stdout == ""
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in res.stderr
    assert "bad.toml" in lines[0] and needle in lines[0]


def test_bad_argument_one_line(model_file):
    res = run("modes", str(model_file), "--fmax", "-5")
    assert res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1


def test_simulate_json_contract(capsys):
    """`ufmt simulate --json`: one JSON object with the metrics the issue lists."""
    assert main(["simulate", "--json", "--rpm", "350", "--feed", "10", "--depth", "3"]) == 0
    out = json.loads(capsys.readouterr().out)
    for key in (
        "pv_nm",
        "pv_tilt_removed_nm",
        "rms_nm",
        "zre_peak_nm",
        "tip_acc_peak_mm_s2",
    ):
        assert np.isfinite(out[key])
    # PSD1 not resolved: the 52.4 mm plate spans < 3 periods of 33 mm (tests/test_psd.py);
    # PSD2 resolved by the line profiles at 0.03 mm (tests/test_lines.py)
    assert out["psd1_rms_nm"] is None and out["psd2_rms_nm"] > 0
    assert out["psd_line_spacing_mm"] == pytest.approx(0.03)
    assert out["pv_nm"] > 0


def test_simulate_rejects_non_physical_process():
    res = run("simulate", "--rpm", "nan")
    assert res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1
    assert "Traceback" not in res.stderr


def test_simulate_warns_outside_table_1(capsys):
    assert main(["simulate", "--json", "--rpm", "500"]) == 0
    captured = capsys.readouterr()
    assert "outside" in captured.err and "rpm" in captured.err
    assert json.loads(captured.out)["pv_nm"] > 0
