"""The calibration file (``ufmt/data/calibration.toml``): reading and checking it.

:func:`load_calibration` reads the file into a :class:`Calibration` and loads its prior model
and its reference table. Every table is checked here, before anything is computed, and a
mistake raises one line naming the file, the table and the field
(:class:`~ufmt.errors.StudyError`, or ModelError for the prior):

* ``[settings]`` -> :class:`Settings`, the numerics of the identification
  (:mod:`ufmt.calibration.identify`);
* ``[[parameter]]`` -> :class:`Parameter`, one identified stiffness factor each;
* ``[targets]`` -> :class:`Targets`, the Table 3 modes to match;
* ``[constraint]`` (optional) -> :class:`Constraint`, springs that may barely move the modes;
* ``[response]`` (optional) -> :class:`ResponseSettings`, the ``[machine]`` parameters and the
  response measurements of the response fit (:mod:`ufmt.calibration.response_fit`, whose
  docstring explains the fields); :func:`read_response_settings` reads this table alone.

The bands of ``[[parameter]]`` and ``[[response.parameter]]`` are also the packaged machine's
documented uncertainty bands (:mod:`ufmt.studies.bands`): they apply to the packaged machine
only; another model declares its own in ``[[uncertain]]`` tables (:mod:`ufmt.model.uncertain`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ufmt.calibration.frequencies import Reference, read_reference
from ufmt.defaults import PAPER_MODES
from ufmt.errors import StudyError
from ufmt.model.load import load_model
from ufmt.model.machine import Machine
from ufmt.model.schema import Model
from ufmt.tables import Where, short_vector
from ufmt.tomlfile import read_toml

FIELDS = ("stiffness", "rotational_stiffness")  # the hinge fields a [[parameter]] scales
COLUMNS = ("modal_test_hz", "mstmm_hz", "fem_hz")  # the Table 3 columns [targets] may match
TOP_KEYS = (
    "prior",
    "reference",
    "output",
    "output_name",
    "targets",
    "settings",
    "parameter",
    "constraint",
    "response",
)
CONSTRAINT_KEYS = ("hinges", "modes", "factor", "max_change_percent", "weight", "source")
TARGET_KEYS = ("modes", "column", "source")
PARAMETER_KEYS = ("name", "hinges", "field", "components", "band", "reason")
FIT_PARAMETER_KEYS = ("key", "band", "start", "scale", "unit", "reason", "fit")
FIT_TARGET_KEYS = (
    "metric",
    "reference",
    "factor",
    "kind",
    "unit",
    "scale_nm",
    "weight",
    "note",
)
RESPONSE_KEYS = (
    "method",
    "diff_step",
    "max_evaluations",
    "starts",
    "parameter",
    "target",
)
FIT_TARGET_KINDS = ("value", "positive")
FIT_SCALES = ("log", "linear")


@dataclass(frozen=True)
class Parameter:
    """One identified factor s: ``k = s k_prior`` on ``components`` of ``field`` of ``hinges``.

    band : (lower, upper) bounds of s [-], lower <= 1 <= upper (the prior is inside).
    """

    name: str
    hinges: tuple[str, ...]
    field: str
    components: tuple[int, ...]
    band: tuple[float, float]
    reason: str = ""


@dataclass(frozen=True)
class Settings:
    """Numerical settings of the identification (``[settings]`` of calibration.toml).

    regularisation : rho, weight of |u| [-]; trust_region : initial t, largest |d_p| per step;
    min_trust_region : stop when t falls below; max_iterations : local steps per run;
    tolerance_percent : stop when no paired frequency changes by more than this [%] in a step;
    elements_per_beam : beam mesh of the cheap assembled model; n_modes : modes solved;
    accept_max_percent, accept_mean_percent : the local run has stalled when it ends above
    these or with shape mismatches; shape_penalty : cost of one shape mismatch in J;
    seed, population, generations : differential evolution (scipy ``rng``, ``popsize``,
    ``maxiter``) of the global start; global_start : allow it at all.
    """

    regularisation: float = 0.05
    trust_region: float = 0.3
    min_trust_region: float = 1e-3
    max_iterations: int = 60
    tolerance_percent: float = 0.05
    elements_per_beam: int = 8
    n_modes: int = PAPER_MODES
    accept_max_percent: float = 3.0
    accept_mean_percent: float = 1.0
    shape_penalty: float = 0.01
    global_start: bool = True
    seed: int = 1
    population: int = 10
    generations: int = 60


_SETTING_RULES = {  # name -> (type, lower bound, strict)
    "regularisation": (float, 0.0, False),
    "trust_region": (float, 0.0, True),
    "min_trust_region": (float, 0.0, True),
    "max_iterations": (int, 1, False),
    "tolerance_percent": (float, 0.0, True),
    "elements_per_beam": (int, 1, False),
    "n_modes": (int, 1, False),
    "accept_max_percent": (float, 0.0, True),
    "accept_mean_percent": (float, 0.0, True),
    "shape_penalty": (float, 0.0, False),
    "global_start": (bool, None, False),
    "seed": (int, 0, False),
    "population": (int, 1, False),
    "generations": (int, 1, False),
}


@dataclass(frozen=True)
class Constraint:
    """A statement that the springs of ``hinges`` barely move the natural frequencies.

    Scaling all of them by ``factor`` (or 1/factor) may change no tested frequency by more than
    ``max_change_percent``, linearised: ``share_m ln(factor) / 2 <= ln(1 + max/100)`` with
    share_m the mode's strain-energy share in those springs. The violation enters J with
    ``weight`` (1: as much as the same ln-frequency error).
    """

    hinges: tuple[str, ...]
    factor: float
    max_change_percent: float
    weight: float = 1.0
    source: str = ""
    modes: tuple[int, ...] = ()  # Table 3 modes it applies to (empty: every tested mode)

    @property
    def limit(self) -> float:
        """Largest allowed strain-energy share [-]."""
        return 2.0 * math.log1p(self.max_change_percent / 100.0) / math.log(self.factor)

    def violation(self, shares: np.ndarray) -> np.ndarray:
        """ln-frequency change beyond the allowed one, per mode (>= 0)."""
        return np.maximum(0.0, 0.5 * math.log(self.factor) * (shares - self.limit))


@dataclass(frozen=True)
class Targets:
    """Table 3 modes to match: numbers (model mode N is paired with Table 3 mode N) and [Hz]."""

    modes: tuple[int, ...]
    frequencies_hz: np.ndarray
    column: str = "modal_test_hz"
    source: str = ""


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
        """The value at search coordinate ``x`` (the inverse of :meth:`to_x`)."""
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
        """Weighted residual of our value: relative error, or one-sided for ``positive``."""
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


@dataclass(frozen=True)
class Calibration:
    """A validated calibration file: inputs, parameters, targets and settings."""

    source: str
    prior: Path
    reference: Path
    output: Path
    output_name: str
    parameters: tuple[Parameter, ...]
    targets: Targets
    settings: Settings
    constraint: Constraint | None = None
    response: ResponseSettings | None = None  # the [response] table (None: no response fit)


def load_calibration(
    path: str | Path, prior: str | Path | None = None, output: str | Path | None = None
) -> tuple[Calibration, Model, Reference]:
    """Read and check a calibration file, its prior model and its reference table.

    ``prior`` and ``output`` override the file's entries; the file's own paths are relative to
    its directory. Raises :class:`~ufmt.errors.StudyError` (or ModelError for the prior) with
    one line naming the file, the table and the field.
    """
    source = str(path)
    top = Where(source, error=StudyError)
    data = read_toml(path)
    top.keys(data, TOP_KEYS, required=("prior", "reference", "output"))
    base = Path(path).parent
    for key in ("prior", "reference", "output"):
        top.string(key, data[key], allow_empty=True)
    prior_path = Path(prior) if prior is not None else base / data["prior"]
    out_path = Path(output) if output is not None else base / data["output"]
    reference_path = base / data["reference"]
    model = load_model(prior_path)
    reference = read_reference(reference_path)
    settings = _settings(top, data.get("settings", {}))
    parameters = _parameters(top, data.get("parameter", []), model)
    targets = _targets(top, data.get("targets"), reference, settings, reference_path)
    name = top.string("output_name", data.get("output_name", "UFMT"))
    constraint = _constraint(top, data.get("constraint"), model)
    response = None
    if data.get("response") is not None:  # checked now, not after the identification
        response = read_response_settings(data["response"], read_toml(reference_path), source)
    calibration = Calibration(
        source,
        prior_path,
        reference_path,
        out_path,
        name,
        parameters,
        targets,
        settings,
        constraint,
        response,
    )
    return calibration, model, reference


def _settings(top: Where, table) -> Settings:
    top.mapping("settings", table, "[settings]")
    where = top.sub("settings")
    where.keys(table, _SETTING_RULES)
    values = {}
    for key, value in table.items():
        kind, low, strict = _SETTING_RULES[key]
        if kind is bool:
            values[key] = where.boolean(key, value)
        elif kind is int:
            values[key] = where.integer(key, value, low)
        else:
            values[key] = where.number(key, value, sign="positive" if strict else "nonnegative")
    return Settings(**values)


def _parameters(top: Where, tables, model: Model) -> tuple[Parameter, ...]:
    tables = top.tables("parameter", tables, required=True)
    hinge_names = [h.name for h in model.hinges]
    seen_names, seen_entries = [], {}
    out = []
    for i, t in enumerate(tables):
        name = top.sub(f"parameter[{i}]").string("name", t.get("name"))
        where = top.sub(f"parameter {name!r}")
        where.keys(t, PARAMETER_KEYS, required=("hinges", "field", "components", "band"))
        seen_names = where.unique("name", [*seen_names, name])
        hinges = where.items("hinges", t["hinges"], "hinge name", required=True)
        for j, h in enumerate(hinges):
            where.choice(f"hinges[{j}]", h, hinge_names, "hinge")
        fld = where.choice("field", t["field"], FIELDS, "hinge field")
        comps = where.items("components", t["components"], "component", required=True)
        for j, c in enumerate(comps):
            where.integer(f"components[{j}]", c, 0, 2)
        where.unique("components", comps)
        band = where.interval("band", t["band"], allow_equal=True, sign="positive")
        if band[0] == band[1]:  # the search needs room (bounds lower < upper)
            where.fail(
                "band",
                f"empty range {short_vector(band)} (allowed: 0 < lower <= 1 <= upper, lower <"
                " upper); to hold these hinges at the prior, leave the parameter out",
            )
        if not band[0] <= 1.0 <= band[1]:
            where.fail(
                "band",
                f"{short_vector(band)} does not contain 1, the prior"
                " (allowed: 0 < lower <= 1 <= upper)",
            )
        for h in hinges:
            values = getattr(model.hinge(h), fld)
            for c in comps:
                if not (0 < values[c] < math.inf):
                    where.fail(
                        "components",
                        f"{h} {fld}[{c}] is {values[c]!r} in {model.source}; "
                        "only finite, nonzero stiffness can be scaled",
                    )
                if (h, fld, c) in seen_entries:
                    where.fail(
                        "hinges",
                        f"{h} {fld}[{c}] is also scaled by parameter {seen_entries[(h, fld, c)]!r}",
                    )
                seen_entries[(h, fld, c)] = name
        reason = t.get("reason", "")
        out.append(Parameter(name, tuple(hinges), fld, tuple(comps), band, reason))
    return tuple(out)


def read_parameters(top: Where, tables, model: Model) -> tuple[Parameter, ...]:
    """The ``[[parameter]]`` tables of any calibration or settings file (``top`` names the
    file) against ``model``: the one reading of identified stiffness factors."""
    return _parameters(top, tables, model)


def _constraint(top: Where, table, model: Model) -> Constraint | None:
    if table is None:
        return None
    top.mapping("constraint", table, "[constraint]")
    where = top.sub("constraint")
    where.keys(table, CONSTRAINT_KEYS, required=("hinges", "factor", "max_change_percent"))
    names = [h.name for h in model.hinges]
    hinges = where.items("hinges", table["hinges"], "hinge name", required=True)
    for j, h in enumerate(hinges):
        where.choice(f"hinges[{j}]", h, names, "hinge")
    factor = where.minimum("factor", where.number("factor", table["factor"]), 1.0, strict=True)
    values = {"factor": factor}
    for key in ("max_change_percent", "weight"):
        values[key] = where.number(key, table.get(key, 1.0), sign="positive")
    modes = where.items("modes", table.get("modes", []), "Table 3 mode number")
    for j, k in enumerate(modes):
        where.integer(f"modes[{j}]", k)
    return Constraint(
        tuple(hinges), source=str(table.get("source", "")), modes=tuple(modes), **values
    )


def _targets(top: Where, table, reference: Reference, settings: Settings, ref_path) -> Targets:
    if table is None:
        top.missing("targets", "give the Table 3 modes to match")
    top.mapping("targets", table, "[targets]")
    where = top.sub("targets")
    where.keys(table, TARGET_KEYS, required=("modes",))
    column = where.choice("column", table.get("column", "modal_test_hz"), COLUMNS, "column")
    modes = where.items("modes", table["modes"], "Table 3 mode number", required=True)
    values = reference.column(column)
    for j, k in enumerate(modes):
        where.integer(f"modes[{j}]", k)
        if k not in values:
            where.fail(
                f"modes[{j}]",
                f"{k!r} has no {column!r} in {ref_path}; modes with one: "
                f"{', '.join(map(str, values))}",
            )
        if k > settings.n_modes:
            where.fail(f"modes[{j}]", f"{k} exceeds settings n_modes = {settings.n_modes}")
    where.unique("modes", modes)
    modes = sorted(modes)
    hz = np.array([values[k] for k in modes])
    return Targets(tuple(modes), hz, column, str(table.get("source", "")))


def known_machine_keys() -> tuple[str, ...]:
    """The ``[machine]`` keys the model loader reads (fields of :class:`Machine`)."""
    return tuple(f.name for f in dataclasses.fields(Machine))


def _lookup(reference: Mapping, dotted: str, where: Where) -> float:
    value = reference
    for part in dotted.split("."):
        if not isinstance(value, Mapping) or part not in value:
            where.fail("reference", f"{dotted!r} is not a value of paper_reference.toml")
        value = value[part]
    if isinstance(value, bool) or not isinstance(value, int | float):
        where.fail("reference", f"{dotted!r} is not a number")
    return float(value)


def read_response_settings(table, reference: Mapping, source: str) -> ResponseSettings:
    """Check the ``[response]`` table of a calibration file (``source`` names it in errors);
    ``reference`` is the paper_reference.toml the targets' values are read from."""
    Where(source, error=StudyError).mapping("response", table, "[response]")
    where = Where(source, "response", error=StudyError)
    where.keys(table, RESPONSE_KEYS)
    known = known_machine_keys()
    parameters, skipped = [], []
    for i, t in enumerate(where.tables("parameter", table.get("parameter", []))):
        parameter = _fit_parameter(where, i, t)
        if parameter.key not in known:
            skipped.append(parameter.key)
            continue
        parameters.append(parameter)
    targets = [
        _fit_target(where, i, t, reference)
        for i, t in enumerate(where.tables("target", table.get("target", []), required=True))
    ]
    method = where.choice("method", table.get("method", "periodic"), ("periodic", "time"), "method")
    return ResponseSettings(
        tuple(parameters),
        tuple(skipped),
        tuple(targets),
        method,
        where.number("diff_step", table.get("diff_step", 1e-2), sign="positive"),
        int(where.number("max_evaluations", table.get("max_evaluations", 200), sign="positive")),
        where.integer("starts", table.get("starts", 1), 1),
    )


