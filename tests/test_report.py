"""ufmt report: one self-contained page (oracle: the files in a hand-made results folder; every
PNG there is embedded byte for byte, nothing is fetched from a network)."""

from __future__ import annotations

import base64
import json
import re
from pathlib import Path

import numpy as np
import pandas as pd

from ufmt.cli import main
from ufmt.model.load import load_model
from ufmt.plots import new_axes, save_figure

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "bridge.toml"


def _png(path: Path) -> bytes:
    fig, ax = new_axes(figsize=(2, 1.5))
    ax.plot(np.arange(3))
    return save_figure(fig, path).read_bytes()


def _results(root: Path) -> dict[str, bytes]:
    """A results folder: validation (tables, figures, reference cut), an FRF and one study."""
    pngs = {}
    validation = root / "validation"
    (validation / "reference-process").mkdir(parents=True)
    pd.DataFrame({"mode": [1, 2], "mstmm_hz": [7.45, 9.99]}).to_csv(
        validation / "frequencies.csv", index=False
    )
    for rel in (
        "validation/frequencies.png",
        "validation/mode-2.png",
        "validation/mode-11.png",
        "validation/reference-process/surface.png",
        "frf/frf.png",
        "sweep-x/pv_vs_parameters.png",
    ):
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        pngs[rel] = _png(root / rel)
    study = root / "sweep-x"
    pd.DataFrame({"rpm": [150.0, 300.0, 350.0], "pv_nm": [3.0, 2.0, 1.0]}).to_csv(
        study / "points.csv", index=False
    )
    meta = {
        "kind": "sweep",
        "description": "a <tiny> sweep",
        "headline": "PV falls as rpm rises",
        "plots": ["pv_vs_parameters.png"],
        "model_sha256": "abc123",
        "git": {"revision": "deadbeef", "dirty": False},
        "run": {"points_total": 3, "wall_s": 1.5},
        "versions": {"ufmt": "0.1.0"},
        "study_text": 'kind = "sweep"',
    }
    (study / "meta.json").write_text(json.dumps(meta), encoding="utf-8")
    return pngs


def test_report_embeds_every_figure_and_needs_no_network(tmp_path, capsys):
    pngs = _results(tmp_path)
    assert main(["report", str(EXAMPLE), "--results", str(tmp_path)]) == 0
    assert "report.html" in capsys.readouterr().out
    page = (tmp_path / "report.html").read_text(encoding="utf-8")
    embedded = [base64.b64decode(d) for d in re.findall(r"data:image/png;base64,([^\"]+)", page)]
    assert sorted(embedded) == sorted(pngs.values())
    # mode figures in mode order, not string order
    assert page.index("mode-2.png") < page.index("mode-11.png")
    assert not re.search(r"(src|href)=\"?(https?:)?//", page)
    assert "PV falls as rpm rises" in page and "deadbeef" in page and "abc123" in page
    assert "a &lt;tiny&gt; sweep" in page  # text is escaped
    # the Table 1 warning of the study's points is on the page, not only in the CSV
    assert "1 with rpm outside 200-400 rpm" in page
    assert load_model(EXAMPLE).name in page


def test_report_lists_what_is_missing(tmp_path, capsys):
    assert main(["report", str(EXAMPLE), "--results", str(tmp_path / "none")]) == 2  # no folder
    assert "--results" in capsys.readouterr().err and not (tmp_path / "none").exists()
    (tmp_path / "none").mkdir()  # an empty results folder: every part listed as missing
    assert main(["report", str(EXAMPLE), "--results", str(tmp_path / "none")]) == 0
    page = (tmp_path / "none" / "report.html").read_text(encoding="utf-8")
    assert "missing:" in page and "data:image/png" not in page


def test_machine_table_gives_every_value_its_unit_band_and_how_it_was_set():
    from ufmt.calibration.settings import load_calibration
    from ufmt.model.load import packaged_path
    from ufmt.model.machine import MACHINE_FIELDS, OPTIONAL_FIELDS
    from ufmt.report import _asked_for_edges, _calibration_of, design_table, machine_table

    model = load_model()  # the calibrated model: its calibration file says what was fitted
    calibration = _calibration_of(model)
    assert calibration is not None
    table = machine_table(model, calibration).set_index("field")
    assert list(table.index) == [*MACHINE_FIELDS, *OPTIONAL_FIELDS]
    assert (table["unit"] != "").all() and not table["value"].str.contains("None").any()
    fits = {
        p.key: p for p in load_calibration(packaged_path("calibration.toml"))[0].response.parameters
    }
    asked = _asked_for_edges(model)  # the header's AT BOUND keys: held at their start
    for key, fit in fits.items():
        fitted = fit.fit and key not in asked
        assert table.loc[key, "set by"].startswith("fitted" if fitted else "held")
    for key, value in asked.items():
        assert value in fits[key].band or min(abs(value - b) for b in fits[key].band) < 1e-5
        assert getattr(model.machine, key) == fits[key].start
    straightness = model.machine.straightness_m
    at_edge = straightness in fits["straightness_m"].band
    assert ("AT A BAND EDGE" in table.loc["straightness_m", "set by"]) == at_edge
    design = design_table(model, calibration)
    assert len(design) == len(model.design) and design["set by"].str.startswith("identified").all()
    # a user's model: nothing claims to be fitted
    user = load_model(EXAMPLE)
    assert _calibration_of(user) is None
    if user.machine is not None:
        assert (
            not machine_table(user)
            .astype(str)
            .apply(lambda c: c.str.contains("fitted"))
            .any()
            .any()
        )


