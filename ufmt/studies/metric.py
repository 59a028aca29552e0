"""The metric a study ranks: which number of a point's record its finding, tables and figures
are about.

Sweeps, grids and sensitivity studies take ``metric = "<record metric>"``; the optimisers
take ``objective = "<record metric>"``. Any metric of a :func:`ufmt.evaluate` record
(:data:`ufmt.design.METRICS`) is allowed. The default is the interferometer's PV
(``pv_measured_nm``: the clear aperture with piston and tilt removed, the feed marks as the
instrument sees them), the number a shop measures and the paper's Table 4 reports; the
whole-plate PV (``pv_nm``) is dominated by what an interferometer removes as tilt. A study of
a function other than ``ufmt.evaluate`` defaults to ``pv_nm``, the one key such a function is
required to return. The headline, every table's ranking column and every figure of a study
name the metric they rank (:func:`metric_label`).
"""

from __future__ import annotations

from collections.abc import Mapping

from ufmt.design import METRICS
from ufmt.errors import closest_name
from ufmt.tables import Where

DEFAULT_METRIC = "pv_measured_nm"
#: Default of a study whose function is not ``ufmt.evaluate`` (its required output).
CUSTOM_FUNCTION_METRIC = "pv_nm"
EVALUATE_FUNCTION = "ufmt.evaluate:evaluate"

#: Words for a metric in findings and axis labels (the unit comes from the name's suffix).
WORDS = {
    "pv_nm": "whole-plate PV",
    "pv_aperture_nm": "clear-aperture PV",
    "pv_tilt_removed_nm": "PV with tilt removed",
    "pv_measured_nm": "interferometer PV",
    "rms_measured_nm": "interferometer RMS",
    "rms_nm": "whole-plate RMS",
    "psd1_rms_nm": "PSD1 band RMS",
    "psd2_rms_nm": "PSD2 band RMS",
    "force_peak_n": "peak cutting force",
    "waviness_rms_nm": "waviness RMS",
    "zre_peak_nm": "z_re average peak",
    "pv_dynamic_nm": "PV of the cutting-force vibration alone (whole plate, eq. 4.1)",
    "pv_dynamic_steady_nm": "PV of the cutting-force vibration alone in the steady cut",
    "edge_runout_nm": "edge run-out of the cutting-force vibration",
    "tip_acc_measured_mm_s2": "accelerometer peak",
}
UNITS = {"nm": "nm", "n": "N", "mm_s2": "mm/s²", "hz": "Hz"}


def read_metric(where: Where, data: Mapping, field: str) -> str:
    """The study's ``field`` (``metric`` or ``objective``): a record metric, or the default
    for the study's function (module docstring); an unknown name fails with a did-you-mean."""
    if field not in data:
        function = data.get("function", EVALUATE_FUNCTION)
        return DEFAULT_METRIC if function == EVALUATE_FUNCTION else CUSTOM_FUNCTION_METRIC
    name = data[field]
    if not isinstance(name, str) or name not in METRICS:
        near = closest_name(str(name), METRICS)
        hint = f"did you mean {near!r}? " if near else ""
        where.fail(
            field, f"{name!r} is not a record metric: {hint}choose from {', '.join(METRICS)}"
        )
    return name


def metric_unit(name: str) -> str:
    """The unit of a metric from its name's suffix (``_nm`` -> nm), or ''."""
    for suffix, unit in UNITS.items():
        if name.endswith(f"_{suffix}"):
            return unit
    return ""


def metric_words(name: str) -> str:
    """The metric in words (``pv_measured_nm`` -> "interferometer PV"); a source's PV
    (``pv_dynamic_nm``) is "PV of the dynamic source alone"."""
    if name in WORDS:
        return WORDS[name]
    if name.startswith("pv_") and name.endswith("_nm"):
        return f"PV of the {name[3:-3].replace('_', ' ')} source alone"
    return name


def metric_label(name: str) -> str:
    """Words, unit and key, e.g. "interferometer PV [nm] (pv_measured_nm)"."""
    unit = metric_unit(name)
    return f"{metric_words(name)}{f' [{unit}]' if unit else ''} ({name})"
