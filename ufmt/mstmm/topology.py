"""Automatic deduction of the MSTMM topology: orient the connection graph towards ground, cut
closed loops, and lay out the boundary unknowns (paper section 2.4, eqs. 2.15-2.22).

The graph (:mod:`ufmt.mstmm.graph`) has a node per rigid or virtual body, two massless nodes
per beam (its end points, ``"<beam>@start"`` and ``"<beam>@end"``) and the ground node; edges
are the hinges and the beams (both two-port elements). What each body kind adds is in its
entry of :data:`ufmt.mstmm.bodies.BODY_RULES`. A maximum spanning tree rooted at ground is
chosen so that beams and fully elastic hinges stay in the tree and hinges with released
directions are cut where a loop allows it (a released direction in a cut hinge costs no extra
unknown).
Tree edges run from the child (input end) to the parent (output end). A non-tree edge is cut
where its input end meets a body: that body gets an extra input end with state C·Z
(DESIGN.md), and the edge's output enters the other body as an input end. Non-tree edges at
ground take their input at ground (zero displacement, six unknown reactions).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.linalg import qr

from ufmt.errors import ModelError
from ufmt.kinematics import point_motion
from ufmt.model.schema import GROUND, Model
from ufmt.mstmm.bodies import rules_of
from ufmt.mstmm.graph import DISPLACEMENT_NAMES, STATE_NAMES, Edge, Node, Topology
from ufmt.recent import Recent


def build_topology(model: Model) -> Topology:
    """Orient the graph towards ground, cut loops and lay out Z_all (paper eqs. 2.15-2.22)."""
    nodes: dict[str, Node] = {GROUND: Node(GROUND, None)}
    edges: list[Edge] = []
    for body in model.bodies:
        body_nodes, body_edges = rules_of(body).graph(model, body)
        nodes.update((node.name, node) for node in body_nodes)
        edges += body_edges
    for h in model.hinges:
        ends = [_hinge_end(model, s, h.at) for s in h.between]
        edges.append(Edge(h.name, "hinge", h, ends[0], ends[1], h.at, h.at))

    _spanning_tree(nodes, edges, model)
    order = _orient(nodes, edges)
    return _layout_unknowns(nodes, edges, order)


def _hinge_end(model: Model, side: str, point) -> str:
    """The graph node a hinge at ``point`` meets on ``side`` (a body name or ground)."""
    if side == GROUND:
        return GROUND
    body = model.body(side)
    return rules_of(body).hinge_end(body, point)


def _spanning_tree(nodes, edges, model) -> None:
    """Kruskal maximum spanning tree: bodies' own edges (beams) > elastic hinges > hinges
    with releases."""
    parent = {n: n for n in nodes}

    def find(n):
        while parent[n] != n:
            parent[n] = parent[parent[n]]
            n = parent[n]
        return n

    def weight(e: Edge) -> int:
        if e.kind == "body":
            return 3
        return 1 if e.released.any() else 2

    for i in sorted(range(len(edges)), key=lambda i: (-weight(edges[i]), i)):
        e = edges[i]
        ra, rb = find(e.a), find(e.b)
        if ra != rb:
            parent[ra] = rb
            e.tree = True
    root = find(GROUND)
    for n in nodes:
        if find(n) != root:
            body = n.split("@")[0]
            raise ModelError(f"{model.source}: body {body!r}: not connected to ground")


def _orient(nodes: dict[str, Node], edges: list[Edge]) -> list[str]:
    """Root the tree at ground (BFS), orient every edge, return nodes tips-first."""
    adjacency: dict[str, list[int]] = {n: [] for n in nodes}
    for i, e in enumerate(edges):
        if e.tree:
            adjacency[e.a].append(i)
            adjacency[e.b].append(i)
    bfs = [GROUND]
    seen = {GROUND}
    for n in bfs:
        for i in adjacency[n]:
            e = edges[i]
            child = e.b if e.a == n else e.a
            if child in seen:
                continue
            seen.add(child)
            nodes[child].parent_edge = i
            nodes[child].depth = nodes[n].depth + 1
            e.input_node, e.output_node = child, n
            bfs.append(child)
    for i, e in enumerate(edges):
        if e.tree:
            if e.output_node != GROUND:
                nodes[e.output_node].inputs.append((i, "edge"))
            continue
        if GROUND in (e.a, e.b):  # input at ground: zero displacement, unknown reactions
            e.input_node = GROUND
            e.output_node = e.b if e.a == GROUND else e.a
        else:  # cut where the input end meets the deeper body
            deeper_a = nodes[e.a].depth >= nodes[e.b].depth
            e.input_node, e.output_node = (e.a, e.b) if deeper_a else (e.b, e.a)
            nodes[e.input_node].inputs.append((i, "cut"))
        nodes[e.output_node].inputs.append((i, "edge"))
    for name, node in nodes.items():
        if name != GROUND:
            node.output_point = edges[node.parent_edge].point_at(name)
    return [n for n in reversed(bfs) if n != GROUND]


def _layout_unknowns(nodes, edges, order) -> Topology:
    labels: list[str] = []

    def new(label: str) -> int:
        labels.append(label)
        return len(labels) - 1

    root_columns, cut_columns, ground_columns = {}, {}, {}
    released_columns: dict[int, dict[int, int]] = {}
    free_tip_columns = {}
    for i, e in enumerate(edges):
        if e.tree and e.output_node == GROUND:
            root_columns[i] = np.array([new(f"{e.name}:reaction {s}") for s in STATE_NAMES[6:]])
    for i, e in enumerate(edges):
        if e.tree:
            continue
        rel = e.released
        cols = -np.ones(12, dtype=int)
        first = 6 if e.input_node == GROUND else 0
        for s in range(first, 12):
            direction = s - 9 if s >= 9 else s - 3 if s >= 6 else None
            if direction is not None and rel[direction]:
                continue  # a released direction transmits nothing: known zero
            cols[s] = new(f"{e.name}:input {STATE_NAMES[s]}")
        (ground_columns if e.input_node == GROUND else cut_columns)[i] = cols
    for i, e in enumerate(edges):
        for d in np.flatnonzero(e.released):
            released_columns.setdefault(i, {})[int(d)] = new(
                f"{e.name}:released Δ{DISPLACEMENT_NAMES[d]}"
            )
    for name in order:
        if not nodes[name].inputs:
            free_tip_columns[name] = np.array(
                [new(f"{name}:free tip {s}") for s in DISPLACEMENT_NAMES]
            )
    return Topology(
        nodes,
        edges,
        order,
        labels,
        cut_columns,
        ground_columns,
        released_columns,
        free_tip_columns,
        root_columns,
    )


def transfer_topology(model: Model) -> Topology:
    """The topology of ``model`` with its redundant rigid directions released.

    It depends on :meth:`~ufmt.model.schema.Model.structure_key` (bodies, hinge places,
    rigid and released directions), not on the stiffness values: it is built once per such
    structure (the last TOPOLOGIES_KEPT) and shared by the designs of a stiffness study, each
    with its hinge edges bound to its own hinges.
    """

    def build():
        redundant = redundant_rigid(model)
        return build_topology(with_released(model, redundant)), redundant

    topology, redundant = _TOPOLOGIES.get(model.structure_key(), build)
    model = with_released(model, redundant)
    edges = [
        replace(e, element=model.hinge(e.name)) if e.kind == "hinge" else e for e in topology.edges
    ]
    return replace(topology, edges=edges)


TOPOLOGIES_KEPT = 8
_TOPOLOGIES = Recent(TOPOLOGIES_KEPT)  # structure key -> (topology, redundant directions)


def with_released(model: Model, directions) -> Model:
    """``model`` with the hinge directions ``directions`` ((hinge, direction) pairs) released."""
    for name, j in directions:
        six = model.hinge(name).stiffness6.copy()
        six[j] = 0.0
        model = model.with_hinge(name, stiffness=six[:3], rotational_stiffness=six[3:])
    return model


def redundant_rigid(model: Model) -> list[tuple[str, int]]:
    """The rigid hinge directions (hinge, direction) that repeat other rigid restrictions.

    A rigid direction that repeats a restriction already imposed by other rigid directions
    adds nothing kinematically, but it leaves a self-stress that no displacement sees: U_all
    would be singular at every ω. Releasing it gives the same motions and frequencies.
    Every body gets six small-motion dofs [r; θ] at a reference point (centre of mass, or the
    hinge point for virtual bodies and beam ends); a rigid direction j of a hinge at P
    constrains e_j·(u_a(P) - u_b(P)) with u(P) = [r + θ × (P - ref); θ]; ground is fixed.
    Independent rows are picked by pivoted QR; the dependent ones are returned.
    """
    rows, owners = [], []
    nodes: dict[str, int] = {}
    for h in model.hinges:
        for j in np.flatnonzero(h.rigid):
            entries = []
            for side, sign in zip(h.between, (1.0, -1.0), strict=True):
                if side == GROUND:
                    continue
                body = model.body(side)
                node = rules_of(body).hinge_end(body, h.at)
                ref = rules_of(body).reference(body, h.at)
                motion = point_motion(np.asarray(h.at) - ref)
                entries.append((nodes.setdefault(node, len(nodes)), sign * motion[j]))
            rows.append(entries)
            owners.append((h.name, int(j)))
    if not rows:
        return []
    g = np.zeros((len(rows), 6 * len(nodes)))
    for r, entries in enumerate(rows):
        for k, vec in entries:
            g[r, 6 * k : 6 * k + 6] += vec
    g /= np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-300)
    _, rr, piv = qr(g.T, pivoting=True, mode="economic")
    diag = np.abs(np.diag(rr))
    rank = int(np.sum(diag > 1e-9 * diag[0])) if diag.size else 0
    return [owners[r] for r in piv[rank:]]
