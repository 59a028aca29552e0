"""Overall transfer equation U_all(ω) Z_all = 0 (paper eqs. 2.15-2.22), batched over ω.

Every state vector in the system is a linear function of the boundary unknowns Z_all. Starting
from the tips (cut states, ground reactions of cut ground hinges, free tips) the states are
transferred element by element towards the root; each state is kept as a block of columns of
Z_all only (the unknowns of its own subtree), which makes the work per element proportional to
the paper's path products. The rows of U_all are the root conditions (zero displacement at
ground, reactions), the geometric equations of multi-input bodies (eqs. 2.5-2.7) and one
zero-force condition per released direction of a tree hinge.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ufmt.kinds import hinge_kind_of
from ufmt.kinematics import load_transfer
from ufmt.model.schema import GROUND, Model
from ufmt.mstmm import elements
from ufmt.mstmm.bodies import rules_of
from ufmt.mstmm.graph import Topology
from ufmt.mstmm.topology import transfer_topology

CUT = np.diag(np.r_[np.ones(6), -np.ones(6)])  # C = diag(I3, I3, -I3, -I3)
CUT.flags.writeable = False
GROWTH_LIMIT = 1e8  # condition growth allowed along a transfer path before segmenting


def _physical_scaling(model: Model) -> np.ndarray:
    """State scaling [1/m, 1/rad·ℓ, 1/(k ℓ), 1/k] making a stage's condition number physical.

    k is the geometric mean of the model's finite translational hinge stiffnesses [N/m] and
    ℓ the spread of its hinge points [m].
    """
    k = np.concatenate([h.stiffness for h in model.hinges])
    k = k[(k > 0) & np.isfinite(k)]
    k_ref = float(np.exp(np.mean(np.log(k)))) if k.size else 1.0
    pts = np.array([h.at for h in model.hinges])
    ell = float(np.sqrt(((pts - pts.mean(axis=0)) ** 2).sum(axis=1).mean())) or 1.0
    return np.r_[np.ones(3), np.full(3, ell), np.full(3, 1 / (k_ref * ell)), np.full(3, 1 / k_ref)]


def equilibrate(u: np.ndarray):
    """Positive row and column scalings making U_all's rows and columns O(1)."""
    a = np.abs(u)
    r = a.max(axis=2, keepdims=True)
    r[r == 0] = 1.0
    a /= r
    c = a.max(axis=1, keepdims=True)
    c[c == 0] = 1.0
    return 1.0 / r, 1.0 / c


@dataclass
class State:
    """A state vector as a linear map of the unknowns: ``Z = arr @ Z_all[cols]``."""

    cols: np.ndarray  # (k,) column indices into Z_all
    arr: np.ndarray  # (n_omega, 12, k)

    def transfer(self, u: np.ndarray) -> State:
        """U @ Z for transfer matrices ``u``: (n_omega, 12, 12), or (12, 12) constant in ω."""
        return State(self.cols, u @ self.arr)

    def __add__(self, other: State) -> State:
        """Sum of two maps; columns need not be sorted, shared ones are added."""
        cols, at, shared, rest = _sum_plan(_key(self.cols), _key(other.cols))
        if shared is None:  # disjoint subtrees: just stack the columns
            return State(cols, np.concatenate([self.arr, other.arr], axis=2))
        arr = self.arr.astype(np.result_type(self.arr, other.arr), copy=True)
        arr[:, :, at] += other.arr[:, :, shared]
        return State(cols, np.concatenate([arr, other.arr[:, :, rest]], axis=2))

    def rows(self, rows) -> State:
        """The map restricted to some of its rows (an equation block of U_all)."""
        return State(self.cols, self.arr[:, rows, :])


@functools.lru_cache(maxsize=65536)
def _sum_plan(cols_a: bytes, cols_b: bytes):
    """Index plan of the sum of two state maps with these column arrays (int64 bytes): the
    summed columns, and where b's shared columns add into a (None if disjoint) and which of
    b's columns are appended. A walk repeats the same sums at every call."""
    a, b = np.frombuffer(cols_a, dtype=np.int64), np.frombuffer(cols_b, dtype=np.int64)
    pos = {int(c): i for i, c in enumerate(a)}
    shared = np.array([j for j, c in enumerate(b) if int(c) in pos], dtype=int)
    if shared.size == 0:
        return _frozen(np.concatenate([a, b])), None, None, None
    at = np.array([pos[int(b[j])] for j in shared], dtype=int)
    rest = np.array([j for j in range(b.size) if int(b[j]) not in pos], dtype=int)
    return _frozen(np.concatenate([a, b[rest]])), _frozen(at), _frozen(shared), _frozen(rest)


