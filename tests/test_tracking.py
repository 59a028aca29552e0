"""Modes followed along a stiffness axis by MAC (ufmt.studies.tracking).

Oracle: two uncoupled bodies on their own springs, each moving only along z. Body a's mode is
sqrt(k_a / m_a) / 2 pi and crosses body b's fixed mode as k_a is swept: sorted by frequency
the two swap at the crossing, followed by MAC each stays on its own body's analytic curve.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ufmt.design import apply_design
from ufmt.model.load import load_model
from ufmt.studies.tracking import cross_mac, tracked_modes

M_A, M_B, K_B = 10.0, 20.0, 2.0e6
INF = "inf"

MODEL = f"""
name = "two bodies that cross"

[[body]]
name = "a"
kind = "rigid"
mass = {M_A}
center_of_mass = [0.0, 0.0, 0.0]
inertia = [[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]]

[[body]]
name = "b"
kind = "rigid"
mass = {M_B}
center_of_mass = [1.0, 0.0, 0.0]
inertia = [[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]]

[[hinge]]
name = "ha"
between = ["ground", "a"]
at = [0.0, 0.0, 0.0]
stiffness = [{INF}, {INF}, 1.0e6]
rotational_stiffness = [{INF}, {INF}, {INF}]

[[hinge]]
name = "hb"
between = ["ground", "b"]
at = [1.0, 0.0, 0.0]
stiffness = [{INF}, {INF}, {K_B}]
rotational_stiffness = [{INF}, {INF}, {INF}]

[design.ka]
hinge = "ha"
field = "stiffness"
components = [2]
"""


def _hz(k: float, m: float) -> float:
    return math.sqrt(k / m) / (2 * math.pi)


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    path = tmp_path_factory.mktemp("tracking") / "cross.toml"
    path.write_text(MODEL, encoding="utf-8")
    return load_model(path)


def test_each_track_stays_on_its_bodys_analytic_curve_through_the_crossing(model):
    values = np.geomspace(0.3e6, 3.0e6, 9)  # body a's mode crosses body b's at k_a = 1e6
    table = tracked_modes(
        lambda k: apply_design(model, {"ka": k}, model.design), values, "ka", count=2
    )
    by_track = {name: rows.sort_values("value") for name, rows in table.groupby("track_name")}
    assert set(by_track) == {"a z", "b z"}
    a, b = by_track["a z"], by_track["b z"]
    assert np.allclose(a["frequency_hz"], [_hz(k, M_A) for k in values], rtol=1e-6)
    assert np.allclose(b["frequency_hz"], _hz(K_B, M_B), rtol=1e-6)
    # sorted by frequency the modes swap: mode 1 is body a below the crossing, b above it
    assert a["mode"].iloc[0] == 1 and a["mode"].iloc[-1] == 2
    assert np.all(table["mac_previous"].dropna() > 0.999)


def test_the_mass_weighted_mac_of_a_solution_with_itself_is_the_identity(model):
    from ufmt.mstmm.solve import solve_modes

    shapes = solve_modes(model, count=2).shapes
    assert np.allclose(cross_mac(model, shapes, shapes), np.eye(2), atol=1e-12)


def test_a_beam_field_moves_to_another_gauss_rule_exactly():
    """Oracle: a polynomial field of degree g - 1 through g Gauss points is the Lagrange
    interpolant itself, so on another rule's points it equals the polynomial (two designs'
    shapes may carry different numbers of points)."""
    from types import SimpleNamespace

    from ufmt.studies.tracking import _on_grid

    start, end = np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, 0.4])
    beam = SimpleNamespace(start=start, end=end, length=0.6)
    axis = (end - start) / 0.6

    def rule(g):
        x, w = np.polynomial.legendre.leggauss(g)
        s = 0.3 * (x + 1)
        return start + s[:, None] * axis, 0.3 * w, s

    def field(s):  # (2 modes, points, 6): degree <= 7 in s
        base = np.stack([s**k for k in range(6)], axis=-1) * (1 + s[:, None] ** 2)
        return np.stack([base, -2 * base])

    p8, w8, s8 = rule(8)
    p11, w11, s11 = rule(11)
    at, weights, moved = _on_grid(beam, (p8, w8, field(s8)), (p11, w11, None))
    assert np.array_equal(at, p11) and np.array_equal(weights, w11)
    np.testing.assert_allclose(moved, field(s11), rtol=1e-10, atol=1e-12)
