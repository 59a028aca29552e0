"""Near-repeated roots: a bending pair split by a small asymmetry is found as two simple roots.

The README's bridge example (``examples/bridge.toml``) carries a 0.3 m steel shaft whose
second bending pair (~17957 Hz) is split by only 2.4e-8 (relative) because the bridge's
inertia differs about x and y. The assembled estimates of the pair are one cluster; the
multiplicity-2 Newton step 2-cycles between the two simple roots (c + e -> c + d²/e) and,
before the fix, the pair was reported lost (``ufmt simulate examples/bridge.toml`` exited 2).
"""

import tomllib
from pathlib import Path

import numpy as np

from ufmt.assembled import assembled_modes
from ufmt.model.load import model_from_dict
from ufmt.mstmm.overall import TransferSystem
from ufmt.mstmm.roots import TWO_PI
from ufmt.mstmm.solve import solve_modes
from ufmt.solvers import solve_modes as solve_by

BRIDGE = Path(__file__).resolve().parents[1] / "examples" / "bridge.toml"
FMAX_HZ = 18500.0  # just above the shaft's second bending pair
PAIR_HZ = 17957.1


def bridge(symmetric: bool = False):
    """The bridge example; ``symmetric`` gives the bridge equal inertia about x and y, which
    makes every bending pair of the (axisymmetric) shaft an exact double root."""
    data = tomllib.loads(BRIDGE.read_text())
    if symmetric:
        inertia = np.array(data["body"][0]["inertia"], dtype=float)
        inertia[1, 1] = inertia[0, 0]
        data["body"][0]["inertia"] = inertia.tolist()
    return model_from_dict(data, source=str(BRIDGE))


def det_sign(system: TransferSystem, omega: np.ndarray) -> np.ndarray:
    """Sign of det U_all (LU with partial pivoting; positive scalings cannot change it)."""
    sign, _ = np.linalg.slogdet(system.evaluate(omega))
    return sign


def pair(f: np.ndarray) -> np.ndarray:
    return f[np.abs(f / PAIR_HZ - 1) < 1e-5]


def test_split_pair_of_the_bridge_is_two_sign_changes_of_det():
    """Oracle: det U_all changes sign at a simple root, so below, between and above the two
    roots of the pair its sign alternates; the split matches the independent assembled
    model's (which resolves the asymmetry, not the beam's discretisation)."""
    model = bridge()
    solution = solve_modes(model, fmax_hz=FMAX_HZ, shapes=False)
    assembled = solve_by(model, fmax_hz=FMAX_HZ, method="assembled")
    assert solution.frequencies_hz.size == solution.expected == assembled.frequencies_hz.size
    lo, hi = pair(solution.frequencies_hz)
    split = hi - lo
    assert 1e-9 * hi < split < 1e-6 * hi  # one cluster of estimates, two distinct roots
    system = TransferSystem(model)
    system.segment_for(FMAX_HZ)
    probes = TWO_PI * np.array([lo - split, 0.5 * (lo + hi), hi + split])
    sign = det_sign(system, probes)
    assert sign[0] * sign[1] == -1.0 and sign[1] * sign[2] == -1.0
    a_lo, a_hi = pair(assembled.frequencies_hz)
    assert np.isclose(split, a_hi - a_lo, rtol=0.05)


def test_exact_pair_of_the_symmetric_bridge_stays_one_double_root():
    """Oracle: with equal bridge inertia about x and y the model is symmetric under the
    x <-> y swap, so the pair is exactly repeated: found once per multiplicity, equal to the
    root's precision, and det U_all keeps its sign across it (even multiplicity)."""
    model = bridge(symmetric=True)
    estimates = assembled_modes(model, fmax_hz=FMAX_HZ).frequencies_hz
    assert pair(np.asarray(estimates)).size == 2
    f = pair(solve_modes(model, fmax_hz=FMAX_HZ, shapes=False).frequencies_hz)
    assert f.size == 2 and np.isclose(f[0], f[1], rtol=1e-9, atol=0)
    system = TransferSystem(model)
    system.segment_for(FMAX_HZ)
    sign = det_sign(system, TWO_PI * f[0] * np.array([1 - 1e-6, 1 + 1e-6]))
    assert sign[0] == sign[1]
