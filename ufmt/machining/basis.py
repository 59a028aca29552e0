"""Modal basis: the data the cutting response needs from the eigen-solution.

The MSTMM (or any other) eigen-solver fills a :class:`ModalBasis`; everything downstream (cutting
force, modal response, machined surface) reads only this object.

The mode shapes are those of one slide position, ``slide_y`` (by default half way through the
leading arc's cut, :mod:`ufmt.machining.slide`). They are not recomputed as the slide travels
over the cut (on the packaged machine the frequencies move by at most 0.15 % and the
tool-workpiece receptance by at most 1.6 % from the cut's start to its end; docs/ufmt-model.md,
'The slide where it cuts'); the response does follow the contact point, the material point of
the workpiece under the tool, whose arm from the workpiece body's centre of mass changes with
the slide (see :mod:`ufmt.machining.cut_geometry`). Body centres are in the model file's
coordinates (the carriage drawn at Y = 0), whatever ``slide_y`` the shapes were solved at.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class ModalBasis:
    """Natural frequencies, modal masses and body motions of the first n modes.

    Attributes
    ----------
    omega : (n,) natural angular frequencies [rad/s], ascending, > 0.
    modal_mass : (n,) modal masses <V^s, M V^s> [kg] (paper eq. 3.11).
    body_shapes : body name -> (n, 6) rigid motion per mode, [r_C (3) [m]; theta (3) [rad]],
        machine frame (:mod:`ufmt.machining.machine_frame`; the global frame of an upright
        spindle), at the body's centre of mass (same normalisation as ``modal_mass``).
    body_centers : body name -> (3,) centre of mass [m].
    hinge_damping : (n, n) Phi_rel^T C_hinge Phi_rel [kg/s], the hinge dampers projected on the
        modes (same normalisation; :mod:`ufmt.machining.damping`), or None: no hinge damps
        (the modal equations are then classically damped).
    slide_y : slide position Y [m] of the configuration the modes were solved at (0: as the
        model file draws it).
    varying : ((hinge, d (6, n)), ...) the hinges whose stiffness depends on frequency and
        their relative motion in the modes (same normalisation; the basis is then the static
        model's, :mod:`ufmt.machining.film_basis`), or () when none does.
    resolved_hz : the highest natural frequency [Hz] the response paths sample (None: the
        highest mode); a film basis' Ritz modes above it hold the film's stiffening and respond
        quasi-statically (the recurrence is exact for them at any step).
    tool : the tool carrier's coupling when the basis carries the tool as an oscillator
        (:func:`ufmt.machining.tool.with_tool`: the tool body's shapes are then the tool
        carrier's), or None.
    """

    omega: np.ndarray
    modal_mass: np.ndarray
    body_shapes: dict[str, np.ndarray]
    body_centers: dict[str, np.ndarray]
    hinge_damping: np.ndarray | None = None
    slide_y: float = 0.0
    tool: ToolCoupling | None = None
    varying: tuple = ()
    resolved_hz: float | None = None

    def __post_init__(self):
        omega = np.asarray(self.omega, dtype=float)
        mass = np.asarray(self.modal_mass, dtype=float)
        if omega.ndim != 1 or omega.size == 0:
            raise ValueError(f"omega must be a non-empty 1-D array, got shape {omega.shape}")
        if not (np.all(np.isfinite(omega)) and np.all(omega > 0) and np.all(np.diff(omega) >= 0)):
            raise ValueError("omega must be finite, > 0 and ascending")
        if mass.shape != omega.shape or not np.all(mass > 0):
            raise ValueError(f"modal_mass must have shape {omega.shape} and be > 0")
        shapes, centers = {}, {}
        for name, s in self.body_shapes.items():
            s = np.asarray(s, dtype=float)
            if s.shape != (omega.size, 6):
                raise ValueError(
                    f"body_shapes[{name!r}] has shape {s.shape}, need {(omega.size, 6)}"
                )
            if name not in self.body_centers:
                raise ValueError(f"body_centers has no entry for body {name!r}")
            shapes[name] = _readonly(s)
            centers[name] = _readonly(np.asarray(self.body_centers[name], dtype=float).reshape(3))
        if self.hinge_damping is not None:
            c = np.asarray(self.hinge_damping, dtype=float)
            if c.shape != (omega.size, omega.size) or not np.all(np.isfinite(c)):
                raise ValueError(f"hinge_damping must be a finite {(omega.size,) * 2} matrix")
            object.__setattr__(self, "hinge_damping", _readonly(c))
        for _, d in self.varying:
            if np.shape(d) != (6, omega.size):
                raise ValueError(f"varying: hinge motion must have shape {(6, omega.size)}")
        object.__setattr__(self, "omega", _readonly(omega))
        object.__setattr__(self, "modal_mass", _readonly(mass))
        object.__setattr__(self, "body_shapes", shapes)
        object.__setattr__(self, "body_centers", centers)

    @property
    def n_modes(self) -> int:
        """Number of modes n."""
        return self.omega.size

    def truncated(self, n: int) -> ModalBasis:
        """The first ``n`` modes (all of them if ``n`` >= n_modes); a basis with the tool is
        cut before the tool is added (ValueError)."""
        if n >= self.n_modes:
            return self
        if n < 1:
            raise ValueError(f"n_modes must be >= 1, got {n}")
        if self.tool is not None:
            raise ValueError("cut the machine's basis before the tool is added to it")
        return ModalBasis(
            omega=self.omega[:n],
            modal_mass=self.modal_mass[:n],
            body_shapes={k: v[:n] for k, v in self.body_shapes.items()},
            body_centers=self.body_centers,
            hinge_damping=None if self.hinge_damping is None else self.hinge_damping[:n, :n],
            slide_y=self.slide_y,
            varying=tuple((h, d[:, :n]) for h, d in self.varying),
            resolved_hz=self.resolved_hz,
        )

    def point_shapes(self, body: str, points) -> np.ndarray:
        """Translation of points on ``body`` in every mode, r_C + theta x (p - C).

        Parameters
        ----------
        body : body name (a key of ``body_shapes``).
        points : (P, 3) or (3,) points [m], machine frame (as ``body_centers``).

        Returns
        -------
        (n, P, 3) translations [m per unit modal coordinate] ((n, 3) for a single point).
        """
        if body not in self.body_shapes:
            raise KeyError(f"unknown body {body!r}; the basis has {sorted(self.body_shapes)}")
        p = np.asarray(points, dtype=float)
        single = p.ndim == 1
        d = np.atleast_2d(p) - self.body_centers[body]
        s = self.body_shapes[body]
        out = s[:, None, :3] + np.cross(s[:, None, 3:], d[None, :, :])
        return out[:, 0, :] if single else out


@dataclass(frozen=True, eq=False)
class ToolCoupling:
    """The tool carrier on its shank in a basis of m = n + 1 modes (n of the machine).

    body: the tool body (its shapes are the carrier's); stretch (m,) the shank's deflection, carrier
    minus head z at the tool point [m per unit coordinate]; structure (n, m) the machine's modal
    coordinates in each mode, scaled by the square roots of their modal masses [sqrt(kg)] (the
    machine's structural damping diag(2 zeta w) carried to the basis); structure_omega (n,) the
    machine's natural frequencies [rad/s]; mode: the index of the tool's own mode; mass [kg],
    stiffness [N/m] and damping [N s/m] of the carrier on the shank; point (3,) the tool point the
    shank is attached at [m].
    """

    body: str
    stretch: np.ndarray
    structure: np.ndarray
    structure_omega: np.ndarray
    mode: int
    mass: float
    stiffness: float
    damping: float
    point: np.ndarray

    def __post_init__(self):
        for name in ("stretch", "structure", "structure_omega", "point"):
            object.__setattr__(self, name, _readonly(getattr(self, name)))


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a
