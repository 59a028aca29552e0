"""Fixtures shared by the test modules (stateless helpers are in synthetic.py).

Models are immutable, so one loaded object serves the whole session.
"""

import os

import pytest
from synthetic import packaged_model

from ufmt.machining.modal import modal_basis
from ufmt.model.load import load_model


@pytest.fixture(scope="session", autouse=True)
def _own_evaluation_cache(tmp_path_factory):
    """Each test session (each pytest-xdist worker) has an evaluation cache of its own, empty
    at the start: no test reuses points that an earlier run or another worker left in the
    user's cache, so a run computes what a fresh clone computes. Tests that need a cache of
    their own (or none) still set UFMT_CACHE_DIR themselves."""
    before = os.environ.get("UFMT_CACHE_DIR")
    os.environ["UFMT_CACHE_DIR"] = str(tmp_path_factory.mktemp("evaluation-cache"))
    yield
    if before is None:
        os.environ.pop("UFMT_CACHE_DIR", None)
    else:
        os.environ["UFMT_CACHE_DIR"] = before


@pytest.fixture(scope="session")
def packaged():
    """The packaged, calibrated UFMT."""
    return load_model()


@pytest.fixture(scope="session")
def packaged_basis(packaged):
    """The packaged UFMT's default modal basis (every mode below the default cutoff, the slide
    half way through the cut), as ``ufmt.simulate`` and ``ufmt validate`` build it."""
    return modal_basis(packaged)


@pytest.fixture(scope="session")
def packaged_unit_force():
    """The packaged UFMT with ``force_scale = 1`` (the literature force coefficients)."""
    return packaged_model()
