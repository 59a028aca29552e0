"""The documented bands of a model's uncertain inputs, read from where they are documented
(never restated here), so that a band added there is an input of the uncertainty and
tolerance studies at once (:func:`model_bands`).

A model file that declares ``[[uncertain]]`` tables (:mod:`ufmt.model.uncertain`) has those
inputs and no others. The packaged machine's bands belong to the packaged machine alone: a
model without its own tables gets them only if its content is the packaged model's
(:func:`is_packaged_machine`: the same :func:`ufmt.fingerprint.model_sha256`, wherever the
file lies); any other model has no uncertain inputs until it declares them.

The packaged machine's bands come from two sources, both in the packaged calibration file
(``ufmt/data/calibration.toml``, reasons in docs/ufmt-model.md):

* ``[[response.parameter]]``: the physically uncertain ``[machine]`` numbers (force
  coefficient, spindle tilt, error motion and its phase, straightness and its wavelength, and
  any key added there that the model loader knows) with their band and search scale, as
  parameters ``machine.<key>``;
* ``[[parameter]]``: the identified stiffness factors s (``k = s k_prior``,
  ``band[0] <= s <= band[1]``) of one hinge and one component (the bearings' radial, axial
  and angular stiffnesses, the slide's pads, the foundation), as parameters
  ``hinge.<name>.<field>[i]`` over the absolute band ``band * k_prior`` [N/m or N m/rad],
  log scale. Factors tied over several hinges or components are not one model parameter and
  are left out.

Keys of the model loader without a documented band (its :data:`OPTIONAL_FIELDS` ranges say
only what a file may hold) are not listed: give them a ``range`` in the study file.

Damping has no calibration entry (the paper gives none and nothing identifies it), so its band
is an engineering assumption stated here (:data:`DAMPING_BANDS`), as two parameters:

* ``machine.modal_damping_ratio``: the structural modal damping ratio of every mode (the
  ``[machine]`` key, default 0.01, the bodies' own damping; a design parameter, so the
  uncertainty and tolerance studies sample it with the other ``machine.*`` bands), band
  0.005-0.02, log scale. Measured modal damping of precision machine structures with bolted
  and aerostatic joints is about 1-5 % in total, most of it in the joints (Slocum, *Precision
  Machine Design*, 1992, ch. 7; Altintas, *Manufacturing Automation*, 2nd ed., 2012, ch. 3);
  the model's joints are its hinges, so the bodies' share is the low end: half to twice the
  default.
* ``damping.hinge_factor`` (:func:`damping_bands`, outside the model's design vocabulary):
  one factor on every hinge damper of the model (``damping`` and
  ``rotational_damping``; written as zeta 1-5 % per joint at a reference frequency,
  docs/ufmt-model.md), band 0.5-2, log scale: a joint's damping ratio is known to about a
  factor of two (squeeze-film air gaps, bolted interfaces, grout), and the per-joint values
  already span the 1-5 % of the literature.

``ufmt simulate --uncertainty`` samples both (:mod:`ufmt.studies.intervals`: the factor on
the model's hinge dampers); a study samples the ratio only (``ufmt.evaluate`` has no hinge
damping factor).
"""

from __future__ import annotations

import fnmatch
import functools
from dataclasses import dataclass
from pathlib import Path

from ufmt.calibration.settings import load_calibration
from ufmt.design import MACHINE_PREFIX, design_target, machine_target
from ufmt.errors import StudyError
from ufmt.fingerprint import file_sha256, model_sha256
from ufmt.model.load import load_model, packaged_path
from ufmt.model.machine import OPTIONAL_FIELDS
from ufmt.model.schema import Model
from ufmt.model.uncertain import HINGE_DAMPING_FACTOR

CALIBRATION = "calibration.toml"  # the packaged file holding the bands
_COMPONENTS = "xyz"


@dataclass(frozen=True)
class DocumentedBand:
    """The documented band [low, high] [SI] of one parameter; ``log``: its natural scale is
    logarithmic (stiffnesses, the force factor); ``reason``: the documented reason."""

    parameter: str
    low: float
    high: float
    log: bool
    unit: str
    reason: str


DAMPING_PREFIX = "damping."
DAMPING_BANDS = (
    (
        f"{MACHINE_PREFIX}modal_damping_ratio",
        0.005,
        0.02,
        "structural modal damping ratio of every mode (bodies' own share of"
        " the 1-5 % measured on precision machines; assumption, ufmt.studies.bands)",
    ),
    (
        HINGE_DAMPING_FACTOR,
        0.5,
        2.0,
        "factor on every hinge damper (a joint's damping ratio known to"
        " about a factor of two; assumption, ufmt.studies.bands)",
    ),
)


