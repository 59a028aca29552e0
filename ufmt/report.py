"""One self-contained HTML page of everything in ``results/``: ``ufmt report`` / ``make report``.

The page opens with a "Summary" (:mod:`ufmt.report_summary`: the machine, the reference cut's
headline numbers with their intervals, the comparison with the paper like for like, each
study's answer), then holds the model, the validation tables and figures (``results/validation/``),
the reference cut and the FRF, each study's finding, tables and plots (``results/<study>/``,
read from ``meta.json``), and the provenance of every study (model and code hashes, git
revision, package versions, timings). Figures are embedded as base64 PNG and the style sheet
is inline, so the file opens anywhere without a network. Tables show numbers to four
significant digits under headers in words with units; a table longer than
:data:`MAX_TABLE_ROWS` rows is linked as its CSV file (relative to the page), not inlined. It
reads existing results only: a missing part is listed as missing, never recomputed.
"""

from __future__ import annotations

import html
import json
import re
from pathlib import Path

import numpy as np
import pandas as pd

from ufmt import files
from ufmt.machining.process import TABLE1_RANGE
from ufmt.model.machine import DIRECTIONS, MACHINE_FIELDS, OPTIONAL_FIELDS
from ufmt.model.schema import Model
from ufmt.report_html import MAX_TABLE_ROWS, STYLE, column_header, details, figures, more, relative
from ufmt.report_html import csv as _csv
from ufmt.report_html import missing as _missing
from ufmt.report_html import table_html as _table
from ufmt.report_summary import plate_words, summary_parts
from ufmt.studies.fields import DEFAULT_FUNCTION

__all__ = ["MAX_TABLE_ROWS", "build_report", "column_header", "write_report"]

REPORT = "report.html"
VALIDATION = "validation"
REFERENCE_CUT = "reference-process"
FRF = "frf"
FINDINGS_TABLE = "findings.csv"  # the paper's findings (the Summary shows them)
UNCERTAINTY = "uncertainty"  # the uncertainty study's folder: the intervals of the headlines
#: A study's tables shown in its section (when present).
STUDY_TABLES = (
    "optima.csv",
    "indices.csv",
    "pareto.csv",
    "distribution.csv",
    "sobol.csv",
    "contrast.csv",
    "allocation.csv",
    "budget.csv",
    "interval.csv",
    "tradeoff.csv",
)


def write_report(results: str | Path = "results", model: Model | None = None, output=None) -> Path:
    """Write the HTML report of ``results`` to ``output`` (default ``results/report.html``).

    Parameters
    ----------
    results : the results folder (``validation/``, ``frf/``, one folder per study).
    model : the model summarised at the top (default: the packaged UFMT).
    output : the HTML file (default ``<results>/report.html``).

    Returns
    -------
    pathlib.Path
        The file written.
    """
    results = Path(results)
    path = Path(output) if output is not None else results / REPORT
    return files.write_text(path, build_report(results, model, page_dir=path.parent))


def build_report(results: str | Path = "results", model: Model | None = None, page_dir=None) -> str:
    """The report as one HTML string (see :func:`write_report`); ``page_dir`` is the folder
    the page is written to (links to long tables are relative to it; default ``results``)."""
    from ufmt import __version__

    if model is None:
        from ufmt.model.load import load_model, packaged_path

        model = load_model(packaged_path())
    results = Path(results)
    page_dir = Path(page_dir) if page_dir is not None else results
    studies = _studies(results)
    sections = [
        ("summary", "Summary", _summary_section(results, model, studies)),
        ("model", "Model", _model_section(model)),
        (
            "validation",
            "Validation against the paper",
            _validation_section(results / VALIDATION, page_dir),
        ),
        ("reference-cut", "Reference cut and FRF", _reference_section(results, page_dir)),
    ]
    contrasts = _contrasts(results / UNCERTAINTY)
    common = _common_versions(studies)
    sections += [
        (name, f"Study: {name}", _study_section(d, meta, page_dir, contrasts, model, common))
        for name, d, meta in studies
    ]
    nav = " ".join(
        f'<a href="#{key}">{html.escape(title.removeprefix("Study: "))}</a>'
        for key, title, _ in sections
    )
    body = "\n".join(
        f'<h2 id="{key}">{html.escape(title)}</h2>\n{content}' for key, title, content in sections
    )
    return (
        "<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
        f"<title>ufmt report: {html.escape(model.name)}</title><style>{STYLE}</style></head>"
        f"<body><h1>ufmt report: {html.escape(model.name)}</h1>"
        f"<p>ufmt {__version__}; built by <code>ufmt report</code> from the files in "
        f"<code>{html.escape(str(results))}/</code> (nothing recomputed)."
        f"{_versions_sentence(common)}</p>"
        f"<nav>{nav}</nav>\n{body}\n</body></html>\n"
    )


