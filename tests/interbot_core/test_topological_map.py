"""Tests for interbot_core.topological_map: the YAML format, its validation and queries."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from interbot_core.topological_map import (
    TopologicalMap,
    TopologicalMapError,
    load_topological_map,
)

DATA = Path(__file__).parent / "data"
FIXTURE = DATA / "tiny_topo.yaml"


def _nodes(n: int) -> list[dict[str, Any]]:
    return [{"id": i, "name": f"N{i}", "x": 3.0 * i, "y": 0.0, "yaw": 0.0} for i in range(n)]


def test_load_fixture() -> None:
    topo = load_topological_map(FIXTURE)
    assert len(topo) == 5
    assert topo.map_yaml_path == (DATA / "tiny_map.yaml").resolve()
    assert topo.home_id == 0
    lab = topo.node(1)
    assert lab.name == "Lab A" and lab.requests and lab.tour and lab.info == "Lab A info"
    assert lab.pose.yaw == pytest.approx(math.pi / 2)
    assert [n.id for n in topo.tour_nodes()] == [0, 1, 2, 4]
    assert [n.id for n in topo.request_nodes()] == [1, 4]
    weights = {(a.u, a.v): a.weight for a in topo.arcs}
    assert weights[(0, 1)] == pytest.approx(10.0)  # straight-line distance
    assert weights[(3, 4)] == 12.5  # explicit
    assert topo.neighbours(1) == (0, 2, 4)


def test_ring_when_arcs_absent() -> None:
    topo = TopologicalMap.from_dict({"nodes": _nodes(4)})
    pairs = {(a.u, a.v) for a in topo.arcs}
    assert pairs == {(0, 1), (1, 2), (2, 3), (3, 0)}
    assert dict(((a.u, a.v), a.weight) for a in topo.arcs)[(3, 0)] == pytest.approx(9.0)
    assert topo.map_yaml_path is None


@pytest.mark.parametrize(("n", "expected"), [(1, set()), (2, {(0, 1)})])
def test_ring_degenerate_sizes(n: int, expected: set[tuple[int, int]]) -> None:
    topo = TopologicalMap.from_dict({"nodes": _nodes(n)})
    assert {(a.u, a.v) for a in topo.arcs} == expected


def test_empty_arc_list_means_no_arcs() -> None:
    assert TopologicalMap.from_dict({"nodes": _nodes(3), "arcs": []}).arcs == ()


def test_nodes_in_any_order_and_explicit_home() -> None:
    nodes = _nodes(3)[::-1]
    nodes[0]["home"] = True  # node 2
    topo = TopologicalMap.from_dict({"nodes": nodes})
    assert [n.id for n in topo.nodes] == [0, 1, 2]
    assert topo.home_id == 2


def test_node_error_names_file_and_range() -> None:
    topo = TopologicalMap.from_dict({"nodes": _nodes(22)}, source="maps/isr_floor0_topo.yaml")
    with pytest.raises(TopologicalMapError) as err:
        topo.node(42, "goal")
    assert str(err.value) == "goal 42 is not a node of maps/isr_floor0_topo.yaml (nodes 0..21)"
    with pytest.raises(TopologicalMapError, match="not a node id"):
        topo.node(True)


def test_nearest_node_ties_to_lowest_id() -> None:
    topo = TopologicalMap.from_dict({"nodes": _nodes(3)})
    assert topo.nearest_node(4.0, 1.0) == 1
    assert topo.nearest_node(1.5, 0.0) == 0  # equidistant from 0 and 1
    assert topo.nearest_node(100.0, 0.0) == 2


def _with(mutate: Any) -> dict[str, Any]:
    data: dict[str, Any] = {"map": "m.yaml", "nodes": _nodes(3), "arcs": [[0, 1], [1, 2]]}
    mutate(data)
    return data


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda d: d.pop("nodes"), "nodes is missing"),
        (lambda d: d["nodes"][1].pop("x"), r"node 1 \('N1'\): nodes\[1\]\.x is missing"),
        (lambda d: d["nodes"][1].update(x="abc"), r"nodes\[1\]\.x must be a number, got 'abc'"),
        (
            lambda d: d["nodes"][1].update(y=float("nan")),
            r"nodes\[1\]\.y must be a finite number, got nan",
        ),
        (lambda d: d["nodes"][1].update(yaw=True), r"nodes\[1\]\.yaw must be a number, got True"),
        (lambda d: d["nodes"][1].update(id=0), "duplicate node id 0"),
        (lambda d: d.update(nodes=[]), "nodes has 0 elements; at least 1 are allowed"),
        (lambda d: d["nodes"][1].update(id=7), r"missing \[1\], out of range \[7\]"),
        (
            lambda d: d["nodes"][1].update(id=-1),
            r"nodes\[1\]\.id = -1 is outside the allowed range 0\.\.inf",
        ),
        (lambda d: d["nodes"][1].update(id="1"), r"nodes\[1\]\.id must be an integer"),
        (lambda d: d["nodes"][1].update(name=""), r"nodes\[1\]\.name must be a non-empty string"),
        (
            lambda d: d["nodes"][1].update(tour="yes"),
            r"nodes\[1\]\.tour must be true or false, got 'yes'",
        ),
        (lambda d: d["nodes"][1].update(info=3), r"nodes\[1\]\.info must be a string"),
        (
            lambda d: d["nodes"].__setitem__(1, "N1"),
            r"nodes\[1\] must be an object with keys id, name, x, y, yaw",
        ),
        (
            lambda d: [d["nodes"][0].update(home=True), d["nodes"][2].update(home=True)],
            r"at most one node may have home: true, found nodes \[0, 2\]",
        ),
        (lambda d: d["arcs"].append([1, 9]), r"arcs\[2\] \[1, 9\]: 9 is not a node \(nodes 0..2\)"),
        (lambda d: d["arcs"].append([2, 2]), "is a self-loop"),
        (lambda d: d["arcs"].append([0, 2, -1.0]), "weight must be a finite number >= 0"),
        (
            lambda d: d["arcs"].append([0, 2, float("inf")]),
            r"arcs\[2\]\[2\] must be a finite number, got inf",
        ),
        (lambda d: d["arcs"].append([0]), r"an arc is \[u, v\] or \[u, v, weight\]"),
        (lambda d: d["arcs"].append([0, 1.5]), "node ids must be integers"),
        (lambda d: d["arcs"].append([2, 1]), r"arc \[2, 1\] is listed twice"),
        (lambda d: d.update(arcs={"a": 1}), r"arcs must be a list of \[u, v\] or \[u, v, weight\]"),
        (lambda d: d.update(map=3), "map must be the occupancy-grid YAML file name, got 3"),
    ],
)
def test_validation_errors_name_file_and_item(mutate: Any, message: str) -> None:
    with pytest.raises(TopologicalMapError, match=message) as err:
        TopologicalMap.from_dict(_with(mutate), source="maps/x_topo.yaml")
    assert str(err.value).startswith("maps/x_topo.yaml: ")


def test_loader_errors(tmp_path: Path) -> None:
    missing = tmp_path / "nope.yaml"
    with pytest.raises(TopologicalMapError, match="cannot read"):
        load_topological_map(missing)
    bad = tmp_path / "bad.yaml"
    bad.write_text("nodes: [unclosed", encoding="utf-8")
    with pytest.raises(TopologicalMapError, match="invalid YAML"):
        load_topological_map(bad)
    no_map = tmp_path / "no_map.yaml"
    no_map.write_text("nodes:\n  - {id: 0, name: A, x: 0, y: 0, yaw: 0}\n", encoding="utf-8")
    with pytest.raises(TopologicalMapError, match=r"no_map.yaml: missing 'map'"):
        load_topological_map(no_map)
    listed = tmp_path / "list.yaml"
    listed.write_text("- 1\n", encoding="utf-8")
    with pytest.raises(TopologicalMapError, match="expected a mapping"):
        load_topological_map(listed)


def test_map_is_frozen() -> None:
    topo = TopologicalMap.from_dict({"nodes": _nodes(2)})
    with pytest.raises(AttributeError):
        topo.home_id = 1  # type: ignore[misc]