def _fit_parameter(response: Where, index: int, t) -> FitParameter:
    """The ``index``-th ``[[response.parameter]]`` table."""
    at = response.sub(f"parameter[{index}]")
    at.required(t, ("key",))
    key = at.string("key", t["key"], allow_empty=True)
    where = response.sub(f"parameter {key!r}")
    where.keys(t, FIT_PARAMETER_KEYS, required=("band", "start"))
    scale = where.choice("scale", t.get("scale", "log"), FIT_SCALES, "scale")
    positive = {"sign": "positive", "allowed": "> 0 for scale 'log'"} if scale == "log" else {}
    band = where.interval("band", t["band"], **positive)
    start = where.within("start", where.number("start", t["start"]), *band)
    fit = where.boolean("fit", t.get("fit", True))
    return FitParameter(
        key,
        band,
        start,
        scale,
        str(t.get("unit", "")),
        str(t.get("reason", "")),
        fit,
    )


def _fit_target(response: Where, index: int, t, reference: Mapping) -> FitTarget:
    """The ``index``-th ``[[response.target]]`` table."""
    at = response.sub(f"target[{index}]")
    at.required(t, ("metric",))
    metric = at.string("metric", t["metric"], allow_empty=True)
    where = response.sub(f"target {metric!r}")
    where.keys(t, FIT_TARGET_KEYS)
    kind = where.choice("kind", t.get("kind", "value"), FIT_TARGET_KINDS, "kind")
    paper = (
        0.0
        if kind == "positive"
        else _lookup(reference, str(t.get("reference", "")), where)
        * where.number("factor", t.get("factor", 1.0), sign="positive")
    )
    return FitTarget(
        metric,
        paper,
        kind,
        str(t.get("unit", "")),
        where.number("scale_nm", t.get("scale_nm", 1.0), sign="positive"),
        where.number("weight", t.get("weight", 1.0), sign="nonnegative"),
        str(t.get("note", "")),
    )
