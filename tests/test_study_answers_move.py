"""A packaged study's answer moves when the machine's dynamics move. The process sweep's
answer (the lowest interferometer PV over its speed axis) on the calibrated machine and on
the same machine with the fly-cutting head's axial air bearing softened tenfold, which lowers
the head's z mode and raises the tool-workpiece static compliance in z by several per cent
(`ufmt frf` at 1 Hz). z_re's peak is not asserted: it is the tool carrier's ringing half a
carrier period after the force's entry step, where the head mode is mass-controlled, so it
does not follow the static compliance (tests/test_pulse_closed_form.py)."""

from __future__ import annotations

import pandas as pd
import pytest

import ufmt
from ufmt.design import design_value
from ufmt.studies.parallel import Execution
from ufmt.studies.runner import run_study

STUDY = """kind = "sweep"
name = "answer"

[base]
feed_mm_min = 15.0
depth_um = 4.0
{base}
[[axis]]
parameter = "rpm"
values = [250.0, 350.0]
"""


def lowest(tmp_path, name: str, base: str = "") -> pd.Series:
    """The lowest value of every metric over the speed axis."""
    path = tmp_path / f"{name}.toml"
    path.write_text(STUDY.format(base=base))
    run_study(path, Execution(jobs=1), results=tmp_path / name, progress=False)
    points = pd.read_csv(tmp_path / name / "answer" / "points.csv")
    ok = points[points["status"] == "ok"]
    assert len(ok) == 2
    return ok[["pv_measured_nm"]].min()


@pytest.fixture(scope="module")
def answers(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("answers")
    calibrated = design_value(ufmt.load_model(), "head_axial_stiffness_N_m")
    soft = f"head_axial_stiffness_N_m = {0.1 * calibrated!r}\n"
    return lowest(tmp, "base"), lowest(tmp, "soft", soft)


def test_the_shops_answer_moves_when_the_head_axial_bearing_softens(answers):
    """The default answer (the interferometer's PV) changes by more than rounding."""
    base, soft = answers
    assert abs(soft["pv_measured_nm"] / base["pv_measured_nm"] - 1) > 5e-3
