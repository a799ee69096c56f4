"""One room model for both apps (`interbot_core.rooms`): rooms from the topological map's
``area``, the node a room maps to, translations, where a click lands, label points."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from interbot_core.occupancy_grid import FREE, load_map
from interbot_core.rooms import (
    DEFAULT_ROOM_SIZE,
    RoomMapError,
    load_room_map,
    point_in_polygon,
    polygon_centroid,
    room_map,
)
from interbot_core.topological_map import TopologicalMap, load_topological_map

REPO = Path(__file__).resolve().parents[2]
ISR_TOPO = REPO / "maps" / "isr_floor0_topo.yaml"
SQUARE = [[7.0, 2.0], [10.0, 2.0], [10.0, 5.0], [7.0, 5.0]]
NODES = [
    {"id": 0, "name": "Entrance", "x": 1.0, "y": 1.0, "yaw": 0.0, "tour": True, "home": True,
     "area": [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]], "name_pt": "Entrada"},
    {"id": 1, "name": "Corner", "x": 5.0, "y": 1.0, "yaw": 0.0, "area": [],
     "name_pt": "Canto"},
    {"id": 2, "name": "Lab door", "x": 8.0, "y": 1.0, "yaw": 1.57, "area": SQUARE},
    {"id": 3, "name": "Lab", "x": 8.5, "y": 3.5, "yaw": 1.57, "info": "Robots.", "tour": True,
     "requests": True, "area": SQUARE, "name_pt": "Laboratório", "info_pt": "Robôs."},
    {"id": 4, "name": "Office", "x": 3.0, "y": 4.0, "yaw": 3.14, "kind": "entrance",
     "area": [[2.0, 3.0], [5.0, 3.0], [5.0, 5.0], [2.0, 5.0]]},
    {"id": 5, "name": "Hall", "x": 20.0, "y": 20.0, "yaw": 0.0},
    {"id": 6, "name": "Bend", "x": 12.0, "y": 1.0, "yaw": 0.0, "kind": "waypoint"},
]  # fmt: skip


def build(nodes: list[dict[str, object]]) -> tuple[TopologicalMap, dict[str, object]]:
    raw: dict[str, object] = {"nodes": nodes}
    return TopologicalMap.from_dict(raw, source="t.yaml"), raw


@pytest.fixture(scope="module")
def isr() -> tuple[TopologicalMap, object]:
    topo = load_topological_map(ISR_TOPO)
    return topo, load_room_map(ISR_TOPO, topo)


def test_rooms_waypoints_shared_areas_and_default_squares() -> None:
    rooms = room_map(*build(NODES))
    assert [r.id for r in rooms.rooms] == [0, 3, 4, 5]  # 1 and 6 are waypoints
    lab = rooms.room(2)  # the door node is drawn as the lab; the lab's own node is 3
    assert lab.id == 3 and lab.node_ids == (3, 2) and lab.covers(2) and not lab.covers(4)
    assert lab.bounds() == (7.0, 2.0, 10.0, 5.0) and lab.requests and lab.explicit
    hall = rooms.room(5)
    assert not hall.explicit and hall.bounds() == pytest.approx(
        (20.0 - DEFAULT_ROOM_SIZE / 2, 20.0 - DEFAULT_ROOM_SIZE / 2, 21.0, 21.0)
    )
    assert not rooms.in_a_room(1) and not rooms.in_a_room(6) and rooms.in_a_room(2)
    with pytest.raises(KeyError, match=r"node 1 is in no room of t\.yaml"):
        rooms.room(1)
    assert rooms.name(4) == "Office" and rooms.name(42) == "#42" and rooms.name(None) == "?"
    assert rooms.node_xy(2) == (8.0, 1.0) and rooms.node_xy(99) is None
    assert rooms.topo.home_id == 0


def test_the_own_node_prefers_requests_then_tour_then_inside_then_lowest_id() -> None:
    def own(*flags: dict[str, object]) -> int:
        nodes = [
            {"id": i, "name": f"n{i}", "x": 8.0, "y": 3.0, "yaw": 0.0, "area": SQUARE, **f}
            for i, f in enumerate(flags)
        ]
        return room_map(*build(nodes)).rooms[0].id

    assert own({}, {"requests": True}, {"tour": True}) == 1
    assert own({}, {"kind": "inside"}, {"tour": True}) == 2
    assert own({}, {"kind": "inside"}) == 1
    assert own({}, {}) == 0


def test_translations_for_rooms_and_for_nodes_that_are_not_rooms() -> None:
    rooms = room_map(*build(NODES)).in_language("pt")
    lab = rooms.room(3)
    assert (lab.name, lab.info) == ("Laboratório", "Robôs.")
    assert rooms.room(4).name == "Office"  # no name_pt: English
    assert rooms.name(1) == "Canto" and rooms.language == "pt"
    assert rooms.in_language("en").room(3).name == "Lab"


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"area": [[2.0, 3.0], [5.0]]}, r"t.yaml: node 4: area\[1\] must be an array of 2"),
        (
            {"area": [[2.0, 3.0], [5.0, 3.0]]},
            r"t.yaml: node 4: area must be \[\] or a list of at "
            r"least 3 \[x, y\] points \[m\], got 2",
        ),
        ({"area": [[0, 0], [1, 0], [1, "a"]]}, r"t.yaml: node 4: area\[2\]\[1\] must be a number"),
        ({"area": [[0, 0], [1, 0], [1, math.nan]]}, r"node 4: area\[2\]\[1\] must be a finite"),
        ({"kind": "door"}, r"node 4: kind must be one of entrance, inside, waypoint; got 'door'"),
        ({"name_pt": 3}, r"node 4: name_pt must be a string, got 3"),
        ({"info_pt": "x" * 1001}, r"node 4: info_pt has 1001 characters; at most 1000 are"),
    ],
)
def test_bad_room_keys_name_the_file_node_and_key(change: dict[str, object], message: str) -> None:
    nodes = [dict(n) for n in NODES]
    nodes[4].update(change)
    with pytest.raises(RoomMapError, match=message):
        room_map(*build(nodes))


def test_load_room_map_reads_the_file_and_names_it(tmp_path: Path) -> None:
    path = tmp_path / "topo.yaml"
    path.write_text(yaml.safe_dump({"map": "floor.yaml", "nodes": NODES}), encoding="utf-8")
    rooms = load_room_map(path)
    assert rooms.topo.map_yaml_path == tmp_path / "floor.yaml" and rooms.topo.source == str(path)
    path.write_text(path.read_text(encoding="utf-8").replace("kind: entrance", "kind: 7"))
    with pytest.raises(RoomMapError, match=r"topo.yaml: node 4: kind must be one of"):
        load_room_map(path)


def test_a_click_selects_the_room_it_lands_in_else_a_node_within_the_snap_radius() -> None:
    rooms = room_map(*build(NODES))
    hit = rooms.room_at(8.0, 4.0)
    assert hit is not None and hit.id == 3
    assert rooms.room_at(8.0, 1.0) is None  # the lab's door node, in the corridor
    door = rooms.room_at(8.0, 1.3, snap_radius=1.5)
    assert door is not None and door.id == 3  # snaps to the door node: the lab
    assert rooms.room_at(12.0, 1.0, snap_radius=1.5) is None  # a waypoint never snaps
    assert rooms.room_at(500.0, 500.0, snap_radius=1.5) is None


def test_isr_rooms_map_to_their_own_nodes(isr) -> None:
    topo, rooms = isr
    assert len(rooms.rooms) >= 10 and all(r.explicit for r in rooms.rooms)
    shared = rooms.room(6)  # the shared experimental area's door: its room is node 7
    assert shared.id == 7 and shared.node_ids == (7, 6) and shared.requests
    cx, cy = polygon_centroid(shared.area)
    assert rooms.room_at(cx, cy).id == 7
    for room in rooms.rooms:  # one own node per outline, each the room's requests/tour node
        for other in room.node_ids[1:]:
            node = topo.nodes[other]
            assert not node.requests and not (node.tour and not topo.nodes[room.id].tour)
    assert not rooms.in_a_room(1)  # SW corner


def test_isr_labels_sit_on_clear_floor_in_their_room_and_a_click_there_selects_it(isr) -> None:
    _, rooms = isr
    grid = load_map(REPO / "maps" / "isr_floor0.yaml")
    labelled = rooms.with_labels(grid)
    for room in labelled.rooms:
        x, y = room.label
        assert room.contains(x, y), room.name
        assert labelled.room_at(x, y).id == room.id  # the click target
        row, col = grid.world_to_cell(x, y)
        r, c = int(row), int(col)
        patch = grid.cells[r - 4 : r + 5, c - 4 : c + 5]  # 0.4 m around the label's centre
        assert (patch == FREE).all(), f"{room.name!r} sits on something at {x, y}"
    xy = np.array([room.label for room in labelled.rooms])
    gaps = np.hypot(*(xy[:, None, :] - xy[None, :, :]).transpose(2, 0, 1))
    assert gaps[np.triu_indices(len(xy), 1)].min() >= 1.5  # labels stay apart


def test_point_in_polygon_square() -> None:
    square = [(0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (0.0, 2.0)]
    assert point_in_polygon(1.0, 1.0, square)
    assert not point_in_polygon(3.0, 1.0, square)
    assert not point_in_polygon(1.0, -0.1, square)


@settings(max_examples=100)
@given(x=st.floats(-5, 5), y=st.floats(-5, 5), dx=st.floats(-3, 3), dy=st.floats(-3, 3))
def test_point_in_polygon_matches_rectangle_test(x: float, y: float, dx: float, dy: float) -> None:
    rect = [(dx, dy), (dx + 2, dy), (dx + 2, dy + 1), (dx, dy + 1)]
    inside = dx < x < dx + 2 and dy < y < dy + 1
    on_edge = any(math.isclose(a, b) for a, b in ((x, dx), (x, dx + 2), (y, dy), (y, dy + 1)))
    if not on_edge:
        assert point_in_polygon(x, y, rect) == inside


def test_polygon_centroid_of_an_l_shape_and_a_degenerate_polygon() -> None:
    ell = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 1.0), (1.0, 2.0), (0.0, 2.0)]
    assert polygon_centroid(ell) == pytest.approx((5 / 6, 5 / 6))
    assert polygon_centroid(list(reversed(ell))) == pytest.approx((5 / 6, 5 / 6))
    assert polygon_centroid([(0.0, 0.0), (1.0, 1.0), (2.0, 2.0)]) == pytest.approx((1.0, 1.0))