def _summary_section(results: Path, model: Model, studies) -> str:
    """The Summary (:func:`ufmt.report_summary.summary_parts`) as HTML."""
    return _summary_html(summary_parts(results, model, studies))


def _summary_html(summary) -> str:
    """Summary parts as HTML ("columns": their lists of parts side by side)."""
    parts = []
    for kind, content in summary:
        if kind == "columns":
            cells = "".join(f"<div>{_summary_html(c)}</div>" for c in content if c)
            parts.append(f'<div class="columns">{cells}</div>')
        elif kind == "text":
            parts.append(f"<p>{html.escape(content)}</p>")
        elif kind == "heading":
            parts.append(f"<h3>{html.escape(content)}</h3>")
        elif kind == "table":
            parts.append(_table(content))
        else:
            items = "".join(
                f'<li><a href="#{html.escape(name)}">{html.escape(name)}</a>: '
                f"{html.escape(_first_clauses(text))}</li>"
                for name, text in content
            )
            parts.append(f'<ul class="finding">{items}</ul>')
    return "\n".join(parts)


#: A study's answer in the summary is cut at a clause boundary after this many characters (the
#: whole finding is in the study's section).
SUMMARY_ANSWER_CHARS = 130


#: A study's finding in its section shows this many characters; the rest opens on a click.
FINDING_CHARS = 420


def _first_clauses(text: str, chars: int = SUMMARY_ANSWER_CHARS, tail: str = " … (below)") -> str:
    """``text`` up to the last "; " before ``chars`` characters, with ``tail`` where cut."""
    if len(text) <= chars:
        return text
    cut = text.rfind("; ", 0, chars)
    if cut <= 0:  # no clause ends in time: the last whole word
        cut = text.rfind(" ", 0, chars)
    return (text[:cut] if cut > 0 else text[:chars]).rstrip(",:") + tail


def _finding(text: str) -> str:
    """A study's finding: its first clauses, the rest folded under them when longer."""
    shown = _first_clauses(text, FINDING_CHARS, "")
    rest = text[len(shown) :].lstrip("; ,:")
    more = details("… the rest of the finding", f"<p>{html.escape(rest)}</p>") if rest else ""
    return f'<div class="finding"><b>Finding:</b> {html.escape(shown)}{more}</div>'


def _studies(results: Path) -> list[tuple[str, Path, dict]]:
    """(name, folder, meta) of every study folder (one with a meta.json naming its kind)."""
    found = []
    for folder in sorted(p for p in results.iterdir() if p.is_dir()) if results.is_dir() else []:
        meta_file = folder / "meta.json"
        if meta_file.is_file():
            meta = json.loads(meta_file.read_text(encoding="utf-8"))
            if meta.get("kind"):
                found.append((folder.name, folder, meta))
    return found


# ---------------------------------------------------------------------------------------------
# sections


def _model_section(model: Model) -> str:
    """The bodies in one sentence, the hinges' stiffnesses in a table, then every
    ``[machine]`` and ``[design]`` value."""
    bodies = ", ".join(
        f"{b.number}. {b.name} ({b.kind}{f', {b.mass:.3g} kg' if b.mass else ''})"
        for b in model.bodies
    )
    hinges = pd.DataFrame(
        [
            {
                "hinge": h.name,
                "between": "–".join(h.between),
                "stiffness x, y, z [N/m]": " ".join(f"{v:.3g}" for v in h.stiffness),
                "rotational stiffness x, y, z [N m/rad]": " ".join(
                    f"{v:.3g}" for v in h.rotational_stiffness
                ),
            }
            for h in model.hinges
            if not np.all(np.isinf(h.stiffness6))
        ]
    )
    rigid = [h.name for h in model.hinges if np.all(np.isinf(h.stiffness6))]
    joined = f" Rigid in every direction: {', '.join(rigid)}." if rigid else ""
    parts = [
        f"<p><b>{html.escape(model.name)}</b> ({html.escape(_shown_path(model.source))}): "
        f"{len(model.bodies)} bodies, {len(model.hinges)} hinges. Bodies: "
        f"{html.escape(bodies)}.{html.escape(joined)}</p>",
        more(
            details(f"The elastic hinges' stiffnesses (table, {len(hinges)})", _table(hinges)),
            _parameter_tables(model),
        ),
    ]
    return "\n".join(parts)


