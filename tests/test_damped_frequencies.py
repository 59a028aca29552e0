"""Damped natural frequencies and damping ratios (oracles: the closed form of a 1-DOF damped
oscillator, w_n = sqrt(k/m), zeta = zeta_0 + c/(2 m w_n), w_d = w_n sqrt(1 - zeta^2); the
eigenvalues of the first-order matrix of a 2-DOF chain assembled by hand from its M, C and K,
its structural damping M Phi diag(2 zeta_0 w) Phi^T M built from its own eigenvectors; the
complex eigenvalues of the assembled finite-element model of the bridge example with the same
dampers, on the same modes and on all of them)."""

import json
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
import scipy.linalg

from ufmt.assembled.matrices import assemble
from ufmt.assembled.solve import assembled_modes
from ufmt.cli import main
from ufmt.machining.damped_frequencies import damped_frequencies
from ufmt.model.load import load_model_text

RIGID = "[inf, inf, inf]"
BRIDGE = "examples/bridge.toml"


def body(name: str, mass: float, z: float) -> str:
    return (
        f'[[body]]\nname = "{name}"\nkind = "rigid"\nmass = {mass}\n'
        f"center_of_mass = [0.0, 0.0, {z}]\ninertia = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]\n"
    )


def hinge(name: str, a: str, b: str, z: float, k: float, c: float) -> str:
    return (
        f'[[hinge]]\nname = "{name}"\nbetween = ["{a}", "{b}"]\nat = [0.0, 0.0, {z}]\n'
        f"stiffness = [inf, inf, {k}]\nrotational_stiffness = {RIGID}\n"
        f"damping = [0.0, 0.0, {c}]\n"
    )


def chain(masses, springs, dampers) -> str:
    """Rigid bodies stacked along z, each on the one below by a z spring and dashpot."""
    text = 'name = "chain"\n'
    below = "ground"
    for i, (m, k, c) in enumerate(zip(masses, springs, dampers, strict=True)):
        text += body(f"b{i}", m, float(i + 1))
        text += hinge(f"h{i}", below, f"b{i}", i + 0.5, k, c)
        below = f"b{i}"
    return text


@pytest.mark.parametrize("c", [0.0, 2.0e3, 2.0e4])
def test_one_dof_matches_the_closed_form(c):
    m, k, zeta0 = 50.0, 4.0e7, 0.01
    model = load_model_text(chain([m], [k], [c]))
    result = damped_frequencies(model, count=1, zeta=zeta0)
    wn = np.sqrt(k / m)
    zeta = zeta0 + c / (2 * m * wn)
    np.testing.assert_allclose(result.natural_hz, [wn / (2 * np.pi)], rtol=1e-9)
    np.testing.assert_allclose(result.damping_ratio, [zeta], rtol=1e-9)
    np.testing.assert_allclose(
        result.damped_hz, [wn * np.sqrt(1 - zeta**2) / (2 * np.pi)], rtol=1e-9
    )
    assert result.hinge_dampers == (c > 0)


def hand_poles(masses, springs, dampers, zeta0):
    """Upper-half-plane poles of M x'' + (C + C_0) x' + K x = 0 assembled by hand."""
    m1, m2 = masses
    k1, k2 = springs
    c1, c2 = dampers
    mass = np.diag([m1, m2])
    stiff = np.array([[k1 + k2, -k2], [-k2, k2]])
    damp = np.array([[c1 + c2, -c2], [-c2, c2]])
    w2, phi = scipy.linalg.eigh(stiff, mass)  # unit modal mass
    damp = damp + mass @ phi @ np.diag(2 * zeta0 * np.sqrt(w2)) @ phi.T @ mass
    inv = np.linalg.inv(mass)
    a = np.block([[np.zeros((2, 2)), np.eye(2)], [-inv @ stiff, -inv @ damp]])
    lam = np.linalg.eigvals(a)
    lam = lam[lam.imag > 0]
    return lam[np.argsort(np.abs(lam))]


def test_two_dof_chain_matches_the_hand_assembled_eigenvalues():
    masses, springs, dampers, zeta0 = (80.0, 20.0), (6.0e7, 2.0e7), (3.0e4, 8.0e3), 0.02
    model = load_model_text(chain(masses, springs, dampers))
    result = damped_frequencies(model, count=2, zeta=zeta0)
    lam = hand_poles(masses, springs, dampers, zeta0)
    np.testing.assert_allclose(result.natural_hz, np.abs(lam) / (2 * np.pi), rtol=1e-8)
    np.testing.assert_allclose(result.damped_hz, lam.imag / (2 * np.pi), rtol=1e-8)
    np.testing.assert_allclose(result.damping_ratio, -lam.real / np.abs(lam), rtol=1e-7)
    # non-proportional dampers: the two ratios differ from what each mode alone would give
    assert result.hinge_dampers


