"""The segmentation of the transfer (TransferSystem.segment_for, segment_designs) against the
former per-node loop, and det U_all unchanged by any choice of segments."""

import numpy as np
import pytest

from ufmt.kinds import rigid
from ufmt.model.load import load_model
from ufmt.mstmm import elements, overall
from ufmt.mstmm.overall import GROWTH_LIMIT, TransferSystem, segment_designs

FMAX_HZ = 5000.0
FACTORS = (1e-3, 1e-2, 0.3, 1.0, 3.0, 10.0, 100.0)  # all hinge stiffnesses scaled


def scaled(model, factor):
    """``model`` with every hinge stiffness times ``factor`` (the same structure)."""
    for h in model.hinges:
        model = model.with_hinge(
            h.name,
            stiffness=h.stiffness * factor,
            rotational_stiffness=h.rotational_stiffness * factor,
        )
    return model


@pytest.fixture(scope="module")
def designs():
    model = load_model()
    return [scaled(model, f) for f in FACTORS]


def physical_scaling(model):
    """State scaling [1/m, 1/rad·ℓ, 1/(k ℓ), 1/k], k the geometric mean of the finite
    translational stiffnesses, ℓ the rms spread of the hinge points (segment_for's docs)."""
    k = np.concatenate([h.stiffness for h in model.hinges])
    k_ref = np.exp(np.mean(np.log(k[(k > 0) & np.isfinite(k)])))
    pts = np.array([h.at for h in model.hinges])
    ell = np.sqrt(((pts - pts.mean(axis=0)) ** 2).sum(axis=1).mean())
    return np.r_[np.ones(3), np.full(3, ell), np.full(3, 1 / (k_ref * ell)), np.full(3, 1 / k_ref)]


def former_segments(system, fmax_hz):
    """Oracle: the former loop, node by node in transfer order, each stage built from the
    element formulas (hinge, beam, rigid body's first input) and its path products' 2-norm
    condition numbers computed one node at a time."""
    topo, w = system.topology, np.array([2 * np.pi * fmax_hz])
    scale = physical_scaling(system.model)
    path, chosen = {}, []
    for name in topo.order:
        node = topo.nodes[name]
        e = topo.edges[node.parent_edge]
        if e.kind == "hinge":
            stage = elements.hinge(w, e.element.stiffness6)[0]
        else:
            ends = e.point_at(e.input_node), e.point_at(e.output_node)
            stage = elements.beam(w, e.element, *ends)[0]
        body = node.body
        if body is not None:
            p_in = topo.first_input_point(name)
            args = (body.mass, body.inertia, body.center_of_mass, p_in, node.output_point)
            stage = stage @ rigid.first_input_transfer(w, *args)[0]
        stage = scale[:, None] * stage / scale[None, :]
        upstream = [
            path[topo.edges[i].input_node]
            for i, role in node.inputs
            if role == "edge" and topo.edges[i].tree
        ]
        products = [stage @ p for p in upstream] or [stage]
        conds = [np.linalg.cond(p) for p in products]
        worst = int(np.argmax(conds))
        path[name] = products[worst]
        if conds[worst] > GROWTH_LIMIT:
            chosen.append(name)
            path[name] = np.eye(12)
    return tuple(chosen)


def test_segments_are_the_former_loops(designs):
    """Oracle: the former per-node loop on seven stiffness scalings (1e-3 to 100), which
    segment the packaged model in different places (at least four distinct choices)."""
    found = [TransferSystem(d).segment_for(FMAX_HZ) for d in designs]
    assert found == [former_segments(TransferSystem(d), FMAX_HZ) for d in designs]
    assert len(set(found)) >= 4


def test_designs_segmented_together_get_their_own_segments(designs):
    """Oracle: each design segmented alone; together (one batched SVD per level) every
    design keeps its own choice, and segment_for then reuses it."""
    alone = [TransferSystem(d, FMAX_HZ).segments for d in designs]
    systems = [TransferSystem(d) for d in designs]
    segment_designs(systems, FMAX_HZ)
    assert [s.segments for s in systems] == alone
    assert [s.segment_for(FMAX_HZ) for s in systems] == alone


def test_segment_for_another_fmax_chooses_again(designs):
    """Oracle: a fresh system segmented at each f_max; the kept choice is only reused for
    the f_max it was made for."""
    system = TransferSystem(designs[0])
    for fmax_hz in (5000.0, 300.0, 5000.0):
        assert system.segment_for(fmax_hz) == TransferSystem(designs[0], fmax_hz).segments
    assert TransferSystem(designs[0], 300.0).segments != system.segment_for(5000.0)


def test_growth_limit_sets_where_the_transfer_is_segmented(designs, monkeypatch):
    """GROWTH_LIMIT is the condition growth allowed along a path: a lower limit segments
    more often, and every choice is the former loop's under that limit."""
    counts = []
    for limit in (1e3, 1e5, GROWTH_LIMIT):
        monkeypatch.setattr(overall, "GROWTH_LIMIT", limit)
        monkeypatch.setitem(globals(), "GROWTH_LIMIT", limit)
        found = TransferSystem(designs[3]).segment_for(FMAX_HZ)
        assert found == former_segments(TransferSystem(designs[3]), FMAX_HZ)
        counts.append(len(found))
    assert counts[0] > counts[1] > counts[2] > 0


@pytest.mark.parametrize("limit", [1e2, GROWTH_LIMIT])
def test_segments_leave_det_u_all_unchanged(designs, monkeypatch, limit):
    """Oracle: the dense U_all without segments (Schur complement of the identity blocks:
    det is unchanged, a property of the construction) at frequencies low enough for the
    unsegmented products to keep their accuracy."""
    monkeypatch.setattr(overall, "GROWTH_LIMIT", limit)
    model = designs[3]
    plain, segmented = TransferSystem(model), TransferSystem(model, FMAX_HZ)
    assert segmented.size > plain.size == plain.order
    omega = 2 * np.pi * np.array([37.0, 151.0, 403.0, 988.0])
    sign_a, log_a = np.linalg.slogdet(plain.evaluate(omega))
    sign_b, log_b = np.linalg.slogdet(segmented.evaluate(omega))
    assert np.array_equal(sign_a, sign_b)
    assert np.allclose(log_a, log_b, rtol=0, atol=1e-9)


def test_designs_of_different_structures_are_not_segmented_together(designs):
    other = load_model().with_hinge("h14", stiffness=[0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="one structure"):
        segment_designs([TransferSystem(designs[0]), TransferSystem(other)], FMAX_HZ)
