"""The spring hinge kind (paper eqs. 2.13, 2.14): constant springs and dampers along and about
the global axes between two bodies; the default kind of a ``[[hinge]]`` table.

Its stiffness does not depend on frequency, so the Wittrick-Williams count of the exact
dynamic stiffness applies as it is and every solver takes ``Hinge.stiffness6`` directly.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from ufmt.tables import Where

NAME = "spring"
FIELDS: tuple[str, ...] = ()  # no fields beyond every hinge's (ufmt.model.rules.HINGE_FIELDS)
REQUIRED: tuple[str, ...] = ()


def parse(where: Where, table: Mapping) -> dict[str, np.ndarray]:
    """The kind's own fields of a hinge table (none)."""
    return {}


def written(hinge) -> list[tuple[str, object]]:
    """The kind's own fields written back (none)."""
    return []


def storage_stiffness6(hinge, omega) -> np.ndarray:
    """Real stiffness k'(ω) (n, 6) [N/m, N m/rad] at ω [rad/s]: the constant springs."""
    omega = np.atleast_1d(np.asarray(omega, dtype=float))
    return np.broadcast_to(hinge.stiffness6, (omega.size, 6))


def complex_stiffness6(hinge, omega) -> np.ndarray:
    """Complex stiffness k'(ω) + iω c (n, 6) of the springs and dampers at ω [rad/s]."""
    omega = np.atleast_1d(np.asarray(omega, dtype=float))
    return hinge.stiffness6[None, :] + 1j * omega[:, None] * hinge.damping6[None, :]


def bounds6(hinge) -> tuple[np.ndarray, np.ndarray]:
    """Constant stiffnesses (6,) bounding k'(ω) from below and above: the springs themselves."""
    return hinge.stiffness6, hinge.stiffness6


def count_applies(hinge) -> bool:
    """Constant stiffness: the Wittrick-Williams count applies (always)."""
    return True


def branches6(hinge) -> tuple[np.ndarray, np.ndarray]:
    """(rates (6,) [1/s], branch stiffness (6,)) of internal spring-dashpot branches: none."""
    return np.zeros(6), np.zeros(6)


def rotated(hinge, along: Callable[[np.ndarray, str], np.ndarray]):
    """The kind's own fields along the machine's axes (none)."""
    return hinge
