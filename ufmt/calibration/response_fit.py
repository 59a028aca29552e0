"""Fit of the physically uncertain ``[machine]`` parameters to the paper's response measurements.

The ``[response]`` table of ``calibration.toml`` declares

* ``[[response.parameter]]``: a ``[machine]`` key, its documented band and start value, and
  whether it is searched in ``log`` (scale factors) or ``linear`` coordinates, or held at its
  start (``fit = false``). A key the model
  loader does not know (not a field of :class:`ufmt.model.machine.Machine`) is skipped with a
  note, so the file can list parameters that later versions of the loader add. A key whose
  current value is a pair (``workpiece_size``) is set to (v, v).
* ``[[response.target]]``: a metric of :func:`ufmt.simulate.simulate` (or ``centre_rise_nm``,
  :func:`centre_rise_nm`), the dotted key of its value in ``paper_reference.toml`` with a unit
  factor, and its kind: ``value`` (relative residual ``ours / paper - 1``) or ``positive``
  (one-sided: residual ``max(0, -ours) / scale_nm``, for a shape the paper states in words).

and the fit is a bounded nonlinear least squares (scipy ``least_squares``, trust-region
reflective, in coordinates that map each band onto [0, 1], so ``diff_step`` is a fraction of
the band) of the weighted residuals at the reference process (sections 3.3,
4.2: 300 rpm, 15 mm/min, 4 um). PV is a maximum over the surface, so the cost has kinks where
local searches stop; ``starts`` > 1 restarts the search from the documented start values and
``starts - 1`` Latin-hypercube points of the bands (fixed seed) and keeps the lowest cost.
Restarts do not make an underdetermined fit identifiable: a key the targets cannot pin down is
declared ``fit = false`` and held at its documented ``start`` (docs/ufmt-model.md, 'Which keys
are fitted'). The fitted values are rounded to
:data:`ufmt.calibration.identify.SIGNIFICANT` digits. A value at a band's edge means the
measurements ask for more than the band allows: it is reported (``at_bound``), not widened.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

from ufmt.calibration.tables import check_keys, read_band
from ufmt.calibration.tables import fail as _fail
from ufmt.model.machine import Machine, read_machine
from ufmt.model.schema import Model

PARAMETER_KEYS = ("key", "band", "start", "scale", "unit", "reason", "fit")
TARGET_KEYS = ("metric", "reference", "factor", "kind", "unit", "scale_nm", "weight", "note")
RESPONSE_KEYS = (
    "method",
    "diff_step",
    "max_evaluations",
    "starts",
    "parameter",
    "target",
)
KINDS = ("value", "positive")
SCALES = ("log", "linear")
CENTRE_FRACTION = 0.5  # the "middle part": the central half of the plate in x and in y
BOUND_RTOL = 1e-3  # a fitted value within this (relative) of a band edge is "at the bound"


@dataclass(frozen=True)
class FitParameter:
    """One fitted ``[machine]`` key: band [lower, upper] and start, in its own unit."""

    key: str
    band: tuple[float, float]
    start: float
    scale: str = "log"
    unit: str = ""
    reason: str = ""
    fit: bool = True  # False: held at ``start`` (a documented value the data cannot identify)

    def _map(self, value: float) -> float:
        return math.log(value) if self.scale == "log" else value

    def to_x(self, value: float) -> float:
        """Search coordinate: 0 at the band's lower edge, 1 at its upper (log or linear)."""
        lo, hi = map(self._map, self.band)
        return (self._map(value) - lo) / (hi - lo)

    def from_x(self, x: float) -> float:
        lo, hi = map(self._map, self.band)
        v = lo + float(x) * (hi - lo)
        return math.exp(v) if self.scale == "log" else v


@dataclass(frozen=True)
class FitTarget:
    """One measured quantity: our ``metric``, the paper's value (times ``factor``) and kind."""

    metric: str
    paper: float
    kind: str = "value"
    unit: str = ""
    scale_nm: float = 1.0
    weight: float = 1.0
    note: str = ""

    def residual(self, ours: float) -> float:
        if self.kind == "positive":
            return self.weight * max(0.0, -ours) / self.scale_nm
        return self.weight * (ours / self.paper - 1.0)


@dataclass(frozen=True)
class ResponseSettings:
    """The ``[response]`` table: parameters (known keys only), skipped keys, targets."""

    parameters: tuple[FitParameter, ...]
    skipped: tuple[str, ...]
    targets: tuple[FitTarget, ...]
    method: str = "periodic"
    diff_step: float = 1e-2
    max_evaluations: int = 200
    starts: int = 1


def known_machine_keys() -> tuple[str, ...]:
    """The ``[machine]`` keys the model loader reads (fields of :class:`Machine`)."""
    return tuple(f.name for f in dataclasses.fields(Machine))


