"""Immutable model objects: bodies, hinges and the model that holds them.

All quantities are SI and expressed in one global frame (see ../shared/DESIGN.md and the
README's model-file schema). Objects are built by :mod:`ufmt.model.load`, which validates every
field; constructing them directly skips validation. Vectors are read-only numpy arrays.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from ufmt.model.machine import Machine

GROUND = "ground"


def frozen_array(values, shape=None) -> np.ndarray:
    """A read-only float copy of ``values`` (optionally reshaped) [same units as input]."""
    a = np.array(values, dtype=float)
    if shape is not None:
        a = a.reshape(shape)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class RigidBody:
    """Rigid body (paper eqs. 2.8, 2.9, 3.1).

    mass [kg]; center_of_mass [m]; inertia [kg m^2] tensor about the centre of mass.
    """

    name: str
    mass: float
    center_of_mass: np.ndarray
    inertia: np.ndarray
    number: int | None = None
    kind: str = field(default="rigid", init=False)


@dataclass(frozen=True, eq=False)
class VirtualBody:
    """Massless point body (paper eq. 2.11); every hinge on it must share one point."""

    name: str
    number: int | None = None
    kind: str = field(default="virtual", init=False)

    @property
    def mass(self) -> float:
        """Mass [kg]: none (every body kind has a ``mass``)."""
        return 0.0


@dataclass(frozen=True, eq=False)
class Beam:
    """Straight beam: axial, torsion, bending in two planes (paper eqs. 2.12, 3.3), by
    Euler-Bernoulli or Timoshenko bending theory.

    start, end [m] end points; density [kg/m^3]; youngs_modulus, shear_modulus [Pa];
    area [m^2]; second_moment_y, second_moment_z [m^4] about the local y and z axes;
    polar_moment [m^4] (rotary inertia in torsion, rho*J_p); torsion_constant [m^4]
    (torsional stiffness G*J_t); orientation: a vector fixing the local y axis, or None for
    the default (global z projected off the axis; global x when the axis is vertical);
    theory: "euler-bernoulli" or "timoshenko" (shear deformation and rotary inertia in
    bending); shear_coefficient: κ of the section (Timoshenko only, else None).
    """

    name: str
    start: np.ndarray
    end: np.ndarray
    density: float
    youngs_modulus: float
    shear_modulus: float
    area: float
    second_moment_y: float
    second_moment_z: float
    polar_moment: float
    torsion_constant: float
    orientation: np.ndarray | None = None
    number: int | None = None
    theory: str = "euler-bernoulli"
    shear_coefficient: float | None = None
    kind: str = field(default="beam", init=False)

    @property
    def timoshenko(self) -> bool:
        """Whether bending takes shear deformation and rotary inertia."""
        return self.theory == "timoshenko"

    @property
    def length(self) -> float:
        """Beam length [m]."""
        return float(np.linalg.norm(self.end - self.start))

    @property
    def mass(self) -> float:
        """Beam mass [kg]."""
        return self.density * self.area * self.length


Body = RigidBody | VirtualBody | Beam


@dataclass(frozen=True, eq=False)
class Hinge:
    """Spatial spring-damper hinge (paper eqs. 2.13, 2.14).

    between: two body names (or "ground"); at [m] the hinge point;
    stiffness [N/m] along global x, y, z; rotational_stiffness [N m/rad] about global x, y, z
    (0 = released direction, inf = rigid); damping [N s/m]; rotational_damping [N m s/rad].
    ``kind`` names its hinge kind (:data:`ufmt.kinds.HINGE_KINDS`, default the constant
    spring); ``extra`` holds that kind's own fields (name -> read-only array), e.g. an
    aerostatic film's stiffness ratio; ``stiffness`` is then the static (zero-frequency) one.
    """

    name: str
    between: tuple[str, str]
    at: np.ndarray
    stiffness: np.ndarray
    rotational_stiffness: np.ndarray
    damping: np.ndarray
    rotational_damping: np.ndarray
    number: int | None = None
    kind: str = "spring"
    extra: Mapping[str, np.ndarray] = field(default_factory=dict)

    @property
    def stiffness6(self) -> np.ndarray:
        """[kx, ky, kz, k'x, k'y, k'z] [N/m, N m/rad]."""
        return np.concatenate([self.stiffness, self.rotational_stiffness])

    @property
    def damping6(self) -> np.ndarray:
        """[cx, cy, cz, c'x, c'y, c'z] [N s/m, N m s/rad]."""
        return np.concatenate([self.damping, self.rotational_damping])

    @property
    def released(self) -> np.ndarray:
        """Boolean mask of the six directions that transmit nothing (stiffness 0)."""
        return self.stiffness6 == 0.0

    @property
    def rigid(self) -> np.ndarray:
        """Boolean mask of the six directions that are rigid (stiffness inf)."""
        return np.isinf(self.stiffness6)


@dataclass(frozen=True)
class DesignParameter:
    """A named design parameter: the ``components`` (0, 1, 2 = x, y, z) of a hinge's
    ``field`` (``stiffness`` [N/m] or ``rotational_stiffness`` [N m/rad]) set together.

    Setting the parameter to a value scales the components in proportion so that their mean
    is the value (the calibrated anisotropy is kept); see :func:`ufmt.evaluate.apply_design`.
    """

    name: str
    hinge: str
    field: str
    components: tuple[int, ...]
    description: str = ""


@dataclass(frozen=True)
class UncertainInput:
    """One uncertain input the model file declares (its ``[[uncertain]]`` table): the
    parameter ``name`` (a name :func:`ufmt.design.apply_design` sets, or
    ``damping.hinge_factor``), its band [low, high] [SI], ``log``: sampled log-uniform (else
    uniform), and ``source``: where the band comes from."""

    name: str
    low: float
    high: float
    log: bool
    source: str


@dataclass(frozen=True, eq=False)
class Model:
    """A validated machine model: bodies, hinges, the machine geometry and design parameters.

    ``machine`` is the validated ``[machine]`` table (tool and workpiece geometry used by the
    cutting dynamics, :class:`~ufmt.model.machine.Machine`), or None when the file has none;
    ``design`` the named design parameters of the ``[design]`` table (name ->
    :class:`DesignParameter`); ``uncertain`` the uncertain inputs the file declares (its
    ``[[uncertain]]`` tables, :mod:`ufmt.model.uncertain`); ``source`` is the file it came
    from (for messages).
    """

    name: str
    bodies: tuple[Body, ...]
    hinges: tuple[Hinge, ...]
    machine: Machine | None = None
    design: dict[str, DesignParameter] = field(default_factory=dict)
    uncertain: tuple[UncertainInput, ...] = ()
    source: str = "<memory>"

    def __repr__(self) -> str:
        """One line (the full tables would flood a notebook): name, counts and the file."""
        extras = [f"{len(self.design)} design parameters"] if self.design else []
        extras += ["[machine]"] if self.machine is not None else []
        extras += [f"{len(self.uncertain)} uncertain inputs"] if self.uncertain else []
        return (
            f"Model({self.name!r}: {len(self.bodies)} bodies, {len(self.hinges)} hinges"
            f"{''.join(', ' + e for e in extras)}; source={self.source!r})"
        )

    def body(self, name: str) -> Body:
        """The body called ``name`` (KeyError lists the valid names)."""
        for b in self.bodies:
            if b.name == name:
                return b
        raise KeyError(f"unknown body {name!r}; bodies are {[b.name for b in self.bodies]}")

    def hinge(self, name: str) -> Hinge:
        """The hinge called ``name`` (KeyError lists the valid names)."""
        for h in self.hinges:
            if h.name == name:
                return h
        raise KeyError(f"unknown hinge {name!r}; hinges are {[h.name for h in self.hinges]}")

    def structure_key(self) -> tuple:
        """The model's identity apart from its stiffness values (a key for what the designs
        of a stiffness study share): its bodies (the same objects), where each hinge is and
        which of its directions are rigid or released."""
        stiffness6 = np.array([h.stiffness6 for h in self.hinges]).reshape(-1, 6)
        return (
            self.bodies,  # identity-hashed bodies: shared by every design of one loaded model
            tuple((h.name, tuple(h.between), h.at.tobytes()) for h in self.hinges),
            np.isinf(stiffness6).tobytes(),  # the rigid directions of every hinge
            (stiffness6 == 0.0).tobytes(),  # the released ones
        )

    def with_hinge(self, name: str, **changes) -> Model:
        """A copy with hinge ``name`` changed, e.g. ``stiffness=[...]`` (values as in Hinge)."""
        self.hinge(name)
        conv = {k: frozen_array(v) if k != "between" else v for k, v in changes.items()}
        hinges = tuple(replace(h, **conv) if h.name == name else h for h in self.hinges)
        return replace(self, hinges=hinges)
