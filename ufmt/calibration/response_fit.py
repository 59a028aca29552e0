"""Fit of the physically uncertain ``[machine]`` parameters to the paper's response measurements.

The ``[response]`` table of ``calibration.toml`` (read and checked by
:func:`ufmt.calibration.settings.read_response_settings`) declares

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
:data:`ufmt.calibration.rounding.SIGNIFICANT` digits. A value at a band's edge means the
measurements ask for more than the band allows: it is reported (``at_bound``, with the value
it asked for), held at its documented start and the others fitted again; never widened,
never shipped at the edge. A target of ``weight = 0`` is compared and reported, not fitted.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd
from scipy.optimize import least_squares
from scipy.stats import qmc
from tqdm import tqdm

from ufmt.calibration.rounding import rounded
from ufmt.calibration.settings import ResponseSettings
from ufmt.machining.modal import modal_basis
from ufmt.model.machine import read_machine
from ufmt.model.schema import Model
from ufmt.simulate import simulate

CENTRE_FRACTION = 0.5  # the "middle part": the central half of the plate in x and in y
#: A fitted value within this share of its band (in the search coordinate: the log of a
#: log-scaled key) of an edge is "at the bound": the fit asks for the edge, which is not shipped.
EDGE_FRACTION = 0.02


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
    wanted: dict = field(default_factory=dict)  # key -> the edge value the fit asked for

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
    first = np.array([p.to_x(p.start) for p in params])
    if starts == 1 or not params:
        return [first]
    return [first, *qmc.LatinHypercube(len(params), seed=0).random(starts - 1)]


def fit_response(
    model: Model, settings: ResponseSettings, process, basis=None, progress: bool = False
) -> ResponseFit:
    """Fit the settings' parameters of ``model`` to its targets at ``process`` (module doc).

    ``basis`` (default: ``modal_basis(model)``) is the model's modal basis; the fitted keys
    change the cut, not the structure, so one basis serves every evaluation. A key the fit
    drives within :data:`EDGE_FRACTION` of an edge of its band is a finding, not a value: it is
    held at its documented start, the others are fitted again, and the result names it in
    ``at_bound`` with the value it asked for in ``wanted``.
    """
    basis = modal_basis(model) if basis is None else basis
    wanted: dict[str, float] = {}
    evaluations = 0
    while True:
        fit = _fit_once(model, settings, process, basis, progress)
        evaluations += fit.evaluations
        edges = {
            p.key: fit.values[p.key]
            for p in settings.parameters
            if p.fit
            and min(p.to_x(fit.values[p.key]), 1 - p.to_x(fit.values[p.key])) <= EDGE_FRACTION
        }
        if not edges:
            break
        wanted.update(edges)
        settings = replace(
            settings,
            parameters=tuple(
                replace(p, fit=False) if p.key in edges else p for p in settings.parameters
            ),
        )
    return replace(fit, at_bound=tuple(wanted), wanted=wanted, evaluations=evaluations)


def _fit_once(model: Model, settings: ResponseSettings, process, basis, progress) -> ResponseFit:
    """One bounded least-squares fit of the settings' ``fit`` parameters (the others held at
    their start) from every start point; the lowest cost is kept."""
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
    return ResponseFit(settings, values, final, res, (), evaluations, process)
