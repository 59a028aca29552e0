"""The beam kind (paper eqs. 2.12, 3.3): a straight prismatic beam, axial, torsion and bending
in two planes between two end points.

Two nodes (its ends), six small motions each; no mass block of its own: its inertia is in its
four deformations (:func:`parts`), each a formulation with one interface (transfer matrix,
exact dynamic stiffness and clamped-clamped count, finite element, the mesh's element length
rule): the axial and torsion rods of :mod:`ufmt.kinds.rod` and the two bending planes of its
``theory``, a module of :data:`THEORIES`. The MSTMM's transfer matrix and member stiffness and
the assembled model's frame element put the parts in place. Hinges act on its ends only.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from ufmt.errors import ModelError
from ufmt.kinds import euler_bernoulli, timoshenko
from ufmt.kinds.rod import Rod
from ufmt.kinds.timoshenko import cowper_circle
from ufmt.kinematics import point_motion
from ufmt.model.rules import (
    BEAM_END_RTOL,
    PARALLEL_RTOL,
    SECTION_FIELDS,
    derived,
    real,
    vector,
)
from ufmt.model.schema import Beam, frozen_array
from ufmt.tables import Where, short_number, short_vector

NAME = "beam"
CLASS = Beam
CIRCLE_FIELDS = ("diameter", "inner_diameter")
#: bending theory (the model file's ``theory``) -> its module: ``planes(beam)``, the x1-y and
#: x1-z planes, each with the interface of :class:`ufmt.kinds.euler_bernoulli.Plane`
THEORIES = {"euler-bernoulli": euler_bernoulli, "timoshenko": timoshenko}
REQUIRED = ("start", "end", "density", "youngs_modulus", "shear_modulus")
OPTIONAL = ("torsion_constant", "orientation", "theory", "shear_coefficient")
FIELDS = REQUIRED + CIRCLE_FIELDS + SECTION_FIELDS + OPTIONAL
WRITTEN = REQUIRED + SECTION_FIELDS + OPTIONAL  # theory and κ: only when Timoshenko
#: shear coefficient κ allowed in a model file (Cowper 1966: 0.5 to 0.9 for usual sections)
SHEAR_COEFFICIENT_BAND = (0.05, 1.0)
FORM = "member"  # two end nodes and its parts between them (start, end, parts)
ONE_FRAME = False  # its motion is a field along it
MASSLESS = False
MEMBER = True  # an exact member stiffness with a clamped-clamped count
MESHED = True  # the assembled model meshes it
HINGES_AT_ENDS = True  # a hinge on it sits at an end (and stays there)


def parse(where: Where, name: str, table: Mapping, number: int | None) -> Beam:
    start = vector(where, "start", table["start"], "finite", "[m]", "coordinate")
    end = vector(where, "end", table["end"], "finite", "[m]", "coordinate")
    axis = end - start
    length = float(np.linalg.norm(axis))
    if length <= 0:
        where.fail(
            "end", f"beam length is 0: start and end are both {short_vector(start)} (allowed: > 0)"
        )
    density = real(where, "density", table["density"], "positive", "[kg/m^3]", "density")
    youngs = real(where, "youngs_modulus", table["youngs_modulus"], "positive", "[Pa]", "modulus")
    shear = real(where, "shear_modulus", table["shear_modulus"], "positive", "[Pa]", "modulus")
    section = _section(where, table)
    orientation = None
    if "orientation" in table:
        orientation = vector(where, "orientation", table["orientation"], "finite")
        size = np.linalg.norm(orientation)
        sine = np.linalg.norm(np.cross(orientation, axis)) / (size * length) if size > 0 else 0.0
        if sine <= PARALLEL_RTOL:
            where.fail(
                "orientation",
                f"{short_vector(orientation)} is zero or parallel to the beam axis "
                f"{derived(axis / length)} "
                "(allowed: any vector not parallel to the axis; it fixes local y)",
            )
    theory = table.get("theory", "euler-bernoulli")
    where.choice("theory", where.string("theory", theory), tuple(THEORIES), "theory", "theories")
    kappa = _shear_coefficient(where, table, theory, youngs / (2.0 * shear) - 1.0)
    return Beam(
        name=name,
        start=start,
        end=end,
        density=density,
        youngs_modulus=youngs,
        shear_modulus=shear,
        orientation=orientation,
        number=number,
        theory=theory,
        shear_coefficient=kappa,
        **section,
    )


def _shear_coefficient(where: Where, table: Mapping, theory: str, poisson: float):
    """κ of a Timoshenko beam: the file's ``shear_coefficient``, or Cowper's (1966) for a
    circular section (``diameter``, ``inner_diameter``) with ν = E/(2G) - 1; None for an
    Euler-Bernoulli beam."""
    if theory != "timoshenko":
        if "shear_coefficient" in table:
            where.fail("shear_coefficient", 'applies to theory = "timoshenko" only')
        return None
    if "shear_coefficient" in table:
        low, high = SHEAR_COEFFICIENT_BAND
        kappa = real(where, "shear_coefficient", table["shear_coefficient"], "positive")
        if not low <= kappa <= high:
            where.outside("shear_coefficient", kappa, low, high)
        return kappa
    if "diameter" not in table:
        where.missing("shear_coefficient", "a Timoshenko beam with an explicit section")
    if not -1.0 < poisson <= 0.5:
        where.fail(
            "shear_modulus",
            f"Poisson's ratio E/(2G) - 1 = {poisson:.4g} is not physical (allowed: -1 < nu <= "
            "0.5) for the default shear coefficient; give shear_coefficient",
        )
    ratio = float(table.get("inner_diameter", 0.0)) / float(table["diameter"])
    return cowper_circle(poisson, ratio)


_SECTION_LIMITS = {
    "area": "area",
    "second_moment_y": "second_moment",
    "second_moment_z": "second_moment",
    "polar_moment": "second_moment",
}


def _section(where: Where, table: Mapping) -> dict[str, float]:
    """Section properties from ``diameter`` (solid/hollow circle) or the explicit fields."""
    explicit = [k for k in SECTION_FIELDS + ("torsion_constant",) if k in table]
    if "diameter" in table:
        if explicit:
            where.fail(
                explicit[0],
                "give either 'diameter' (circular section) or the explicit section "
                f"({', '.join(SECTION_FIELDS)}), not both",
            )
        return _circle(where, table)
    if "inner_diameter" in table:
        where.fail("inner_diameter", "needs 'diameter' (hollow circular section)")
    if not explicit:
        where.missing("diameter", f"a section: give 'diameter', or {', '.join(SECTION_FIELDS)}")
    for key in SECTION_FIELDS:
        if key not in table:
            where.missing(key, f"an explicit section needs {', '.join(SECTION_FIELDS)}")
    units = {"area": "[m^2]"}
    section = {
        k: real(where, k, table[k], "positive", units.get(k, "[m^4]"), _SECTION_LIMITS.get(k, ""))
        for k in SECTION_FIELDS
    }
    section["torsion_constant"] = (
        real(
            where,
            "torsion_constant",
            table["torsion_constant"],
            "positive",
            "[m^4]",
            "second_moment",
        )
        if "torsion_constant" in table
        else section["polar_moment"]
    )
    return section


def _circle(where: Where, table: Mapping) -> dict[str, float]:
    """Section of a solid or hollow circle (``diameter``, ``inner_diameter``)."""
    outer = real(where, "diameter", table["diameter"], "positive", "[m]", "diameter")
    inner = 0.0
    if "inner_diameter" in table:
        inner = real(
            where, "inner_diameter", table["inner_diameter"], "nonnegative", "[m]", "diameter"
        )
        if inner >= outer:
            where.fail(
                "inner_diameter",
                f"{short_number(inner)} is not less than diameter {short_number(outer)} "
                "(allowed: 0 <= inner_diameter < diameter)",
            )
    second = math.pi * (outer**4 - inner**4) / 64.0
    return {
        "area": math.pi * (outer**2 - inner**2) / 4.0,
        "second_moment_y": second,
        "second_moment_z": second,
        "polar_moment": 2.0 * second,
        "torsion_constant": 2.0 * second,
    }


def written(body: Beam) -> list[tuple[str, object]]:
    """(field, value) written back after name, kind and number (the theory and the shear
    coefficient only for a Timoshenko beam: an Euler-Bernoulli file reads as before)."""
    skipped = () if body.timoshenko else ("theory", "shear_coefficient")
    return [(k, getattr(body, k)) for k in WRITTEN if k not in skipped]


def points(body: Beam) -> dict[str, np.ndarray]:
    """The points [m] the body's fields place (field -> point)."""
    return {"start": body.start, "end": body.end}


