"""The user-machine example in examples/: a model that is not the packaged one, simulated and
swept end to end through the CLI over a design parameter it declares itself (oracle: the study's
own points agree with the simulation at the base design, and the cutting-force vibration's PV
falls as the spindle's axial bearing stiffens)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from ufmt.cli import main
from ufmt.studies.outputs import read_table

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.fixture(autouse=True)
def _own_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("UFMT_CACHE_DIR", str(tmp_path / "cache"))


def test_example_simulates_and_its_study_runs(tmp_path, capsys):
    assert main(["simulate", str(EXAMPLES / "bridge.toml"), "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["model"] == "spindle on a bridge" and record["pv_nm"] > 0

    results = tmp_path / "results"
    study = EXAMPLES / "bridge-sweep.toml"
    assert main(["run", str(study), "--results", str(results), "--jobs", "1"]) == 0
    points = read_table(results / "bridge-sweep" / "points.csv")
    assert (points["status"] == "ok").all() and len(points) == 5
    stiffness = points["spindle_axial_stiffness_N_m"].to_numpy()
    # the middle point is the model's own value (scale 1): the same PV as `ufmt simulate`
    assert np.isclose(stiffness[2], 4e8)
    assert np.isclose(points["pv_nm"].iloc[2], record["pv_nm"], rtol=1e-9)
    assert np.all(np.diff(points["pv_dynamic_nm"].to_numpy()) < 0)
