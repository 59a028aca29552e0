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
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ufmt.calibration.frequencies import Reference, read_reference
from ufmt.calibration.tables import check_keys, fail, read_band, suggest
from ufmt.defaults import PAPER_MODES
from ufmt.model.load import load_model
from ufmt.model.machine import Machine
from ufmt.model.schema import Model
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


_KIND_NAMES = {float: "a number", int: "an integer"}


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
    where = str(path)
    data = read_toml(path)
    check_keys(where, data, TOP_KEYS)
    base = Path(path).parent
    for key in ("prior", "reference", "output"):
        if not isinstance(data.get(key), str):
            fail(where, f"field {key!r}: {data.get(key)!r} must be a file path (string)")
    prior_path = Path(prior) if prior is not None else base / data["prior"]
    out_path = Path(output) if output is not None else base / data["output"]
    reference_path = base / data["reference"]
    model = load_model(prior_path)
    reference = read_reference(reference_path)
    settings = _settings(where, data.get("settings", {}))
    parameters = _parameters(where, data.get("parameter", []), model)
    targets = _targets(where, data.get("targets"), reference, settings, reference_path)
    name = data.get("output_name", "UFMT")
    if not isinstance(name, str) or not name:
        fail(where, f"field 'output_name': {name!r} must be a non-empty string")
    constraint = _constraint(where, data.get("constraint"), model)
    response = None
    if data.get("response") is not None:  # checked now, not after the identification
        response = read_response_settings(data["response"], read_toml(reference_path), where)
    calibration = Calibration(
        where,
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


def _settings(where: str, table) -> Settings:
    if not isinstance(table, dict):
        fail(where, "[settings] must be a table")
    check_keys(f"{where}: [settings]", table, _SETTING_RULES)
    values = {}
    for key, value in table.items():
        kind, low, strict = _SETTING_RULES[key]
        ok = (
            isinstance(value, bool)
            if kind is bool
            else (isinstance(value, int | float) and not isinstance(value, bool))
        )
        if ok and kind is int:
            ok = isinstance(value, int)
        if ok and low is not None:
            ok = math.isfinite(value) and (value > low if strict else value >= low)
        if not ok:
            need = (
                "true or false"
                if kind is bool
                else f"{_KIND_NAMES[kind]} {'>' if strict else '>='} {low:g}"
            )
            fail(f"{where}: [settings]", f"field {key!r}: {value!r} must be {need}")
        values[key] = kind(value)
    return Settings(**values)


def _parameters(where: str, tables, model: Model) -> tuple[Parameter, ...]:
    if not isinstance(tables, list) or not tables:
        fail(where, "[[parameter]]: none given; list at least one parameter to identify")
    hinge_names = [h.name for h in model.hinges]
    seen_names, seen_entries = set(), {}
    out = []
    for i, t in enumerate(tables):
        label = f"{where}: parameter[{i}]"
        if not isinstance(t, dict):
            fail(label, "must be a table")
        name = t.get("name")
        if not isinstance(name, str) or not name:
            fail(label, f"field 'name': {name!r} must be a non-empty string")
        label = f"{where}: parameter {name!r}"
        check_keys(label, t, PARAMETER_KEYS)
        if name in seen_names:
            fail(label, "field 'name': used by another parameter")
        seen_names.add(name)
        hinges = t.get("hinges")
        if not isinstance(hinges, list) or not hinges:
            fail(label, f"field 'hinges': {hinges!r} must list hinge names")
        for h in hinges:
            if h not in hinge_names:
                fail(
                    label,
                    f"field 'hinges': {h!r} is not a hinge of {model.source}"
                    f"{suggest(h, hinge_names)}; hinges: {', '.join(hinge_names)}",
                )
        fld = t.get("field")
        if fld not in FIELDS:
            fail(label, f"field 'field': {fld!r} is not one of {', '.join(FIELDS)}")
        comps = t.get("components")
        if (
            not isinstance(comps, list)
            or not comps
            or not all(
                isinstance(c, int) and not isinstance(c, bool) and 0 <= c <= 2 for c in comps
            )
            or len(set(comps)) != len(comps)
        ):
            fail(label, f"field 'components': {comps!r} must list distinct 0, 1, 2 (x, y, z)")
        band = read_band(
            label, t.get("band"), lambda lo, hi: 0 < lo <= 1 <= hi, "0 < lower <= 1 <= upper"
        )
        for h in hinges:
            values = getattr(model.hinge(h), fld)
            for c in comps:
                if not (0 < values[c] < math.inf):
                    fail(
                        label,
                        f"field 'components': {h} {fld}[{c}] is {values[c]!r} in {model.source}; "
                        "only finite, nonzero stiffness can be scaled",
                    )
                if (h, fld, c) in seen_entries:
                    fail(
                        label,
                        f"field 'hinges': {h} {fld}[{c}] is also scaled by parameter "
                        f"{seen_entries[(h, fld, c)]!r}",
                    )
                seen_entries[(h, fld, c)] = name
        reason = t.get("reason", "")
        out.append(Parameter(name, tuple(hinges), fld, tuple(comps), band, reason))
    return tuple(out)


def _constraint(where: str, table, model: Model) -> Constraint | None:
    if table is None:
        return None
    label = f"{where}: [constraint]"
    if not isinstance(table, dict):
        fail(where, "[constraint] must be a table")
    check_keys(label, table, CONSTRAINT_KEYS)
    names = [h.name for h in model.hinges]
    hinges = table.get("hinges")
    if not isinstance(hinges, list) or not hinges or any(h not in names for h in hinges):
        fail(label, f"field 'hinges': {hinges!r} must list hinges of {model.source}")
    values = {}
    for key, low in (("factor", 1.0), ("max_change_percent", 0.0), ("weight", 0.0)):
        v = table.get(key, 1.0 if key == "weight" else None)
        if (
            isinstance(v, bool)
            or not isinstance(v, int | float)
            or not math.isfinite(v)
            or v <= low
        ):
            fail(label, f"field {key!r}: {v!r} must be a number > {low:g}")
        values[key] = float(v)
    modes = table.get("modes", [])
    if not isinstance(modes, list) or not all(isinstance(k, int) for k in modes):
        fail(label, f"field 'modes': {modes!r} must list Table 3 mode numbers")
    return Constraint(
        tuple(hinges), source=str(table.get("source", "")), modes=tuple(modes), **values
    )


def _targets(where: str, table, reference: Reference, settings: Settings, ref_path) -> Targets:
    label = f"{where}: [targets]"
    if not isinstance(table, dict):
        fail(where, "[targets]: missing; give the Table 3 modes to match")
    check_keys(label, table, TARGET_KEYS)
    column = table.get("column", "modal_test_hz")
    if column not in COLUMNS:
        fail(label, f"field 'column': {column!r} is not one of {', '.join(COLUMNS)}")
    modes = table.get("modes")
    if not isinstance(modes, list) or not modes:
        fail(label, f"field 'modes': {modes!r} is empty; list at least one Table 3 mode number")
    values = reference.column(column)
    for k in modes:
        if not isinstance(k, int) or isinstance(k, bool) or k not in values:
            fail(
                label,
                f"field 'modes': {k!r} has no {column!r} in {ref_path}; modes with one: "
                f"{', '.join(map(str, values))}",
            )
        if k > settings.n_modes:
            fail(label, f"field 'modes': {k} exceeds [settings] n_modes = {settings.n_modes}")
    if len(set(modes)) != len(modes):
        fail(label, f"field 'modes': {modes!r} lists a mode twice")
    modes = sorted(modes)
    hz = np.array([values[k] for k in modes])
    return Targets(tuple(modes), hz, column, str(table.get("source", "")))


def known_machine_keys() -> tuple[str, ...]:
    """The ``[machine]`` keys the model loader reads (fields of :class:`Machine`)."""
    return tuple(f.name for f in dataclasses.fields(Machine))


def _number(where, table, key, default=None, positive=False) -> float:
    v = table.get(key, default)
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        fail(where, f"field {key!r}: {v!r} must be a finite number")
    if positive and v <= 0:
        fail(where, f"field {key!r}: {v!r} must be > 0")
    return float(v)


def _count(where, table, key) -> int:
    """An integer field >= 1 (default 1)."""
    value = table.get(key, 1)
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        fail(where, f"field {key!r}: {value!r} must be an integer >= 1")
    return value


def _lookup(reference: Mapping, dotted: str, where: str) -> float:
    value = reference
    for part in dotted.split("."):
        if not isinstance(value, Mapping) or part not in value:
            fail(where, f"field 'reference': {dotted!r} is not a value of paper_reference.toml")
        value = value[part]
    if isinstance(value, bool) or not isinstance(value, int | float):
        fail(where, f"field 'reference': {dotted!r} is not a number")
    return float(value)


def read_response_settings(table, reference: Mapping, where: str) -> ResponseSettings:
    """Check the ``[response]`` table of a calibration file (``where`` names it in errors);
    ``reference`` is the paper_reference.toml the targets' values are read from."""
    where = f"{where}: [response]"
    if not isinstance(table, Mapping):
        fail(where, "must be a table")
    check_keys(where, table, RESPONSE_KEYS)
    known = known_machine_keys()
    parameters, skipped = [], []
    for i, t in enumerate(table.get("parameter", [])):
        parameter = _fit_parameter(f"{where}: parameter[{i}]", where, t)
        if parameter.key not in known:
            skipped.append(parameter.key)
            continue
        parameters.append(parameter)
    targets = [
        _fit_target(f"{where}: target[{i}]", where, t, reference)
        for i, t in enumerate(table.get("target", []))
    ]
    if not targets:
        fail(where, "[[response.target]]: none given")
    method = table.get("method", "periodic")
    if method not in ("periodic", "time"):
        fail(where, f"field 'method': {method!r} is not one of periodic, time")
    return ResponseSettings(
        tuple(parameters),
        tuple(skipped),
        tuple(targets),
        method,
        _number(where, table, "diff_step", 1e-2, positive=True),
        int(_number(where, table, "max_evaluations", 200, positive=True)),
        _count(where, table, "starts"),
    )


def _fit_parameter(label: str, where: str, t) -> FitParameter:
    """One ``[[response.parameter]]`` table (``label``: its place, until its key is known)."""
    if not isinstance(t, Mapping) or not isinstance(t.get("key"), str):
        fail(label, "must be a table with a 'key' (a [machine] field name)")
    label = f"{where}: parameter {t['key']!r}"
    check_keys(label, t, FIT_PARAMETER_KEYS)
    band = read_band(label, t.get("band"), lambda lo, hi: lo < hi, "lower < upper")
    scale = t.get("scale", "log")
    if scale not in FIT_SCALES:
        fail(label, f"field 'scale': {scale!r} is not one of {', '.join(FIT_SCALES)}")
    if scale == "log" and band[0] <= 0:
        fail(label, f"field 'band': {list(band)!r} must be > 0 for scale 'log'")
    start = _number(label, t, "start")
    if not band[0] <= start <= band[1]:
        fail(label, f"field 'start': {start!r} must lie in the band {list(band)!r}")
    fit = t.get("fit", True)
    if not isinstance(fit, bool):
        fail(label, f"field 'fit': {fit!r} must be true or false")
    return FitParameter(
        t["key"],
        band,
        start,
        scale,
        str(t.get("unit", "")),
        str(t.get("reason", "")),
        fit,
    )


def _fit_target(label: str, where: str, t, reference: Mapping) -> FitTarget:
    """One ``[[response.target]]`` table (``label``: its place, until its metric is known)."""
    if not isinstance(t, Mapping) or not isinstance(t.get("metric"), str):
        fail(label, "must be a table with a 'metric'")
    label = f"{where}: target {t['metric']!r}"
    check_keys(label, t, FIT_TARGET_KEYS)
    kind = t.get("kind", "value")
    if kind not in FIT_TARGET_KINDS:
        fail(label, f"field 'kind': {kind!r} is not one of {', '.join(FIT_TARGET_KINDS)}")
    paper = (
        0.0
        if kind == "positive"
        else _lookup(reference, str(t.get("reference", "")), label)
        * _number(label, t, "factor", 1.0, positive=True)
    )
    return FitTarget(
        t["metric"],
        paper,
        kind,
        str(t.get("unit", "")),
        _number(label, t, "scale_nm", 1.0, positive=True),
        _number(label, t, "weight", 1.0, positive=True),
        str(t.get("note", "")),
    )
