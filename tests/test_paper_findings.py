"""The paper's findings (section 4.2, Figs. 15-16) as properties of the packaged model, judged
on both metrics, and the response calibration of Table 4.

Two PVs judge each finding: the whole-plate PV (``pv_nm``: max - min of every point, as the
paper defines it) and the PV as the laser interferometer measures it (``pv_measured_nm``:
clear aperture, piston and tilt removed, feed marks below its lateral resolution; the
quantity Table 4 compares, ufmt.machining.instruments). The paper's bearing findings come
from its dynamic model, so they are also judged on the cutting-force vibration's PV alone
(``pv_by_source_nm["dynamic"]``); where a statement is not reproduced on a metric, a strict
expected failure says so with the numbers (packaged model of this commit).
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


METRICS = ("pv_nm", "pv_measured_nm")


def pv(model, process=REFERENCE, metric="pv_nm") -> float:
    return simulate(model, process).metrics[metric]


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


@pytest.mark.xfail(
    strict=True,
    reason=(
        "the packaged model was fitted in the former band 0.3-3 and sits at 3 (specific "
        "thrust 9.6 GPa); the band from the specific forces of diamond on KDP is 0.5-5/3 "
        "until the model is recalibrated in it"
    ),
)
def test_force_scale_lies_in_its_physical_band():
    """Specific cutting forces >= 1 GPa and specific thrust <= 5 GPa for diamond on KDP
    (docs/ufmt-model.md, 'Cutting force'): the calibration band of force_scale."""
    fits = read_toml(packaged_path("calibration.toml"))["response"]["parameter"]
    low, high = next(p["band"] for p in fits if p["key"] == "force_scale")
    assert low <= packaged().machine.force_scale <= high


@pytest.mark.xfail(
    strict=True,
    reason=(
        "not reproduced: the interferometer's PV is 6.5 nm against 142.91 nm with the "
        "geometric sources as physics (the guideway carried by the carriage's pads prints "
        "< 1 nm on the 52.4 mm plate; at their typical values every geometric source together "
        "adds < 2 nm); the workholding form (band +-150 nm, held at 0) is the one documented "
        "source that reaches Table 4's size: 150 nm of bowl gives 93.9 nm inside the aperture"
    ),
)
def test_packaged_model_reproduces_the_measured_pv():
    """Table 4: 142.91 nm measured (laser interferometer), within 10 %, as the interferometer
    stage measures our surface (the response fit's primary target)."""
    measured = read_toml(packaged_path("paper_reference.toml"))["surface_pv"]["measured_nm"]
    assert pv(packaged(), metric="pv_measured_nm") == pytest.approx(measured, rel=0.10)


@pytest.mark.parametrize("metric", METRICS)
def test_stiffer_angular_head_bearing_lowers_pv(metric):
    """Fig. 15: the higher the head's angular air-bearing stiffness, the better (0.5x/1x/2x;
    this commit: measured 6.80/6.55/5.79 nm, whole plate 97.90/96.80/95.06 nm)."""
    values = [pv(scaled_hinge("h31", rotation=(f, f, 1)), metric=metric) for f in (0.5, 1, 2)]
    assert values[0] > values[1] > values[2]


def test_stiffer_angular_head_bearing_lowers_the_vibration_pv():
    """Fig. 15 on the paper's own surface (the cutting-force vibration alone). With the tool
    carrier ringing on the head (ufmt.machining.tool) it falls: 64.587/64.534/64.422 nm at
    the h31 tilt factor 0.5/1/2 (with a massless tool it did not: 39.59/39.35/40.32 nm)."""
    values = [dynamic_pv(scaled_hinge("h31", rotation=(f, f, 1))) for f in (0.5, 1.0, 2.0)]
    assert values[0] > values[1] > values[2]


@pytest.mark.parametrize("metric", METRICS)
@pytest.mark.parametrize(
    "better, worse",
    [
        (Process(400.0, 15.0, 4.0), Process(200.0, 15.0, 4.0)),  # higher spindle speed
        (Process(300.0, 4.0, 4.0), Process(300.0, 16.0, 4.0)),  # lower feed
        (Process(300.0, 15.0, 2.0), Process(300.0, 15.0, 8.0)),  # smaller depth of cut
    ],
)
def test_process_trends_of_fig_16(better, worse, metric):
    assert pv(packaged(), better, metric) < pv(packaged(), worse, metric)


def spindle_bearing_changes(measure) -> list[float]:
    """Relative change of ``measure(model)`` for the h25 bearing x0.5 and x2."""
    base = measure(packaged())
    return [
        measure(scaled_hinge("h25", translation=(f, f, f), rotation=(f, f, 1))) / base - 1
        for f in (0.5, 2.0)
    ]


@pytest.mark.parametrize(
    "metric",
    [
        "pv_nm",
        pytest.param(
            "pv_measured_nm",
            marks=pytest.mark.xfail(
                strict=True,
                reason=(
                    "not reproduced on the interferometer's PV once the geometric sources are "
                    "physics (the guideway carried by the pads prints < 1 nm on the 52.4 mm "
                    "plate): it is then the vibration inside the aperture, 6.55 nm, which h25 "
                    "x0.5 / x2 moves by +6.3 / -12.8 % (it diluted the bearing's effect when a "
                    "fitted 200 nm straightness wave made it 65.5 nm)"
                ),
            ),
        ),
    ],
)
def test_spindle_air_bearing_changes_pv_little(metric):
    """Section 4.2: the spindle air-bearing stiffness has little influence (here: < 5 % for a
    factor 2 either way; this commit: whole plate +0.2 / -1.1 %)."""
    changes = spindle_bearing_changes(lambda model: pv(model, metric=metric))
    assert max(abs(c) for c in changes) < 0.05


def test_spindle_air_bearing_changes_the_vibration_pv_little():
    """Section 4.2 on the cutting-force vibration's PV (the paper's dynamic response); this
    commit: h25 x0.5 / x2 move it by +0.7 / -0.2 % (39.35 -> 39.64 / 39.26 nm). Reproduced
    since the tool and holder's compliance (13.4 nm/N, fitted to z_re) is in the model: it
    is four times the machine's at the point cut, so the bearing's share of z_re is small.
    The identification still cannot meet the constraint this statement sets on Table 3
    (largest h25 strain-energy share 0.20 against 0.057)."""
    assert max(abs(c) for c in spindle_bearing_changes(dynamic_pv)) < 0.05
