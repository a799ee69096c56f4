"""Rooms of the Tablet's map read from a topological-map YAML with ``area`` outlines."""

from __future__ import annotations

from pathlib import Path

import pytest

from tablet_app.floor_plan import FloorPlanError, load_floor_plan
from tablet_app.main import DEFAULT_TOPO, parse_args


def test_rooms_areas_waypoints_and_shared_areas(topo_path: Path) -> None:
    plan = load_floor_plan(topo_path)
    assert [room.id for room in plan.touch_rooms()] == [0, 3, 4]
    lab = plan.room(3)
    assert lab.node_ids == (3, 2) and lab.covers(2) and not lab.covers(4)
    assert lab.bounds() == (7.0, 2.0, 10.0, 5.0)
    assert not plan.room(1).touchable  # area: [] is a corridor waypoint
    assert plan.map_yaml is not None and plan.map_yaml.name == "floor.yaml"
    assert plan.bounds() == (0.0, 0.0, 10.0, 5.0)
    assert plan.name(4) == "Office" and plan.name(42) == "#42"


def test_bad_area_names_the_file_and_node(topo_path: Path) -> None:
    text = topo_path.read_text(encoding="utf-8").replace(
        "area: [[2.0, 3.0], [5.0, 3.0], [5.0, 5.0], [2.0, 5.0]]", "area: [[2.0, 3.0], [5.0]]"
    )
    topo_path.write_text(text, encoding="utf-8")
    with pytest.raises(FloorPlanError, match=r"topo.yaml: node 4: 'area'"):
        load_floor_plan(topo_path)


def test_the_shipped_isr_map_loads_when_present() -> None:
    if not DEFAULT_TOPO.exists():
        pytest.skip(f"{DEFAULT_TOPO} not generated yet")
    plan = load_floor_plan(DEFAULT_TOPO)
    rooms = plan.touch_rooms()
    assert len(rooms) >= 10
    assert all(room.area for room in rooms)


def test_command_line_defaults() -> None:
    args = parse_args([])
    assert (args.host, args.port, args.windowed, args.lang) == ("127.0.0.1", 5555, False, "en")
    args = parse_args(["--host", "10.0.0.2", "--port", "6000", "--windowed", "--lang", "pt"])
    assert (args.host, args.port, args.windowed, args.lang) == ("10.0.0.2", 6000, True, "pt")
    with pytest.raises(SystemExit):
        parse_args(["--port", "0"])
