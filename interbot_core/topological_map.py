"""Topological maps: named nodes (rooms, checkpoints) joined by weighted arcs.

A topological map sits on top of an occupancy grid (thesis §3.1, Fig. 3.1b): nodes are poses in
the ``map`` frame that the robot can drive to (``yaw`` is the heading faced on arrival) and arcs are
the drivable connections between them. Shortest routes between nodes are found with Floyd-Warshall
(thesis §3.4, see :mod:`interbot_core.route_planner`).

File format (YAML, beside the occupancy-grid YAML it belongs to)::

    map: isr_floor0.yaml          # occupancy grid, path relative to this file
    nodes:
      - {id: 0, name: Main Entrance, x: -30.0, y: 0.0, yaw: 0.0,
         info: "Text shown on arrival", tour: true, requests: false}
    arcs:                         # optional; absent (or null) = a ring in id order
      - [0, 1]                    # weight = straight-line distance
      - [1, 2, 12.5]              # explicit weight [m]

Node ids must be exactly 0..N-1 (any order in the file). ``home: true`` marks the home node (at
most one; default node 0). Without ``arcs`` the nodes form a ring 0-1-...-(N-1)-0, as the thesis's
``initialData()`` (Algorithm 4) builds its distance matrix; ``arcs: []`` means no arcs at all.
Unknown extra keys are allowed and ignored. The file is declared by `TopologicalMapFile`
(msgspec); every problem raises :class:`TopologicalMapError` naming the file, the node or arc,
the value and what is allowed.
"""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any

import msgspec
from msgspec import Meta

from interbot_core import schema
from interbot_core.geometry import Pose2D
from interbot_core.schema import SchemaError

logger = logging.getLogger(__name__)


class TopologicalMapError(ValueError):
    """A topological map is malformed or a node id is not in it; the message names the file."""


@dataclass(frozen=True)
class Node:
    """One node of the topological map: a pose in the ``map`` frame plus what the UI shows."""

    id: int
    name: str
    pose: Pose2D  # [m, m, rad]; yaw is the heading faced on arrival
    info: str = ""  # text shown on arrival (guided tour)
    tour: bool = False  # a stop of the guided tour
    requests: bool = False  # requests/deliveries may be picked up here
    home: bool = False


@dataclass(frozen=True)
class Arc:
    """An undirected arc between nodes ``u`` and ``v`` with its length ``weight`` [m]."""

    u: int
    v: int
    weight: float  # [m]


