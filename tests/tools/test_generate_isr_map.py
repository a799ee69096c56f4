"""Tests of the floor plan, its rasterisation and the ISR floor 0 maps generated from it."""

from __future__ import annotations

import copy
import importlib.util
import itertools
import math
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage
from scipy.sparse.csgraph import connected_components, shortest_path

from interbot_core.occupancy_grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid, load_map
from interbot_core.topological_map import load_topological_map
from robot_daemon.sim.floor_plan import (
    FloorPlan,
    FloorPlanError,
    load_floor_plan,
    parse_floor_plan,
    rasterise,
)

REPO = Path(__file__).resolve().parents[2]
PLAN_PATH = REPO / "maps" / "isr_floor0_plan.yaml"
TOPO_PATH = REPO / "maps" / "isr_floor0_topo.yaml"
REQUIRED_ROOMS = {
    "Main Entrance",
    "ISR Shared Experimental Area",
    "Mecatronics Lab",
    "Library",
    "Bar",
}
ROBOT_WIDTH = 0.55  # [m]
ARC_INFLATION = 0.3  # [m]
NODE_CLEARANCE = 0.35  # [m]


@pytest.fixture(scope="module")
def raw_plan() -> dict[str, Any]:
    data = yaml.safe_load(PLAN_PATH.read_text(encoding="utf-8"))
    assert isinstance(data, dict)
    return data


@pytest.fixture(scope="module")
def plan() -> FloorPlan:
    return load_floor_plan(PLAN_PATH)


@pytest.fixture(scope="module")
def grid(plan: FloorPlan) -> OccupancyGrid:
    return rasterise(plan)


@pytest.fixture(scope="module")
def topo(plan: FloorPlan, grid: OccupancyGrid) -> dict[str, Any]:
    return topological_map_dict(plan, grid)


def load_generator() -> ModuleType:
    """The authoring tool, loaded by its path (tools/ is not a package)."""
    spec = importlib.util.spec_from_file_location(
        "generate_isr_map", REPO / "tools" / "generate_isr_map.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


GENERATOR = load_generator()
topological_map_dict = GENERATOR.topological_map_dict
door_openings = GENERATOR.door_openings


@pytest.fixture(scope="module")
def generator() -> ModuleType:
    return GENERATOR


def inflated_reference(grid: OccupancyGrid, radius: float) -> np.ndarray:
    """Blocked cells dilated by a disk of ``radius`` [m]: the readable reference for arcs."""
    r = math.floor(radius / grid.resolution + 1e-9)
    yy, xx = np.mgrid[-r : r + 1, -r : r + 1]
    disk = (xx**2 + yy**2) * grid.resolution**2 <= radius**2 + 1e-12
    return np.asarray(ndimage.binary_dilation(grid.blocked(), structure=disk), dtype=bool)


def brute_clearance(grid: OccupancyGrid, x: float, y: float, search: float = 2.0) -> float:
    """Distance [m] from (x, y) to the nearest blocked cell centre, by direct search."""
    row, col = (int(v) for v in grid.world_to_cell(x, y))
    n = int(search / grid.resolution)
    r0, r1 = max(row - n, 0), min(row + n + 1, grid.height)
    c0, c1 = max(col - n, 0), min(col + n + 1, grid.width)
    rows, cols = np.nonzero(grid.blocked()[r0:r1, c0:c1])
    if rows.size == 0:
        return search
    bx, by = grid.cell_to_world(rows + r0, cols + c0)
    return float(np.min(np.hypot(bx - x, by - y)))


def sample_segment(
    a: tuple[float, float], b: tuple[float, float], step: float = 0.01
) -> tuple[np.ndarray, np.ndarray]:
    n = max(2, math.ceil(math.hypot(b[0] - a[0], b[1] - a[1]) / step) + 1)
    t = np.linspace(0.0, 1.0, n)
    return a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])


def rooms_of(data: dict[str, Any], name: str) -> dict[str, Any]:
    for room in data["rooms"]:
        if room["name"] == name:
            return room  # type: ignore[no-any-return]
    raise AssertionError(name)


# ------------------------------------------------------------------------------ the plan


def test_plan_loads_with_the_required_rooms(plan: FloorPlan) -> None:
    names = {room.name for room in plan.rooms}
    assert len(plan.rooms) >= 15
    assert names >= REQUIRED_ROOMS
    assert [room.name for room in plan.rooms if room.home] == ["Main Entrance"]
    assert {room.name for room in plan.rooms if room.requests} == {
        "ISR Shared Experimental Area",
        "Mecatronics Lab",
    }
    assert all(room.doors for room in plan.rooms)
    assert all(0.9 <= door.width <= 1.2 for room in plan.rooms for door in room.doors)
    assert sum(len(room.furniture) for room in plan.rooms) >= 30


