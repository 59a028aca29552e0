"""``machine.<key>`` design parameters: the [machine] values a study or an uncertainty analysis
varies (force coefficient, geometric error amplitudes, plate size), set through the same
checks as the model file's."""

from __future__ import annotations

import math

import pytest

from ufmt.design import apply_design, design_value, machine_parameters, unknown_design_parameter
from ufmt.errors import ModelError, StudyError
from ufmt.evaluate import evaluate
from ufmt.model.load import load_model
from ufmt.model.machine import OPTIONAL_FIELDS


def test_every_optional_machine_number_is_a_parameter():
    names = machine_parameters()
    for key in OPTIONAL_FIELDS:
        assert f"machine.{key}" in names
    model = load_model()
    assert all(unknown_design_parameter(n, model) is None for n in names)


def test_machine_parameter_round_trip_and_band():
    model = load_model()
    changed = apply_design(
        model, {"machine.straightness_m": 7e-8, "machine.workpiece_size[1]": 0.1}
    )
    assert changed.machine.straightness_m == 7e-8
    assert changed.machine.workpiece_size[1] == 0.1
    assert design_value(changed, "machine.straightness_m") == 7e-8
    assert design_value(changed, "machine.workpiece_size[1]") == 0.1
    assert model.machine.straightness_m != 7e-8  # the loaded model is untouched
    with pytest.raises(ModelError, match="straightness_m.*outside the allowed range"):
        apply_design(model, {"machine.straightness_m": 5e-5})
    with pytest.raises(StudyError, match="did you mean 'machine.straightness_m'"):
        apply_design(model, {"machine.straightnes_m": 1e-8})


def test_force_scale_scales_the_vibration_linearly():
    """Oracle: the response is linear in the cutting force, so z_re and the acceleration
    scale with force_scale (and the record is not a cached one of another value)."""
    process = {"rpm": 300.0, "feed_mm_min": 15.0, "depth_um": 4.0}
    one = evaluate({"machine.force_scale": 1.0}, process)
    two = evaluate({"machine.force_scale": 2.0}, process)
    assert two["zre_peak_nm"] == pytest.approx(2.0 * one["zre_peak_nm"], rel=1e-9)
    assert two["force_peak_n"] == pytest.approx(2.0 * one["force_peak_n"], rel=1e-9)
    assert math.isfinite(one["waviness_rms_nm"]) and math.isfinite(one["tip_acc_measured_mm_s2"])
