"""Study files (TOML): the immutable :class:`Study` and the :class:`StudyKind` record of each
kind (:mod:`ufmt.studies.fields` reads the fields, :mod:`ufmt.studies.load` a whole file).

A study file names its kind and what to vary. Common top-level fields::

    kind = "sweep"                       # a study kind of ufmt.studies.kinds: sweep, grid,
                                         #   optimise-process, ...
    name = "sweep-stiffness"             # optional; default: the file's stem; -> results/<name>/
    description = "..."                  # optional
    function = "ufmt.evaluate:evaluate"  # optional: "module:attribute" or "file.py:attribute"
                                         #   (relative to the study file); called as
                                         #   f(design, process, model) -> dict with "pv_nm"
    model = "../my-machine.toml"         # optional model file (relative to the study file);
                                         #   default: the packaged UFMT

    [base]                               # fixed values for every point (others: calibrated
    rpm = 300.0                          #   design, reference process)

    [design.head_z_N_m]                  # optional: design parameters of this study, added
    hinge = "h31"                        #   to the model's own [design] table (same schema,
    field = "stiffness"                  #   see ufmt.model.load.parse_design)
    components = [2]

Parameters are the model's (and the study's) declared design parameters
(``head_angular_stiffness_Nm_rad`` on the packaged UFMT), ``hinge.<name>.stiffness[i]`` /
``hinge.<name>.rotational_stiffness[i]``, and ``rpm``, ``feed_mm_min``, ``depth_um``. The model
is loaded while the study is parsed, and every value the study can set (base, axis values,
bound ends; ``scale`` resolved against the calibrated value) is checked with the model
loader's rules before any point runs: a negative or absurd stiffness, a ``scale`` of a released
(0) or rigid (inf) component, or a process value <= 0 is a :class:`~ufmt.errors.StudyError`.
Values along an axis or a bound are given by exactly one of::

    values = [1e6, 2e6, 5e6]             # explicit values
    range = [200.0, 400.0]               # absolute low, high (with n and spacing for an axis)
    scale = [0.1, 10.0]                  # low, high as multiples of the calibrated value
    n = 9                                # number of values (axes only; default 9)
    spacing = "log"                      # linear | log (default linear)

Each kind's own fields are documented in its module (:mod:`ufmt.studies.kinds` lists them).

Every problem raises :class:`~ufmt.errors.StudyError` with one line naming the file, the table
and the field, in the wording of :mod:`ufmt.tables` (the model and calibration files' too).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ufmt.model.schema import DesignParameter


@dataclass(frozen=True)
class Axis:
    """Values of one parameter: absolute, or multiples of its calibrated value (``relative``)."""

    parameter: str
    values: tuple[float, ...]
    log: bool = False
    relative: bool = False

    def resolved(self, baseline: Mapping[str, float]) -> tuple[float, ...]:
        """Absolute values, scaling relative ones by ``baseline[parameter]``."""
        if not self.relative:
            return self.values
        return tuple(v * baseline[self.parameter] for v in self.values)


@dataclass(frozen=True)
class Bound:
    """Search or sampling interval of one parameter; ``log`` searches in log10 of it."""

    parameter: str
    low: float
    high: float
    log: bool = False
    relative: bool = False

    def resolved(self, baseline: Mapping[str, float]) -> tuple[float, float]:
        """Absolute (low, high), scaling relative ones by ``baseline[parameter]``."""
        factor = baseline[self.parameter] if self.relative else 1.0
        return self.low * factor, self.high * factor


@dataclass(frozen=True)
class Group:
    """Points varied together: one axis (a one-at-a-time sweep) or several (a grid)."""

    name: str
    axes: tuple[Axis, ...]

    def points(self, baseline: Mapping[str, float]) -> list[dict[str, float]]:
        """Full-factorial points over the axes (first axis slowest)."""
        names = [a.parameter for a in self.axes]
        values = [a.resolved(baseline) for a in self.axes]
        return [dict(zip(names, combo, strict=True)) for combo in itertools.product(*values)]


@dataclass(frozen=True)
class Study:
    """A validated study file; ``options`` holds the kind's own fields with defaults filled."""

    path: Path
    name: str
    kind: str
    description: str
    function: str
    model: Path | None
    base: dict[str, float]
    groups: tuple[Group, ...] = ()
    bounds: tuple[Bound, ...] = ()
    options: dict[str, Any] = field(default_factory=dict)
    inputs: tuple[str, ...] = ()  # sampled uncertain inputs (band draws), columns of points.csv
    text: str = ""
    design: dict[str, DesignParameter] = field(default_factory=dict)
    baseline: dict[str, float] = field(default_factory=dict)
    content_sha256: str = ""

    @property
    def parameters(self) -> tuple[str, ...]:
        """Every parameter the study sets: base keys, then axes and bounds, in file order."""
        names = list(self.base)
        names += [a.parameter for g in self.groups for a in g.axes]
        names += [b.parameter for b in self.bounds]
        names += list(self.inputs)
        return tuple(dict.fromkeys(names))

    @property
    def relative_parameters(self) -> tuple[str, ...]:
        """Parameters given as multiples of their calibrated value (need a baseline)."""
        items = [a for g in self.groups for a in g.axes] + list(self.bounds)
        return tuple(dict.fromkeys(i.parameter for i in items if i.relative))


@dataclass(frozen=True)
class StudyKind:
    """A study kind: its own top-level fields and what a run of it does.

    Each kind's module defines one; :mod:`ufmt.studies.kinds` names them all.

    * ``parse(where, data, parameters)``: check the kind's fields of the parsed TOML ``data``
      and return the kind's parts of the :class:`Study` (``groups``, ``bounds``,
      ``options``). ``where`` is the file's :class:`ufmt.tables.Where` (``where.integer``,
      ``where.number``, ``where.choice``, ``where.sub("table")``, ``where.fail`` ...);
      ``parameters`` the :class:`ufmt.studies.fields.Parameters` the study can set (with
      its ``base`` values); :mod:`ufmt.studies.fields` reads ``[[axis]]``, ``[[grid]]`` and
      ``[[bound]]`` tables;
    * ``planned_points(study)``: the number of points a run requests (exact, or an
      optimiser's budget: an upper bound);
    * ``analyse(study, evaluator, baseline, out_dir)``: request the points from the run's
      :class:`ufmt.studies.journal.Evaluator`, write the kind's ``tables`` (file names in
      ``out_dir``, besides points.csv) and return the headline finding;
    * ``figures(out_dir)``: the figures of a finished run drawn from its tables, by PNG file
      name;
    * ``simulated_figures(study, out_dir)`` (optional): figures that need a few simulations
      beyond the tables (run in the outputs step, only when plots are drawn), by PNG name.
    """

    name: str
    fields: tuple[str, ...]
    tables: tuple[str, ...]
    parse: Callable[..., dict[str, Any]]
    planned_points: Callable[..., int]
    analyse: Callable[..., str]
    figures: Callable[..., dict]
    simulated_figures: Callable[..., dict] | None = None