def test_corridors_form_a_loop_of_two_long_parallel_corridors(plan: FloorPlan) -> None:
    corridors = {c.name: c.rect for c in plan.corridors}
    south, north = corridors["South corridor"], corridors["North corridor"]
    west, east = corridors["West corridor"], corridors["East corridor"]
    for long in (south, north):
        assert long.width > 60.0 and 2.0 <= long.height <= 2.5
    for end in (west, east):
        assert 2.0 <= end.width <= 2.5
        assert end.overlaps(south) and end.overlaps(north)


MUTATIONS: list[tuple[str, Any, str]] = [
    (
        "door too narrow",
        lambda d: rooms_of(d, "Bar")["doors"][0].update(width=0.7),
        r"room 'Bar': rooms\[\d+\]\.doors\[0\]\.width = 0\.7 m is outside the allowed range \[0\.9, 1\.2\] m",
    ),
    (
        "door in an unknown wall",
        lambda d: rooms_of(d, "Library")["doors"][0].update(wall="up"),
        r"room 'Library': rooms\[\d+\]\.doors\[0\]\.wall must be one of north, south, east, west; got 'up'",
    ),
    (
        "door facing no corridor",
        lambda d: rooms_of(d, "Library")["doors"][0].update(wall="north"),
        r"room 'Library' doors\[0\]: the north wall .* does not open onto a corridor",
    ),
    (
        "door beyond the wall's end",
        lambda d: rooms_of(d, "Bar")["doors"][0].update(offset=8.5),
        r"room 'Bar' doors\[0\]: 'offset' 8.5 puts the door outside the south wall",
    ),
    (
        "furniture outside the room",
        lambda d: rooms_of(d, "Bar")["furniture"].append(
            {"name": "sofa", "x": [-3.5, -2.0], "y": [15, 16]}
        ),
        r"room 'Bar' furniture\[4\] \(sofa\): 'x'/'y' must lie inside the room",
    ),
    (
        "furniture blocking a door",
        lambda d: rooms_of(d, "Bar")["furniture"].append(
            {"name": "crate", "x": [-6.5, -5.5], "y": [13.0, 13.5]}
        ),
        r"room 'Bar' furniture\[4\] \(crate\): blocks doors\[0\]",
    ),
    (
        "rooms overlapping",
        lambda d: rooms_of(d, "Bar").update(x=[-12.0, -3.0]),
        r"room 'Computer Vision Lab': 'x'/'y' overlap room 'Bar'",
    ),
    (
        "room outside the building",
        lambda d: rooms_of(d, "Library").update(x=[-34.5, -22.0]),
        r"room 'Library': 'x'/'y' lie outside the building outline",
    ),
    (
        "inverted rectangle",
        lambda d: rooms_of(d, "Bar").update(y=[19.8, 12.8]),
        r"room 'Bar': 'x'/'y': rectangle needs x_min < x_max and y_min < y_max",
    ),
    (
        "missing field",
        lambda d: rooms_of(d, "Bar").pop("x"),
        r"room 'Bar': rooms\[\d+\]\.x is missing",
    ),
    (
        "non-numeric field",
        lambda d: rooms_of(d, "Bar")["doors"][0].update(offset="middle"),
        r"room 'Bar': rooms\[\d+\]\.doors\[0\]\.offset must be a number, got 'middle'",
    ),
    (
        "request room without an inside node",
        lambda d: rooms_of(d, "Mecatronics Lab").pop("inside"),
        r"room 'Mecatronics Lab': a room with requests: true needs 'inside",
    ),
    (
        "duplicate room name",
        lambda d: rooms_of(d, "Bar").update(name="Library"),
        r"room 'Library': the name is used twice",
    ),
    (
        "two homes",
        lambda d: rooms_of(d, "Bar").update(home=True),
        r"exactly one room needs home: true",
    ),
    (
        "misspelt field",
        lambda d: rooms_of(d, "Bar").update(furnitur=[]),
        r"room 'Bar': unknown key 'rooms\[\d+\]\.furnitur' \(allowed: x, y, name, doors, furniture",
    ),
    (
        "flag not a boolean",
        lambda d: rooms_of(d, "Bar").update(tour="yes"),
        r"room 'Bar': rooms\[\d+\]\.tour must be true or false, got 'yes'",
    ),
    (
        "unknown node in the ring",
        lambda d: d["ring"].append("Cafeteria"),
        r"ring\[\d+\]: 'Cafeteria' is not a node",
    ),
    (
        "node missing from the ring",
        lambda d: d["ring"].remove("Bar"),
        r"ring: missing nodes \['Bar'\]",
    ),
    (
        "unknown node in an arc",
        lambda d: d["arcs"].append(["Bar", "Kitchen"]),
        r"arcs\[4\]: 'Kitchen' is not a node",
    ),
]


