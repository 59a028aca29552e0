"""The calibration run behind ``ufmt calibrate`` (make calibrate).

:func:`calibrate` reads the calibration file (:mod:`ufmt.calibration.settings`), identifies the
hinge stiffnesses (:mod:`ufmt.calibration.identify`), checks the identified model by the MSTMM
against Table 3 (:func:`ufmt.calibration.frequencies.validate`), fits the ``[response]``
parameters (:mod:`ufmt.calibration.response_fit`) and writes the model file (``ufmt.toml``,
under a :func:`provenance_header` saying how it was made) and the identification log (one row
per iteration, then the MSTMM check).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from ufmt import files
from ufmt.calibration.frequencies import Validation, validate
from ufmt.calibration.identify import Identification, identify
from ufmt.calibration.reduced import apply_parameters
from ufmt.calibration.response import reference_process
from ufmt.calibration.response_fit import EDGE_FRACTION, ResponseFit, fit_response, with_values
from ufmt.calibration.settings import Calibration, load_calibration
from ufmt.model.schema import Model
from ufmt.model.write import model_to_toml
from ufmt.tomlfile import read_toml


def _sha256(path: Path) -> str:
    """The first 16 hex digits of the file's SHA-256 (its fingerprint in the header)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16]


def provenance_header(
    calibration: Calibration,
    result: Identification,
    mstmm_errors: np.ndarray,
    response: ResponseFit | None = None,
) -> str:
    """Comment block on top of the generated model file: how it was made and how to remake it."""
    err = np.abs(mstmm_errors)
    lines = [
        "# GENERATED FILE - do not edit by hand.",
        "# Written by `ufmt calibrate` (make calibrate); regenerate with:",
        "#     python -m ufmt.cli calibrate [--prior PATH] [--settings PATH] [--output PATH]",
        f"# Prior: {calibration.prior.name} (sha256 {_sha256(calibration.prior)}); settings: "
        f"{Path(calibration.source).name} (sha256 {_sha256(Path(calibration.source))}).",
        f"# Targets: Table 3 modes {', '.join(map(str, calibration.targets.modes))}, column "
        f"{calibration.targets.column!r} of {calibration.reference.name}.",
        f"# MSTMM result: max |error| {err.max():.3f} %, mean |error| {err.mean():.3f} %; "
        f"global start used: {'yes' if result.used_global_start else 'no'}.",
    ]
    c = calibration.constraint
    if c is not None:
        shares = result.evaluation.shares
        modes = ", ".join(map(str, c.modes or calibration.targets.modes))
        lines.append(
            f"# Constraint: {', '.join(c.hinges)} x{c.factor:g} moves none of modes {modes} by "
            f"more than {c.max_change_percent:g} % (strain-energy share <= {c.limit:.3f}); "
            f"largest share {shares.max():.3f} "
            f"(mode {calibration.targets.modes[int(shares.argmax())]})."
        )
    lines.append("# Identified factors (k = s * k_prior; band in brackets):")
    width = max(len(p.name) for p in result.parameters)
    for p, s in zip(result.parameters, result.scales, strict=True):
        lines.append(f"#   {p.name:<{width}}  s = {s:.6g}  [{p.band[0]:g}, {p.band[1]:g}]")
    if response is not None:
        lines.append(
            f"# Response fit ({response.settings.method} path, reference process; "
            "[machine] values, band in brackets):"
        )
        for p in response.settings.parameters:
            flag = "" if p.fit else "  held"
            if p.key in response.at_bound:
                flag = (
                    f"  AT BOUND: the fit asks for {response.wanted[p.key]:.6g}, within"
                    f" {100 * EDGE_FRACTION:g} % of the band's edge; held at its documented value"
                )
            lines.append(
                f"#   {p.key} = {response.values[p.key]:.6g} {p.unit}  "
                f"[{p.band[0]:g}, {p.band[1]:g}]{flag}"
            )
        for key in response.settings.skipped:
            lines.append(f"#   {key}: not a [machine] field of this version, skipped")
        for t, r in zip(response.settings.targets, response.residuals, strict=True):
            paper = "> 0" if t.kind == "positive" else f"{t.paper:.6g}"
            lines.append(
                f"#   {t.metric}: ours {response.metrics[t.metric]:.4g}, paper {paper} {t.unit}, "
                f"residual {r:+.3f}"
            )
    return "\n".join(lines) + "\n"


@dataclass(frozen=True, eq=False)
class CalibrationRun:
    """What ``ufmt calibrate`` did: the identification, the model, its MSTMM check, the
    response fit (None without a ``[response]`` table) and the file written."""

    identification: Identification
    model: Model
    validation: Validation
    output: Path
    response: ResponseFit | None = None


def calibrate(
    settings_path: str | Path,
    prior: str | Path | None = None,
    output: str | Path | None = None,
    log_path: str | Path | None = None,
    progress: bool = False,
) -> CalibrationRun:
    """Identify the stiffnesses of a calibration file, check them by the MSTMM, fit the
    ``[response]`` parameters, write the model and the log."""
    calibration, model, reference = load_calibration(settings_path, prior, output)
    result = identify(
        model,
        calibration.parameters,
        calibration.targets,
        calibration.settings,
        reference,
        constraint=calibration.constraint,
        progress=progress,
    )
    identified = replace(
        apply_parameters(model, calibration.parameters, result.u), name=calibration.output_name
    )
    check = validate(identified, reference, calibration.settings.n_modes)
    fit = None
    if calibration.response is not None:
        fit = fit_response(
            identified,
            calibration.response,
            reference_process(read_toml(calibration.reference)),
            None,  # the response's default basis (every mode below the cutoff)
            progress=progress,
        )
        identified = with_values(identified, fit.values)
    tested = check.table.set_index("mode").loc[list(calibration.targets.modes)]
    errors = 100.0 * (tested["mstmm_hz"].to_numpy() / calibration.targets.frequencies_hz - 1.0)
    tip = check.summary["tool_tip_z_modes_above_neighbours"]
    final = {
        "stage": "mstmm check",
        "iteration": 0,
        "max_abs_error_percent": float(np.abs(errors).max()),
        "mean_abs_error_percent": float(np.abs(errors).mean()),
        "shape_mismatches": int(tested["tag_check"].isin(["class", "bodies"]).sum())
        + sum(not above for above in tip.values()),
        "mismatched_modes": " ".join(
            str(k)
            for k in sorted(
                set(check.summary["tag_mismatches"]) | {k for k, a in tip.items() if not a}
            )
        ),
    }
    final.update(
        {f"s[{p.name}]": s for p, s in zip(calibration.parameters, result.scales, strict=True)}
    )
    log = pd.concat([result.log, pd.DataFrame([final])], ignore_index=True)
    files.write_text(
        calibration.output,
        provenance_header(calibration, result, errors, fit) + model_to_toml(identified),
    )
    if log_path is not None:
        files.write_with(log_path, lambda b: log.to_csv(b, index=False, float_format="%.8g"))
    return CalibrationRun(replace(result, log=log), identified, check, calibration.output, fit)