#: Units of the required ``[machine]`` keys (the optional ones carry theirs in OPTIONAL_FIELDS).
MACHINE_UNITS = {
    "tool_body": "-",
    "workpiece_body": "-",
    "spindle_axis_xy": "m",
    "cutting_plane_z": "m",
    "tool_radius": "m",
    "workpiece_size": "m",
    "workpiece_center_xy": "m",
    "rotation": "-",
}


def _parameter_tables(model: Model) -> str:
    """Every ``[machine]`` and ``[design]`` value with its unit, its band and whether the
    calibration fitted it (for the model ``ufmt calibrate`` wrote; "as written" otherwise)."""
    calibration = _calibration_of(model)
    parts = []
    if model.machine is not None:
        parts.append(
            details(
                "Machine ([machine]): each value, its band (docs/ufmt-model.md) and how it "
                "was set (table)",
                _machine_html(machine_table(model, calibration)),
            )
        )
    if model.design:
        parts.append(
            details(
                "Design parameters ([design]) (table)", _table(design_table(model, calibration))
            )
        )
    return "\n".join(parts)


def _machine_html(table: pd.DataFrame) -> str:
    """The ``[machine]`` table, the keys left at their defaults in one sentence below it."""
    default = table["set by"].str.startswith("default (")
    rest = ", ".join(
        f"{r['field']} = {r['value']} {r['unit']}" for _, r in table[default].iterrows()
    )
    note = f"<p>At their defaults: {html.escape(rest)}.</p>" if rest else ""
    return _table(table[~default]) + note


def _calibration_of(model: Model):
    """The packaged calibration when ``model`` is the model it writes, else None."""
    from ufmt.calibration.settings import load_calibration
    from ufmt.model.load import packaged_path

    try:
        calibration, _, _ = load_calibration(packaged_path("calibration.toml"))
    except (OSError, ValueError):  # StudyError and ModelError are ValueErrors
        return None
    same = Path(model.source).resolve() == Path(calibration.output).resolve()
    return calibration if same else None


def machine_table(model: Model, calibration=None) -> pd.DataFrame:
    """One row per ``[machine]`` key: value, unit, band, how it was set."""
    machine = model.machine
    written = machine.table
    fits = (
        {p.key: p for p in calibration.response.parameters}
        if calibration and calibration.response
        else {}
    )
    asked = _asked_for_edges(model) if fits else {}
    rows = []
    for key in MACHINE_FIELDS:
        value = getattr(machine, key)
        how = _how_set(key, value, fits.get(key), "geometry (as written)")
        unit = MACHINE_UNITS[key]
        rows.append({"field": key, "value": _value(value), "unit": unit, "band": "", "set by": how})
    for key, (default, low, high, unit) in OPTIONAL_FIELDS.items():
        value = getattr(machine, key)
        written_how = (
            "as written in the model file" if key in written else f"default ({_value(default)})"
        )
        how = _how_set(key, value, fits.get(key), written_how, asked)
        rows.append(
            {
                "field": key,
                "value": _value(value),
                "unit": unit,
                "band": _band((low, high)),
                "set by": how,
            }
        )
    for key in (k for k in DIRECTIONS if k in written):  # a spindle's orientation, if given
        value = _value(getattr(machine, key))
        how = "as written in the model file"
        rows.append({"field": key, "value": value, "unit": "-", "band": "unit", "set by": how})
    return pd.DataFrame(rows)


