"""Calibration of any model against its modal test: ``ufmt calibrate --prior MODEL --test
FILE [--settings FILE]``.

Parameters are stiffness factors ``k = s k_prior`` on listed hinge components, each within a
declared band (the ``[[parameter]]`` tables of the calibration file, read by
:func:`ufmt.calibration.settings.read_parameters`; without a settings file, one factor per
hinge field with finite stiffness, band DEFAULT_BAND). With ``u = ln s`` the fit minimises

    J(u) = sum_m (ln f_m(u) - ln f_t,m)^2 + rho^2 sum_p u_p^2,      ln band_p[0] <= u_p <= ..[1]

over the test modes m paired with a model mode (:func:`ufmt.calibration.correlation.
correlate`: by MAC where the test has shapes, by order otherwise; paired again at every
evaluation), f_m by the MSTMM. scipy's bounded trust-region least squares solves it with
finite-difference sensitivities. rho (``regularisation``) keeps parameters the test cannot
see at the prior.

Identifiability, before the fit. The sensitivity matrix S = d ln f / d u at the prior
(forward differences, one row per paired test mode) gives each factor's standard deviation
``sigma_f sqrt(diag((S^T S + rho^2 I)^-1))`` for a frequency uncertainty sigma_f
(``frequency_error_percent``, relative). A factor whose deviation exceeds IDENTIFIED_SHARE of
its band's width ``ln(band[1] / band[0])`` is not identified by this test: the one with the
largest such ratio is held at its prior, the deviations of the rest computed again, until every
factor left is identified; only those are fitted. The data's rank is the number of singular
values s_i of S with ``sigma_f / s_i`` below IDENTIFIED_SHARE of the median band width (the
directions of factor space the test pins down); it is never more than the number of paired
modes. Every residual (before and after), every factor with its band, bound flag, deviation
(after the fit for the fitted ones) and whether it was held is reported.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

from ufmt.calibration.correlation import Correlation, correlate
from ufmt.calibration.modal_test import ModalTest
from ufmt.calibration.reduced import apply_parameters
from ufmt.calibration.settings import Parameter, read_parameters
from ufmt.calibration.test_file import read_test
from ufmt.errors import StudyError
from ufmt.model.load import as_model
from ufmt.model.schema import Model
from ufmt.model.write import model_to_toml
from ufmt.tables import Where
from ufmt.tomlfile import read_toml

DEFAULT_BAND = (0.5, 2.0)  # default band of each factor: a stiffness known to a factor of two
AT_BOUND = 1e-3  # |u - ln bound| below this: the factor sits at its bound
IDENTIFIED_SHARE = 0.25  # [-] largest deviation of an identified factor, share of its band
SETTINGS_KEYS = ("settings", "parameter")


@dataclass(frozen=True)
class UpdateSettings:
    """``[settings]`` of a model-update file: regularisation rho [-], max_evaluations of the
    least squares, frequency_error_percent (sigma_f of the identifiability) [%], step: the
    finite-difference step in u [-]."""

    regularisation: float = 0.01
    max_evaluations: int = 200
    frequency_error_percent: float = 0.5
    step: float = 1e-4


_RULES = {  # key -> (kind, lower, upper)
    "regularisation": (float, 0.0, 10.0),
    "max_evaluations": (int, 1, 100_000),
    "frequency_error_percent": (float, 1e-6, 50.0),
    "step": (float, 1e-8, 0.1),
}


def default_parameters(model: Model) -> tuple[Parameter, ...]:
    """One factor per hinge field (translational, rotational) over its finite, nonzero
    components, band DEFAULT_BAND."""
    out = []
    for hinge in model.hinges:
        for field in ("stiffness", "rotational_stiffness"):
            values = getattr(hinge, field)
            comps = tuple(i for i in range(3) if 0.0 < values[i] < math.inf)
            if comps:
                name = f"{hinge.name}.{field}"
                out.append(Parameter(name, (hinge.name,), field, comps, DEFAULT_BAND, "default"))
    return tuple(out)


def read_update_settings(path, model: Model) -> tuple[UpdateSettings, tuple[Parameter, ...]]:
    """The settings file of a model update: ``[settings]`` (optional, :class:`UpdateSettings`)
    and ``[[parameter]]`` tables (as in calibration.toml: name, hinges, field, components,
    band, reason) against ``model``; one line naming file, table and field on a mistake."""
    top = Where(str(path), error=StudyError)
    data = read_toml(path)
    top.keys(data, SETTINGS_KEYS, required=("parameter",))
    values = {}
    table = top.mapping("settings", data.get("settings", {}), "[settings]")
    where = top.sub("settings")
    where.keys(table, _RULES)
    for key, value in table.items():
        kind, low, high = _RULES[key]
        if kind is int:
            values[key] = where.integer(key, value, low, high)
        else:
            values[key] = where.within(key, where.number(key, value), low, high)
    return UpdateSettings(**values), read_parameters(top, data["parameter"], model)


@dataclass(frozen=True, eq=False, repr=False)
class ModelUpdate:
    """A calibrated model and how it was found: ``parameters`` with their identified
    ``scales`` s, ``deviation`` (the relative standard deviation of each s, module docstring),
    ``at_bound`` (names), the correlation ``before`` (prior) and ``after``, ``model`` the
    calibrated model, ``evaluations`` of the MSTMM, ``held`` (names of the factors the test
    cannot identify, at their prior), ``rank`` of the data and the ``singular_values`` of S."""

    prior: Model
    model: Model
    parameters: tuple[Parameter, ...]
    scales: np.ndarray
    deviation: np.ndarray
    at_bound: tuple[str, ...]
    before: Correlation
    after: Correlation
    settings: UpdateSettings
    evaluations: int
    held: tuple[str, ...]
    rank: int
    singular_values: np.ndarray

    def __repr__(self) -> str:
        b, a = self.before.summary(), self.after.summary()
        return (
            f"ModelUpdate({self.prior.name!r}: {len(self.parameters)} factors, data rank "
            f"{self.rank}, {len(self.held)} held, mean |error| "
            f"{b['mean_abs_error_percent']:.3g} % -> {a['mean_abs_error_percent']:.3g} %, "
            f"max {b['max_abs_error_percent']:.3g} % -> {a['max_abs_error_percent']:.3g} %)"
        )

    def to_frame(self) -> pd.DataFrame:
        """One row per parameter: name, hinges, field, components, band, scale, deviation
        (relative std of s), at_bound, held (not identified: at the prior)."""
        return pd.DataFrame(
            {
                "parameter": [p.name for p in self.parameters],
                "hinges": [" ".join(p.hinges) for p in self.parameters],
                "field": [p.field for p in self.parameters],
                "components": [" ".join(map(str, p.components)) for p in self.parameters],
                "band_low": [p.band[0] for p in self.parameters],
                "band_high": [p.band[1] for p in self.parameters],
                "scale": self.scales,
                "deviation": self.deviation,
                "at_bound": [p.name in self.at_bound for p in self.parameters],
                "held": [p.name in self.held for p in self.parameters],
            }
        )

    def residuals(self) -> pd.DataFrame:
        """Every test mode: its pair, frequency error [%] and MAC with the prior
        (``*_prior``) and with the calibrated model."""
        keys = ["test_mode", "test_hz"]
        pair = ["model_mode", "model_hz", "error_percent", "mac"]
        prior = self.before.table[keys + pair].rename(columns={c: f"{c}_prior" for c in pair})
        return pd.concat([prior, self.after.table[pair]], axis=1)

    def plot(self, ax=None):
        """The MAC matrix of the calibrated model against the test."""
        return self.after.plot(ax=ax)

    def save(self, directory) -> list[Path]:
        """Write ``parameters.csv``, ``residuals.csv`` and the calibrated correlation
        (``correlation.csv``, ``mac.csv``, ``mac.png``) to ``directory``."""
        from ufmt import files

        directory = Path(directory)
        tables = {"parameters.csv": self.to_frame(), "residuals.csv": self.residuals()}
        paths = [
            files.write_with(
                directory / name, lambda b, t=t: t.to_csv(b, index=False, float_format="%.8g")
            )
            for name, t in tables.items()
        ]
        return paths + self.after.save(directory)


def update_model(
    prior, test, parameters=None, settings: UpdateSettings | None = None
) -> ModelUpdate:
    """Calibrate ``prior`` (a path or a model) against ``test`` (a path or a ModalTest) by the
    bounded, regularised fit of the module docstring."""
    prior = as_model(prior)
    test = test if isinstance(test, ModalTest) else read_test(test)
    parameters = tuple(parameters or default_parameters(prior))
    settings = settings or UpdateSettings()
    if not parameters:
        raise StudyError(f"{prior.source}: no hinge with a finite stiffness to calibrate")
    lower = np.log([p.band[0] for p in parameters])
    upper = np.log([p.band[1] for p in parameters])
    target = np.log(test.frequencies_hz)
    count = [0]

    def frequencies(u):
        count[0] += 1
        table = correlate(apply_parameters(prior, parameters, u), test).table
        f = table["model_hz"].to_numpy(dtype=float)
        return np.where(np.isfinite(f), np.log(np.where(np.isfinite(f), f, 1.0)) - target, 0.0)

    start = frequencies(np.zeros(len(parameters)))
    sensitivity = _sensitivity(frequencies, start, len(parameters), settings.step)
    keep, deviation, rank, values = _identifiable(sensitivity, upper - lower, settings)
    if not keep.any():
        raise StudyError(
            f"{test.source}: the test identifies none of the {len(parameters)} factors (data "
            f"rank {rank}): every one would be held at its prior; add modes or sensors"
        )
    u = np.zeros(len(parameters))

    def residual(v):
        u[keep] = v
        return np.concatenate([frequencies(u), settings.regularisation * v])

    fit = least_squares(
        residual,
        np.zeros(int(keep.sum())),
        bounds=(lower[keep], upper[keep] + 1e-15 * (upper[keep] == lower[keep])),
        diff_step=settings.step,
        max_nfev=settings.max_evaluations,
        x_scale=1.0,
    )
    u[keep] = fit.x
    u[~keep] = 0.0
    deviation[keep] = _deviation(fit.jac[: target.size], settings)
    at_bound = tuple(
        p.name
        for p, ui, lo, hi in zip(parameters, u, lower, upper, strict=True)
        if min(ui - lo, hi - ui) < AT_BOUND and lo < hi
    )
    model = apply_parameters(prior, parameters, u)
    model = replace(model, name=f"{prior.name} (calibrated against {Path(test.source).name})")
    held = tuple(p.name for p, k in zip(parameters, keep, strict=True) if not k)
    return ModelUpdate(
        prior,
        model,
        parameters,
        np.exp(u),
        deviation,
        at_bound,
        correlate(prior, test),
        correlate(model, test),
        settings,
        count[0],
        held,
        rank,
        values,
    )


def _sensitivity(frequencies, start: np.ndarray, n: int, step: float) -> np.ndarray:
    """S = d ln f / d u at u = 0 (m, n) by forward differences of step ``step``."""
    columns = []
    for k in range(n):
        u = np.zeros(n)
        u[k] = step
        columns.append((frequencies(u) - start) / step)
    return np.stack(columns, axis=1)


def _deviation(sensitivity: np.ndarray, settings: UpdateSettings) -> np.ndarray:
    """Relative standard deviation of each factor (module docstring)."""
    n = sensitivity.shape[1]
    info = sensitivity.T @ sensitivity + settings.regularisation**2 * np.eye(n)
    sigma = settings.frequency_error_percent / 100.0
    return sigma * np.sqrt(np.diag(np.linalg.pinv(info)))


def _identifiable(sensitivity: np.ndarray, width: np.ndarray, settings: UpdateSettings):
    """(identified mask, deviation at the prior, data rank, singular values of S): factors
    held one at a time, the least identified first (module docstring)."""
    keep = width > 0
    deviation = np.full(width.size, np.inf)
    while keep.any():
        deviation[keep] = _deviation(sensitivity[:, keep], settings)
        ratio = np.where(keep, deviation / np.where(keep, width, 1.0), -np.inf)
        worst = int(np.argmax(ratio))
        if ratio[worst] <= IDENTIFIED_SHARE:
            break
        keep[worst] = False
    values = np.linalg.svd(sensitivity, compute_uv=False)
    sigma = settings.frequency_error_percent / 100.0
    limit = IDENTIFIED_SHARE * float(np.median(width))
    rank = int(np.sum(sigma < limit * values))
    return keep, deviation, rank, values


def write_model(update: ModelUpdate, path, settings_path=None) -> Path:
    """Write the calibrated model with a provenance header (how it was made, every factor
    and the errors); the only way a calibrated user model is written."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    b, a = update.before.summary(), update.after.summary()
    lines = [
        "# GENERATED FILE - do not edit by hand. Written by `ufmt calibrate --prior "
        f"{update.prior.source} --test {update.after.test.source}"
        + (f" --settings {settings_path}`." if settings_path else "`."),
        f"# Test modes paired: {a['paired']}; mean |error| {b['mean_abs_error_percent']:.4g} % "
        f"(prior) -> {a['mean_abs_error_percent']:.4g} %, max {b['max_abs_error_percent']:.4g}"
        f" % -> {a['max_abs_error_percent']:.4g} %; lowest MAC {a['min_mac']:.4g}.",
        f"# Data rank {update.rank} for {len(update.parameters)} factors; held at the prior (the "
        f"test cannot identify them): {', '.join(update.held) or 'none'}.",
        "# Factors (k = s * k_prior; band; relative std at "
        f"{update.settings.frequency_error_percent:g} % frequency error):",
    ]
    for p, s, d in zip(update.parameters, update.scales, update.deviation, strict=True):
        flag = "  AT BOUND" if p.name in update.at_bound else ""
        flag += "  HELD (not identified)" if p.name in update.held else ""
        lines.append(f"#   {p.name}  s = {s:.6g}  [{p.band[0]:g}, {p.band[1]:g}]  +-{d:.2g}{flag}")
    from ufmt import files

    return files.write_text(path, "\n".join(lines) + "\n" + model_to_toml(update.model))
