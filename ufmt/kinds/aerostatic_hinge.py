"""The aerostatic bearing hinge kind: a gas film whose stiffness and damping depend on frequency.

Per direction the film is a standard linear solid (Zener model): the static spring k0 (the
hinge's ``stiffness`` / ``rotational_stiffness``) in parallel with a Maxwell branch, a spring
k_inf - k0 in series with a dashpot, with time constant tau = 1 / (2 pi f_c):

    k*(ω) = k0 (1 + i ω τ r) / (1 + i ω τ),   r = k_inf / k0 >= 1,

a single-pole, single-zero dynamic stiffness. Its storage part k'(ω) = Re k* rises
monotonically from k0 (ω -> 0) to k_inf = r k0 (ω -> inf), half-way at f_c; the film's
equivalent damping c(ω) = Im k* / ω = (k_inf - k0) τ / (1 + ω² τ²) [N s/m] falls from
(k_inf - k0) τ, and its loss Im k* peaks at f_c. The compressibility of the gas makes a
squeezed film a damper at low frequency and a stiffer spring at high frequency.

Sources: F. Al-Bender, *Air Bearings: Theory, Design and Applications*, Wiley (2021), the
film's dynamic stiffness; J. Plessers, R. Snoeys, "Dynamic identification of convergent
externally pressurized gas bearing gaps", ASME J. Tribol. 110(2) (1988) 263, measured film
frequency responses (dynamic stiffness and damping coefficients of circular thrust films),
to which the single-pole, single-zero form is the lowest-order fit. Realistic values for precision
spindles and slides (an uncertain input, not a measured one): static stiffness 2e7-5e8 N/m,
r = 1-3, f_c = 10 Hz - 2 kHz (the squeeze number p_a h² / (24 pi mu R²) ~ 1 for films of
5-20 um on pads of 10-50 mm radius sets the low end).

The hinge's ``damping`` / ``rotational_damping`` dashpots act in parallel (constant), as on a
spring hinge; a released (0) or rigid (inf) static stiffness stays so at every frequency.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import replace

import numpy as np

from ufmt.model.rules import vector
from ufmt.model.schema import frozen_array
from ufmt.tables import Where

NAME = "aerostatic"
FIELDS = (
    "stiffness_ratio",
    "rotational_stiffness_ratio",
    "corner_frequency",
    "rotational_corner_frequency",
)
REQUIRED = ("stiffness_ratio", "corner_frequency")
_UNITS = {"stiffness_ratio": ("[-]", "stiffness_ratio"), "corner_frequency": ("[Hz]", "corner")}


def parse(where: Where, table: Mapping) -> dict[str, np.ndarray]:
    """The film's ratios k_inf / k0 [-] and corner frequencies f_c [Hz] per direction
    (rotational ones default to a constant rotational spring and the translational f_c)."""
    ratio = _field(where, table, "stiffness_ratio")
    corner = _field(where, table, "corner_frequency")
    return {
        "stiffness_ratio": ratio,
        "rotational_stiffness_ratio": _field(where, table, "rotational_stiffness_ratio", 1.0),
        "corner_frequency": corner,
        "rotational_corner_frequency": _field(where, table, "rotational_corner_frequency", corner),
    }


def _field(where: Where, table: Mapping, name: str, default=None) -> np.ndarray:
    """A 3-vector field of the film, checked against its band (LIMITS)."""
    if name not in table:
        return frozen_array(np.broadcast_to(default, 3))
    unit, limit = _UNITS[name.removeprefix("rotational_")]
    return vector(where, name, table[name], "positive", unit, limit)


def written(hinge) -> list[tuple[str, object]]:
    """The film's fields written back, in :data:`FIELDS` order."""
    return [(name, hinge.extra[name]) for name in FIELDS]


def _ratio6(hinge) -> np.ndarray:
    return np.concatenate(
        [hinge.extra["stiffness_ratio"], hinge.extra["rotational_stiffness_ratio"]]
    )


def _tau6(hinge) -> np.ndarray:
    """Time constants tau = 1 / (2 pi f_c) (6,) [s]."""
    corner = np.concatenate(
        [hinge.extra["corner_frequency"], hinge.extra["rotational_corner_frequency"]]
    )
    return 1.0 / (2 * np.pi * corner)


def _film(hinge, omega) -> np.ndarray:
    """k*(ω) (n, 6) of the film alone (no dashpots) at ω [rad/s]; exact k0 at ω = 0, and the
    static value in the released and rigid directions."""
    omega = np.atleast_1d(np.asarray(omega, dtype=float))
    k0 = hinge.stiffness6
    finite = np.isfinite(k0) & (k0 > 0)
    s = 1j * omega[:, None] * _tau6(hinge)[None, :]
    gain = 1.0 + s * (_ratio6(hinge) - 1.0) / (1.0 + s)  # exactly 1 where r = 1
    return np.where(finite, np.where(finite, k0, 0.0) * gain, k0.astype(complex))


def storage_stiffness6(hinge, omega) -> np.ndarray:
    """Storage stiffness k'(ω) = Re k*(ω) (n, 6) [N/m, N m/rad] at ω [rad/s]."""
    return _film(hinge, omega).real


def complex_stiffness6(hinge, omega) -> np.ndarray:
    """k*(ω) + iω c (n, 6): the film and the hinge's dashpots at ω [rad/s]."""
    omega = np.atleast_1d(np.asarray(omega, dtype=float))
    return _film(hinge, omega) + 1j * omega[:, None] * hinge.damping6[None, :]


def bounds6(hinge) -> tuple[np.ndarray, np.ndarray]:
    """Constant stiffnesses (6,) bounding k'(ω): static k0 below, k_inf = r k0 above."""
    k0 = hinge.stiffness6
    return k0, np.where(np.isfinite(k0), k0 * _ratio6(hinge), k0)


def count_applies(hinge) -> bool:
    """Whether k'(ω) is constant (every finite elastic direction has r = 1): then the
    Wittrick-Williams count applies as to a spring hinge."""
    low, high = bounds6(hinge)
    return bool(np.array_equal(low, high))


def branches6(hinge) -> tuple[np.ndarray, np.ndarray]:
    """(1/tau (6,) [1/s], k1 = k_inf - k0 (6,) [N/m, N m/rad]) of the film's Maxwell
    branches (time-domain form: :mod:`ufmt.machining.damping`); k1 = 0 where there is none."""
    low, high = bounds6(hinge)
    finite = np.isfinite(low)
    k1 = np.where(finite, np.where(finite, high, 0.0) - np.where(finite, low, 0.0), 0.0)
    return 1.0 / _tau6(hinge), k1


def rotated(hinge, along: Callable[[np.ndarray, str], np.ndarray]):
    """The film's fields along the machine's axes (``along(values, field)``)."""
    extra = {name: frozen_array(along(hinge.extra[name], name)) for name in FIELDS}
    return replace(hinge, extra=extra)
