"""The packaged UFMT model with ``[machine] force_scale = 1``: the packaged structure with the
literature force coefficients, whatever force_scale the calibration fitted (for tests whose
oracle or edited text assumes the unit factor).
"""

import re
from importlib import resources

from ufmt.model.load import load_model_text


def packaged_text() -> str:
    """Text of the packaged model with force_scale = 1."""
    text = resources.files("ufmt.data").joinpath("ufmt.toml").read_text()
    return re.sub(r"(?m)^force_scale = .*$", "force_scale = 1.0", text)


def packaged_model():
    """The packaged model (force_scale = 1), loaded."""
    return load_model_text(packaged_text(), "ufmt.toml")
