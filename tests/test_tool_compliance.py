"""The tool and holder as a compliant element: a z spring between the tool body and the tip."""

import dataclasses
import re

import numpy as np
import pytest

from ufmt.errors import ModelError
from ufmt.machining.frf import tool_workpiece_receptance
from ufmt.machining.modal import modal_basis
from ufmt.machining.static import residual_flexibility
from ufmt.model.load import load_model_text
from ufmt.model.machine import machine_of


def shank_compliance(side_m: float, overhang_m: float, youngs_pa: float = 2.1e11) -> float:
    """Oracle: tip compliance of a cantilever of square section, L^3 / (3 E I), I = b^4 / 12."""
    return overhang_m**3 / (3 * youngs_pa * side_m**4 / 12)


def test_prior_value_and_band_are_the_shank_geometry():
    """The prior's value is the 10 mm shank at 25 mm overhang; the calibration band spans
    12 mm at 20 mm to 8 mm at 30 mm (docs/ufmt-model.md)."""
    import tomllib
    from importlib import resources

    data = resources.files("ufmt.data")
    prior = tomllib.loads(data.joinpath("ufmt-prior.toml").read_text())["machine"]
    assert prior["tool_compliance_m_per_N"] == pytest.approx(shank_compliance(0.010, 0.025), 1e-3)
    calibration = tomllib.loads(data.joinpath("calibration.toml").read_text())
    (entry,) = [
        p for p in calibration["response"]["parameter"] if p["key"] == "tool_compliance_m_per_N"
    ]
    lo, hi = entry["band"]
    assert lo == pytest.approx(shank_compliance(0.012, 0.020), 1e-3)
    assert hi == pytest.approx(shank_compliance(0.008, 0.030), 1e-2)


@pytest.mark.parametrize("tool_angle", [0.0, 0.6])
def test_the_tool_adds_its_compliance_to_the_receptance_at_every_frequency(packaged, tool_angle):
    """Closed form: a massless spring in series at the tip adds c to H(W) at every W, whatever
    the tip's place on the circle (the spring's mode is far above the band)."""
    machine = machine_of(packaged)
    basis = modal_basis(packaged, 30)
    c = 2.5e-8
    rigid = dataclasses.replace(machine, tool_compliance_m_per_N=0.0)
    soft = dataclasses.replace(machine, tool_compliance_m_per_N=c)
    freq = np.array([1.0, 80.0, 250.0, 766.0])
    h = [
        tool_workpiece_receptance(
            basis, m, freq, tool_angle=tool_angle, residual=residual_flexibility(packaged, basis, m)
        )
        for m in (rigid, soft)
    ]
    np.testing.assert_allclose(h[1] - h[0], c, rtol=1e-9, atol=0)


def test_a_negative_compliance_is_refused():
    from synthetic import packaged_text

    text = re.sub(r"(?m)^tool_compliance_m_per_N = .*$", "", packaged_text())
    text = text.replace("[machine]\n", "[machine]\ntool_compliance_m_per_N = -1e-9\n")
    with pytest.raises(ModelError, match="tool_compliance_m_per_N"):
        load_model_text(text, "ufmt.toml")
