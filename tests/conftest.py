"""Fixtures shared by the test modules (stateless helpers are in synthetic.py).

Models are immutable, so one loaded object serves the whole session.
"""

import pytest
from synthetic import packaged_model

from ufmt.model.load import load_model


@pytest.fixture(scope="session")
def packaged():
    """The packaged, calibrated UFMT."""
    return load_model()


@pytest.fixture(scope="session")
def packaged_unit_force():
    """The packaged UFMT with ``force_scale = 1`` (the literature force coefficients)."""
    return packaged_model()
