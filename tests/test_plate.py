"""Every result says which plate it is for: meta.json's plate_mm (oracle: the study's [base]
machine.workpiece_size, else the model's), the results index, the figures' titles and the
report; the packaged production-plate study resolves PSD1 (oracle: N_MIN_PERIODS periods of
the band's longest wavelength fit in its plate)."""

from __future__ import annotations

import html
import json
import textwrap
from pathlib import Path

import pytest

from ufmt.model.load import load_model
from ufmt.plots import mark_plate, new_figure
from ufmt.studies.load import load_study
from ufmt.studies.outputs import read_meta
from ufmt.studies.parallel import Execution
from ufmt.studies.runner import run_study

HERE = Path(__file__).resolve()
REPO = HERE.parents[1]
PRODUCTION = REPO / "studies" / "sweep-process-150mm.toml"


def flat_pv(design, process, model=None):
    """PV [nm] = feed [mm/min]: a cheap study function (the plate is only recorded)."""
    return {"pv_nm": float(process["feed_mm_min"])}


def _run(tmp_path, base: str) -> Path:
    tmp_path.mkdir(parents=True, exist_ok=True)
    path = tmp_path / "plate.toml"
    body = f"""
    kind = "sweep"
    metric = "pv_nm"
    [base]
    {base}
    [[axis]]
    parameter = "feed_mm_min"
    values = [4.0, 8.0]
    """
    path.write_text(f'function = "{HERE}:flat_pv"\n' + textwrap.dedent(body), "utf-8")
    return run_study(path, Execution(jobs=1), results=tmp_path / "results", progress=False)


def test_a_study_records_its_plate_and_the_index_names_it(tmp_path):
    size = load_model().machine.workpiece_size
    out = _run(tmp_path / "a", '"machine.workpiece_size[0]" = 0.15')
    meta = read_meta(out)
    assert meta["plate_mm"] == pytest.approx([150.0, 1e3 * size[1]])
    index = (out.parent / "README.md").read_text(encoding="utf-8")
    assert f"Plate: 150 mm × {1e3 * size[1]:.4g} mm." in index
    out = _run(tmp_path / "b", "rpm = 300.0")  # no plate in [base]: the model's
    assert read_meta(out)["plate_mm"] == pytest.approx([1e3 * s for s in size])


def test_a_figure_title_names_its_plate():
    fig = new_figure()
    fig.suptitle("PV against feed")
    mark_plate(fig, [150.0, 150.0])
    assert fig.get_suptitle() == "PV against feed\n(150 mm × 150 mm plate)"
    fig = new_figure()
    fig.add_subplot().set_title("Sensitivity")
    mark_plate(fig, [52.4, 52.4])
    assert fig.axes[0].get_title() == "Sensitivity\n(52.4 mm × 52.4 mm plate)"
    mark_plate(fig, None)  # a study without a plate: unchanged
    assert fig.axes[0].get_title() == "Sensitivity\n(52.4 mm × 52.4 mm plate)"


def test_the_report_says_which_plate_each_study_is_for(tmp_path):
    from ufmt.report import build_report

    out = _run(tmp_path, '"machine.workpiece_size[0]" = 0.15\n"machine.workpiece_size[1]" = 0.15')
    page = build_report(out.parent, load_model())
    section = page[page.index(f'id="{out.name}"') :]
    assert "Plate: a 150 mm × 150 mm plate." in section
    summary = page[page.index('id="summary"') : page.index('id="model"')]
    assert "[a 150 mm × 150 mm plate]" in summary
    meta = json.loads((out / "meta.json").read_text(encoding="utf-8"))
    meta["plate_mm"] = [52.4, 52.4]
    (out / "meta.json").write_text(json.dumps(meta), encoding="utf-8")
    page = build_report(out.parent, load_model())
    assert html.escape("Plate: the paper's 52.4 mm × 52.4 mm plate.") in page


def test_the_production_plate_study_holds_three_periods_of_psd1():
    """PSD1 is 2.5-33 mm: its longest wavelength three times must fit in the plate (the
    paper's 52.4 mm plate holds it 1.6 times: null there). The study ranks PSD1."""
    from ufmt.machining.psd import BANDS, N_MIN_PERIODS

    study = load_study(PRODUCTION)
    span = N_MIN_PERIODS * max(BANDS["psd1"])
    plate = [study.baseline[f"machine.workpiece_size[{i}]"] for i in (0, 1)]
    assert min(plate) >= span and study.options["metric"] == "psd1_rms_nm"
    assert load_model().machine.workpiece_size[0] < span


@pytest.mark.slow  # one 150 mm cut: ~20 s
def test_the_production_plate_resolves_psd1_at_the_reference_cut():
    import math

    from ufmt.evaluate import evaluate

    study = load_study(PRODUCTION)
    base = {k: v for k, v in study.baseline.items() if k.startswith("machine.")}
    record = evaluate(base, {"rpm": 300.0, "feed_mm_min": 15.0, "depth_um": 4.0})
    assert record["status"] == "ok" and math.isfinite(record["psd1_rms_nm"])
