"""The Tablet's start-up: its rooms from the topological map (`interbot_core.rooms`, the model
the station uses too) and its command line."""

from __future__ import annotations

from pathlib import Path

import pytest

from interbot_core.rooms import RoomMapError
from tablet_app.main import DEFAULT_TOPO, load_plan, parse_args


def test_rooms_and_floor_image_of_the_fixture(topo_path: Path) -> None:
    plan, grid = load_plan(topo_path)
    assert [room.id for room in plan.rooms] == [0, 3, 4]
    assert plan.room(2).id == 3  # the lab's door is drawn as the lab
    assert plan.topo.map_yaml_path is not None and plan.topo.map_yaml_path.name == "floor.yaml"
    assert grid is not None and plan.bounds() == (0.0, 0.0, 10.0, 5.0)


def test_bad_area_names_the_file_and_node(topo_path: Path) -> None:
    text = topo_path.read_text(encoding="utf-8").replace(
        "area: [[2.0, 3.0], [5.0, 3.0], [5.0, 5.0], [2.0, 5.0]]", "area: [[2.0, 3.0], [5.0]]"
    )
    topo_path.write_text(text, encoding="utf-8")
    with pytest.raises(RoomMapError, match=r"topo.yaml: node 4: area\[1\] must be an array"):
        load_plan(topo_path)


def test_the_shipped_isr_map_loads_when_present() -> None:
    if not DEFAULT_TOPO.exists():
        pytest.skip(f"{DEFAULT_TOPO} not generated yet")
    plan, _ = load_plan(DEFAULT_TOPO)
    assert len(plan.rooms) >= 10
    assert all(room.explicit for room in plan.rooms)


def test_command_line_defaults() -> None:
    args = parse_args([])
    assert (args.host, args.port, args.windowed, args.lang) == ("127.0.0.1", 5555, False, "en")
    args = parse_args(["--host", "10.0.0.2", "--port", "6000", "--windowed", "--lang", "pt"])
    assert (args.host, args.port, args.windowed, args.lang) == ("10.0.0.2", 6000, True, "pt")
    with pytest.raises(SystemExit):
        parse_args(["--port", "0"])
