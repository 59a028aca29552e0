"""The paper's findings (section 4.2, Figs. 15-16) as properties of the packaged model, and
the response calibration of Table 4 (the packaged model reproduces the measured PV).

Which PV judges a finding: the measured PV (Table 4, laser interferometer) is the whole
surface, so it is compared with our total PV (every error source). The paper's bearing
findings (Fig. 15, section 4.2) come from its dynamic model, whose surface is the
cutting-force vibration alone; ours also carries geometric error sources (feed marks, spindle
tilt, error motion, straightness) that no stiffness changes, so those findings are judged on
``pv_by_source_nm["dynamic"]`` (docs/ufmt-model.md, 'The paper's findings').
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


def dynamic_pv(model) -> float:
    """PV [nm] of the surface the cutting-force vibration alone leaves (the paper's surface)."""
    return simulate(model, REFERENCE).pv_by_source_nm["dynamic"]


def scaled_hinge(name, translation=(1, 1, 1), rotation=(1, 1, 1)):
    model = packaged()
    h = model.hinge(name)
    return model.with_hinge(
        name,
        stiffness=h.stiffness * np.asarray(translation),
        rotational_stiffness=h.rotational_stiffness * np.asarray(rotation),
    )


def test_force_scale_lies_in_its_physical_band():
    """Specific cutting forces of diamond on KDP allow a factor 0.3-3 on the
    literature coefficients (docs/ufmt-model.md, response calibration)."""
    assert 0.3 <= packaged().machine.force_scale <= 3.0


def test_packaged_model_reproduces_the_measured_pv():
    """Table 4: 142.91 nm measured (laser interferometer), within 10 % (the validation's
    'reproduced' criterion, ufmt.calibration.response). The PV is the response fit's primary
    target, so this checks that the calibration landed, not an independent prediction."""
    measured = read_toml(packaged_path("paper_reference.toml"))["surface_pv"]["measured_nm"]
    assert pv(packaged()) == pytest.approx(measured, rel=0.10)


@pytest.mark.xfail(
    strict=True,
    reason=(
        "not reproduced: the cutting-force vibration's PV against the h31 tilt factor "
        "0.5/1/2 is 12.30/12.35/13.32 nm, rising, although z_re's average peak falls: stiffer "
        "tilt shifts the head modes against the spindle harmonics and the surface's minimum "
        "over passes. The total PV falls, 143.05/142.91/141.72 nm, but by 1 % through the "
        "geometric sources the paper's model does not have (packaged model of this commit)"
    ),
)
def test_stiffer_angular_head_bearing_lowers_pv():
    """Fig. 15: the higher the head's angular air-bearing stiffness, the better (the paper's
    dynamic surface: judged on the cutting-force vibration's PV)."""
    values = [dynamic_pv(scaled_hinge("h31", rotation=(f, f, 1))) for f in (0.5, 1.0, 2.0)]
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


def test_spindle_air_bearing_changes_pv_little():
    """Section 4.2: the spindle air-bearing stiffness has little influence (here: < 5 % for a
    factor 2 either way), on the cutting-force vibration's PV (the paper's dynamic response).
    Packaged model of this commit: +1.0 % / -4.0 % for h25 x0.5 / x2 (12.35 -> 12.48 / 11.86
    nm). Its identification still cannot meet the constraint this statement sets on Table 3
    (largest h25 strain-energy share 0.20 against 0.057 allowed: README, findings)."""
    base = dynamic_pv(packaged())
    for f in (0.5, 2.0):
        changed = dynamic_pv(scaled_hinge("h25", translation=(f, f, f), rotation=(f, f, 1)))
        assert abs(changed / base - 1) < 0.05