def _number(where, table, key, default=None, positive=False) -> float:
    v = table.get(key, default)
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        _fail(where, f"field {key!r}: {v!r} must be a finite number")
    if positive and v <= 0:
        _fail(where, f"field {key!r}: {v!r} must be > 0")
    return float(v)


def _count(where, table, key) -> int:
    """An integer field >= 1 (default 1)."""
    value = table.get(key, 1)
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        _fail(where, f"field {key!r}: {value!r} must be an integer >= 1")
    return value


def _lookup(reference: Mapping, dotted: str, where: str) -> float:
    value = reference
    for part in dotted.split("."):
        if not isinstance(value, Mapping) or part not in value:
            _fail(where, f"field 'reference': {dotted!r} is not a value of paper_reference.toml")
        value = value[part]
    if isinstance(value, bool) or not isinstance(value, int | float):
        _fail(where, f"field 'reference': {dotted!r} is not a number")
    return float(value)


def read_response_settings(table, reference: Mapping, where: str) -> ResponseSettings:
    """Check the ``[response]`` table of a calibration file (``where`` names it in errors)."""
    where = f"{where}: [response]"
    if not isinstance(table, Mapping):
        _fail(where, "must be a table")
    check_keys(where, table, RESPONSE_KEYS)
    known = known_machine_keys()
    parameters, skipped = [], []
    for i, t in enumerate(table.get("parameter", [])):
        label = f"{where}: parameter[{i}]"
        if not isinstance(t, Mapping) or not isinstance(t.get("key"), str):
            _fail(label, "must be a table with a 'key' (a [machine] field name)")
        label = f"{where}: parameter {t['key']!r}"
        check_keys(label, t, PARAMETER_KEYS)
        band = read_band(label, t.get("band"), lambda lo, hi: lo < hi, "lower < upper")
        scale = t.get("scale", "log")
        if scale not in SCALES:
            _fail(label, f"field 'scale': {scale!r} is not one of {', '.join(SCALES)}")
        if scale == "log" and band[0] <= 0:
            _fail(label, f"field 'band': {list(band)!r} must be > 0 for scale 'log'")
        start = _number(label, t, "start")
        if not band[0] <= start <= band[1]:
            _fail(label, f"field 'start': {start!r} must lie in the band {list(band)!r}")
        fit = t.get("fit", True)
        if not isinstance(fit, bool):
            _fail(label, f"field 'fit': {fit!r} must be true or false")
        if t["key"] not in known:
            skipped.append(t["key"])
            continue
        parameters.append(
            FitParameter(
                t["key"],
                band,
                start,
                scale,
                str(t.get("unit", "")),
                str(t.get("reason", "")),
                fit,
            )
        )
    targets = []
    for i, t in enumerate(table.get("target", [])):
        label = f"{where}: target[{i}]"
        if not isinstance(t, Mapping) or not isinstance(t.get("metric"), str):
            _fail(label, "must be a table with a 'metric'")
        label = f"{where}: target {t['metric']!r}"
        check_keys(label, t, TARGET_KEYS)
        kind = t.get("kind", "value")
        if kind not in KINDS:
            _fail(label, f"field 'kind': {kind!r} is not one of {', '.join(KINDS)}")
        paper = (
            0.0
            if kind == "positive"
            else _lookup(reference, str(t.get("reference", "")), label)
            * _number(label, t, "factor", 1.0, positive=True)
        )
        targets.append(
            FitTarget(
                t["metric"],
                paper,
                kind,
                str(t.get("unit", "")),
                _number(label, t, "scale_nm", 1.0, positive=True),
                _number(label, t, "weight", 1.0, positive=True),
                str(t.get("note", "")),
            )
        )
    if not targets:
        _fail(where, "[[response.target]]: none given")
    method = table.get("method", "periodic")
    if method not in ("periodic", "time"):
        _fail(where, f"field 'method': {method!r} is not one of periodic, time")
    return ResponseSettings(
        tuple(parameters),
        tuple(skipped),
        tuple(targets),
        method,
        _number(where, table, "diff_step", 1e-2, positive=True),
        int(_number(where, table, "max_evaluations", 200, positive=True)),
        _count(where, table, "starts"),
    )


def centre_rise_nm(surface) -> float:
    """Fig. 14's shape as a number [nm]: mean height of the middle part minus the rest's.

    The middle part is the central CENTRE_FRACTION of the plate in x and in y (a quarter of
    its area), on the evenly spaced rows. Positive: "the middle part of the surface is higher
    than the surrounding area" (section 4.2).
    """
    core = surface.core_rows
    x, y, z = surface.x, surface.y[core], surface.z[core]
    half_x = CENTRE_FRACTION * (x.max() - x.min()) / 2
    half_y = CENTRE_FRACTION * (y.max() - y.min()) / 2
    middle = (np.abs(y - (y.max() + y.min()) / 2) <= half_y)[:, None] & (
        np.abs(x - (x.max() + x.min()) / 2) <= half_x
    )[None, :]
    return float(z[middle].mean() - z[~middle].mean()) * 1e9