@pytest.mark.parametrize(
    ("mutate", "message"), [m[1:] for m in MUTATIONS], ids=[m[0] for m in MUTATIONS]
)
def test_validation_errors_name_the_room_and_field(
    raw_plan: dict[str, Any], mutate: Any, message: str
) -> None:
    data = copy.deepcopy(raw_plan)
    mutate(data)
    with pytest.raises(FloorPlanError, match=message) as info:
        # The plan's reader checks the building; the tool checks the node lists it maps.
        topological_map_dict(parse_floor_plan(data, "plan.yaml"))
    assert str(info.value).startswith("plan.yaml: ")


def test_arc_through_a_wall_is_rejected_with_its_names(raw_plan: dict[str, Any]) -> None:
    data = copy.deepcopy(raw_plan)
    data["arcs"].append(["Secretariat", "Library"])
    plan = parse_floor_plan(data, "plan.yaml")
    with pytest.raises(FloorPlanError, match=r"arcs\[4\]: 'Secretariat' -> 'Library' passes"):
        topological_map_dict(plan)


def test_node_on_furniture_is_rejected(raw_plan: dict[str, Any]) -> None:
    data = copy.deepcopy(raw_plan)
    rooms_of(data, "Mecatronics Lab")["inside"] = {"x": 2.3, "y": 15.0}  # 0.2 m from a bench
    plan = parse_floor_plan(data, "plan.yaml")
    with pytest.raises(FloorPlanError, match=r"node 12 \('Mecatronics Lab'\) .* clearance"):
        topological_map_dict(plan)


def test_disconnected_graph_is_rejected(raw_plan: dict[str, Any]) -> None:
    data = copy.deepcopy(raw_plan)
    data["arcs"] = [chain for chain in data["arcs"] if "Mecatronics Lab" not in chain]
    plan = parse_floor_plan(data, "plan.yaml")
    with pytest.raises(FloorPlanError, match=r"nodes \['Mecatronics Lab'\] cannot be reached"):
        topological_map_dict(plan)


def test_load_floor_plan_names_a_missing_file(tmp_path: Path) -> None:
    with pytest.raises(FloorPlanError, match=r"nope\.yaml: cannot read the floor plan"):
        load_floor_plan(tmp_path / "nope.yaml")


# ------------------------------------------------------------------------------ the grid


def test_grid_has_the_isr_frame(grid: OccupancyGrid) -> None:
    assert (grid.width, grid.height) == (1400, 700)
    assert grid.resolution == pytest.approx(0.05)
    assert (grid.origin_x, grid.origin_y) == (pytest.approx(-35.0), pytest.approx(-14.25))
    assert grid.size_m == (pytest.approx(70.0), pytest.approx(35.0))
    # Outside the building is unknown, the outline occupied, the corridors free.
    assert grid.cells[0, 0] == UNKNOWN and grid.cells[-1, -1] == UNKNOWN
    row, col = grid.world_to_cell(-33.9, 0.0)
    assert grid.cells[int(row), int(col)] == OCCUPIED
    assert grid.is_free(-29.2, 3.0) and grid.is_free(0.0, -4.0) and grid.is_free(20.0, 11.4)
    assert set(np.unique(grid.cells).tolist()) == {UNKNOWN, FREE, OCCUPIED}


def test_walls_are_between_015_and_02_m_thick(grid: OccupancyGrid) -> None:
    # Scan up the line x = 15 (Mobile Robotics Lab, south corridor, courtyard, north corridor).
    row, col = grid.world_to_cell(15.0, -13.0)
    column = grid.cells[int(row) :, int(col)]
    runs = []
    count = 0
    for value in column:
        if value == OCCUPIED:
            count += 1
        elif count:
            runs.append(count * grid.resolution)
            count = 0
    corridor_walls = [r for r in runs if r < 0.5]
    assert corridor_walls and all(0.15 <= r <= 0.2 + 1e-9 for r in corridor_walls)