def _key(cols: np.ndarray) -> bytes:
    """Column indices as int64 bytes: the cache key of an index plan."""
    return cols.astype(np.int64, copy=False).tobytes()


def _frozen(a: np.ndarray) -> np.ndarray:
    """``a`` made read-only: cached plans are shared by every walk."""
    a.flags.writeable = False
    return a


def assemble(blocks: list[State], n: int, at=slice(None)) -> np.ndarray:
    """Stack equation blocks (:meth:`TransferSystem.equation_blocks`) into the dense U_all
    (n_omega, n, n), one slice per block; ``at``: only these of the blocks' frequencies."""
    if sum(b.arr.shape[1] for b in blocks) != n:  # pragma: no cover - counting argument
        raise AssertionError(f"U_all has the wrong number of rows for {n} unknowns")
    n_omega = blocks[0].arr[at].shape[0]
    u = np.zeros((n_omega, n, n), dtype=np.result_type(*[b.arr for b in blocks]))
    r0 = 0
    for b in blocks:
        r = b.arr.shape[1]
        u[:, r0 : r0 + r, b.cols] = b.arr[at]
        r0 += r
    return u


def block_layout(blocks: list[State]) -> tuple:
    """Per equation block its row count and its columns (int64 bytes): what the Newton
    iteration's map to S' depends on (:meth:`ufmt.mstmm.reduced.ConstantParts.sparse`)."""
    return tuple((b.arr.shape[1], _key(b.cols)) for b in blocks)


@functools.lru_cache(maxsize=4096)
def _hinge_matrix(stiffness6: tuple) -> np.ndarray:
    """Hinge transfer matrix (12, 12) (eq. 2.13), shared by every design with these values."""
    return _frozen(elements.hinge(np.zeros(1), np.array(stiffness6))[0])


def _unknown_state(n_omega: int, columns: np.ndarray) -> State:
    """A state whose 12 entries are unknowns ``columns`` (-1 = known zero)."""
    cols, template = _selection(_key(columns))
    return State(cols, np.broadcast_to(template, (n_omega, *template.shape)))


@functools.lru_cache(maxsize=4096)
def _selection(columns: bytes) -> tuple[np.ndarray, np.ndarray]:
    """(known columns, (12, k) 0/1 map) of a state of unknowns ``columns`` (-1 = zero)."""
    columns = np.frombuffer(columns, dtype=np.int64)
    known = columns >= 0
    template = np.zeros((12, int(known.sum())))
    template[np.flatnonzero(known), np.arange(known.sum())] = 1.0
    return _frozen(columns[known]), _frozen(template)


@functools.lru_cache(maxsize=4096)
def _other_input(lever: tuple, p_out: tuple) -> np.ndarray:
    """U_{i,Ik}, k >= 2 (eqs. 2.9, 2.11), constant (12, 12)."""
    return _frozen(load_transfer(np.array(lever), np.array(p_out)))


@functools.lru_cache(maxsize=1024)
def _edge_rotation(body, p_in: bytes, p_out: bytes) -> np.ndarray:
    """(12, 12) local-to-global rotation of a body's own edge from ``p_in`` to ``p_out``
    (float64 bytes), shared by every design with this body."""
    rotation = rules_of(body).edge_rotation(body, np.frombuffer(p_in), np.frombuffer(p_out))
    return _frozen(rotation)


@functools.lru_cache(maxsize=1024)
def _body_edge_at(body, p_in: bytes, p_out: bytes, omega: float) -> np.ndarray:
    """A body edge's transfer matrix (12, 12) at one ω [rad/s], shared by every design with
    this body (the segmentation's stage at f_max)."""
    rotation = _edge_rotation(body, p_in, p_out)
    return _frozen(rules_of(body).edge_matrix(np.array([omega]), body, rotation)[0])


FREE_TIP = _frozen(np.eye(12, 6))  # a free tip's state: six unknown displacements, no forces
REACTION = _frozen(-np.eye(12, 6, -6))  # the ground's reactions enter the root's force rows


