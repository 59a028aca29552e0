"""The report's first section, "Summary": what an engineer reads before forwarding the page.

Four parts, each read from the results folder and never recomputed: the machine and the cut;
the headline numbers of the reference cut with their 5-95 % intervals over the documented
bands (``validation/reference-process/metrics.json`` and the uncertainty study's
``distribution.csv``); the comparison with the paper, like for like (``validation/response.csv``
and the natural frequencies' errors in ``validation/frequencies.csv``); and each study's answer
(its headline in ``meta.json``), which says what to change. Every number names its metric.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd

from ufmt.model.schema import Model

#: The reference cut's headline metrics, in the order shown: key -> words [unit].
HEADLINE_METRICS = {
    "pv_measured_nm": "interferometer PV (clear aperture, piston and tilt removed) [nm]",
    "pv_dynamic_nm": "PV of the cutting-force vibration alone, whole plate (eq. 4.1) [nm]",
    "pv_dynamic_steady_nm": "PV of the cutting-force vibration alone, steady cut [nm]",
    "pv_nm": "whole-plate PV, every source [nm]",
    "roughness_pv_nm": "feed-mark roughness PV [nm]",
    "psd1_rms_nm": "PSD1 band RMS (2.5-33 mm) [nm]",
    "psd2_rms_nm": "PSD2 band RMS (0.12-2.5 mm) [nm]",
    "zre_peak_nm": "z_re average peak per period [nm]",
    "tip_acc_measured_mm_s2": "tool-tip acceleration as the accelerometer reports it [mm/s²]",
}


def summary_parts(results: Path, model: Model, studies) -> list[tuple[str, pd.DataFrame | str]]:
    """The summary as (kind, content) parts: ``"text"`` (HTML-escaped by the caller: plain
    text), ``"heading"``, ``"table"`` (a DataFrame with headers in words and units),
    ``"list"`` (study name, answer) or ``"columns"`` (lists of parts side by side), in page
    order."""
    parts: list[tuple[str, pd.DataFrame | str]] = [("text", machine_sentence(model))]
    metrics = _json(results / "validation" / "reference-process" / "metrics.json")
    headline = headline_table(metrics, results / "uncertainty" / "distribution.csv")
    left, right = [], []
    if headline is not None:
        left += [("heading", "The reference cut (300 rpm, 15 mm/min, 4 µm)"), ("table", headline)]
    validation = paper_table(results / "validation" / "response.csv")
    if validation is not None:
        right += [("heading", "Against the paper, like for like"), ("table", validation)]
    frequencies = frequency_sentence(results / "validation" / "frequencies.csv")
    if frequencies:
        right.append(("text", frequencies))
    if left or right:
        parts.append(("columns", [left, right]))
    findings = findings_summary(studies)
    if findings is not None:
        name, table = findings
        parts += [
            ("heading", "The paper's findings, like for like"),
            (
                "text",
                f"{name} study (findings.csv): on the paper's surface (the vibration alone, "
                "steady cut) and the shop's (interferometer); change of each end against base.",
            ),
            ("table", table),
        ]
    own = plate_words({}, model)
    answers = [
        (name, _marked(plate_words(meta, model), own) + meta["headline"])
        for name, _, meta in studies
        if meta.get("headline")
    ]
    if answers:
        parts.append(("heading", "What the studies answer (what to change)"))
        parts.append(("text", f"On {own} unless marked."))
        parts.append(("list", answers))
    return parts


#: The two surfaces of findings.csv, in words for the summary's columns.
FINDING_SURFACES = {
    "pv_dynamic_steady_nm": "steady-cut vibration",
    "pv_measured_nm": "interferometer PV",
}


def findings_summary(studies) -> tuple[str, pd.DataFrame] | None:
    """The first study's findings.csv (:mod:`ufmt.studies.findings`) as one row per statement:
    the change at each end [%] and whether it is reproduced, per surface; None without one."""
    for name, folder, _ in studies:
        path = Path(folder) / "findings.csv"
        if not path.is_file():
            continue
        table = pd.read_csv(path)
        rows = []
        for _, group in table.groupby("key", sort=False):
            first = group.iloc[0]
            row = {"paper's statement": first["statement"], "varied": _varied(first)}
            for metric, words in FINDING_SURFACES.items():
                found = group[group["metric"] == metric]
                if found.empty:
                    continue
                r = found.iloc[0]
                if np.isfinite(r.get("change_low_percent", np.nan)):
                    change = f"{r['change_low_percent']:+.2g} / {r['change_high_percent']:+.2g}"
                else:
                    change = str(r["found"])
                row[f"{words}: change [%]"] = change
                row[f"{words}: reproduced"] = "yes" if r["reproduced"] else "NO"
            rows.append(row)
        return name, pd.DataFrame(rows)
    return None


def _varied(row) -> str:
    """ "x0.5 -> x2" for a stiffness, "200 -> 400 rpm" for a process parameter."""
    if not np.isfinite(row.get("base", np.nan)):
        return str(row["parameter"])
    name = str(row["parameter"])
    if name in PROCESS_WORDS:
        words, unit = PROCESS_WORDS[name]
        return f"{words} {row['low']:g} → {row['high']:g} {unit}"
    words = re.sub(r"_(N_m|Nm_rad)$", "", name).replace("_", " ")
    return f"{words} ×{row['low'] / row['base']:.2g} → ×{row['high'] / row['base']:.2g}"


PROCESS_WORDS = {
    "rpm": ("spindle speed", "rpm"),
    "feed_mm_min": ("feed", "mm/min"),
    "depth_um": ("depth of cut", "µm"),
}


def machine_sentence(model: Model) -> str:
    """One sentence: the model, its size, the plate and the tool."""
    text = f"{model.name}: {len(model.bodies)} bodies, {len(model.hinges)} hinges"
    machine = model.machine
    if machine is None:
        return text + "."
    x, y = (1e3 * s for s in machine.workpiece_size)
    return (
        f"{text}; a {x:.4g} mm × {y:.4g} mm plate cut by a fly-cutter of radius"
        f" {1e3 * machine.tool_radius:.4g} mm."
    )


#: The paper's plate (its Table 1 workpiece), for naming the plate a study ran on.
PAPER_PLATE_MM = 52.4


def _marked(plate: str, own: str) -> str:
    """ "[a 150 mm × 150 mm plate] " for a study on another plate than the model's, else ''."""
    return "" if plate == own else f"[{plate}] "


