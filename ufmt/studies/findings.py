"""The paper's findings (section 4.2, Figs. 15-16), judged like for like from a sweep's points.

Each statement of the paper is read off the points of the axes (or grid) that vary its
parameters: the value at the axis' low end, at the base and at the high end, on two metrics,
the surface the paper models (the cutting-force vibration alone inside the steady cut,
``pv_dynamic_steady_nm``) and what the shop measures (the interferometer's PV,
``pv_measured_nm``). The effect size is the larger |change| of the two ends against the base
[%] (a stiffness at 0.5x and 2x its calibrated value, a process parameter at the ends of Table
1). The spindle statement scales the whole spindle bearing (radial, axial and angular
together), read from a grid over the three. The head-versus-spindle row compares the head's
angular effect with the spindle bearing's, as the paper's wording ("methodical effect" against
"little influence") implies. A sweep writes ``findings.csv`` with ``findings = true``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from ufmt.studies.metric import metric_words

FINDINGS = "findings.csv"
#: The two surfaces each statement is judged on: the paper's own and the shop's.
METRICS = ("pv_dynamic_steady_nm", "pv_measured_nm")
#: "Little influence": |change| below this share for a factor 2 either way (as the paper tests).
LITTLE = 0.05
SPINDLE = (
    "spindle_radial_stiffness_N_m",
    "spindle_axial_stiffness_N_m",
    "spindle_angular_stiffness_Nm_rad",
)


@dataclass(frozen=True)
class Statement:
    """One of the paper's statements: its words, the parameters it scales together and what
    the metric should do as they rise ("falls", "rises", "little" or "unlike-angular")."""

    key: str
    words: str
    parameters: tuple[str, ...]
    expected: str


STATEMENTS = (
    Statement(
        "head-angular",
        "Fig. 15: head angular stiffness: the higher, the better",
        ("head_angular_stiffness_Nm_rad",),
        "falls",
    ),
    Statement(
        "head-radial",
        "Fig. 15: head radial stiffness: not as the angular",
        ("head_radial_stiffness_N_m",),
        "unlike-angular",
    ),
    Statement(
        "head-axial",
        "Fig. 15: head axial stiffness: not as the angular",
        ("head_axial_stiffness_N_m",),
        "unlike-angular",
    ),
    Statement(
        "spindle",
        "Section 4.2: spindle air bearing: little influence",
        SPINDLE,
        "little",
    ),
    Statement("speed", "Fig. 16: higher speed, smoother surface", ("rpm",), "falls"),
    Statement("feed", "Fig. 16: lower feed, smoother surface", ("feed_mm_min",), "rises"),
    Statement(
        "depth",
        "Fig. 16: smaller depth (less force), smoother surface",
        ("depth_um",),
        "rises",
    ),
)


def _at(rows: pd.DataFrame, values: Mapping[str, float]) -> pd.DataFrame:
    """The rows whose columns equal ``values`` (relative tolerance 1e-9)."""
    keep = np.ones(len(rows), bool)
    for name, value in values.items():
        keep &= np.isclose(rows[name].to_numpy(float), value, rtol=1e-9, atol=0.0)
    return rows[keep]


def _ends(ok: pd.DataFrame, statement: Statement, baseline: Mapping[str, float]):
    """(low, base, high) rows of the statement's parameters scaled together, or None: low and
    high are the lowest and highest common scale found with every other parameter at base."""
    names = [p for p in statement.parameters if p in ok]
    if len(names) != len(statement.parameters) or any(p not in baseline for p in names):
        return None
    others = {k: v for k, v in baseline.items() if k in ok and k not in names}
    rows = _at(ok, others)
    scale = rows[names[0]].to_numpy(float) / baseline[names[0]]
    together = np.all(
        [np.isclose(rows[p].to_numpy(float) / baseline[p], scale, rtol=1e-9) for p in names],
        axis=0,
    )
    rows, scale = rows[together], scale[together]
    base = rows[np.isclose(scale, 1.0, rtol=1e-9)]
    if base.empty or scale.min() >= 1.0 or scale.max() <= 1.0:
        return None
    return rows[scale == scale.min()].iloc[0], base.iloc[0], rows[scale == scale.max()].iloc[0]


def _direction(low: float, base: float, high: float) -> str:
    if low > base > high:
        return "falls"
    if low < base < high:
        return "rises"
    return "not monotone"


def findings_table(points: pd.DataFrame, baseline: Mapping[str, float]) -> pd.DataFrame:
    """One row per statement and metric found in ``points`` (the sweep's points.csv), then the
    head-versus-spindle comparison per metric; empty when no statement's points are there."""
    ok = points[points["status"] == "ok"] if "status" in points else points
    rows, effects = [], {}
    for statement in STATEMENTS:
        ends = _ends(ok, statement, baseline)
        if ends is None:
            continue
        low, base, high = ends
        name = statement.parameters[0]
        for metric in METRICS:
            if metric not in ok:
                continue
            values = [float(r[metric]) for r in ends]
            changes = [100.0 * (v / values[1] - 1.0) for v in (values[0], values[2])]
            effect = max(abs(c) for c in changes)
            effects[statement.key, metric] = effect
            rows.append(
                {
                    "statement": statement.words,
                    "key": statement.key,
                    "parameter": "spindle bearing (all)" if statement.key == "spindle" else name,
                    "low": float(low[name]),
                    "base": float(base[name]),
                    "high": float(high[name]),
                    "metric": metric,
                    "value_low_nm": values[0],
                    "value_base_nm": values[1],
                    "value_high_nm": values[2],
                    "change_low_percent": changes[0],
                    "change_high_percent": changes[1],
                    "effect_percent": effect,
                    "found": _direction(*values),
                    "expected": statement.expected,
                }
            )
    table = pd.DataFrame(rows)
    if table.empty:
        return table
    table["reproduced"] = [_reproduced(r, effects) for r in table.to_dict("records")]
    return pd.concat([table, _head_against_spindle(effects)], ignore_index=True)


def _reproduced(row: Mapping, effects: Mapping) -> bool:
    expected, found = row["expected"], row["found"]
    if expected in ("falls", "rises"):
        return found == expected
    if expected == "little":
        return row["effect_percent"] < 100.0 * LITTLE
    angular = effects.get(("head-angular", row["metric"]))
    return found != "falls" or (angular is not None and row["effect_percent"] < angular)


def _head_against_spindle(effects: Mapping) -> pd.DataFrame:
    """Per metric: the head's angular effect exceeds the spindle bearing's."""
    rows = []
    for metric in METRICS:
        head, spindle = effects.get(("head-angular", metric)), effects.get(("spindle", metric))
        if head is None or spindle is None:
            continue
        rows.append(
            {
                "statement": "Section 4.2, Fig. 15: head angular stiffness over spindle bearing",
                "key": "head-vs-spindle",
                "parameter": "head angular against spindle bearing",
                "metric": metric,
                "effect_percent": head,
                "found": f"head {head:.2g} % against spindle {spindle:.2g} %",
                "expected": "head > spindle",
                "reproduced": bool(head > spindle),
            }
        )
    return pd.DataFrame(rows)


def findings_headline(table: pd.DataFrame) -> str:
    """One sentence: how many statements each metric reproduces, and which it does not (the
    effect sizes are in the table)."""
    if table.empty:
        return ""
    parts = []
    for metric in METRICS:
        rows = table[table["metric"] == metric]
        if rows.empty:
            continue
        missed = ", ".join(rows.loc[~rows["reproduced"].astype(bool), "key"])
        parts.append(
            f"on {metric_words(metric)} ({metric}) {int(rows['reproduced'].sum())} of"
            f" {len(rows)} reproduced{f' (not: {missed})' if missed else ''}"
        )
    return "The paper's findings like for like (findings.csv): " + "; ".join(parts) + "."
