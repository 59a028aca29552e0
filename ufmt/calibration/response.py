"""Validation of the cutting response against section 4.2 and Table 4 of the paper.

At the reference process (300 rpm, 15 mm/min, 4 um) the model is simulated on both response
paths and compared with every response measurement of the paper: surface PV (Table 4), the
average peaks of z_re (Fig. 13) and of the tool-tip z acceleration (Fig. 12), and the shape of
Fig. 14 (:func:`ufmt.calibration.response_fit.centre_rise_nm`). The quantities are the
``[response]`` targets of ``calibration.toml`` (the same ones the calibration fits).
"""

from __future__ import annotations

import math
from dataclasses import fields
from pathlib import Path

import pandas as pd

from ufmt.calibration.response_fit import response_metrics
from ufmt.calibration.settings import read_response_settings
from ufmt.machining.cutting import DEFAULT_COEFFICIENTS, FORCE_PARTS, part_amplitude
from ufmt.machining.modal import modal_basis
from ufmt.machining.process import Process
from ufmt.model.load import packaged_path
from ufmt.model.machine import machine_of
from ufmt.model.schema import Model
from ufmt.tomlfile import read_toml

REPRODUCED_PERCENT = 10.0  # a paper value counts as reproduced within this error [%]


def reference_process(reference: dict) -> Process:
    """The process of sections 3.3 and 4.2 from the reference data."""
    p = reference["reference_process"]
    return Process(p["spindle_speed_rpm"], p["feed_mm_min"], p["depth_of_cut_um"])


def implied_forces(model: Model, metrics: dict, process: Process) -> dict[str, dict]:
    """Peak forces [N] and specific forces [GPa] the model's force scale implies at ``process``.

    Per coefficient of :class:`ufmt.machining.cutting.ForceCoefficients`: the force of its
    part on the largest cut, ``force_scale * K`` times the part's amplitude
    (:func:`ufmt.machining.cutting.part_amplitude`: the chip area depth x feed per revolution
    for cutting, thrust, feed; the engaged edge length sqrt(2 r_n a_p) for the edge terms)
    [N], and that force over the chip area [GPa] (for the area part the specific force
    ``force_scale * K`` itself, for the edge part its equivalent on the chip). With a
    ``force_peak_n`` metric (largest simulated force magnitude) also its value and its ratio to
    the chip area. Literature for diamond on KDP: 0.1-1 N, 1-5 GPa.
    """
    machine = machine_of(model)
    area = part_amplitude(process, machine, "area")
    amplitude = {p: part_amplitude(process, machine, p) for p in FORCE_PARTS}
    out = {}
    for f in fields(DEFAULT_COEFFICIENTS):
        part = "edge" if f.name.startswith("edge_") else "area"
        force = machine.force_scale * getattr(DEFAULT_COEFFICIENTS, f.name) * amplitude[part]
        out[f.name] = {"force_n": force, "specific_gpa": force / area * 1e-9}
    if "force_peak_n" in metrics:
        peak = metrics["force_peak_n"]
        out["peak (simulated)"] = {"force_n": peak, "specific_gpa": peak / area * 1e-9}
    return out


QUANTITIES = {  # metric -> (quantity, where the paper gives it)
    "pv_nm": ("surface PV, whole plate", "Table 4 (laser interferometer)"),
    "pv_measured_nm": (
        "measured surface PV against the interferometer's PV of every source",
        "Table 4 (laser interferometer)",
    ),
    "pv_dynamic_nm": (
        "simulated surface PV against the cutting-force vibration's surface, whole plate (eq. 4.1)",
        "Table 4 (the paper's simulation)",
    ),
    "tip_acc_measured_mm_s2": (
        "tool-tip z acceleration average peak per period, through the accelerometer chain",
        "Fig. 12",
    ),
    "zre_peak_nm": ("z_re average peak per period", "Fig. 13"),
    "tip_acc_peak_mm_s2": ("tool-tip z acceleration average peak per period", "Fig. 12"),
    "centre_rise_nm": ("middle part higher than the surrounding area", "Fig. 14"),
}


def response_table(
    model: Model, reference_path: str | Path, basis=None, settings_path=None
) -> pd.DataFrame:
    """One row per paper quantity of section 4.2 / Table 4: the paper's value, ours, the error.

    The quantities and the paper's values (with their unit reading) are the ``[response]``
    targets of the calibration file ``settings_path`` (default the packaged
    ``calibration.toml``); ``fitted`` is True where the target took part in the fit, i.e. where
    the file fits at least one ``[machine]`` key the loader knows and the target's weight is
    not 0 (a weight-0 target is compared, not fitted). Ours is the exact time path
    (``ours``) and the fast periodic path used by the fit (``ours_periodic``). A one-sided
    target (a shape the paper states in words) has no paper value: ``error_percent`` is empty
    and ``reproduced`` says whether ours has the stated sign.

    Columns: quantity, metric, unit, paper, ours, ours_periodic, error_percent, reproduced,
    fitted, source.
    """
    ref = read_toml(reference_path)
    process = reference_process(ref)
    settings_path = packaged_path("calibration.toml") if settings_path is None else settings_path
    settings = read_response_settings(read_toml(settings_path)["response"], ref, str(settings_path))
    basis = modal_basis(model) if basis is None else basis
    exact = response_metrics(model, process, basis, "time")
    fast = response_metrics(model, process, basis, "periodic")
    fitted = bool(settings.parameters)
    rows = []
    for t in settings.targets:
        quantity, source = QUANTITIES.get(t.metric, (t.metric, ""))
        ours = exact[t.metric]
        if t.kind == "positive":
            paper, error, reproduced = math.nan, math.nan, ours > 0
        else:
            paper = t.paper
            error = 100.0 * (ours / paper - 1.0)
            reproduced = abs(error) <= REPRODUCED_PERCENT
        rows.append(
            {
                "quantity": quantity,
                "metric": t.metric,
                "unit": t.unit,
                "paper": paper,
                "ours": ours,
                "ours_periodic": fast[t.metric],
                "error_percent": error,
                "reproduced": reproduced,
                "fitted": fitted and t.weight > 0,
                "source": t.note or source,
            }
        )
    return pd.DataFrame(rows)
