"""The report's HTML pieces: the style sheet, figures in a grid, tables, folded details.

Figures are embedded as base64 PNG in a four-column grid (a wide figure spans two or all
columns by its aspect ratio), each linked to its PNG file beside the page for the full size.
Tables show numbers to four significant digits under headers in words with units; a table
longer than :data:`MAX_TABLE_ROWS` rows is linked as its CSV file, not inlined. Reference
tables (parameters, logs, provenance) are folded in ``<details>`` so the page reads as the
summary and the figures.
"""

from __future__ import annotations

import base64
import html
import os
import struct
from pathlib import Path

import pandas as pd

MAX_TABLE_ROWS = 8  # longer tables are linked as their CSV file, not inlined
MAX_TABLE_CELLS = 120  # so are larger ones (rows x columns): a wide table reads better as a CSV
COLUMN_CHARS = 40  # a column's width follows its longest cell up to this many characters
#: Aspect ratios (width / height) from which a figure spans two, then every grid column.
WIDE, VERY_WIDE = 1.9, 5.0

STYLE = """
body { font-family: sans-serif; max-width: 1340px; margin: 1em auto; padding: 0 0.5em;
       color: #222; line-height: 1.35; }
h1 { border-bottom: 2px solid #444; margin: 0.2em 0; }
h2 { border-bottom: 1px solid #aaa; margin: 0.9em 0 0.3em; }
p { margin: 0.4em 0; }
h3 { margin: 0.8em 0 0.3em; }
table { border-collapse: collapse; font-size: 0.8em; margin: 0.4em 0; width: 100%;
        table-layout: fixed; }
th, td { border: 1px solid #ccc; padding: 2px 6px; text-align: right; vertical-align: top;
         overflow-wrap: break-word; hyphens: auto; }
td.text, th.text, td:first-child, th:first-child { text-align: left; }
pre { white-space: pre-wrap; overflow-wrap: anywhere; }
th { background: #eee; }
.figures { display: grid; grid-template-columns: repeat(4, minmax(0, 1fr)); gap: 6px;
           grid-auto-flow: dense; align-items: start; }
.figures.thumbs { grid-template-columns: repeat(6, minmax(0, 1fr)); }
.figures figure { margin: 0; } .span2 { grid-column: span 2; } .spanall { grid-column: 1 / -1; }
figcaption { font-size: 0.75em; color: #555; }
img { width: 100%; height: auto; border: 1px solid #ddd; }
.finding { background: #eef5ff; padding: 0.4em 1em; border-left: 4px solid #36c; margin: 0.4em 0; }
.warning { background: #fff4e0; padding: 0.4em 1em; border-left: 4px solid #e90; }
.plate { color: #555; font-size: 0.9em; }
.columns { display: grid; grid-template-columns: repeat(2, minmax(0, 1fr)); gap: 1.5em; }
.missing { color: #999; font-style: italic; } code, pre { font-size: 0.85em; }
details { margin: 0.3em 0; } summary { cursor: pointer; color: #36c; }
.more { display: flex; flex-wrap: wrap; column-gap: 2em; }
.more details[open] { flex-basis: 100%; }
nav a { margin-right: 1em; }
"""


def png_size(png: Path) -> tuple[int, int]:
    """(width, height) [px] of a PNG from its header (no image library needed)."""
    with open(png, "rb") as f:
        head = f.read(24)
    return struct.unpack(">II", head[16:24])


def figure(png: Path, page_dir: Path | None = None) -> str:
    """The PNG embedded as a base64 data URI, spanning grid columns by its aspect ratio and
    linked to its file (relative to ``page_dir``), or a note that it is missing."""
    if not png.is_file():
        return missing(str(png))
    width, height = png_size(png)
    aspect = width / max(height, 1)
    span = " class='spanall'" if aspect >= VERY_WIDE else " class='span2'" if aspect >= WIDE else ""
    data = base64.b64encode(png.read_bytes()).decode("ascii")
    image = f'<img alt="{html.escape(png.name)}" src="data:image/png;base64,{data}">'
    if page_dir is not None:
        image = f'<a href="{html.escape(relative(png, page_dir))}">{image}</a>'
    return (
        f"<figure{span}>{image}<figcaption><code>{html.escape(png.name)}</code>"
        "</figcaption></figure>"
    )