def _how_set(key: str, value, fit, otherwise: str, asked: dict | None = None) -> str:
    """How a ``[machine]`` value was set: fitted (in its fit band, an edge flagged), held by
    the calibration, held because the fit asked for a band's edge (``asked``: key -> the
    value the calibrated file's header says it asked for), or ``otherwise``."""
    if fit is None:
        return otherwise
    if asked and key in asked:
        return (
            f"held at its documented value: the fit asked for {asked[key]:g}, its band's edge"
            " (AT BOUND, a finding)"
        )
    if not fit.fit:
        return "held (calibration.toml)"
    low, high = fit.band
    edge = (
        " (AT A BAND EDGE)"
        if np.any(np.asarray(value) <= low) or np.any(np.asarray(value) >= high)
        else ""
    )
    return f"fitted to the paper (Figs. 12-13) in {_band(fit.band)}{edge}"


def _asked_for_edges(model: Model) -> dict[str, float]:
    """Keys the calibrated file's header marks AT BOUND, with the value the fit asked for."""
    try:
        header = Path(model.source).read_text(encoding="utf-8").split("\n[", 1)[0]
    except OSError:
        return {}
    found = re.findall(r"#\s+(\w+) = \S+ .*AT BOUND: the fit asks for (\S+),", header)
    return {key: float(v) for key, v in found}


def design_table(model: Model, calibration=None) -> pd.DataFrame:
    """One row per ``[design]`` parameter: hinge, value, unit, how its hinge was set."""
    from ufmt.design import design_value

    parameters = calibration.parameters if calibration is not None else ()
    rows = []
    for name, d in model.design.items():
        unit = "N/m" if d.field == "stiffness" else "N m/rad"
        found = [
            p
            for p in parameters
            if d.hinge in p.hinges and p.field == d.field and set(p.components) & set(d.components)
        ]
        how = (
            "identified against Table 3: "
            + "; ".join(f"{p.name} in {_band(p.band)} x the prior" for p in found)
            if found
            else "as written in the model file"
        )
        rows.append(
            {
                "parameter": name,
                "hinge": d.hinge,
                "components": " ".join("xyz"[c] for c in d.components),
                "value": _value(design_value(model, name)),
                "unit": unit,
                "set by": how,
            }
        )
    return pd.DataFrame(rows)


def _value(value) -> str:
    if isinstance(value, (tuple, list, np.ndarray)):
        return ", ".join(_value(v) for v in value)
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


def _band(band) -> str:
    return f"[{band[0]:.3g}, {band[1]:.3g}]"


def _validation_section(folder: Path, page_dir: Path) -> str:
    if not folder.is_dir():
        return _missing(f"{folder}/ (run make validate)")
    parts = [
        "<p>Natural frequencies against the modal test of the paper's Table 3 "
        "(<code>frequencies.csv</code>) and the cutting response against Table 4 "
        "(<code>response.csv</code>).</p>"
    ]
    modes = sorted(folder.glob("mode-*.png"), key=lambda p: int(p.stem.split("-")[1]))
    parts.append(figures([folder / "frequencies.png", *modes], page_dir, thumbs=True))
    titles = {
        "frequencies.csv": "Natural frequencies against Table 3 (frequencies.csv)",
        "response.csv": "Residuals of the cutting response against the paper (response.csv)",
        "identification-log.csv": "Identification log (identification-log.csv)",
    }
    parts.append(
        more(*(details(title, _csv(folder / name, page_dir)) for name, title in titles.items()))
    )
    return "\n".join(parts)


def _reference_section(results: Path, page_dir: Path | None = None) -> str:
    cut = results / VALIDATION / REFERENCE_CUT
    parts = [
        "<p>The reference cut of the paper (300 rpm, 15 mm/min, 4 µm; Figs. 6, 7, 13, 14), "
        "from <code>ufmt simulate --method time --plot</code>, and the tool-workpiece "
        "receptance (<code>ufmt frf</code>).</p>"
    ]
    pngs = sorted(cut.glob("*.png")) if cut.is_dir() else []
    frf = sorted((results / FRF).glob("*.png")) if (results / FRF).is_dir() else []
    parts.append(figures([*pngs, *frf], page_dir))
    if not pngs:
        parts.append(_missing(f"{cut}/"))
    if not frf:
        parts.append(_missing(f"{results / FRF}/ (run ufmt frf)"))
    tables = _headline_intervals(cut, results / UNCERTAINTY)  # the budget: pv_by_source.png
    parts.append(details("Headline numbers with their 5-95 % intervals (table)", tables))
    return "\n".join(parts)