def section_width(body: Beam) -> float:
    """Width [m] of its section: the equivalent diameter sqrt(4 A / pi)."""
    return math.sqrt(4.0 * body.area / math.pi)


def check_hinge_point(where: Where, at: np.ndarray, beam: Beam) -> None:
    """A hinge on a beam must sit at one of its ends (within BEAM_END_RTOL of its length)."""
    length = beam.length
    distance = min(np.linalg.norm(at - beam.start), np.linalg.norm(at - beam.end))
    if distance > BEAM_END_RTOL * length:
        where.fail(
            "at",
            f"{short_vector(at)} is not at an end of beam {beam.name!r} (start "
            f"{short_vector(beam.start)}, end {short_vector(beam.end)}; {derived(distance)} m "
            f"away; allowed: within {BEAM_END_RTOL:g} x length {short_number(length)} m of an "
            "end)",
        )


def node_points(model, body: Beam) -> np.ndarray:
    """Its two nodes (2, 3) [m]: start and end."""
    return np.array([body.start, body.end], dtype=float)


def point_map(body: Beam, nodes: np.ndarray, point, source: str) -> tuple[int, np.ndarray]:
    """(node index, T): a hinge acts on the end at ``point`` itself (ModelError elsewhere)."""
    gap = np.linalg.norm(nodes - np.asarray(point, dtype=float), axis=1)
    node = int(np.argmin(gap))
    if gap[node] > BEAM_END_RTOL * body.length:
        raise ModelError(
            f"{source}: body {body.name!r}: a hinge at {np.asarray(point).tolist()} is not at "
            "an end of the beam"
        )
    return node, np.eye(6)