def figures(pngs, page_dir: Path | None = None, thumbs: bool = False) -> str:
    """Several figures in one grid of four columns, or six for ``thumbs`` (pictures read
    at a glance, e.g. mode shapes; a click opens the full size), or '' for none."""
    cells = [figure(Path(p), page_dir) for p in pngs]
    grid = "figures thumbs" if thumbs else "figures"
    return f'<div class="{grid}">{"".join(cells)}</div>' if cells else ""


def more(*folded: str) -> str:
    """Folded parts (:func:`details`) side by side on one line; each opens to the full width."""
    shown = [f for f in folded if f]
    return f'<div class="more">{"".join(shown)}</div>' if shown else ""


def relative(path: Path, page_dir: Path) -> str:
    """``path`` relative to the page's folder, with forward slashes."""
    return Path(os.path.relpath(Path(path).resolve(), Path(page_dir).resolve())).as_posix()


def csv(path: Path, page_dir: Path) -> str:
    """A CSV table inline, or a link to it (relative to ``page_dir``, the page's folder) when
    it is longer than MAX_TABLE_ROWS rows or larger than MAX_TABLE_CELLS cells."""
    if not path.is_file():
        return missing(str(path))
    table = _without_band_inputs(pd.read_csv(path))
    if len(table) > MAX_TABLE_ROWS or table.size > MAX_TABLE_CELLS:
        href = relative(path, page_dir)
        return (
            f'<p>{len(table)} rows, {len(table.columns)} columns: <a href="{html.escape(href)}">'
            f"{html.escape(path.name)}</a> (CSV, beside this page).</p>"
        )
    return table_html(table.rename(columns=column_header))


#: Prefixes of the uncertain inputs' columns (``machine.force_scale``, ``hinge.h31...``):
#: a study with intervals or a robust objective records them per point; inline, they are the
#: calibrated values on every row (the band samples are in their own CSV).
BAND_INPUT_PREFIXES = ("machine.", "hinge.", "damping.")


def _without_band_inputs(table: pd.DataFrame) -> pd.DataFrame:
    """``table`` without the uncertain inputs' columns that hold one value throughout."""
    constant = [
        c
        for c in table.columns
        if str(c).startswith(BAND_INPUT_PREFIXES) and table[c].nunique(dropna=False) <= 1
    ]
    return table.drop(columns=constant)


#: Column-name suffix -> unit, for headers in words.
HEADER_UNITS = (
    ("_percent", "%"),
    ("_pct", "%"),
    ("_mm_s2", "mm/s²"),
    ("_mm_min", "mm/min"),
    ("_Nm_rad", "N m/rad"),
    ("_N_m", "N/m"),
    ("_hz", "Hz"),
    ("_nm", "nm"),
    ("_um", "µm"),
    ("_mm", "mm"),
    ("_min", "min"),
    ("_n", "N"),
    ("_s", "s"),
)


def column_header(name: str) -> str:
    """A CSV column's header in words with its unit: ``pv_measured_nm`` -> "pv measured [nm]",
    ``frequency_hz`` -> "frequency [Hz]" (dotted parameter names are kept as they are)."""
    if "." in name or "[" in name:
        return name
    for suffix, unit in HEADER_UNITS:
        if name.endswith(suffix) and len(name) > len(suffix):
            return f"{name[: -len(suffix)].replace('_', ' ')} [{unit}]"
    return name.replace("_", " ")


def table_html(table: pd.DataFrame) -> str:
    """The table as HTML in the page's fixed layout (numbers to four significant digits): each
    column's share of the width follows its longest cell (capped at COLUMN_CHARS characters),
    so long text wraps in wide columns and numbers keep narrow ones."""
    text = table.to_html(index=False, na_rep="", float_format=lambda v: f"{v:.4g}", border=0)
    lengths = [
        min(
            COLUMN_CHARS,
            max([len(str(c)) // 2, *(len(_shown(v)) for v in table[c])], default=4),
        )
        + 2
        for c in table.columns
    ]
    total = sum(lengths) or 1
    cols = "".join(f'<col style="width:{100 * n / total:.1f}%">' for n in lengths)
    return text.replace(">\n  <thead>", f"><colgroup>{cols}</colgroup>\n  <thead>", 1)


def _shown(value) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)


def details(summary: str, content: str) -> str:
    """``content`` folded under a one-line ``summary`` (opened by a click)."""
    if not content:
        return ""
    return f"<details><summary>{html.escape(summary)}</summary>{content}</details>"


def missing(what: str) -> str:
    return f'<p class="missing">missing: {html.escape(what)}</p>'