def test_every_door_is_passable(plan: FloorPlan, grid: OccupancyGrid) -> None:
    inflated = inflated_reference(grid, ROBOT_WIDTH / 2)
    for opening in door_openings(plan):
        label = f"{opening.room} doors[{opening.index}]"
        nx, ny = opening.normal
        # Free width across the middle of the wall, along the wall.
        mid_x = (opening.room_face[0] + opening.corridor_face[0]) / 2
        mid_y = (opening.room_face[1] + opening.corridor_face[1]) / 2
        row, col = (int(v) for v in grid.world_to_cell(mid_x, mid_y))
        line = grid.cells[row, :] if nx == 0 else grid.cells[:, col]
        centre = col if nx == 0 else row
        lo = hi = centre
        while line[lo - 1] == FREE:
            lo -= 1
        while line[hi + 1] == FREE:
            hi += 1
        assert (hi - lo + 1) * grid.resolution >= 0.9 - 1e-9, label
        # A 0.55 m robot drives straight through: 1 m in front of the corridor face to
        # 1 m inside the room, nothing within half its width.
        start = (opening.corridor_face[0] + nx * 1.0, opening.corridor_face[1] + ny * 1.0)
        end = (opening.room_face[0] - nx * 1.0, opening.room_face[1] - ny * 1.0)
        xs, ys = sample_segment(start, end)
        rows, cols = grid.world_to_cell(xs, ys)
        assert not inflated[rows, cols].any(), label


@settings(max_examples=25, deadline=None)
@given(
    width_cells=st.integers(18, 24),
    offset_cells=st.integers(40, 120),
)
def test_door_opening_is_as_wide_as_declared(
    raw_plan: dict[str, Any], width_cells: int, offset_cells: int
) -> None:
    """Any valid door of the Embedded Systems Lab rasterises to exactly its width."""
    data = copy.deepcopy(raw_plan)
    room = rooms_of(data, "Embedded Systems Lab")
    width, offset = width_cells * 0.05, offset_cells * 0.05
    room["doors"] = [{"wall": "south", "offset": offset, "width": width}]
    room["furniture"] = []
    plan = parse_floor_plan(data, "plan.yaml")
    cells = rasterise(plan)
    row, _ = cells.world_to_cell(0.0, 12.7)  # inside the wall between corridor and room
    c0 = math.floor((10.2 + offset - width / 2 + 35.0) / 0.05 + 0.5 + 1e-6)
    wall_row = cells.cells[int(row), c0 - 5 : c0 + width_cells + 5]
    free_run = np.flatnonzero(wall_row == FREE)
    assert free_run.size == width_cells
    assert free_run[0] == 5 and np.all(np.diff(free_run) == 1)


def test_rasterise_is_deterministic(plan: FloorPlan, grid: OccupancyGrid) -> None:
    assert np.array_equal(rasterise(plan).cells, grid.cells)


# ------------------------------------------------------------------------------ topology


def test_nodes_lie_in_free_space_with_clearance(topo: dict[str, Any], grid: OccupancyGrid) -> None:
    for node in topo["nodes"]:
        assert grid.is_free(node["x"], node["y"]), node["name"]
        assert brute_clearance(grid, node["x"], node["y"]) >= NODE_CLEARANCE, node["name"]


def test_arcs_are_collision_free(topo: dict[str, Any], grid: OccupancyGrid) -> None:
    inflated = inflated_reference(grid, ARC_INFLATION)
    nodes = topo["nodes"]
    for u, v in topo["arcs"]:
        xs, ys = sample_segment((nodes[u]["x"], nodes[u]["y"]), (nodes[v]["x"], nodes[v]["y"]))
        rows, cols = grid.world_to_cell(xs, ys)
        assert not inflated[rows, cols].any(), f"arc {nodes[u]['name']} - {nodes[v]['name']}"


def weights(topo: dict[str, Any]) -> np.ndarray:
    nodes = topo["nodes"]
    n = len(nodes)
    w = np.zeros((n, n))
    for u, v in topo["arcs"]:
        w[u, v] = w[v, u] = math.hypot(nodes[u]["x"] - nodes[v]["x"], nodes[u]["y"] - nodes[v]["y"])
    return w


def test_graph_is_connected(topo: dict[str, Any]) -> None:
    count, _ = connected_components(weights(topo), directed=False)
    assert count == 1