def _assumed_bands(prefix: str) -> dict[str, DocumentedBand]:
    """The assumed damping bands whose name starts with ``prefix``, log scale."""
    return {
        name: DocumentedBand(name, low, high, True, "-", why)
        for name, low, high, why in DAMPING_BANDS
        if name.startswith(prefix)
    }


def damping_bands() -> dict[str, DocumentedBand]:
    """The assumed damping bands outside the design vocabulary (``damping.hinge_factor``)."""
    return _assumed_bands(DAMPING_PREFIX)


def documented_bands(calibration: str | Path | None = None) -> dict[str, DocumentedBand]:
    """Every documented band by parameter name (machine keys first, then hinge stiffnesses),
    read from ``calibration`` (default: the packaged calibration file)."""
    path = packaged_path(CALIBRATION) if calibration is None else Path(calibration)
    settings, prior, _ = load_calibration(path)
    bands: dict[str, DocumentedBand] = {}
    if settings.response is not None:
        for p in settings.response.parameters:
            if p.key in OPTIONAL_FIELDS and p.band[1] > p.band[0]:
                name = f"{MACHINE_PREFIX}{p.key}"
                unit = OPTIONAL_FIELDS[p.key][3]
                bands[name] = DocumentedBand(name, *p.band, p.scale == "log", unit, p.reason)
    bands.update(_assumed_bands(MACHINE_PREFIX))  # the structural damping ratio
    for p in settings.parameters:
        if len(p.hinges) != 1 or len(p.components) != 1 or p.band[1] <= p.band[0]:
            continue
        hinge, component = p.hinges[0], p.components[0]
        prior_value = float(getattr(prior.hinge(hinge), p.field)[component])
        if not 0.0 < prior_value < float("inf"):
            continue
        name = f"hinge.{hinge}.{p.field}[{component}]"
        unit = "N/m" if p.field == "stiffness" else "N m/rad"
        low, high = p.band[0] * prior_value, p.band[1] * prior_value
        reason = f"{p.reason} (factor {p.band[0]:g}-{p.band[1]:g} on the prior)"
        bands[name] = DocumentedBand(name, low, high, True, unit, reason)
    return bands


def matching(pattern: str, bands: dict[str, DocumentedBand]) -> list[str]:
    """The band names matching a shell-style ``pattern`` (``machine.*``, ``hinge.h31.*``), in
    the bands' order."""
    return [name for name in bands if fnmatch.fnmatchcase(name, pattern)]


def is_packaged_machine(model: Model) -> bool:
    """Whether ``model``'s content is the packaged model's (its file anywhere, or loaded)."""
    return model_sha256(model) == _packaged_sha256(file_sha256(packaged_path()))


@functools.lru_cache(maxsize=2)
def _packaged_sha256(file_sha: str) -> str:
    """The packaged model's content hash (keyed by its file's bytes: a recalibration
    rewrites it)."""
    return model_sha256(load_model())


def model_bands(model: Model | None = None, damping: bool = True) -> dict[str, DocumentedBand]:
    """The bands of ``model``'s uncertain inputs (default: the packaged machine): its own
    ``[[uncertain]]`` tables; else, for the packaged machine, :func:`documented_bands` (and
    :func:`damping_bands` if ``damping``); else none. ``damping=False`` leaves out the inputs
    outside the design vocabulary (``damping.*``, which a study cannot set)."""
    if model is not None and model.uncertain:
        return {
            u.name: DocumentedBand(u.name, u.low, u.high, u.log, _unit(model, u.name), u.source)
            for u in model.uncertain
            if damping or not u.name.startswith(DAMPING_PREFIX)
        }
    if model is not None and not is_packaged_machine(model):
        return {}
    return {**documented_bands(), **(damping_bands() if damping else {})}


def no_bands(model: Model) -> StudyError:
    """The one-line error of a model that declares no uncertain inputs."""
    return StudyError(
        f"model {model.source} declares no uncertain inputs: add [[uncertain]] tables to it"
        " (name, band or scale, source; docs/model-files.md); the documented bands of"
        " ufmt/data/calibration.toml belong to the packaged machine only"
    )


def _unit(model: Model, name: str) -> str:
    """The unit of parameter ``name`` of ``model``."""
    if name == HINGE_DAMPING_FACTOR:
        return "-"
    target = machine_target(name) if name.startswith(MACHINE_PREFIX) else None
    if target is not None:
        return "m" if target[1] is not None else OPTIONAL_FIELDS[target[0]][3]
    _, field, _ = design_target(name, model.design)
    return "N/m" if field == "stiffness" else "N m/rad"
