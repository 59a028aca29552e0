"""The transfer graph of the MSTMM: its nodes (bodies, beam ends, ground), its edges (hinges
and bodies' own transfer elements), and the oriented graph with its boundary unknowns
(:class:`Topology`, built by :mod:`ufmt.mstmm.topology`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ufmt.model.schema import Body, Hinge, RigidBody

#: Unknown label kinds of the overall state vector Z_all.
DISPLACEMENT_NAMES = ("x", "y", "z", "θx", "θy", "θz")
STATE_NAMES = DISPLACEMENT_NAMES + ("mx", "my", "mz", "qx", "qy", "qz")


@dataclass(frozen=True)
class NodeTransfer:
    """How a node carries its input states to its output (paper eqs. 2.4-2.11).

    first_input(node, first_point) -> the constant and ω² parts (12, 12) of U_{i,I1} (eq. 2.8)
        with the first input end at ``first_point`` [m], or None where U_{i,I1} is the
        identity (a massless point);
    other_lever(p_k, p_out) -> the point [m] whose lever to ``p_out`` U_{i,Ik} (k >= 2, eqs.
        2.9, 2.11) carries the input forces across;
    geometric_map(p_1, p_k) -> H_k (6, 12) of the geometric equations of input k (eqs.
        2.5-2.7).
    """

    first_input: Callable
    other_lever: Callable
    geometric_map: Callable


@dataclass
class Node:
    """A body of the transfer graph: rigid body, virtual body, beam end or ground.

    transfer: how it carries its input states to its output (None for ground); body: the
    rigid body whose mass and extent it carries (None for a massless point).
    """

    name: str
    transfer: NodeTransfer | None
    body: RigidBody | None = None
    point: np.ndarray | None = None  # [m] of a massless point
    parent_edge: int | None = None
    depth: int = 0
    inputs: list[tuple[int, str]] = field(default_factory=list)  # (edge index, "edge"|"cut")
    output_point: np.ndarray | None = None


@dataclass
class Edge:
    """A two-port element between nodes a and b at points pa, pb: a hinge (kind "hinge") or
    a body's own transfer element (kind "body", e.g. a beam)."""

    name: str
    kind: str  # "hinge" | "body"
    element: Hinge | Body
    a: str
    b: str
    pa: np.ndarray
    pb: np.ndarray
    tree: bool = False
    input_node: str = ""
    output_node: str = ""

    def point_at(self, node: str) -> np.ndarray:
        """The edge's end point at ``node`` [m]."""
        return self.pa if node == self.a else self.pb

    @property
    def released(self) -> np.ndarray:
        """Released directions (six booleans); none for a body edge."""
        if self.kind == "hinge":
            return self.element.released
        return np.zeros(6, dtype=bool)


@dataclass
class Topology:
    """Oriented graph with the boundary unknowns and the processing order."""

    nodes: dict[str, Node]
    edges: list[Edge]
    order: list[str]  # non-ground nodes, tips first (post-order)
    unknown_labels: list[str]
    cut_columns: dict[int, np.ndarray]  # edge index -> 12 column indices (-1 = known zero)
    ground_columns: dict[int, np.ndarray]  # non-tree ground edge -> 12 columns (-1 = zero)
    released_columns: dict[int, dict[int, int]]  # edge -> {direction: δ column}
    free_tip_columns: dict[str, np.ndarray]  # node -> 6 displacement columns
    root_columns: dict[int, np.ndarray]  # root edge -> 6 reaction columns

    def first_input_point(self, name: str) -> np.ndarray:
        """Point of a node's first input end I1 [m]; a free tip's is its output point."""
        node = self.nodes[name]
        if node.inputs:
            return self.edges[node.inputs[0][0]].point_at(name)
        return node.output_point

    @property
    def order_size(self) -> int:
        """Order of the overall transfer matrix U_all (number of boundary unknowns)."""
        return len(self.unknown_labels)

    def body_edge(self, name: str) -> int:
        """Index of the edge that is body ``name``'s own transfer element (a beam)."""
        return next(i for i, e in enumerate(self.edges) if e.kind == "body" and e.name == name)