@dataclass(frozen=True)
class TopologicalMap:
    """A validated, immutable topological map. Build it with :meth:`from_dict` or the loader."""

    nodes: tuple[Node, ...]
    arcs: tuple[Arc, ...]
    map_yaml_path: Path | None = None  # resolved occupancy-grid YAML, None for in-memory maps
    source: str = "<memory>"  # file name used in error messages
    home_id: int = field(init=False)

    def __post_init__(self) -> None:
        src = self.source
        if not self.nodes:
            raise TopologicalMapError(f"{src}: the map has no nodes")
        for index, node in enumerate(self.nodes):
            if node.id != index:
                raise TopologicalMapError(
                    f"{src}: node ids must be 0..{len(self.nodes) - 1} in order; "
                    f"position {index} holds node {node.id}"
                )
        homes = [node.id for node in self.nodes if node.home]
        if len(homes) > 1:
            raise TopologicalMapError(
                f"{src}: at most one node may have home: true, found nodes {homes}"
            )
        seen: set[tuple[int, int]] = set()
        n = len(self.nodes)
        for arc in self.arcs:
            label = f"arc [{arc.u}, {arc.v}]"
            for end in (arc.u, arc.v):
                if not 0 <= end < n:
                    raise TopologicalMapError(
                        f"{src}: {label}: {end} is not a node (nodes 0..{n - 1})"
                    )
            if arc.u == arc.v:
                raise TopologicalMapError(f"{src}: {label} is a self-loop")
            if not (math.isfinite(arc.weight) and arc.weight >= 0.0):
                raise TopologicalMapError(
                    f"{src}: {label}: weight must be a finite number >= 0 [m], got {arc.weight!r}"
                )
            key = (min(arc.u, arc.v), max(arc.u, arc.v))
            if key in seen:
                raise TopologicalMapError(f"{src}: {label} is listed twice")
            seen.add(key)
        object.__setattr__(self, "home_id", homes[0] if homes else 0)

    # ------------------------------------------------------------------ construction

    @classmethod
    def from_dict(
        cls, data: Any, source: str = "<memory>", base_dir: Path | None = None
    ) -> TopologicalMap:
        """Validate parsed YAML ``data`` (`TopologicalMapFile`); ``map`` is resolved against
        ``base_dir`` (or cwd)."""
        if not isinstance(data, Mapping):
            raise TopologicalMapError(
                f"{source}: expected a mapping with 'nodes' (and 'map', 'arcs'), "
                f"got {type(data).__name__}"
            )
        try:
            file = schema.convert(data, TopologicalMapFile, "")
        except SchemaError as exc:
            label = _node_label(data, exc.path)
            raise TopologicalMapError(f"{source}: {label}{exc.message}") from None
        map_path = None if file.map is None else ((base_dir or Path.cwd()) / file.map).resolve()
        by_id: dict[int, NodeEntry] = {}
        for entry in file.nodes:
            if entry.id in by_id:
                raise TopologicalMapError(
                    f"{source}: duplicate node id {entry.id} "
                    f"({by_id[entry.id].name!r} and {entry.name!r})"
                )
            by_id[entry.id] = entry
        n = len(file.nodes)
        missing = sorted(set(range(n)) - set(by_id))
        if missing:
            extra = sorted(set(by_id) - set(range(n)))
            raise TopologicalMapError(
                f"{source}: node ids must be 0..{n - 1} without gaps; "
                f"missing {missing}, out of range {extra}"
            )
        nodes = tuple(by_id[i].node() for i in range(n))
        if file.arcs is None:  # a ring in id order, as the thesis's initialData() builds
            arc_pairs: list[tuple[int, int, float | None]] = [
                (i, (i + 1) % n, None) for i in range(n if n > 2 else n - 1)
            ]
        else:
            arc_pairs = [_arc_ends(raw, i, n, source) for i, raw in enumerate(file.arcs)]
        arcs = tuple(
            Arc(u, v, nodes[u].pose.distance_to(nodes[v].pose) if w is None else w)
            for u, v, w in arc_pairs
        )
        return cls(nodes=nodes, arcs=arcs, map_yaml_path=map_path, source=source)

    # ------------------------------------------------------------------ queries

    def __len__(self) -> int:
        return len(self.nodes)

    def node(self, node_id: int, role: str = "node") -> Node:
        """The node with this id; ``role`` ("goal", "room", ...) only words the error message."""
        if isinstance(node_id, bool) or not isinstance(node_id, int):
            raise TopologicalMapError(
                f"{role} {node_id!r} is not a node id of {self.source} "
                f"(integers 0..{len(self.nodes) - 1})"
            )
        if not 0 <= node_id < len(self.nodes):
            raise TopologicalMapError(
                f"{role} {node_id} is not a node of {self.source} (nodes 0..{len(self.nodes) - 1})"
            )
        return self.nodes[node_id]

    def neighbours(self, node_id: int) -> tuple[int, ...]:
        """Ids of the nodes joined to ``node_id`` by an arc, ascending."""
        self.node(node_id)
        out = {arc.v for arc in self.arcs if arc.u == node_id}
        out |= {arc.u for arc in self.arcs if arc.v == node_id}
        return tuple(sorted(out))

    def weighted_arcs(self) -> list[tuple[int, int, float]]:
        """The arcs as ``(u, v, weight)`` triples, the input of ``floyd_warshall``."""
        return [(arc.u, arc.v, arc.weight) for arc in self.arcs]

    def tour_nodes(self) -> tuple[Node, ...]:
        """Guided-tour stops (``tour: true``) in id order."""
        return tuple(node for node in self.nodes if node.tour)

    def request_nodes(self) -> tuple[Node, ...]:
        """Nodes where requests may be picked up (``requests: true``) in id order."""
        return tuple(node for node in self.nodes if node.requests)

    def nearest_node(self, x: float, y: float) -> int:
        """Id of the node closest to the point (x, y) [m]; ties go to the lowest id."""
        best_id = 0
        best = math.inf
        for node in self.nodes:
            d = math.hypot(node.pose.x - x, node.pose.y - y)
            if d < best:
                best, best_id = d, node.id
        return best_id


