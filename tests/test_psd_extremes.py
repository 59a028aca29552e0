"""The PSD figure of a sweep's best and worst designs.

Oracles: the two designs are the lowest and highest interferometer PV of points.csv (an
ordering of the table), and their recomputation through ``ufmt.simulate`` gives back the PV
the study recorded through ``ufmt.evaluate`` (two independent entry points to the same
physics). A run without plots simulates nothing.
"""

from __future__ import annotations

import numpy as np
import pytest

from ufmt.studies import sweep
from ufmt.studies.load import load_study
from ufmt.studies.outputs import read_meta, read_table
from ufmt.studies.parallel import Execution
from ufmt.studies.runner import run_study

STUDY = """
name = "psd-extremes"
kind = "sweep"
[[axis]]
parameter = "rpm"
values = [250.0, 350.0]
"""


def _run(path, results, plots):
    return run_study(path, Execution(jobs=1), results=results, progress=False, plots=plots)


def test_best_and_worst_psd_figure_is_drawn_only_with_plots(tmp_path, monkeypatch):
    path = tmp_path / "psd-extremes.toml"
    path.write_text(STUDY, encoding="utf-8")

    def refuse(*args, **kwargs):
        raise AssertionError("a run without plots simulated a point")

    with monkeypatch.context() as patch:
        patch.setattr(sweep, "simulate_point", refuse)
        out = _run(path, tmp_path / "r", plots=False)
    assert not (out / sweep.EXTREMES_FIGURE).exists()

    out = _run(path, tmp_path / "r", plots=True)  # reuses the two points, then plots
    assert sweep.EXTREMES_FIGURE in read_meta(out)["plots"]
    assert (out / sweep.EXTREMES_FIGURE).stat().st_size > 0

    table = read_table(out / "points.csv")
    ranking = load_study(path).options["metric"]
    metric = table[ranking].to_numpy(dtype=float)
    assert np.all(np.isfinite(metric)) and metric.min() < metric.max()
    best = table.iloc[int(np.argmin(metric))]
    result = sweep.simulate_point(load_study(path), best)
    assert result.metrics[ranking] == pytest.approx(metric.min(), rel=1e-9)