def test_entrance_nodes_face_their_door_from_the_corridor(
    plan: FloorPlan, topo: dict[str, Any], grid: OccupancyGrid
) -> None:
    openings = {o.room: o for o in door_openings(plan) if o.index == 0}
    entrances = [n for n in topo["nodes"] if n["kind"] == "entrance"]
    assert len(entrances) == len(plan.rooms)
    corridors = [c.rect for c in plan.corridors]
    for node in entrances:
        door = openings[node["room"]]
        dx, dy = door.corridor_face[0] - node["x"], door.corridor_face[1] - node["y"]
        assert 0.8 <= math.hypot(dx, dy) <= 1.0, node["name"]
        assert math.cos(node["yaw"] - math.atan2(dy, dx)) > math.cos(math.radians(1)), node["name"]
        assert any(c.contains_point(node["x"], node["y"]) for c in corridors), node["name"]


def test_request_nodes_are_inside_their_rooms(plan: FloorPlan, topo: dict[str, Any]) -> None:
    requests = [n for n in topo["nodes"] if n["requests"]]
    assert {n["name"] for n in requests} == {"ISR Shared Experimental Area", "Mecatronics Lab"}
    for node in requests:
        assert node["kind"] == "inside" and node["tour"]
        room = plan.room(node["name"])
        assert room.rect.contains_point(node["x"], node["y"])
        assert node["area"] == room.rect.polygon()


def test_node_order_and_flags(topo: dict[str, Any]) -> None:
    nodes = topo["nodes"]
    assert [n["id"] for n in nodes] == list(range(len(nodes)))
    assert nodes[0]["name"] == "Main Entrance" and nodes[0]["home"]
    assert sum(n["home"] for n in nodes) == 1
    rooms = {n["room"] for n in nodes if n["room"] is not None}
    assert len(rooms) >= 15 and rooms >= REQUIRED_ROOMS
    assert 18 <= len(nodes) <= 30
    for node in nodes:
        if node["kind"] == "waypoint":
            assert node["area"] == [] and not node["tour"]
        else:
            assert len(node["area"]) == 4


def test_guided_tour_circulates_in_id_order(topo: dict[str, Any]) -> None:
    """Consecutive tour stops are near each other along the loop and the tour is ~200 m."""
    dist = shortest_path(weights(topo), directed=False)
    stops = [n["id"] for n in topo["nodes"] if n["tour"]]
    assert stops[0] == 0 and len(stops) >= 12
    legs = [dist[a, b] for a, b in zip(stops, [*stops[1:], 0], strict=True)]
    assert max(legs) < 40.0
    assert 180.0 <= sum(legs) <= 260.0
    # In ring order the tour is much shorter than visiting the same stops in a shuffled order.
    shuffled = np.random.default_rng(7).permutation(stops[1:])
    order = [0, *shuffled.tolist(), 0]
    assert sum(dist[a, b] for a, b in itertools.pairwise(order)) > 1.5 * sum(legs)


# ------------------------------------------------------------------------------ generated files


def test_committed_files_equal_a_fresh_generation(generator: ModuleType) -> None:
    assert generator.stale_files(PLAN_PATH) == []


def test_check_reports_a_stale_file(generator: ModuleType, tmp_path: Path) -> None:
    plan_copy = tmp_path / PLAN_PATH.name
    plan_copy.write_bytes(PLAN_PATH.read_bytes())
    assert generator.main([str(plan_copy), "--check"]) == 1
    assert generator.main([str(plan_copy)]) == 0
    assert generator.main([str(plan_copy), "--check"]) == 0
    (tmp_path / "isr_floor0_topo.yaml").write_text("map: x\n", encoding="utf-8")
    assert generator.stale_files(plan_copy) == ["isr_floor0_topo.yaml"]


def test_generated_files_load_with_the_project_loaders(
    grid: OccupancyGrid, topo: dict[str, Any]
) -> None:
    loaded = load_map(REPO / "maps" / "isr_floor0.yaml")
    assert np.array_equal(loaded.cells, grid.cells)
    topological = load_topological_map(TOPO_PATH)
    assert topological.map_yaml_path == (REPO / "maps" / "isr_floor0.yaml").resolve()
    assert len(topological.nodes) == len(topo["nodes"])
    assert topological.home_id == 0
    assert {n.name for n in topological.request_nodes()} == {
        "ISR Shared Experimental Area",
        "Mecatronics Lab",
    }
    assert {n.name for n in topological.nodes} >= REQUIRED_ROOMS
