"""The uncertainty and tolerance numbers of docs/findings.md are the committed results' own:
each quote is rebuilt here from the tables in results/ (the oracle) and must appear there
verbatim, so a regenerated result that moves a number fails here until the page says it."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pandas as pd
import pytest

from ufmt.studies.contrasts import change_text
from ufmt.studies.journal import results_sha256
from ufmt.studies.load import load_study

REPO = Path(__file__).resolve().parents[1]
README = (REPO / "docs" / "findings.md").read_text(encoding="utf-8")
RESULTS = REPO / "results"


def _section(title: str) -> str:
    """The README text from the heading ``title`` to the next heading of any level."""
    start = README.index(title)
    end = re.search(r"^#{1,6} ", README[start + len(title) :], flags=re.M)
    return README[start : start + len(title) + (end.start() if end else len(README))]


def _flat(text: str) -> str:
    return " ".join(text.split())


def _g(value: float, digits: int) -> str:
    """``digits`` significant digits, as the README writes them (no exponent below 1e5)."""
    return f"{float(f'{value:.{digits}g}'):g}" if abs(value) < 1e5 else f"{value:.{digits}g}"


def _table(study: str, name: str) -> pd.DataFrame:
    path = RESULTS / study / name
    if not path.is_file():
        pytest.skip(f"{path} not committed")
    return pd.read_csv(path)


def _meta(study: str) -> dict:
    """The study's meta.json; skip when its results predate the study file (the numbers to
    quote do not exist until ``ufmt run studies/<study>.toml`` has run on it)."""
    meta = json.loads((RESULTS / study / "meta.json").read_text(encoding="utf-8"))
    current = results_sha256(load_study(REPO / "studies" / f"{study}.toml"))
    if meta.get("study_sha256") != current:
        pytest.skip(f"results/{study} predate studies/{study}.toml: regenerate them")
    return meta


def test_worked_example_quotes_the_committed_optimise_tolerances_tables():
    meta = _meta("optimise-tolerances")
    text = _flat(_section("## Worked example: straightness and bearing for PSD1 below 5 nm"))
    allocation = _table("optimise-tolerances", "allocation.csv")
    interval = _table("optimise-tolerances", "interval.csv")
    tradeoff = _table("optimise-tolerances", "tradeoff.csv")
    run = meta["run"]
    jobs = f"{run['jobs']} job" + ("s" if run["jobs"] > 1 else "")
    quotes = [
        f"{run['points_total']} used, {run['wall_s']:.0f} s wall with {jobs}",
    ]
    if "specification" in allocation:
        nominal = allocation[allocation["specification"] == "nominal"].iloc[-1]
    else:
        nominal = allocation.iloc[-1]
    quotes += [
        f"slide straightness ≤ {_g(1e9 * nominal['machine.straightness_m'], 2)} nm",
        f"Cost {_g(nominal['cost'], 3)}",
        f"the model gives PSD1 = {nominal['evaluated']:.2f} nm",
    ]
    first = interval.iloc[0]
    quotes.append(
        f"PSD1 5–95 % {_g(first['q05'], 2)}–{_g(first['q95'], 3)} nm, P(PSD1 ≤ 5 nm) ="
        f" {_g(first['p_meet'], 2)} [{_g(first['p_meet_low'], 2)}, {_g(first['p_meet_high'], 2)}]"
    )
    feasible = tradeoff[tradeoff["feasible"].astype(bool)] if len(tradeoff) else tradeoff
    if len(feasible):  # a trade-off exists only when the loosest tolerances miss some level
        tightest = feasible.iloc[0]
        quotes.append(
            f"{_g(tightest['cost'], 3)} for PSD1 ≤ {_g(tightest['level'], 2)} nm (straightness"
            f" {_g(1e9 * tightest['machine.straightness_m'], 2)} nm)"
        )
    if "specification" in allocation and (allocation["specification"] != "nominal").any():
        likely = allocation[allocation["specification"] != "nominal"].iloc[-1]
        last = interval.iloc[-1]
        quotes += [
            f"slide straightness ≤ {_g(1e9 * likely['machine.straightness_m'], 2)} nm at cost"
            f" {_g(likely['cost'], 3)}",
            f"P(PSD1 ≤ 5 nm) = {_g(last['p_meet'], 2)} [{_g(last['p_meet_low'], 2)},"
            f" {_g(last['p_meet_high'], 2)}]",
        ]
    missing = [q for q in quotes if q not in text]
    assert not missing, (
        f"README worked example does not quote results/optimise-tolerances: {missing}"
    )


def test_make_uncertainty_bullet_quotes_the_committed_uncertainty_tables():
    meta = _meta("uncertainty")
    text = _flat(_section("## Uncertainty and tolerance allocation"))
    distribution = _table("uncertainty", "distribution.csv").set_index("metric")
    sobol = _table("uncertainty", "sobol.csv")
    pv = distribution.loc["pv_measured_nm"]
    inputs = len(meta["options"]["inputs"])
    quotes = [
        f"{inputs} inputs, N = {meta['options']['samples']}: {meta['run']['points_total']}"
        " evaluations",
        f"interferometer PV {_g(pv['q05'], 2)}–{_g(pv['q95'], 2)} nm (median {pv['q50']:.0f})",
        f"P(PV ≤ {pv['limit']:.0f} nm) = {pv['p_meet']:.2f} [{pv['p_meet_low']:.2f},"
        f" {pv['p_meet_high']:.2f}]",
    ]
    for metric in ("zre_peak_nm", "tip_acc_measured_mm_s2"):
        row = distribution.loc[metric]
        quotes.append(f"({_g(row['q05'], 2)}–{_g(row['q95'], 3)}")
    top = sobol.sort_values("ST", ascending=False).groupby("metric").head(1).set_index("metric")
    for metric in ("pv_measured_nm", "zre_peak_nm", "tip_acc_measured_mm_s2"):
        quotes.append(f"{top.loc[metric, 'ST']:.2f} ± {top.loc[metric, 'ST_conf']:.2f}")
    bearings = sobol[sobol["parameter"].str.startswith("hinge.")]
    if len(bearings):
        worst = bearings.sort_values("ST").iloc[-1]
        quotes.append(f"{_g(worst['ST'], 2)} ± {_g(worst['ST_conf'], 2)}")
    contrasts = []
    contrast = RESULTS / "uncertainty" / "contrast.csv"
    if contrast.is_file():  # the sweeps' findings with their intervals, anywhere in the README
        for row in pd.read_csv(contrast).to_dict("records"):
            if math.isfinite(row["change_pct_q05"]):
                contrasts.append(change_text(row))
    missing = [q for q in quotes if q not in text]
    missing += [q for q in contrasts if q not in _flat(README)]
    assert not missing, f"README does not quote results/uncertainty: {missing}"
