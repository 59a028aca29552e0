"""The model file's rules: field names per element, tolerances, physical bands, and the number
checks that apply them (through :class:`ufmt.tables.Where`, so every message has one wording).
"""

from __future__ import annotations

import math

import numpy as np

from ufmt.limits import MAX_NAME_CHARS
from ufmt.model.schema import frozen_array
from ufmt.tables import Where

TOP_FIELDS = ("name", "description", "body", "hinge", "machine", "design", "uncertain")
BODY_FIELDS = ("name", "kind", "number")
SECTION_FIELDS = ("area", "second_moment_y", "second_moment_z", "polar_moment")
HINGE_REQUIRED = ("name", "between", "at", "stiffness", "rotational_stiffness")
HINGE_FIELDS = HINGE_REQUIRED + ("damping", "rotational_damping", "number")  # every kind's

SYMMETRY_RTOL = 1e-9  # inertia symmetry, relative to its largest entry
TRIANGLE_RTOL = 1e-9  # principal-moment triangle inequality, relative to the largest moment
DEFINITE_RTOL = 1e-12  # smallest principal moment must exceed this times the largest
BEAM_END_RTOL = 1e-9  # hinge point to beam end, relative to the beam length
POINT_RTOL = 1e-9  # virtual-body hinge points, relative to the model's coordinate extent
PARALLEL_RTOL = 1e-9  # beam orientation vs. axis: |sin angle| must exceed this

#: Physical magnitude bands [SI]: a finite, nonzero value whose magnitude is outside
#: [low, high] is rejected at load (values far outside them are typing mistakes or overflow the
#: eigen-solvers; signed quantities have low = 0, their allowed range is [-high, high]). Wide
#: on purpose: from a 1 mg part to a 1,000 t foundation, from foams to diamond.
LIMITS = {
    "mass": (1e-6, 1e9, "[kg]"),
    "inertia": (1e-12, 1e12, "[kg m^2]"),  # principal moments
    "inertia_entry": (0.0, 1e12, "[kg m^2]"),  # |I_ij|
    "density": (1.0, 1e5, "[kg/m^3]"),
    "modulus": (1e3, 1e13, "[Pa]"),
    "coordinate": (0.0, 1e4, "[m]"),  # |x|, |y|, |z| of points
    "diameter": (1e-6, 1e3, "[m]"),
    "area": (1e-12, 1e4, "[m^2]"),
    "second_moment": (1e-24, 1e4, "[m^4]"),
    "stiffness": (1e-6, 1e15, "[N/m]"),  # finite nonzero; 0 = released, inf = rigid
    "rotational_stiffness": (1e-6, 1e15, "[N m/rad]"),
    "damping": (0.0, 1e12, "[N s/m]"),
    "rotational_damping": (0.0, 1e12, "[N m s/rad]"),
    "stiffness_ratio": (1.0, 100.0, "[-]"),  # a frequency-dependent hinge's k_inf / k0
    "corner": (1e-3, 1e6, "[Hz]"),  # a frequency-dependent hinge's corner frequency
}

# rule -> the sign rule and whether inf is allowed (Where.number)
_RULES = {
    "finite": (None, False),
    "positive": ("positive", False),
    "nonnegative": ("nonnegative", False),
    "stiffness": ("nonnegative", True),
}
STIFFNESS_ALLOWED = ">= 0, 0 = released, inf = rigid"


def real(where: Where, field: str, value, rule: str, unit: str = "", limit: str = "") -> float:
    """A float checked against ``rule`` (finite | positive | nonnegative | stiffness) and, if
    ``limit`` names one, the physical band ``LIMITS[limit]`` (finite nonzero values only)."""
    sign, infinite = _RULES[rule]
    allowed = STIFFNESS_ALLOWED if rule == "stiffness" else None
    x = where.number(field, value, sign=sign, infinite=infinite, unit=unit, allowed=allowed)
    if limit and math.isfinite(x) and x != 0.0:
        low, high, band_unit = LIMITS[limit]
        if not low <= abs(x) <= high:  # a signed quantity's band bounds its magnitude
            where.outside(field, x, -high if sign is None else low, high, band_unit)
    return x


def vector(
    where: Where, field: str, value, rule: str, unit: str = "", limit: str = ""
) -> np.ndarray:
    """A read-only 3-vector, each component checked by :func:`real` as ``field[i]``."""
    items = where.array(field, value, 3, f"3 numbers {unit}".rstrip())
    return frozen_array(
        [real(where, f"{field}[{i}]", v, rule, unit, limit) for i, v in enumerate(items)]
    )


def label(kind: str, index: int, table) -> str:
    """``body 'x'`` when the table has a usable name (at most MAX_NAME_CHARS characters),
    else ``body #3`` (1-based, file order)."""
    name = table.get("name")
    usable = isinstance(name, str) and name.strip() and len(name) <= MAX_NAME_CHARS
    return f"{kind} {name!r}" if usable else f"{kind} #{index}"


def derived(values) -> str:
    """Computed quantities (distances, principal moments) to 4 significant digits."""
    text = ", ".join(f"{v:.4g}" for v in np.ravel(values))
    return f"[{text}]" if np.ndim(values) else text