def node_mass(body: Beam) -> None:
    """No mass block: the member carries its inertia."""
    return None


def rigidity(body: Beam) -> np.ndarray:
    """(6, 12) rows on its two nodes' motions that vanish when it moves rigidly (end =
    start carried, eq. 2.5)."""
    return np.hstack([-point_motion(body.end - body.start), np.eye(6)])


def moved(body: Beam, shift: np.ndarray) -> Beam:
    """The beam translated by ``shift`` [m]."""
    return replace(body, start=frozen_array(body.start + shift), end=frozen_array(body.end + shift))


SENSOR_MARGIN = 2.0  # [-] section radii from the axis a modal-test sensor may sit
SENSOR_END = 1e-6  # [m] how far past an end a sensor may sit and still be on the beam


def radius(model, body: Beam) -> float:
    """The section's radius [m], sqrt(2 (I_y + I_z) / A) (a solid round section's)."""
    return float(np.sqrt(2.0 * (body.second_moment_y + body.second_moment_z) / body.area))


def check_sensor(where: Where, field: str, model, body: Beam, point) -> None:
    """A sensor between the beam's ends and within SENSOR_MARGIN section radii of its axis."""
    start, end = np.asarray(body.start, float), np.asarray(body.end, float)
    length = float(np.linalg.norm(end - start))
    axis = (end - start) / length
    s = float((point - start) @ axis)
    if not -SENSOR_END <= s <= length + SENSOR_END:
        where.fail(
            field, f"the point is {s:.4g} m along beam {body.name!r} of length {length:.4g} m"
        )
    off = float(np.linalg.norm(point - start - s * axis))
    size = radius(model, body)
    if off > SENSOR_MARGIN * size:
        where.fail(
            field,
            f"{off:.3g} m from the axis of beam {body.name!r} of section radius {size:.3g} m "
            f"(allowed: <= {SENSOR_MARGIN:g} x that)",
        )


VERTICAL_SINE = 1e-9  # an axis this close to global z counts as vertical (schema default)


def section_axis(body: Beam) -> np.ndarray:
    """The section's local y axis in global coordinates: ``orientation`` (default global z, or
    global x for a vertical beam) made orthogonal to the axis; the beam's local frame
    (:func:`local_frame`, both solvers') and the machine frame's rotation take it."""
    e1 = (body.end - body.start) / np.linalg.norm(body.end - body.start)
    ref = body.orientation
    if ref is None:
        vertical = np.linalg.norm(np.cross(e1, [0.0, 0.0, 1.0])) <= VERTICAL_SINE
        ref = np.array([1.0, 0.0, 0.0]) if vertical else np.array([0.0, 0.0, 1.0])
    e2 = ref - (ref @ e1) * e1
    return e2 / np.linalg.norm(e2)


def rotated(body: Beam, frame: np.ndarray) -> Beam:
    """The beam in the frame whose axes are the columns of ``frame`` (global coordinates):
    its ends and its section's local y axis, written out so the section keeps its place."""
    return replace(
        body,
        start=frozen_array(body.start @ frame),
        end=frozen_array(body.end @ frame),
        orientation=frozen_array(section_axis(body) @ frame),
    )