def _chromium() -> str | None:
    import shutil

    return next((p for p in map(shutil.which, ("chromium", "chromium-browser")) if p), None)


#: The page's height budget: screens of a 1400 x 900 px window.
SCREENS, SCREEN_PX = 10, 900


def test_report_fits_a_1400_px_window_without_horizontal_scroll(tmp_path):
    """Rendered in headless Chromium at 1400 px, the page of the repository's results (or of
    a hand-made folder where they are absent) is no wider than the window and no taller than
    SCREENS screens of SCREEN_PX."""
    import subprocess

    import pytest

    browser = _chromium()
    if browser is None:
        pytest.skip("chromium is not installed (apt-get install chromium); the layout is unchecked")
    results = Path(__file__).resolve().parents[1] / "results"
    if not (results / "validation").is_dir():
        results = tmp_path / "results"
        _results(results)
    page = tmp_path / "report.html"
    main(["report", "--results", str(results), "--output", str(page)])
    probe = (
        "<script>window.addEventListener('load', () => { const e = document.documentElement;"
        " document.body.setAttribute('data-overflow', String(e.scrollWidth - e.clientWidth));"
        " document.body.setAttribute('data-height', String(e.scrollHeight));"
        " });</script></body>"
    )
    page.write_text(page.read_text(encoding="utf-8").replace("</body>", probe), encoding="utf-8")
    done = subprocess.run(
        [
            browser,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            f"--window-size=1400,{SCREEN_PX}",
            "--virtual-time-budget=5000",
            "--dump-dom",
            page.as_uri(),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    overflow = re.search(r'data-overflow="(-?\d+)"', done.stdout)
    assert overflow is not None, done.stderr[-2000:]
    assert int(overflow.group(1)) <= 0
    height = int(re.search(r'data-height="(\d+)"', done.stdout).group(1))
    assert height <= SCREENS * SCREEN_PX, height


def test_report_puts_the_intervals_beside_the_reference_cut_and_the_sweep_finding(tmp_path):
    """Oracle: the files themselves. The reference cut's point value (metrics.json) stands
    beside the uncertainty study's quantiles (distribution.csv), and the sweep's finding gets
    the contrast row of contrast.csv that names it; nothing is recomputed."""
    from ufmt.report import build_report

    _results(tmp_path)
    cut = tmp_path / "validation" / "reference-process"
    (cut / "metrics.json").write_text(
        json.dumps({"method": "time", "pv_measured_nm": 65.53, "zre_peak_nm": 34.82}), "utf-8"
    )
    study = tmp_path / "uncertainty"
    study.mkdir()
    meta = {"kind": "uncertainty", "name": "uncertainty", "options": {"inputs": [1, 2, 3]}}
    (study / "meta.json").write_text(json.dumps(meta), encoding="utf-8")
    pd.DataFrame(
        {
            "metric": ["pv_measured_nm", "psd1_rms_nm"],
            "samples": [64, 64],
            "resolved": [64, 0],
            "q05": [27.04, np.nan],
            "q50": [102.5, np.nan],
            "q95": [390.4, np.nan],
            "limit": [100.0, np.nan],
            "p_meet": [0.5, np.nan],
            "p_meet_low": [0.372, np.nan],
            "p_meet_high": [0.628, np.nan],
        }
    ).to_csv(study / "distribution.csv", index=False)
    contrast = {
        "name": "rpm 150 -> 350",
        "study": "sweep-x",
        "parameter": "rpm",
        "from": 150.0,
        "to": 350.0,
        "metric": "pv_nm",
        "point_from": 3.0,
        "point_to": 1.0,
        "point_change": -2.0,
        "point_change_pct": -66.67,
        "samples": 32,
        "resolved": 32,
        "change_pct_q05": -71.25,
        "change_pct_q95": -12.5,
        "p_falls": 1.0,
    }
    pd.DataFrame([contrast]).to_csv(study / "contrast.csv", index=False)
    page = build_report(tmp_path, load_model(EXAMPLE))
    # the summary opens the page: the point value beside its interval, the metric named
    assert re.search(r'<h2 id="([^"]+)"', page).group(1) == "summary"
    summary = page[page.index('id="summary"') : page.index('id="model"')]
    row = re.search(r"<td[^>]*>pv_measured_nm</td>(.*?)</tr>", summary, flags=re.S).group(1)
    assert re.findall(r"<td[^>]*>(.*?)</td>", row) == ["65.53", "27.04 – 390.4"]
    assert "PV falls as rpm rises" in summary  # each study's answer
    reference = page[page.index('id="reference-cut"') :]
    row = re.search(r"<td[^>]*>pv_measured_nm</td>(.*?)</tr>", reference, flags=re.S).group(1)
    cells = re.findall(r"<td[^>]*>(.*?)</td>", row)
    assert cells[:4] == ["65.53", "27.04", "102.5", "390.4"]
    assert "P(≤ 100) = 0.50 [0.37, 0.63]" in cells[-1]
    assert "not resolved" in page and "time path" in page
    sweep = page[page.index('id="sweep-x"') :]
    assert "rpm 150 -&gt; 350: pv_nm 3 -&gt; 1, -66.7 % [-71.2, -12.5], falls in" in sweep


def test_the_repository_report_is_short_enough_to_forward(tmp_path):
    """The page of the committed results inlines at most 150 table rows and 5,000 words
    (figures aside); longer tables are links to their CSV files beside the page."""
    import pytest

    from ufmt.report import build_report

    results = Path(__file__).resolve().parents[1] / "results"
    if not (results / "validation").is_dir():
        pytest.skip("no committed results")
    page = build_report(results)
    text = re.sub(r"<style>.*?</style>|<img[^>]*>", "", page, flags=re.S)
    words = len(re.sub(r"<[^>]+>", " ", text).split())
    assert page.count("<tr") <= 150 and words <= 5000, (page.count("<tr"), words)
    for href in re.findall(r'<a href="([^"#]+)"', page):
        assert (results / href).is_file(), href


def _outside_details(page: str) -> str:
    return re.sub(r"<details>.*?</details>", "", page, flags=re.S)


def _expected_figures(results: Path) -> int:
    """PNGs the page shows (oracle: the folder): validation, reference cut, FRF and every
    study's meta.json plots."""
    count = len(list((results / "validation").glob("*.png")))
    count += len(list((results / "validation" / "reference-process").glob("*.png")))
    count += len(list((results / "frf").glob("*.png")))
    for meta in results.glob("*/meta.json"):
        plots = json.loads(meta.read_text(encoding="utf-8")).get("plots", [])
        count += sum((meta.parent / name).is_file() for name in plots)
    return count


def _check_structure(page: str, results: Path) -> None:
    """Summary first; every figure in a figure grid, one per PNG; outside the folded parts
    only the Summary holds tables; every study section names its plate, its tables folded."""
    assert re.search(r'<h2 id="([^"]+)"', page).group(1) == "summary"
    figures = re.findall(r"<figure[^>]*>", page)
    assert len(figures) == page.count("data:image/png;base64,") == _expected_figures(results)
    grids = re.findall(r'<div class="figures[^"]*">(.*?)</div>', page, flags=re.S)
    assert sum(g.count("<figure") for g in grids) == len(figures)
    summary_end = page.index('<h2 id="model"')
    assert "<table" not in _outside_details(page[summary_end:])
    for folder in results.glob("*/meta.json"):
        name = folder.parent.name
        section = page[page.index(f'<h2 id="{name}"') :]
        section = section[: section.find("<h2 ", 1) if "<h2 " in section[1:] else None]
        assert "Plate: " in section and "Finding:" in section


def test_the_page_is_the_summary_then_figures_with_tables_folded(tmp_path):
    """Oracle: the hand-made folder (every PNG once, in a grid; no table inline below the
    Summary; the study names its plate)."""
    from ufmt.report import build_report

    _results(tmp_path)
    _check_structure(build_report(tmp_path, load_model()), tmp_path)


def test_the_repository_report_keeps_its_structure():
    """The same on the committed results (figure count from the folder, rows and words as
    test_the_repository_report_is_short_enough_to_forward)."""
    import pytest

    from ufmt.report import build_report

    results = Path(__file__).resolve().parents[1] / "results"
    if not (results / "validation").is_dir():
        pytest.skip("no committed results")
    _check_structure(build_report(results), results)
