"""The README's five-line notebook session: load, modes, simulate,
evaluate, plot work as written, and every object a notebook would echo has a repr under
1,000 characters (oracle: the README's own lines; the repr bound of the API style)."""

from __future__ import annotations

import math

from matplotlib.figure import Figure

import ufmt


def test_the_readme_notebook_session_runs_with_short_reprs(monkeypatch):
    monkeypatch.setenv("UFMT_CACHE_DIR", "")  # no cache: the session computes
    model = ufmt.load_model()
    modes = ufmt.solve_modes(model, count=30)
    result = ufmt.simulate(model, ufmt.Process(300, 15, 4))
    record = ufmt.evaluate({"head_axial_stiffness_N_m": 1e9}, ufmt.Process(300, 15, 4))
    figure = result.plot()

    assert isinstance(figure, Figure)
    assert len(modes.frequencies_hz) == 30 and record["status"] == "ok"
    assert math.isfinite(record["pv_nm"]) and math.isfinite(result.metrics["pv_nm"])
    for shown in (model, modes, result):
        assert len(repr(shown)) < 1000, type(shown).__name__
    assert repr(model).startswith("Model(") and "13 bodies" in repr(model)