def test_modes_json_reports_the_damped_modes(tmp_path, capsys):
    masses, springs, dampers = (80.0, 20.0), (6.0e7, 2.0e7), (3.0e4, 8.0e3)
    path = tmp_path / "chain.toml"
    path.write_text(chain(masses, springs, dampers))
    assert main(["modes", str(path), "--json", "--zeta", "0.02"]) == 0
    out = json.loads(capsys.readouterr().out)
    lam = hand_poles(masses, springs, dampers, 0.02)
    np.testing.assert_allclose(out["damped_frequencies_hz"], lam.imag / (2 * np.pi), rtol=1e-8)
    np.testing.assert_allclose(out["damping_ratios"], -lam.real / np.abs(lam), rtol=1e-7)
    assert out["structural_damping_ratio"] == 0.02 and out["hinge_dampers"] is True
    assert len(out["damped_frequencies_hz"]) == out["count"] == 2


def test_assembled_method_has_no_damped_modes(tmp_path, capsys):
    path = tmp_path / "chain.toml"
    path.write_text(chain([50.0], [4.0e7], [0.0]))
    assert main(["modes", str(path), "--json", "--method", "assembled"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["damped_frequencies_hz"] is None and out["damping_ratios"] is None


def damped_bridge():
    """The bridge example with dashpots in its air bearing and table guide."""
    text = open(BRIDGE).read()
    bearing = "rotational_stiffness = [1e7, 1e7, 0.0]"
    guide = "rotational_stiffness = [5e8, 6e8, 5e8]"
    assert bearing in text and guide in text
    text = text.replace(
        bearing, bearing + "\ndamping = [4e4, 4e4, 6e4]\nrotational_damping = [300.0, 300.0, 0.0]"
    )
    text = text.replace(guide, guide + "\ndamping = [2e5, 1e5, 2e5]")
    return load_model_text(text, "bridge-damped")


def with_springs(model, value):
    """``model`` with the non-rigid directions of every damped hinge given the stiffness
    ``value(hinge)`` (6,)."""
    hinges = []
    for h in model.hinges:
        if np.any(h.damping6[~h.rigid] != 0):
            k6 = np.where(h.rigid, np.inf, value(h))
            h = replace(h, stiffness=k6[:3], rotational_stiffness=k6[3:])
        hinges.append(h)
    return replace(model, hinges=tuple(hinges))


def assembled_poles(model, zeta, modes=None, elements=10):
    """Poles of the assembled (finite-element) model's modal equations over its first
    ``modes`` modes (default all): its own mass-normalised shapes, the hinge dampers' matrix
    C = sum c d d^T assembled as the springs are (the stiffness matrix with the dampers' values
    as springs minus the one with those springs removed)."""
    damp = (
        assemble(with_springs(model, lambda h: h.damping6), elements).K
        - assemble(with_springs(model, lambda h: np.zeros(6)), elements).K
    )
    solution = assembled_modes(model, elements_per_beam=elements)
    phi, w = solution.shapes[:modes], 2 * np.pi * solution.frequencies_hz[:modes]
    n = w.size
    d = np.diag(2 * zeta * w) + phi @ damp @ phi.T
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-np.diag(w**2), -d]])
    lam = np.linalg.eigvals(a)
    lam = lam[lam.imag > 0]
    return lam[np.argsort(np.abs(lam))]


def test_damped_bridge_matches_the_assembled_model_on_the_same_modes():
    model = damped_bridge()
    result = damped_frequencies(model, count=15, zeta=0.01, basis_hz=1.0)  # the 15 listed
    lam = assembled_poles(model, 0.01, modes=15)
    assert result.hinge_dampers and result.damping_ratio.max() > 0.1  # strongly coupled
    # the MSTMM's exact beams against a 10-element mesh: agreement to the mesh error
    np.testing.assert_allclose(result.damped_hz, lam.imag / (2 * np.pi), rtol=1e-5)
    np.testing.assert_allclose(result.damping_ratio, -lam.real / np.abs(lam), rtol=5e-5)


def test_a_wider_basis_converges_to_the_full_assembled_model():
    model = damped_bridge()
    lam = assembled_poles(model, 0.01)[:15]  # every mode of the assembled model
    errors = []
    for basis_hz in (1.0, 3000.0, 12000.0):
        result = damped_frequencies(model, count=15, zeta=0.01, basis_hz=basis_hz)
        errors.append(np.max(np.abs(result.damped_hz / (lam.imag / (2 * np.pi)) - 1)))
    assert errors[0] > 3 * errors[1] and errors[1] > 3 * errors[2]


def test_result_saves_its_table(tmp_path):
    result = damped_frequencies(load_model_text(chain([50.0], [4.0e7], [2.0e3])), zeta=0.01)
    csv, png = result.save(tmp_path)
    table = pd.read_csv(csv)
    np.testing.assert_allclose(table["damped_hz"], result.damped_hz, rtol=1e-9)
    assert png.stat().st_size > 0 and "1 damped modes" in repr(result)
