"""Helpers shared by the test modules (synthetic machines, bases and residuals, and the
packaged model at unit force scale); fixtures are in conftest.py.

* MACHINE: a ``[machine]`` table (SI units) for the cutting, response and surface tests;
  SMALL the same on a small plate, so that the whole-workpiece time path is fast.
* synthetic_basis, random_residual: a random modal basis and residual flexibility.
* dynamic_surface: the surface of z_re alone, composed as ``ufmt.simulate`` composes it.
* axisymmetric_chain: a random chain whose y and z modes are double roots.
* packaged_text, packaged_model: the packaged UFMT with ``force_scale = 1`` (the literature
  force coefficients, whatever the calibration fitted).
* process_running, child_pids, still_running: the process table as /proc shows it (the
  oracle of the tests that kill a run and look for workers left behind).
"""

import re
import time
from importlib import resources
from pathlib import Path

import numpy as np

from ufmt.defaults import DEFAULT_SPACING
from ufmt.machining.basis import ModalBasis
from ufmt.machining.static import ResidualFlexibility
from ufmt.machining.surface import surface_passes
from ufmt.model.load import load_model_text

MACHINE = {
    "tool_body": "head",
    "workpiece_body": "slider",
    "spindle_axis_xy": [0.0, 0.0],
    "cutting_plane_z": 0.0,
    "tool_radius": 0.25,
    "workpiece_size": [0.41, 0.41],
    "workpiece_center_xy": [0.0, 0.0],
    "rotation": "cw",
}

# a small plate so that the whole-workpiece time path takes a fraction of a second
SMALL = {**MACHINE, "tool_radius": 0.06, "workpiece_size": [0.1, 0.2]}


def synthetic_basis(n=6, seed=3, f_lo=8.0, f_hi=400.0, slider_turns=True):
    """n modes with random rigid motions of the head and the slider (and an idle bed)."""
    rng = np.random.default_rng(seed)
    shapes = {}
    for body in ("head", "slider", "bed"):
        s = rng.normal(size=(n, 6))
        s[:, 3:] *= 2.0
        shapes[body] = s
    if not slider_turns:
        shapes["slider"][:, 3:] = 0.0
    return ModalBasis(
        omega=2 * np.pi * np.geomspace(f_lo, f_hi, n),
        modal_mass=np.full(n, 2000.0),
        body_shapes=shapes,
        body_centers={"head": [0, 0, 0.15], "slider": [0, 0, -0.15], "bed": [0, 0, -1.0]},
    )


def dynamic_surface(table, machine, feed_per_rev, spacing=DEFAULT_SPACING, trailing_arc=False):
    """The surface of z_re alone, composed as ufmt.simulate composes its surfaces: the lower
    pass of the source heights on one set of passes."""
    passes = surface_passes(machine, feed_per_rev, spacing, trailing_arc)
    return passes.lower([passes.dynamic(table, machine)])


def random_residual(seed=5):
    """A symmetric positive-definite 12 x 12 residual flexibility (synthetic, [m/N])."""
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(12, 12))
    matrix = 1e-10 * (a @ a.T / 12 + np.eye(12))
    centers = np.array([[0, 0, 0.15], [0, 0, -0.15]], dtype=float)
    return ResidualFlexibility(matrix=matrix, centers=centers, static=matrix)


def axisymmetric_chain(seed: int) -> dict:
    """Random chain of rigid bodies along x on isotropic springs, inertia diag(Jx, J, J): the
    y and z bending of the chain are identical, so those modes are double roots."""
    rng = np.random.default_rng(seed)
    bodies, hinges, previous = [], [], "ground"
    x = 0.0
    for i in range(3):
        x += rng.uniform(0.1, 0.4)
        j = rng.uniform(0.01, 0.1)
        bodies.append(
            {
                "name": f"b{i}",
                "kind": "rigid",
                "mass": rng.uniform(1.0, 20.0),
                "center_of_mass": [x, 0.0, 0.0],
                "inertia": np.diag([rng.uniform(0.01, 0.1), j, j]).tolist(),
            }
        )
        k, kr = 10 ** rng.uniform(6, 8), 10 ** rng.uniform(4, 6)
        at = [x - rng.uniform(0.02, 0.08), 0.0, 0.0]
        hinges.append(
            {
                "name": f"h{i}",
                "between": [previous, f"b{i}"],
                "at": at,
                "stiffness": [k] * 3,
                "rotational_stiffness": [kr] * 3,
            }
        )
        previous = f"b{i}"
    return {"name": f"chain{seed}", "body": bodies, "hinge": hinges}


def packaged_text() -> str:
    """Text of the packaged model with force_scale = 1."""
    text = resources.files("ufmt.data").joinpath("ufmt.toml").read_text()
    return re.sub(r"(?m)^force_scale = .*$", "force_scale = 1.0", text)


def packaged_model():
    """The packaged model (force_scale = 1), loaded."""
    return load_model_text(packaged_text(), "ufmt.toml")


def process_running(pid: int) -> bool:
    """Whether process ``pid`` runs (a zombie left for its parent or init to reap has ended)."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    return "\nState:\tZ" not in status


def child_pids(pid: int) -> list[int]:
    """The children of process ``pid``, over all its threads."""
    found = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        found += [int(c) for c in (task / "children").read_text().split()]
    return found


def still_running(pids: list[int], within_s: float) -> list[int]:
    """Wait up to ``within_s`` [s] for every process in ``pids`` to end; those still running."""
    deadline = time.monotonic() + within_s
    while time.monotonic() < deadline and any(process_running(p) for p in pids):
        time.sleep(0.1)
    return [p for p in pids if process_running(p)]