def plate_mm(meta: dict, model: Model | None) -> tuple[float, float] | None:
    """The plate [mm] a study ran on: its ``[base]`` ``machine.workpiece_size`` where set,
    else the model's (None without a ``[machine]`` table)."""
    if meta.get("plate_mm"):  # written by the run (ufmt.studies.journal.plate_mm)
        return tuple(float(v) for v in meta["plate_mm"])
    base = meta.get("baseline", {}) or {}
    default = model.machine.workpiece_size if model is not None and model.machine else None
    sizes = [base.get(f"machine.workpiece_size[{i}]") for i in (0, 1)]
    if default is None and None in sizes:
        return None
    return tuple(1e3 * (s if s is not None else default[i]) for i, s in enumerate(sizes))


def plate_words(meta: dict, model: Model | None) -> str:
    """ "the paper's 52.4 mm × 52.4 mm plate" or "a 150 mm × 150 mm plate" (see
    :func:`plate_mm`)."""
    size = plate_mm(meta, model)
    if size is None:
        return "the model's plate"
    whose = "the paper's " if all(abs(s - PAPER_PLATE_MM) < 0.5 for s in size) else "a "
    return f"{whose}{size[0]:.4g} mm × {size[1]:.4g} mm plate"


def headline_table(metrics: dict | None, distribution: Path) -> pd.DataFrame | None:
    """The reference cut's headline metrics with their 5-95 % intervals where the uncertainty
    study has them; None without ``metrics.json``."""
    if not metrics:
        return None
    values = {**metrics, **{f"pv_{k}_nm": v for k, v in metrics.get("pv_by_source_nm", {}).items()}}
    spread = pd.read_csv(distribution).set_index("metric") if distribution.is_file() else None
    rows = []
    for key, words in HEADLINE_METRICS.items():
        if key not in values:
            continue
        value = values[key]
        interval = ""
        if spread is not None and key in spread.index:
            r = spread.loc[key]
            interval = f"{r['q05']:.4g} – {r['q95']:.4g}" if r["resolved"] > 0 else "not resolved"
        rows.append(
            {
                "quantity": words,
                "metric": key,
                "value": "not resolved on this plate" if value is None else f"{value:.4g}",
                "5–95 % over the bands": interval,
            }
        )
    return pd.DataFrame(rows)


def paper_table(response: Path) -> pd.DataFrame | None:
    """The paper's response quantities beside ours, each with the metric it is compared with."""
    if not response.is_file():
        return None
    table = pd.read_csv(response)
    return pd.DataFrame(
        {
            "paper's quantity": table["quantity"],
            "compared with": table["metric"],
            "paper": [_number(v) for v in table["paper"]],
            "ours": [_number(v) for v in table["ours"]],
            "error [%]": [_number(v, "+.1f") for v in table["error_percent"]],
            "fitted": ["yes" if f else "no" for f in table["fitted"]],
        }
    )


def frequency_sentence(frequencies: Path) -> str:
    """Max and mean |error| of the natural frequencies against the modal test."""
    if not frequencies.is_file():
        return ""
    table = pd.read_csv(frequencies)
    if "mstmm_error_percent" not in table:
        return ""
    tested = table.dropna(subset=["mstmm_error_percent"])
    errors = np.abs(tested["mstmm_error_percent"].to_numpy(float))
    if not errors.size:
        return ""
    return (
        f"Natural frequencies against the modal test (Table 3, {errors.size} modes): max |error|"
        f" {errors.max():.2f} %, mean {errors.mean():.2f} % (frequencies.csv)."
    )


def _number(value, spec: str = ".4g") -> str:
    return "" if value is None or not np.isfinite(value) else format(float(value), spec)


def _json(path: Path) -> dict | None:
    return json.loads(path.read_text(encoding="utf-8")) if path.is_file() else None