def hinge_motion(body: Beam, shapes, ends, point) -> np.ndarray:
    """Motion ``[r; θ]`` (6, n) of the end at ``point`` [m]; ``ends`` = (positions (2, 3),
    motion (n, 2, 6)) of its two ends in each mode."""
    positions, motion = ends
    end = int(np.argmin(np.linalg.norm(positions - point, axis=1)))
    return motion[:, end, :].T


def sensor_motion(body: Beam, shapes, point, field_point) -> np.ndarray:
    """Motion (n, 6) of ``point`` [m] carried by the section nearest it
    (``field_point(point)``: the field's motion there)."""
    return field_point(point)


# -- formulations -------------------------------------------------------------------------------

ONES = np.ones(4)
#: the x1-z plane's transfer state [w, θy, my, qz] is the x1-y plane's with θ and m negated
PLANE_SIGNS = np.array([1.0, -1.0, -1.0, 1.0])
XZ_END_SIGNS = np.array([1.0, -1.0, 1.0, -1.0])  # end motions: θy = -dw/dx


@dataclass(frozen=True)
class Part:
    """One deformation of a beam and where it sits, in the beam's local axes.

    formulation: a :class:`~ufmt.kinds.rod.Rod` or a theory's ``Plane``; state: its entries of
    the MSTMM's 12-state ``[x y z θx θy θz mx my mz qx qy qz]`` (the formulation's state order)
    with ``state_signs``; ends: its entries of the end motions ``[u v w θx θy θz]`` of the
    start then the end (member and element) with ``end_signs``.
    """

    formulation: object
    state: tuple[int, ...]
    state_signs: np.ndarray
    ends: tuple[int, ...]
    end_signs: np.ndarray


def parts(body: Beam) -> tuple[Part, ...]:
    """Its axial and torsion rods (``q = -N``, ``m = +GJθ'``) and its x1-y (I_z) and x1-z
    (I_y) bending planes of its theory."""
    rho, a = body.density, body.area
    axial = Rod(body.youngs_modulus * a, rho * a, -1.0)
    torsion = Rod(body.shear_modulus * body.torsion_constant, rho * body.polar_moment, 1.0)
    xy, xz = THEORIES[body.theory].planes(body)
    return (
        Part(axial, (0, 9), ONES[:2], (0, 6), ONES[:2]),
        Part(torsion, (3, 6), ONES[:2], (3, 9), ONES[:2]),
        Part(xy, (1, 5, 8, 10), ONES, (1, 5, 7, 11), ONES),
        Part(xz, (2, 4, 7, 11), PLANE_SIGNS, (2, 4, 8, 10), XZ_END_SIGNS),
    )


def local_frame(body: Beam, p_in, p_out) -> np.ndarray:
    """Columns e1, e2, e3 of the beam's local frame for a transfer from end ``p_in`` to end
    ``p_out``: e1 along it, e2 :func:`section_axis`, e3 = e1 x e2 (flipping e1 flips e3 only,
    which leaves the second moments about e2 and e3 unchanged)."""
    e1 = np.asarray(p_out, dtype=float) - p_in
    e1 /= np.linalg.norm(e1)
    e2 = section_axis(body)
    return np.column_stack([e1, e2, np.cross(e1, e2)])


def mass_products(body: Beam, field_a, field_b) -> np.ndarray:
    """⟨V_a, M V_b⟩ (n, 6) [kg] per global direction of two motion fields ``(positions,
    weights, motion (n, g, 6))`` at the same quadrature points: ∫ρA u_a·u_b ds per axis and
    ∫ρJp τ_a τ_b ds (τ the twist about the axis), and the sections' rotary inertia ∫ρI θ_a θ_b
    ds of planes that have it, split over the global axes by the squared axis components."""
    _, wts, ma = field_a
    mb = field_b[2]
    rho = body.density
    out = np.empty((ma.shape[0], 6))
    out[:, :3] = rho * body.area * np.einsum("ngi,ngi,g->ni", ma[..., :3], mb[..., :3], wts)
    axis = (body.end - body.start) / body.length
    twist = (ma[..., 3:] @ axis) * (mb[..., 3:] @ axis) @ wts
    out[:, 3:] = rho * body.polar_moment * twist[:, None] * axis[None, :] ** 2
    frame = local_frame(body, body.start, body.end)
    xy, xz = (part.formulation for part in parts(body)[2:])
    for e, plane in ((frame[:, 1], xz), (frame[:, 2], xy)):  # θy about e2, θz about e3
        if plane.rho_i:
            turn = (ma[..., 3:] @ e) * (mb[..., 3:] @ e) @ wts
            out[:, 3:] += plane.rho_i * turn[:, None] * e[None, :] ** 2
    return out