def segment_designs(systems: list[TransferSystem], fmax_hz: float) -> None:
    """:meth:`TransferSystem.segment_for` of designs of one structure (one topology) at once.

    The stages of every node are stacked over the designs, and the path products of all
    nodes of one level of the transfer graph (their upstream paths known) and of all designs
    go through one batched SVD. Each design gets the segments it gets alone, bitwise: the
    same products and singular values, matrix by matrix.
    """
    topo = systems[0].topology
    if any(s.topology.nodes is not topo.nodes for s in systems):
        raise ValueError("segment_designs: the designs must share one structure (topology)")
    w = np.array([2 * np.pi * fmax_hz])
    stages = _stages(systems, w)  # node -> (designs, 12, 12)
    n = len(systems)
    path: dict[str, np.ndarray] = {}  # product of the stages since the last segment
    chosen: set[tuple[int, str]] = set()  # (design, node)
    for level in _levels(topo):
        products, spans = [], []
        for name in level:
            upstream = [path[node] for node in _tree_inputs(topo, name)]
            spans.append((len(products), len(products) + max(len(upstream), 1)))
            products += [stages[name] @ p for p in upstream] or [stages[name]]
        products = np.stack(products, axis=1)  # (designs, paths, 12, 12)
        conds = np.linalg.cond(products)
        worst = np.empty((n, len(level)), dtype=int)  # per design and node: its worst path
        for j, (a, b) in enumerate(spans):  # the first worst, as alone
            worst[:, j] = a if b == a + 1 else a + np.argmax(conds[:, a:b], axis=1)
        designs = np.arange(n)[:, None]
        kept = products[designs, worst]  # (designs, nodes, 12, 12)
        over = conds[designs, worst] > GROWTH_LIMIT
        kept[over] = np.eye(12)
        path.update((name, kept[:, j]) for j, name in enumerate(level))
        chosen.update((int(d), level[j]) for d, j in zip(*np.nonzero(over), strict=True))
    for d, system in enumerate(systems):
        system.segments = tuple(name for name in topo.order if (d, name) in chosen)
        system._segmented_for = fmax_hz


def _stages(systems: list[TransferSystem], w: np.ndarray) -> dict[str, np.ndarray]:
    """Per node, its stage (parent element after body, physically scaled) at the one
    frequency ``w`` [rad/s], stacked over the designs (designs, 12, 12)."""
    topo = systems[0].topology
    nodes = [topo.nodes[name] for name in topo.order]
    omega = float(w[0])
    stage = np.array([[s._stage_edge(node.parent_edge, omega) for node in nodes] for s in systems])
    first = [systems[0]._first_input(node, w) for node in nodes]  # the designs' shared bodies
    massive = [k for k, f in enumerate(first) if f is not None]
    if massive:
        stage[:, massive] = stage[:, massive] @ np.array([first[k][0] for k in massive])
    scale = np.array([_physical_scaling(s.model) for s in systems])[:, None]
    stage = scale[:, :, :, None] * stage / scale[:, :, None, :]
    return {name: stage[:, k] for k, name in enumerate(topo.order)}


def _tree_inputs(topo: Topology, name: str) -> list[str]:
    """The nodes whose output enters node ``name`` through a tree edge, in input order."""
    return [
        topo.edges[i].input_node
        for i, role in topo.nodes[name].inputs
        if role == "edge" and topo.edges[i].tree
    ]


def _levels(topo: Topology) -> list[list[str]]:
    """The nodes in levels, tips first: a node's tree inputs come from earlier levels (in
    topological order within each level)."""
    level: dict[str, int] = {}
    for name in topo.order:
        level[name] = 1 + max((level[node] for node in _tree_inputs(topo, name)), default=-1)
    out: list[list[str]] = [[] for _ in range(1 + max(level.values(), default=-1))]
    for name in topo.order:
        out[level[name]].append(name)
    return out


