"""Names of the record metrics in words and units, for findings, tables and figures.

``pv_measured_nm`` -> "interferometer PV", unit "nm"; a source's own PV (``pv_dynamic_nm``)
reads "PV of the dynamic source alone" unless it has words of its own. Used by the studies'
findings, their figures and the report, so all three name a metric the same way.
"""

from __future__ import annotations

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
    "pv_dynamic_nm": "whole-plate PV of the cutting-force vibration alone",
    "pv_dynamic_steady_nm": "steady-cut PV of the cutting-force vibration alone",
    "edge_runout_nm": "edge run-out of the cutting-force vibration",
    "tip_acc_measured_mm_s2": "accelerometer peak",
    "pv_feed_marks_nm": "feed-mark PV (roughness)",
    "cutting_time_min": "cutting time of one pass",
}
UNITS = {"nm": "nm", "n": "N", "mm_s2": "mm/s²", "hz": "Hz", "min": "min"}


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


def metric_axis_label(name: str) -> str:
    """Words and unit, e.g. "interferometer PV [nm]" (an axis or colour-bar label)."""
    unit = metric_unit(name)
    return f"{metric_words(name)}{f' [{unit}]' if unit else ''}"
