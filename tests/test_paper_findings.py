"""The paper's findings (section 4.2, Figs. 15-16) as properties of the packaged model, and
the force calibration of Table 4 (the packaged model's force scale reproduces the measured PV).
"""

from functools import lru_cache

import numpy as np
import pytest

from ufmt.machining.process import Process
from ufmt.model.load import load_model, packaged_path
from ufmt.simulate import simulate
from ufmt.tomlfile import read_toml

REFERENCE = Process(300.0, 15.0, 4.0)


@lru_cache(maxsize=1)
def packaged():
    return load_model(packaged_path())


def pv(model, process=REFERENCE, **options) -> float:
    return simulate(model, process, **options).metrics["pv_nm"]


def scaled_hinge(name, translation=(1, 1, 1), rotation=(1, 1, 1)):
    model = packaged()
    h = model.hinge(name)
    return model.with_hinge(
        name,
        stiffness=h.stiffness * np.asarray(translation),
        rotational_stiffness=h.rotational_stiffness * np.asarray(rotation),
    )


def test_force_scale_lies_in_its_physical_band():
    """Issue 8: specific cutting forces of diamond on KDP allow a factor 0.3-3 on the
    literature coefficients (docs/ufmt-model.md, response calibration)."""
    assert 0.3 <= packaged().machine["force_scale"] <= 3.0


@pytest.mark.xfail(
    strict=True,
    reason=(
        "not reproduced: with force_scale inside [0.3, 3] cutting-force vibration alone gives a "
        "PV of ~13 nm (the response fit ends at the band's edge, results/validation/"
        "response.csv); the paper's 142.91 nm must contain error sources this model does not "
        "have yet (issue 8 item 3)"
    ),
)
def test_packaged_model_reproduces_the_measured_pv():
    """Table 4: 142.91 nm measured (laser interferometer), within 10 %."""
    measured = read_toml(packaged_path("paper_reference.toml"))["surface_pv"]["measured_nm"]
    assert pv(packaged()) == pytest.approx(measured, rel=0.10)


@pytest.mark.xfail(
    strict=True,
    reason=(
        "not reproduced after the recalibration with the head bearing's geometric tilt "
        "stiffness and the spindle-bearing constraint: PV against the h31 tilt factor "
        "0.25/0.5/1/2/4 is 11.96/10.28/10.65/10.61/9.13 nm, not monotone; with PV from "
        "cutting-force vibration alone the tilt mostly shifts modes against the spindle "
        "harmonics"
    ),
)
def test_stiffer_angular_head_bearing_lowers_pv():
    """Fig. 15: the higher the head's angular air-bearing stiffness, the better."""
    values = [pv(scaled_hinge("h31", rotation=(f, f, 1))) for f in (0.5, 1.0, 2.0)]
    assert values[0] > values[1] > values[2]


@pytest.mark.parametrize(
    "better, worse",
    [
        (Process(400.0, 15.0, 4.0), Process(200.0, 15.0, 4.0)),  # higher spindle speed
        (Process(300.0, 4.0, 4.0), Process(300.0, 16.0, 4.0)),  # lower feed
        (Process(300.0, 15.0, 2.0), Process(300.0, 15.0, 8.0)),  # smaller depth of cut
    ],
)
def test_process_trends_of_fig_16(better, worse):
    assert pv(packaged(), better) < pv(packaged(), worse)


@pytest.mark.xfail(
    strict=True,
    reason=(
        "not reproduced: the identification now carries the paper's statement as a constraint "
        "(h25 x2 moves no tool-tip z mode by more than 2 %), but Table 3 cannot be fitted with "
        "it met (largest h25 strain-energy share 0.20 against 0.057 allowed); doubling h25 "
        "still lowers PV by ~23 %, halving it raises PV by ~5 % (the head bearing h31: -51 % "
        "and +77 %)"
    ),
)
def test_spindle_air_bearing_changes_pv_little():
    """Section 4.2: the spindle air-bearing stiffness has little influence (here: < 5 % for a
    factor 2 either way)."""
    base = pv(packaged())
    for f in (0.5, 2.0):
        changed = pv(scaled_hinge("h25", translation=(f, f, f), rotation=(f, f, 1)))
        assert abs(changed / base - 1) < 0.05