def _headline_intervals(cut: Path, uncertainty: Path) -> str:
    """The reference cut's headline numbers (``metrics.json`` of ``ufmt simulate --save``)
    beside their 5-95 % intervals over the documented bands, read from the uncertainty
    study's ``distribution.csv`` (never recomputed here)."""
    title = "<h3>Headline numbers with their uncertainty intervals</h3>"
    table_file, meta_file = uncertainty / "distribution.csv", uncertainty / "meta.json"
    if not table_file.is_file() or not meta_file.is_file():
        return title + _missing(f"{table_file} (make uncertainty)")
    metrics = cut / "metrics.json"
    point = json.loads(metrics.read_text(encoding="utf-8")) if metrics.is_file() else {}
    meta = json.loads(meta_file.read_text(encoding="utf-8"))
    table = pd.read_csv(table_file)
    quantiles = [c for c in table.columns if c.startswith("q")]  # the study's own quantiles
    rows = []
    for r in table.to_dict("records"):
        value = point.get(r["metric"])
        resolved = r["resolved"] > 0
        row = {"metric": r["metric"], "reference cut": "" if value is None else f"{value:.4g}"}
        for i, column in enumerate(quantiles):
            shown = f"{r[column]:.4g}" if resolved else ("not resolved" if i == 0 else "")
            row[f"{float(column[1:]):g} %"] = shown
        row["samples resolved"] = f"{r['resolved']} of {r['samples']}"
        row["P(meet)"] = _p_meet(r)
        rows.append(row)
    inputs = meta.get("options", {}).get("inputs", [])
    note = (
        f"<p>Point values: the reference cut ({html.escape(str(point.get('method', '?')))} "
        f"path, <code>{html.escape(str(metrics))}</code>). Intervals: the "
        f"<code>{html.escape(meta.get('name', UNCERTAINTY))}</code> study over "
        f"{len(inputs)} documented bands (the study function's periodic path; "
        f"<code>distribution.csv</code>), its independent samples only. A point value outside "
        "its interval sits at the edge of a band it was fitted to.</p>"
    )
    return title + note + _table(pd.DataFrame(rows))


def _p_meet(row: dict) -> str:
    if not np.isfinite(row.get("p_meet", np.nan)):
        return ""
    return (
        f"P(≤ {row['limit']:.4g}) = {row['p_meet']:.2f} "
        f"[{row['p_meet_low']:.2f}, {row['p_meet_high']:.2f}]"
    )


def _contrasts(uncertainty: Path) -> pd.DataFrame | None:
    """The uncertainty study's ``contrast.csv`` (the sweeps' findings with intervals), or
    None."""
    path = uncertainty / "contrast.csv"
    return pd.read_csv(path, keep_default_na=False, na_values=[""]) if path.is_file() else None


def _finding_intervals(name: str, contrasts: pd.DataFrame | None) -> str:
    """This study's findings evaluated at the uncertainty study's samples, one sentence each
    (:func:`ufmt.studies.contrasts.sentence`), or ''."""
    from ufmt.studies.contrasts import sentence

    if contrasts is None or "study" not in contrasts:
        return ""
    rows = contrasts[contrasts["study"] == name].to_dict("records")
    if not rows:
        return ""
    items = "".join(f"<li>{html.escape(sentence(r))}</li>" for r in rows)
    return (
        '<div class="finding"><b>The finding over the uncertain inputs</b> (the change between '
        "the sweep's ends, its 5-95 % interval over the uncertainty study's samples of the "
        f"documented bands; <code>{UNCERTAINTY}/contrast.csv</code>):<ul>{items}</ul></div>"
    )


