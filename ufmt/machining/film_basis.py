"""The modal basis of a model whose hinge stiffness depends on frequency (an aerostatic film,
:mod:`ufmt.kinds.aerostatic_hinge`): a Rayleigh-Ritz basis of its static model.

The film's branch states (:mod:`ufmt.machining.damping`) add k*(W) - k0 on the film's relative
motion d, projected on the basis. The static model's own modes (film at k0) represent that
change poorly: a stiffer film deforms the structure near it in shapes the low static modes
lack, and their span converges slowly with the basis size. The basis is therefore the union of
the static model's modes and the high-frequency model's (film at k_inf), both below the same
cutoff, made K0- and M-orthonormal by Rayleigh-Ritz in the static model:

    M_r = Psi^T M Psi (mass products of the MSTMM shapes, :func:`ufmt.mstmm.modes.kinetic_terms`),
    K_r: Phi0^T K0 Phi0 = Omega0², Phi0^T K0 Phi_inf = Omega0² Phi0^T M Phi_inf,
         Phi_inf^T K0 Phi_inf = Omega_inf² - D_inf^T (k_inf - k0) D_inf,

(K_inf Phi_inf = M Phi_inf Omega_inf², D_inf the film's relative motion in those modes), the
directions in which M_r is singular to 1e-10 of its largest eigenvalue dropped. The Ritz modes
are exact eigenmodes of the static model within the span; the static correction above the basis
(the static model's flexibility minus the basis' own) stays consistent. The span holds both
limits of the film exactly, and the film's change between them is represented to the
interpolation between the two sets. The Ritz modes above both sets' highest mode are the
film's local stiffening; the response paths sample the basis for the modes up to it
(``ModalBasis.resolved_hz``) and the rest respond quasi-statically.
"""

from __future__ import annotations

import numpy as np

from ufmt.kinds import hinge_kind_of
from ufmt.machining.basis import ModalBasis
from ufmt.machining.damping import relative_motion
from ufmt.model.schema import Model
from ufmt.mstmm.dependent import bounding
from ufmt.mstmm.modes import ModeShapes, kinetic_terms

MASS_RTOL = 1e-10  # union directions with a mass eigenvalue below this (relative) are dropped


def film_basis(model: Model, static: ModeShapes, high: ModeShapes) -> ModalBasis:
    """ModalBasis of frequency-dependent ``model`` from the shapes of its static model
    (``static``) and of its high-frequency model (``high``), module docstring; with its hinge
    dampers and the film's hinge motion (``varying``)."""
    films = [h for h in model.hinges if not hinge_kind_of(h).count_applies(h)]
    damped = [h for h in model.hinges if np.any(h.damping6[~h.rigid] != 0.0)]
    hinges = films + [h for h in damped if h not in films]
    low_model, high_model = bounding(model, upper=False), bounding(model, upper=True)
    motion = [
        np.concatenate(pair, axis=1)
        for pair in zip(
            relative_motion(low_model, static, hinges),
            relative_motion(high_model, high, hinges),
            strict=True,
        )
    ]
    x, omega = _ritz(model, static, high, motion[: len(films)], films)
    body_shapes = {k: x.T @ np.concatenate([v, high.rigid[k]]) for k, v in static.rigid.items()}
    damping = None
    if damped:
        damping = sum(
            (d.T * np.where(h.rigid, 0.0, h.damping6)) @ d
            for h, d in zip(hinges, (m @ x for m in motion), strict=True)
            if h in damped
        )
    return ModalBasis(
        omega=omega,
        modal_mass=np.ones(omega.size),
        body_shapes=body_shapes,
        body_centers=dict(static.centers),
        hinge_damping=damping,
        varying=tuple((h, d @ x) for h, d in zip(films, motion, strict=True)),
        resolved_hz=float(max(static.frequencies_hz[-1], high.frequencies_hz[-1])),
    )


def _ritz(model: Model, static: ModeShapes, high: ModeShapes, film_motion, films):
    """(X (N, r): the Ritz modes in the union's coordinates, omega (r,) [rad/s])."""
    mass = _mass_products(model, static, high)
    n0 = static.frequencies_hz.size
    stiffness = np.zeros_like(mass)
    stiffness[:n0, :n0] = np.diag(static.omega**2)
    stiffness[:n0, n0:] = static.omega[:, None] ** 2 * mass[:n0, n0:]
    stiffness[n0:, :n0] = stiffness[:n0, n0:].T
    stiffening = np.diag(high.omega**2)
    for hinge, d in zip(films, film_motion, strict=True):
        low, top = hinge_kind_of(hinge).bounds6(hinge)
        finite = np.isfinite(low)
        change = np.zeros(6)
        change[finite] = top[finite] - low[finite]
        stiffening = stiffening - (d[:, n0:].T * change) @ d[:, n0:]
    stiffness[n0:, n0:] = stiffening
    s, v = np.linalg.eigh(mass)
    keep = s > MASS_RTOL * s.max()
    t = v[:, keep] / np.sqrt(s[keep])
    reduced = t.T @ stiffness @ t
    lam, y = np.linalg.eigh((reduced + reduced.T) / 2)
    positive = lam > 0.0
    return t @ y[:, positive], np.sqrt(lam[positive])


def _mass_products(model: Model, a: ModeShapes, b: ModeShapes) -> np.ndarray:
    """Psi^T M Psi (N, N) [kg per unit modal coordinate²] of the union Psi = [a, b]."""
    rigid = {k: np.concatenate([v, b.rigid[k]]) for k, v in a.rigid.items()}
    beams = {}
    for k, (p, w, m) in a.beams.items():
        p_b, w_b, m_b = b.beams[k]
        if not (np.array_equal(p, p_b) and np.array_equal(w, w_b)):
            raise ValueError(f"beam {k!r}: the two sets of shapes sample it differently")
        beams[k] = (p, w, np.concatenate([m, m_b]))
    n = a.frequencies_hz.size + b.frequencies_hz.size
    i, j = np.divmod(np.arange(n * n), n)
    terms = kinetic_terms(
        model,
        {k: v[i] for k, v in rigid.items()},
        {k: (p, w, m[i]) for k, (p, w, m) in beams.items()},
        {k: v[j] for k, v in rigid.items()},
        {k: (p, w, m[j]) for k, (p, w, m) in beams.items()},
    )
    out = terms.sum(axis=(1, 2)).reshape(n, n)
    return (out + out.T) / 2
