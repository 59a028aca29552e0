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


def test_force_scale_lies_in_its_physical_band():
    """Specific cutting forces >= 1 GPa and specific thrust <= 5 GPa for diamond on KDP
    (docs/ufmt-model.md, 'Cutting force'): the calibration band of force_scale."""
    fits = read_toml(packaged_path("calibration.toml"))["response"]["parameter"]
    low, high = next(p["band"] for p in fits if p["key"] == "force_scale")
    assert low <= packaged().machine.force_scale <= high


@pytest.mark.xfail(
    strict=True,
    reason=(
        "not reproduced: the interferometer's PV is 9.8 nm against 142.91 nm with the "
        "geometric sources as physics at their typical values (the guideway carried by the "
        "carriage's pads prints < 1 nm on the 52.4 mm plate; every geometric source together "
        "adds < 2 nm) and the force at its documented value; the workholding form (band "
        "+-150 nm, held at 0) is the one documented source that reaches Table 4's size: "
        "150 nm of bowl gives 93.9 nm inside the aperture"
    ),
)
def test_packaged_model_reproduces_the_measured_pv():
    """Table 4: 142.91 nm measured (laser interferometer), within 10 %, as the interferometer
    stage measures our surface (compared, not fitted: no fitted key is a geometric source)."""
    measured = read_toml(packaged_path("paper_reference.toml"))["surface_pv"]["measured_nm"]
    assert pv(packaged(), metric="pv_measured_nm") == pytest.approx(measured, rel=0.10)


@pytest.mark.parametrize("metric", METRICS)
def test_stiffer_angular_head_bearing_lowers_pv(metric):
    """Fig. 15: the higher the head's angular air-bearing stiffness, the better (0.5x/1x/2x;
    this commit: interferometer 9.814/9.809/9.787 nm, whole plate 92.310/92.305/92.266 nm:
    monotone, but effects of 0.3 % and 0.05 %, far below the paper's "methodical effect")."""
    values = [pv(scaled_hinge("h31", rotation=(f, f, 1)), metric=metric) for f in (0.5, 1, 2)]
    assert values[0] > values[1] > values[2]


@pytest.mark.xfail(
    strict=True,
    reason=(
        "not reproduced on the vibration's own surface: at the h31 tilt factor 0.5/1/2 the "
        "steady-cut dynamic PV is 18.055/18.126/18.249 nm and the whole-plate one "
        "49.248/49.311/49.432 nm (rising by < 1.1 %); the tool and holder's compliance fitted to "
        "Fig. 13 (28.7 nm/N) is about eight times the machine's at the point cut, so the head's "
        "bearings barely reach the tool-workpiece compliance (z_re 34.944/34.942/34.939 nm)"
    ),
)
@pytest.mark.parametrize("metric", ["pv_dynamic_nm", "pv_dynamic_steady_nm"])
def test_stiffer_angular_head_bearing_lowers_the_vibration_pv(metric):
    """Fig. 15 on the paper's own surface, the cutting-force vibration alone: on the paper's
    definition (eq. 4.1, whole plate) and inside the steady cut (the machine, not the edge)."""
    values = [
        simulate(scaled_hinge("h31", rotation=(f, f, 1)), REFERENCE).metrics[metric]
        for f in (0.5, 1.0, 2.0)
    ]
    assert values[0] > values[1] > values[2]


SPEED_ON_THE_INTERFEROMETER = pytest.mark.xfail(
    strict=True,
    reason=(
        "not reproduced on the interferometer's PV: 9.32 nm at 400 rpm against 7.64 nm at "
        "200 rpm (15 mm/min, 4 um), while the whole-plate PV (62.1 against 184.8 nm) and the "
        "steady-cut vibration (17.3 against 21.8 nm) fall with speed as the paper says"
    ),
)


@pytest.mark.parametrize(
    "metric", ["pv_nm", "pv_dynamic_steady_nm", "pv_measured_nm"], ids=lambda m: m
)
@pytest.mark.parametrize(
    "better, worse",
    [
        (Process(400.0, 15.0, 4.0), Process(200.0, 15.0, 4.0)),  # higher spindle speed
        (Process(300.0, 4.0, 4.0), Process(300.0, 16.0, 4.0)),  # lower feed
        (Process(300.0, 15.0, 2.0), Process(300.0, 15.0, 8.0)),  # smaller depth of cut
    ],
)
def test_process_trends_of_fig_16(better, worse, metric, request):
    """Fig. 16: higher speed, lower feed, smaller depth give a lower PV: on the whole plate, on
    the vibration's steady cut and on the interferometer."""
    if better.rpm == 400.0 and metric == "pv_measured_nm":
        request.applymarker(SPEED_ON_THE_INTERFEROMETER)
    assert pv(packaged(), better, metric) < pv(packaged(), worse, metric)


