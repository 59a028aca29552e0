"""Content hashes that decide whether a stored result may be reused: a file's bytes, a model's
content, a Python file's syntax tree, and the physics code.

The physics code is an allow-list, :data:`PHYSICS`: the modules whose source can change what
:func:`ufmt.evaluate` returns. An edit anywhere else (studies, plots, report, cli,
calibration, the evaluation cache) keeps every cached record and every resumable study row.
``tests/test_studies.py`` checks that the list covers every ufmt module an evaluation loads,
apart from the few that cannot change a record (named there with their reason). The only file
an evaluation reads besides its modules is the model file, whose content keys the cache on its
own (:func:`model_sha256`).
"""

from __future__ import annotations

import ast
import functools
import hashlib
import os
from pathlib import Path

from ufmt.model.schema import Model
from ufmt.model.write import model_to_toml

PACKAGE = Path(__file__).resolve().parent

#: Package-relative paths of the physics source: a folder stands for every ``*.py`` in it.
PHYSICS = (
    "errors.py",  # the error types and messages a failed evaluation records
    "defaults.py",  # the reference process, the default basis and grid
    "tables.py",  # the table checker whose messages a failed evaluation records
    "tomlfile.py",  # the file reader whose messages a failed evaluation records
    "model",  # loading and validating model files, [machine] and [design] tables
    "kinds",  # body and hinge kinds: fields, readers, formulations (bending theories, the film)
    "kinematics.py",  # rigid-point kinematics of both solvers
    "assembled",  # the mass-stiffness model (static flexibility, calibration's reduced model)
    "mstmm",  # natural frequencies (counted by Wittrick-Williams) and mode shapes
    "solvers.py",  # solve_modes by either solver
    "machining",  # modal basis, cutting force, error sources, response, surface
    "simulate.py",  # one cut
    "simulation_result.py",  # the result of a cut, whose to_dict an evaluation reads
    "arguments.py",  # the argument checks whose messages a failed evaluation records
    "limits.py",  # the budgets whose messages a failed evaluation records
    "design.py",  # design parameters -> hinge values, the reference process, record names
    "evaluate.py",  # the record itself
)


def file_sha256(path: str | os.PathLike) -> str:
    """SHA-256 hex digest of a file's bytes (read in blocks: a huge file costs time, not
    memory, before the loader refuses it)."""
    with Path(path).open("rb") as fh:
        return hashlib.file_digest(fh, "sha256").hexdigest()


def model_sha256(model: Model) -> str:
    """SHA-256 of a model's content (its canonical TOML and the content of the files it names,
    the guideway's profile): comments, layout and the file's location do not change it."""
    text = model_to_toml(model)
    profile = model.machine.straightness_profile if model.machine is not None else None
    if profile is not None:
        text += f"\n# straightness_profile sha256 {profile.digest}\n"
    return hashlib.sha256(text.encode()).hexdigest()


def source_sha256(path: str | os.PathLike) -> str:
    """SHA-256 of a Python file's syntax tree: comments and formatting do not change it (a
    file that does not parse is hashed by its bytes)."""
    text = Path(path).read_bytes()
    try:
        return hashlib.sha256(ast.dump(ast.parse(text)).encode()).hexdigest()
    except (SyntaxError, ValueError):
        return hashlib.sha256(text).hexdigest()


def physics_sources() -> list[Path]:
    """The Python files of :data:`PHYSICS`, sorted."""
    paths = []
    for entry in PHYSICS:
        path = PACKAGE / entry
        paths += sorted(path.rglob("*.py")) if path.is_dir() else [path]
    return sorted(paths)


@functools.cache
def code_sha256() -> str:
    """SHA-256 over the syntax trees of the physics source (:data:`PHYSICS`), keyed by their
    paths inside the package."""
    digest = hashlib.sha256()
    for path in physics_sources():
        digest.update(path.relative_to(PACKAGE).as_posix().encode())
        digest.update(source_sha256(path).encode())
    return digest.hexdigest()