def with_values(model: Model, values: Mapping[str, float]) -> Model:
    """``model`` with the given ``[machine]`` keys set (a pair-valued key gets (v, v))."""
    machine = dict(model.machine.table)
    for key, v in values.items():
        current = machine.get(key)
        machine[key] = [float(v), float(v)] if isinstance(current, list | tuple) else float(v)
    return replace(model, machine=read_machine(machine, model.source))


def response_metrics(model: Model, process, basis, method: str) -> dict[str, float]:
    """The simulation's metrics plus :func:`centre_rise_nm` of its surface."""
    from ufmt.simulate import simulate

    result = simulate(model, process, basis=basis, method=method)
    return {**result.metrics, "centre_rise_nm": centre_rise_nm(result.surface)}


@dataclass(frozen=True, eq=False)
class ResponseFit:
    """The fitted values, the metrics there, residuals per target and the values at a bound."""

    settings: ResponseSettings
    values: dict[str, float]
    metrics: dict[str, float]
    residuals: np.ndarray
    at_bound: tuple[str, ...]
    evaluations: int
    process: object = None  # the reference Process

    def __repr__(self) -> str:
        values = ", ".join(f"{k}={v:.6g}" for k, v in self.values.items())
        return f"ResponseFit({values}; at bound: {list(self.at_bound)}; cost {self.cost:.4g})"

    @property
    def cost(self) -> float:
        return 0.5 * float(self.residuals @ self.residuals)

    def to_frame(self) -> pd.DataFrame:
        """One row per target: metric, paper value, ours, residual."""
        return pd.DataFrame(
            {
                "metric": [t.metric for t in self.settings.targets],
                "kind": [t.kind for t in self.settings.targets],
                "paper": [t.paper for t in self.settings.targets],
                "ours": [self.metrics[t.metric] for t in self.settings.targets],
                "residual": self.residuals,
            }
        )


def start_points(params, starts: int) -> list[np.ndarray]:
    """Start points of the fit in band coordinates [0, 1]: the documented start values, then
    ``starts - 1`` points of a Latin hypercube with a fixed seed (deterministic)."""
    from scipy.stats import qmc

    first = np.array([p.to_x(p.start) for p in params])
    if starts == 1 or not params:
        return [first]
    return [first, *qmc.LatinHypercube(len(params), seed=0).random(starts - 1)]


def fit_response(
    model: Model, settings: ResponseSettings, process, basis=None, progress: bool = False
) -> ResponseFit:
    """Fit the settings' parameters of ``model`` to its targets at ``process`` (module doc).

    ``basis`` (default: ``modal_basis(model)``) is the model's modal basis; the fitted keys
    change the cut, not the structure, so one basis serves every evaluation.
    """
    from tqdm import tqdm

    from ufmt.calibration.identify import rounded
    from ufmt.machining.modal import modal_basis

    basis = modal_basis(model) if basis is None else basis
    held = {p.key: p.start for p in settings.parameters if not p.fit}
    model = with_values(model, held)
    params = tuple(p for p in settings.parameters if p.fit)

    def metrics_at(x) -> dict[str, float]:
        values = {p.key: p.from_x(v) for p, v in zip(params, x, strict=True)}
        return response_metrics(with_values(model, values), process, basis, settings.method)

    bar = tqdm(desc="response fit", unit="sim", disable=not progress, dynamic_ncols=True)

    def residuals(x) -> np.ndarray:
        m = metrics_at(x)
        r = np.array([t.residual(m[t.metric]) for t in settings.targets])
        bar.update()
        bar.set_postfix_str(f"cost {0.5 * float(r @ r):.4g}")
        return r

    best, evaluations = None, 0
    try:
        for x0 in start_points(params, settings.starts):
            x = x0
            if params:
                sol = least_squares(
                    residuals,
                    x0,
                    bounds=(np.zeros(len(params)), np.ones(len(params))),
                    method="trf",
                    diff_step=settings.diff_step,
                    max_nfev=settings.max_evaluations,
                )
                x, evaluations = sol.x, evaluations + int(sol.nfev)
            fitted = {p.key: float(rounded(p.from_x(v))[0]) for p, v in zip(params, x, strict=True)}
            values = {p.key: (held | fitted)[p.key] for p in settings.parameters}
            final = response_metrics(with_values(model, values), process, basis, settings.method)
            res = np.array([t.residual(final[t.metric]) for t in settings.targets])
            if best is None or res @ res < best[2] @ best[2]:
                best = (values, final, res)
    finally:
        bar.close()
    values, final, res = best
    at_bound = tuple(
        p.key
        for p in params
        if min(abs(values[p.key] - b) for b in p.band) <= BOUND_RTOL * max(map(abs, p.band))
    )
    return ResponseFit(settings, values, final, res, at_bound, evaluations, process)