def spindle_bearing_changes(measure) -> list[float]:
    """Relative change of ``measure(model)`` for the h25 bearing x0.5 and x2."""
    base = measure(packaged())
    return [
        measure(scaled_hinge("h25", translation=(f, f, f), rotation=(f, f, 1))) / base - 1
        for f in (0.5, 2.0)
    ]


@pytest.mark.parametrize("metric", METRICS)
def test_spindle_air_bearing_changes_pv_little(metric):
    """Section 4.2: the spindle air-bearing stiffness has little influence (here: < 5 % for a
    factor 2 either way; this commit, h25 x0.5 / x2: whole plate -0.01 / -0.01 %,
    interferometer +0.08 / -0.34 %)."""
    changes = spindle_bearing_changes(lambda model: pv(model, metric=metric))
    assert max(abs(c) for c in changes) < 0.05


def test_spindle_air_bearing_changes_the_vibration_pv_little():
    """Section 4.2 on the cutting-force vibration's PV (the paper's dynamic response); this
    commit: h25 x0.5 / x2 move it by +0.00 / +0.00 % (49.311 -> 49.312 / 49.313 nm). Reproduced
    since the tool and holder's compliance (28.7 nm/N, fitted to z_re) is in the model: it
    is about eight times the machine's at the point cut, so the bearing's share of z_re is
    small. The identification still cannot meet the constraint this statement sets on Table 3
    (largest h25 strain-energy share 0.20 against 0.057)."""
    assert max(abs(c) for c in spindle_bearing_changes(dynamic_pv)) < 0.05


def effect(model_of, metric) -> float:
    """The larger |relative change| of ``metric`` at the reference cut when ``model_of(f)``
    scales a bearing by f = 0.5 and f = 2 (the effect size of findings.csv)."""
    base = pv(packaged(), metric=metric)
    return max(abs(pv(model_of(f), metric=metric) / base - 1) for f in (0.5, 2.0))


def head_angular(f):
    return scaled_hinge("h31", rotation=(f, f, 1))


def spindle_bearing(f):
    return scaled_hinge("h25", translation=(f, f, f), rotation=(f, f, 1))


HEAD_AGAINST_SPINDLE_ON_THE_INTERFEROMETER = pytest.mark.xfail(
    strict=True,
    reason=(
        "not reproduced on the interferometer's PV: the head's angular stiffness at x0.5 / x2 "
        "moves it by at most 0.23 % and the whole spindle bearing by 0.34 %: the 'methodical "
        "effect' is no larger than the 'little influence' (on the steady-cut vibration: 0.68 "
        "against 0.025 %)"
    ),
)


@pytest.mark.slow  # ~20 s a metric; the fast suite's twin: tests/test_findings.py
@pytest.mark.parametrize(
    "metric",
    [
        "pv_dynamic_steady_nm",
        pytest.param("pv_measured_nm", marks=HEAD_AGAINST_SPINDLE_ON_THE_INTERFEROMETER),
    ],
)
def test_the_head_angular_stiffness_matters_more_than_the_spindle_bearing(metric):
    """Section 4.2 and Fig. 15 together: the spindle bearing's "little influence" against the
    head's angular "methodical effect" implies the head's effect is the larger (x0.5 / x2 of
    each; the whole spindle bearing, radial, axial and angular together)."""
    assert effect(head_angular, metric) > effect(spindle_bearing, metric)


AXIAL_ON_THE_INTERFEROMETER = pytest.mark.xfail(
    strict=True,
    reason=(
        "not reproduced on the interferometer's PV: the head's axial stiffness acts as the "
        "angular one is said to, only more: x0.5 / x1 / x2 give 9.837 / 9.809 / 9.737 nm "
        "(falling, -0.74 % at x2) against the angular's 0.23 %"
    ),
)


@pytest.mark.slow  # ~20 s a case; the fast suite's twin: tests/test_findings.py
@pytest.mark.parametrize(
    "direction, metric",
    [
        ("radial", "pv_dynamic_steady_nm"),
        ("radial", "pv_measured_nm"),
        ("axial", "pv_dynamic_steady_nm"),
        pytest.param("axial", "pv_measured_nm", marks=AXIAL_ON_THE_INTERFEROMETER),
    ],
)
def test_radial_and_axial_head_stiffness_do_not_act_as_the_angular(direction, metric):
    """Fig. 15: "the relations between radial and axial air-bearing stiffness and machined
    surface are not as that of the angular": not the angular's monotone fall with stiffness,
    or a smaller effect than the angular's (x0.5 / x1 / x2)."""
    translation = {"radial": (1, 1, 0), "axial": (0, 0, 1)}[direction]

    def model_of(f):
        return scaled_hinge("h31", translation=tuple(f if t else 1 for t in translation))

    values = [pv(model_of(f), metric=metric) for f in (0.5, 1.0, 2.0)]
    falls = values[0] > values[1] > values[2]
    assert not falls or effect(model_of, metric) < effect(head_angular, metric)
