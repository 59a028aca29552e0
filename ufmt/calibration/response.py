"""Validation of the cutting response against section 4.2 and Table 4 of the paper.

At the reference process (300 rpm, 15 mm/min, 4 um) the packaged model is simulated on both
response paths; the PV is what the force scale was fitted to (time path), the average peaks of
z_re and of the tool-tip z acceleration are reported without fitting, next to the paper's
values read from ``ufmt/data/paper_reference.toml``.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from ufmt.machining.process import Process
from ufmt.model.schema import Model
from ufmt.tomlfile import read_toml


def reference_process(reference: dict) -> Process:
    """The process of sections 3.3 and 4.2 from the reference data."""
    p = reference["reference_process"]
    return Process(p["spindle_speed_rpm"], p["feed_mm_min"], p["depth_of_cut_um"])


def response_table(model: Model, reference_path: str | Path, basis=None) -> pd.DataFrame:
    """One row per quantity: this project's periodic and time-domain values, the paper's.

    Columns: quantity, unit, periodic, time, paper_simulated, paper_measured, fitted
    (True where the value was used to fit the force scale), note.
    """
    from ufmt.machining.modal import modal_basis
    from ufmt.simulate import simulate

    ref = read_toml(reference_path)
    process = reference_process(ref)
    basis = modal_basis(model) if basis is None else basis
    per = simulate(model, process, basis=basis, method="periodic").metrics
    tim = simulate(model, process, basis=basis, method="time").metrics
    acc, zre, pv = ref["tool_tip_acceleration"], ref["relative_displacement"], ref["surface_pv"]
    rows = [
        (
            "surface PV",
            "nm",
            per["pv_nm"],
            tim["pv_nm"],
            pv["simulated_nm"],
            pv["measured_nm"],
            True,
            "force scale fitted to the measured PV on the time path",
        ),
        (
            "surface PV, tilt removed",
            "nm",
            per["pv_tilt_removed_nm"],
            tim["pv_tilt_removed_nm"],
            None,
            None,
            False,
            "",
        ),
        ("surface RMS", "nm", per["rms_nm"], tim["rms_nm"], None, None, False, ""),
        (
            "z_re average peak per period",
            "nm",
            per["zre_peak_nm"],
            tim["zre_peak_nm"],
            zre["z_re_average_peak_nm"],
            None,
            False,
            "not fitted",
        ),
        (
            "tool-tip z acceleration average peak per period",
            "mm/s^2",
            per["tip_acc_peak_mm_s2"],
            tim["tip_acc_peak_mm_s2"],
            acc["average_peak_simulated"],
            acc["average_peak_measured"],
            False,
            f"not fitted; the paper prints '{acc['unit']}'",
        ),
    ]
    columns = [
        "quantity",
        "unit",
        "periodic",
        "time",
        "paper_simulated",
        "paper_measured",
        "fitted",
        "note",
    ]
    return pd.DataFrame(rows, columns=columns)
