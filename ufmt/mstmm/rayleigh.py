"""Rayleigh-quotient polish of MSTMM natural frequencies from their own mode shapes.

At high frequencies the transfer products grow (entries ~ (mω²/k)^n along a path), U_all loses
digits, and det U_all is only known to a noise band around each root. The mode shape from its
null vector is accurate to first order, so ω² = 2V/2T* of that shape is accurate to second
order: strain energy from the forces the hinges transmit (q²/k, m²/k' in elastic directions)
and from the beams' internal forces (N²/EA, T²/GJ_t, M²/EI), over the kinetic-energy
coefficient ⟨V, M V⟩ (paper eqs. 3.5, 3.11).
"""

from __future__ import annotations

import numpy as np

from ufmt.mstmm import elements
from ufmt.mstmm.modes import GAUSS_POINTS, ModeShapes, modal_mass
from ufmt.mstmm.overall import TransferSystem


def rayleigh_frequencies_hz(system: TransferSystem, shapes: ModeShapes) -> np.ndarray:
    """ω/2π [Hz] of each mode from its Rayleigh quotient (strain over kinetic energy)."""
    omega = shapes.omega
    z = shapes.z_all
    _, states = system.evaluate(omega, keep_states=True)
    strain = np.zeros(omega.size)
    x, wts = np.polynomial.legendre.leggauss(GAUSS_POINTS)
    for i, e in enumerate(system.topology.edges):
        st = states[("edge_in", i)]
        z_in = np.einsum("nik,nk->ni", st.arr, z[:, st.cols])
        if e.kind == "hinge":
            k = e.element.stiffness6
            elastic = (k > 0) & np.isfinite(k)
            forces = np.concatenate([z_in[:, 9:12], z_in[:, 6:9]], axis=1)
            strain += (forces[:, elastic] ** 2 / k[elastic]).sum(axis=1)
            continue
        beam = e.element
        p_in, p_out = e.point_at(e.input_node), e.point_at(e.output_node)
        frame = elements.beam_frame(beam, p_in, p_out)
        s = 0.5 * (x + 1.0) * beam.length
        stiff = np.array(
            [
                beam.youngs_modulus * beam.area,  # N from q_x
                beam.shear_modulus * beam.torsion_constant,  # torsion from m_x
                beam.youngs_modulus * beam.second_moment_y,
                beam.youngs_modulus * beam.second_moment_z,
            ]
        )
        density = np.zeros((omega.size, s.size))
        for g, sg in enumerate(s):  # a few Gauss points, each batched over all modes
            zg = np.einsum("nij,nj->ni", elements.beam(omega, beam, p_in, p_out, sg), z_in)
            q_loc, m_loc = zg[:, 9:12] @ frame, zg[:, 6:9] @ frame
            resultants = np.stack([q_loc[:, 0], m_loc[:, 0], m_loc[:, 1], m_loc[:, 2]], axis=1)
            density[:, g] = (resultants**2 / stiff).sum(axis=1)
        strain += density @ (0.5 * wts * beam.length)
    kinetic = modal_mass(system.model, shapes.rigid, shapes.beams)
    return np.sqrt(strain / kinetic) / (2 * np.pi)
