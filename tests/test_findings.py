"""The paper's findings like for like (ufmt.studies.findings): oracle, a study function of
closed form whose change at each axis end is known exactly, run through a real sweep with
``findings = true``; the report's Summary shows the same rows."""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ufmt.studies.findings import FINDINGS, LITTLE, findings_table
from ufmt.studies.outputs import read_meta, read_table
from ufmt.studies.parallel import Execution
from ufmt.studies.runner import run_study

HERE = Path(__file__).resolve()
BASE = {
    "rpm": 300.0,
    "feed_mm_min": 15.0,
    "depth_um": 4.0,
    "head_angular_stiffness_Nm_rad": 1e7,
    "spindle_radial_stiffness_N_m": 2e8,
    "spindle_axial_stiffness_N_m": 3e8,
    "spindle_angular_stiffness_Nm_rad": 5e6,
}
SPINDLE = [k for k in BASE if k.startswith("spindle")]


def power_pv(design, process, model=None):
    """Steady-cut PV = 20 a^-0.1 s^0.01 (rpm/300)^-0.5 and interferometer PV = 10 a^0.05
    s^-0.2 (rpm/300)^0.3, a and s the head's angular and the spindle bearing's scale (the
    geometric mean of its three components)."""
    a = design.get("head_angular_stiffness_Nm_rad", BASE["head_angular_stiffness_Nm_rad"])
    a /= BASE["head_angular_stiffness_Nm_rad"]
    s = np.prod([design.get(k, BASE[k]) / BASE[k] for k in SPINDLE]) ** (1 / 3)
    n = process["rpm"] / 300.0
    steady = 20.0 * a**-0.1 * s**0.01 * n**-0.5
    measured = 10.0 * a**0.05 * s**-0.2 * n**0.3
    return {"pv_nm": measured, "pv_dynamic_steady_nm": steady, "pv_measured_nm": measured}


STUDY = """
kind = "sweep"
findings = true

[base]
rpm = 300.0
feed_mm_min = 15.0
depth_um = 4.0
head_angular_stiffness_Nm_rad = 1e7
spindle_radial_stiffness_N_m = 2e8
spindle_axial_stiffness_N_m = 3e8
spindle_angular_stiffness_Nm_rad = 5e6

[[axis]]
parameter = "head_angular_stiffness_Nm_rad"
values = [5e6, 1e7, 2e7]

[[axis]]
parameter = "rpm"
values = [200.0, 300.0, 400.0]

[[grid]]
name = "spindle_bearing"
[[grid.axis]]
parameter = "spindle_radial_stiffness_N_m"
values = [1e8, 4e8]
[[grid.axis]]
parameter = "spindle_axial_stiffness_N_m"
values = [1.5e8, 6e8]
[[grid.axis]]
parameter = "spindle_angular_stiffness_Nm_rad"
values = [2.5e6, 1e7]
"""


@pytest.fixture(scope="module")
def findings(tmp_path_factory):
    folder = tmp_path_factory.mktemp("findings")
    path = folder / "paper-findings.toml"
    path.write_text(f'function = "{HERE}:power_pv"\n' + textwrap.dedent(STUDY), "utf-8")
    out = run_study(path, Execution(jobs=1), results=folder / "results", progress=False)
    return out, read_table(out / FINDINGS).set_index(["key", "metric"])


def _change(factor: float, exponent: float) -> float:
    return 100.0 * (factor**exponent - 1.0)


def test_each_statement_gets_its_closed_form_change_and_verdict(findings):
    _, table = findings
    head = table.loc[("head-angular", "pv_dynamic_steady_nm")]
    assert head[["change_low_percent", "change_high_percent"]].tolist() == pytest.approx(
        [_change(0.5, -0.1), _change(2.0, -0.1)], rel=1e-9
    )
    assert head["found"] == "falls" and head["reproduced"]  # stiffer: lower, as the paper says
    head = table.loc[("head-angular", "pv_measured_nm")]
    assert head["found"] == "rises" and not head["reproduced"]
    # the whole spindle bearing scaled together (the grid's corners), not one direction
    spindle = table.loc[("spindle", "pv_dynamic_steady_nm")]
    assert spindle["effect_percent"] == pytest.approx(
        _change(2.0, 0.01), rel=1e-9
    )  # the larger end
    assert spindle["effect_percent"] < 100 * LITTLE and spindle["reproduced"]
    spindle = table.loc[("spindle", "pv_measured_nm")]
    assert spindle["effect_percent"] == pytest.approx(_change(0.5, -0.2), rel=1e-9)
    assert not spindle["reproduced"]  # 14.9 % is not "little"
    speed = table.loc[("speed", "pv_dynamic_steady_nm")]
    assert [speed["low"], speed["high"]] == [200.0, 400.0]
    assert speed["change_high_percent"] == pytest.approx(_change(4 / 3, -0.5), rel=1e-9)
    assert speed["reproduced"] and not table.loc[("speed", "pv_measured_nm")]["reproduced"]
    # head against spindle: |head effect| > |spindle effect| on the steady cut only
    assert table.loc[("head-vs-spindle", "pv_dynamic_steady_nm")]["reproduced"]
    assert not table.loc[("head-vs-spindle", "pv_measured_nm")]["reproduced"]
    # statements whose points the study does not have are left out, not guessed
    keys = set(table.index.get_level_values("key"))
    assert keys == {"head-angular", "spindle", "speed", "head-vs-spindle"}


def test_the_headline_counts_what_the_table_reproduces(findings):
    out, table = findings
    headline = read_meta(out)["headline"]
    steady = table.xs("pv_dynamic_steady_nm", level="metric")["reproduced"]
    measured = table.xs("pv_measured_nm", level="metric")["reproduced"]
    assert f"{int(steady.sum())} of {len(steady)} reproduced" in headline
    assert f"{int(measured.sum())} of {len(measured)} reproduced" in headline


def test_a_statement_needs_both_ends_and_the_base():
    points = pd.DataFrame(
        {"head_angular_stiffness_Nm_rad": [1e7, 2e7], "pv_measured_nm": [10.0, 9.0]}
    )
    assert findings_table(points, {"head_angular_stiffness_Nm_rad": 1e7}).empty


def test_the_summary_shows_one_row_per_statement(findings):
    from ufmt.report_summary import findings_summary

    out, table = findings
    name, summary = findings_summary([(out.name, out, {})])
    assert name == out.name
    assert len(summary) == len(set(table.index.get_level_values("key")))
    row = summary.iloc[0]
    assert row["steady-cut vibration: reproduced"] == "yes"
    assert row["interferometer PV: reproduced"] == "NO"
    assert row["varied"].endswith("×0.5 → ×2")
    assert "_" not in row["varied"]  # words, not a code identifier