def load_topological_map(path: str | Path) -> TopologicalMap:
    """Load and validate a topological-map YAML file; ``map`` is required and resolved."""
    source = str(path)
    file_path = Path(path)
    data = schema.read_yaml(path, TopologicalMapError, "topological map")
    if isinstance(data, Mapping) and data.get("map") is None:
        raise TopologicalMapError(
            f"{source}: missing 'map' (the occupancy-grid YAML this map belongs to)"
        )
    topo = TopologicalMap.from_dict(data, source=source, base_dir=file_path.resolve().parent)
    logger.info(
        "loaded topological map %s: %d nodes, %d arcs, home %d",
        source,
        len(topo.nodes),
        len(topo.arcs),
        topo.home_id,
    )
    return topo


# ---------------------------------------------------------------------- the file's declaration

NodeName = Annotated[str, Meta(pattern=r"\S", extra={"format": "a non-empty string"})]
# An arc is [u, v] or [u, v, weight]: msgspec has no union of two array shapes, so the entries
# are finite numbers and `_arc_ends` checks the length and that the ends are node ids.
ArcEntry = tuple[schema.Finite, ...]


class NodeEntry(msgspec.Struct, frozen=True):
    """One entry of ``nodes:`` as written in the file (unknown keys are ignored)."""

    id: Annotated[int, Meta(ge=0)]
    name: NodeName
    x: schema.Finite  # [m]
    y: schema.Finite  # [m]
    yaw: schema.Finite  # [rad]
    info: str | None = ""
    tour: bool = False
    requests: bool = False
    home: bool = False

    def node(self) -> Node:
        return Node(
            self.id,
            self.name,
            Pose2D(self.x, self.y, self.yaw),
            self.info or "",
            self.tour,
            self.requests,
            self.home,
        )


class TopologicalMapFile(msgspec.Struct, frozen=True):
    """The topological-map YAML (see the module docstring); unknown keys are ignored."""

    nodes: Annotated[list[NodeEntry], Meta(min_length=1)]
    map: (
        Annotated[str, Meta(min_length=1, extra={"format": "the occupancy-grid YAML file name"})]
        | None
    ) = None
    arcs: (
        Annotated[list[ArcEntry], Meta(extra={"format": "a list of [u, v] or [u, v, weight]"})]
        | None
    ) = None


def _node_label(data: Mapping[str, Any], path: str) -> str:
    """``node 1 ('N1'): `` for an error inside ``nodes[1]`` whose id and name can be read."""
    found = re.match(r"nodes\[(\d+)\]", path)
    nodes = data.get("nodes")
    if found is None or path.endswith(".id") or not isinstance(nodes, list):
        return ""
    if int(found[1]) >= len(nodes):
        return ""
    raw = nodes[int(found[1])]
    if not isinstance(raw, Mapping) or "id" not in raw:
        return ""
    return f"node {raw['id']!r}" + (f" ({raw['name']!r})" if "name" in raw else "") + ": "


def _arc_ends(raw: ArcEntry, index: int, n: int, source: str) -> tuple[int, int, float | None]:
    label = f"arcs[{index}] [{', '.join(f'{x:g}' for x in raw)}]"
    if len(raw) not in (2, 3):
        raise TopologicalMapError(f"{source}: {label}: an arc is [u, v] or [u, v, weight]")
    if not all(float(end).is_integer() for end in raw[:2]):
        raise TopologicalMapError(f"{source}: {label}: node ids must be integers")
    u, v = int(raw[0]), int(raw[1])
    for end in (u, v):
        if not 0 <= end < n:
            raise TopologicalMapError(f"{source}: {label}: {end} is not a node (nodes 0..{n - 1})")
    if u == v:
        raise TopologicalMapError(f"{source}: {label} is a self-loop")
    if len(raw) == 3 and raw[2] < 0:
        raise TopologicalMapError(
            f"{source}: {label}: weight must be a finite number >= 0 [m], got {raw[2]!r}"
        )
    return u, v, None if len(raw) == 2 else float(raw[2])