def _study_section(
    folder: Path,
    meta: dict,
    page_dir: Path,
    contrasts: pd.DataFrame | None = None,
    model=None,
    common: dict | None = None,
) -> str:
    plate = f'<span class="plate">Plate: {html.escape(plate_words(meta, model))}.</span>'
    parts = [f"<p>{plate} {html.escape(meta.get('description') or '')}</p>"]
    finding = meta.get("headline") or "(run incomplete)"
    parts.append(_finding(finding))
    parts.append(_finding_intervals(folder.name, contrasts))
    warning = _range_warning(folder / "points.csv")
    if warning:
        parts.append(f'<p class="warning">{html.escape(warning)}</p>')
    parts.append(figures([folder / name for name in meta.get("plots", [])], page_dir))
    tables = [name for name in STUDY_TABLES if (folder / name).is_file()]
    if (folder / FINDINGS_TABLE).is_file():
        href = html.escape(relative(folder / FINDINGS_TABLE, page_dir))
        parts.append(
            f"<p>The paper's findings like for like: in the Summary; every value in <a href=\""
            f'{href}">{FINDINGS_TABLE}</a>.</p>'
        )
    shown = "".join(f"<h3>{name}</h3>" + _csv(folder / name, page_dir) for name in tables)
    parts.append(
        more(
            details(f"Tables: {', '.join(tables)}", shown),
            details("provenance", _provenance(meta, common)),
        )
    )
    return "\n".join(parts)


def _range_warning(points_csv: Path) -> str:
    """One sentence counting the points outside the paper's Table 1 ranges, or ''."""
    if not points_csv.is_file():
        return ""
    points = pd.read_csv(points_csv)
    outside = []
    for name, (low, high, unit) in TABLE1_RANGE.items():
        if name in points:
            n = int(((points[name] < low) | (points[name] > high)).sum())
            if n:
                outside.append(f"{n} with {name} outside {low:g}-{high:g} {unit}")
    if not outside:
        return ""
    return (
        f"Warning: of {len(points)} points, " + "; ".join(outside) + ". The paper validated "
        "the model only within its Table 1 ranges."
    )


def _common_versions(studies) -> dict:
    """The package versions every study ran with ({} without a study)."""
    found = [meta.get("versions", {}) for _, _, meta in studies]
    if not found:
        return {}
    return {k: v for k, v in found[0].items() if all(f.get(k) == v for f in found)}


def _versions_sentence(common: dict) -> str:
    if not common:
        return ""
    versions = ", ".join(f"{k} {v}" for k, v in common.items())
    return f" Every study ran with {html.escape(versions)} (others: each study's provenance)."


def _provenance(meta: dict, common: dict | None = None) -> str:
    """Where the study's numbers come from, in one paragraph (meta.json has it all); package
    versions shared by every study (``common``) are named once, at the top of the page, the
    others here."""
    run = meta.get("run", {})
    git = meta.get("git", {})
    own = {k: v for k, v in meta.get("versions", {}).items() if (common or {}).get(k) != v}
    versions = ", ".join(f"{k} {v}" for k, v in own.items())
    short = {k: (meta.get(k) or "")[:12] for k in ("model_sha256", "code_sha256")}
    items = {
        "study file": meta.get("study_file"),
        "function": None if meta.get("function") == DEFAULT_FUNCTION else meta.get("function"),
        "model": None if meta.get("model") == "packaged" else meta.get("model"),
        "SHA-256 of model, code": f"{short['model_sha256']}, {short['code_sha256']}",
        "git": f"{(git.get('revision') or '')[:12]}{' (dirty)' if git.get('dirty') else ''}",
        "started": meta.get("started"),
        "status": None if meta.get("status") == "complete" else meta.get("status"),
        "points (new, reused, failed)": (
            f"{run.get('points_total')} ({run.get('points_new')}, {run.get('points_reused')}, "
            f"{run.get('points_failed')})"
        ),
        "wall [s], jobs": f"{run.get('wall_s')}, {run.get('jobs')} ({run.get('backend')})",
        "versions": versions,
    }
    text = "; ".join(f"{k}: {v}" for k, v in items.items() if v not in (None, "", "None"))
    return f"<p><small>{html.escape(text)}.</small></p>"


# ---------------------------------------------------------------------------------------------
# HTML pieces


def _shown_path(source: str) -> str:
    """A model file's path relative to the current folder when under it (the page then reads
    the same on every checkout), else as given."""
    path = Path(source)
    try:
        return str(path.resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(source)