class TransferSystem:
    """The MSTMM of one model: topology plus element data, evaluated at any ω array."""

    def __init__(self, model: Model, fmax_hz: float | None = None):
        self.model = model
        self.topology: Topology = transfer_topology(model)
        self.segments: tuple[str, ...] = ()
        self._segmented_for: float | None = None  # fmax_hz [Hz] the segments are chosen for
        self._edge_rotations: dict[int, np.ndarray] = {}
        self._constant_parts: dict = {}  # hinge edge index or node name -> matrices (or None)
        if fmax_hz is not None:
            self.segment_for(fmax_hz)

    def segment_for(self, fmax_hz: float) -> tuple[str, ...]:
        """Choose the nodes after which the transfer is segmented for ω up to 2π·fmax_hz.

        Long transfer products lose the small solution components next to the growing ones
        (mω²/k per stage at high frequency). Following each path from the tips, the stages
        (body then parent element, physically scaled) are multiplied up; where the 2-norm
        condition number (SVD) of the product since the last segment passes GROWTH_LIMIT
        (the worst path into a multi-input body counts) the node's output state becomes 12
        new unknowns S with 12 equations Z_out - S = 0. (The product of the stages' own
        condition numbers, a bound, put up to a third more segments than needed on the
        packaged model.) The matrix grows, but its determinant is exactly det U_all (Schur
        complement with an identity block), so roots and null vectors are unchanged. The
        choice is kept: asked again for the same ``fmax_hz`` the system returns it
        (:func:`segment_designs` chooses for several designs at once).
        """
        if self._segmented_for != fmax_hz:
            segment_designs([self], fmax_hz)
        return self.segments

    @property
    def order(self) -> int:
        """Order of U_all (boundary unknowns; segment states not counted)."""
        return self.topology.order_size

    @property
    def size(self) -> int:
        """Size of the evaluated matrix: U_all's order plus 12 per segment."""
        return self.topology.order_size + 12 * len(self.segments)

    def _edge_matrix(self, index: int, omega: np.ndarray) -> np.ndarray:
        """Transfer matrix of edge ``index``: (12, 12) if constant in ω, else (n, 12, 12)."""
        e = self.topology.edges[index]
        if e.kind == "hinge":
            kind = hinge_kind_of(e.element)
            if not kind.count_applies(e.element):  # k'(ω): the storage stiffness at each ω
                return elements.hinge(omega, kind.storage_stiffness6(e.element, omega))
            if index not in self._constant_parts:
                self._constant_parts[index] = _hinge_matrix(tuple(e.element.stiffness6))
            return self._constant_parts[index]
        return rules_of(e.element).edge_matrix(omega, e.element, self.edge_rotation(index))

    def edge_rotation(self, index: int) -> np.ndarray:
        """(12, 12) rotation of body edge ``index`` (a beam) from its local frame (input end
        to output end) to the global frame (e.g. :func:`ufmt.mstmm.elements.beam_rotation`),
        computed once per body and direction (shared by the designs of a study)."""
        if index not in self._edge_rotations:
            self._edge_rotations[index] = _edge_rotation(*self._body_edge_key(index))
        return self._edge_rotations[index]

    def _body_edge_key(self, index: int) -> tuple:
        """(body, input point, output point as float64 bytes) of body edge ``index``."""
        e = self.topology.edges[index]
        ends = (e.point_at(e.input_node), e.point_at(e.output_node))
        return (e.element, *(np.asarray(p, dtype=float).tobytes() for p in ends))

    def _stage_edge(self, index: int, omega: float) -> np.ndarray:
        """Edge ``index``'s transfer matrix (12, 12) at one ω [rad/s] (a stage of
        :meth:`segment_for`); a body edge's is computed once per body, direction and ω."""
        if self.topology.edges[index].kind == "hinge":
            u = self._edge_matrix(index, np.array([omega]))
            return u[0] if u.ndim == 3 else u
        return _body_edge_at(*self._body_edge_key(index), omega)

    def _first_input(self, node, omega: np.ndarray) -> np.ndarray | None:
        """U_{i,I1} (eq. 2.8) as (n_omega, 12, 12), or None where it is the identity (a
        massless point); its constant and ω² parts are cached per node."""
        if node.name not in self._constant_parts:
            first = self.topology.first_input_point(node.name)
            self._constant_parts[node.name] = node.transfer.first_input(node, first)
        parts = self._constant_parts[node.name]
        if parts is None:
            return None
        base, inertial = parts
        return base[None] + (omega**2)[:, None, None] * inertial[None]

    def _edge_output(self, index: int, state_in: State, omega: np.ndarray) -> State:
        out = state_in.transfer(self._edge_matrix(index, omega))
        for direction, col in self.topology.released_columns.get(index, {}).items():
            delta = np.zeros((omega.size, 12, 1))
            delta[:, direction, 0] = 1.0
            out = out + State(np.array([col]), delta)
        return out

    def evaluate(self, omega) -> np.ndarray:
        """U_all(ω) as (n_omega, n, n) for ω [rad/s]."""
        return assemble(self.equation_blocks(omega)[0], self.size)

    def equation_blocks(self, omega, keep_states: bool = False) -> tuple[list[State], dict]:
        """U_all(ω)'s rows as equation blocks, in order (:func:`assemble` stacks them,
        :func:`place` scatters them), and with ``keep_states`` every state map
        (:meth:`states`), from one walk."""
        return self._walk(np.atleast_1d(np.asarray(omega, dtype=float)), keep_states)

    def states(self, omega) -> dict:
        """Every state map at ω [rad/s]: ``("node_in", node, k)`` (k-th input end),
        ``("node_out", node)``, ``("edge_in", edge)`` and ``("edge_out", edge)`` to State
        objects (U_all is not assembled)."""
        return self._walk(np.atleast_1d(np.asarray(omega, dtype=float)), True)[1]

    def _walk(self, omega: np.ndarray, keep_states: bool) -> tuple[list[State], dict]:
        """Transfer every state from the tips to the root: U_all's equation blocks and, with
        ``keep_states``, every state map."""
        nw = omega.size
        topo = self.topology
        n_base = topo.order_size
        segment_cols = {
            name: n_base + 12 * j + np.arange(12) for j, name in enumerate(self.segments)
        }
        rows: list[State] = []
        states: dict = {}
        edge_out: dict[int, State] = {}
        for i, columns in (topo.cut_columns | topo.ground_columns).items():
            z_in = _unknown_state(nw, columns)
            edge_out[i] = self._edge_output(i, z_in, omega)
            if keep_states:
                states[("edge_in", i)] = z_in
                states[("edge_out", i)] = edge_out[i]
        for name in topo.order:
            node = topo.nodes[name]
            p_out = node.output_point
            inputs: list[tuple[State, np.ndarray]] = []
            for i, role in node.inputs:
                e = topo.edges[i]
                if role == "cut":
                    z = _unknown_state(nw, topo.cut_columns[i])
                    inputs.append((z.transfer(CUT), e.point_at(name)))
                else:
                    inputs.append((edge_out[i], e.point_at(name)))
            if not inputs:  # free tip: six unknown displacements, zero forces
                cols = topo.free_tip_columns[name]
                inputs.append((State(cols, np.broadcast_to(FREE_TIP, (nw, 12, 6))), p_out))
            out = self._node_output(node, inputs, omega)
            for k in range(1, len(inputs)):  # geometric equations (2.5-2.7)
                (z1, p1), (zk, pk) = inputs[0], inputs[k]
                h_k = node.transfer.geometric_map(p1, pk)
                rows.append(zk.transfer(h_k) + State(z1.cols, -z1.arr[:, 0:6, :]))
            if keep_states:
                for k, (z, _) in enumerate(inputs):
                    states[("node_in", name, k)] = z
                states[("node_out", name)] = out
            i = node.parent_edge
            for direction in topo.released_columns.get(i, {}):
                force_row = 9 + direction if direction < 3 else 6 + direction - 3
                rows.append(out.rows([force_row]))
            if name in segment_cols:  # Z_out - S = 0, transfer continues from S
                cols = segment_cols[name]
                ident = np.broadcast_to(np.eye(12), (nw, 12, 12))
                rows.append(out + State(cols, -ident))
                out = State(cols, ident)
            edge_out[i] = self._edge_output(i, out, omega)
            if keep_states:
                states[("edge_in", i)] = out
                states[("edge_out", i)] = edge_out[i]
            if topo.edges[i].output_node == GROUND:  # root: zero displacement, reactions
                reaction = np.broadcast_to(REACTION, (nw, 12, 6))
                rows.append(edge_out[i] + State(topo.root_columns[i], reaction))
        return rows, states

    def _node_output(self, node, inputs, omega) -> State:
        """Output state of a body from its input states (eqs. 2.4, 2.8, 2.9, 2.11)."""
        z1 = inputs[0][0]
        p_out = node.output_point
        first = self._first_input(node, omega)
        out = z1 if first is None else z1.transfer(first)
        for zk, pk in inputs[1:]:
            lever = node.transfer.other_lever(pk, p_out)
            out = out + zk.transfer(_other_input(tuple(lever), tuple(p_out)))
        return out
