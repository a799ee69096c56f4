"""The guided tour's headline, guarded: on the realistic world (a building that is not the map,
people about, the initial pose set by hand) a short tour completes with no collision and no
localisation loss; and the tour graphs shipped for the two real buildings are drivable."""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import pytest
import yaml

from interbot_core.occupancy_grid import load_map
from interbot_core.topological_map import load_topological_map
from robot_daemon.config import DEFAULT_MAP, DEFAULT_TOPO
from robot_daemon.planning.bottleneck import free_width, widest_way
from robot_daemon.planning.config import PlannerConfig
from robot_daemon.planning.costmap import Costmap
from robot_daemon.planning.global_planner import GlobalPlanner
from robot_daemon.scenarios import tour
from robot_daemon.scenarios.runner import ScenarioOptions

REPO = Path(__file__).resolve().parents[3]
REAL_GRAPHS = {
    "willow": REPO / "maps" / "willow_topo.yaml",
    "fetch_office": REPO / "maps" / "fetch_office_topo.yaml",
}
SHORT_TOUR_STOPS = ("Secretariat", "Restrooms")  # the Restrooms' wall is glass (seed 1)


def _reduced_topo(tmp_path: Path, stops: tuple[str, ...]) -> Path:
    """The ISR graph with only ``stops`` (and home) as tour stops."""
    data: dict[str, Any] = yaml.safe_load(DEFAULT_TOPO.read_text())
    data["map"] = str(DEFAULT_MAP)
    for node in data["nodes"]:
        node["tour"] = node["name"] in stops
    path = tmp_path / "isr_short_tour.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.fixture(scope="module")
def short_tour(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    topo = _reduced_topo(tmp_path_factory.mktemp("tour"), SHORT_TOUR_STOPS)
    options = ScenarioOptions(topo_yaml=topo, seed=1, people=3, max_sim_time=300.0)
    figures = tour.run(options).figures
    print(figures)  # shown by pytest when a test fails
    return figures


def test_short_realistic_tour_completes_without_collision_or_loss(
    short_tour: dict[str, Any],
) -> None:
    f = short_tour
    assert f["completed"], f["reason"]
    assert f["stops_visited"] == f["stops_total"] == len(SHORT_TOUR_STOPS)
    assert f["collisions"] == 0
    assert f["localisation_losses"] == 0
    assert f["loc_silent_failures"] == 0
    assert f["world"] == "realistic"


def test_short_realistic_tour_is_never_silently_lost(short_tour: dict[str, Any]) -> None:
    """While the localiser reports ok its error stays under issue 12's 0.3 m (the start pose
    was set by hand up to 0.3 m / 10 degrees off); the robot never touched anything."""
    assert short_tour["loc_max_m"] < 0.3
    assert short_tour["loc_heading_max_deg"] < 10.0
    assert short_tour["min_clearance_m"] > 0.0


def test_short_realistic_tour_splits_its_error_into_the_map_s_and_the_localiser_s(
    short_tour: dict[str, Any],
) -> None:
    """The world-frame error over the reference's samples is at most the map's own error (a
    perfect matcher's, `map_echo`) plus the localiser's relative to it (RMS: Minkowski); the
    realistic world moves rooms by centimetres, so the map's share is not zero."""
    f = short_tour
    assert f["loc_echo_samples"] >= 0.1 * f["duration_s"]  # one every 0.5 s while ok
    assert f["loc_sub_rms_m"] <= f["loc_echo_rms_m"] + f["loc_own_rms_m"] + 1e-4
    assert f["loc_echo_rms_m"] > 0.005
    assert f["loc_own_max_m"] < 0.3 and f["loc_echo_max_m"] < 0.3


def test_short_realistic_tour_learns_that_the_plan_drawn_map_has_walls_on_faces(
    short_tour: dict[str, Any],
) -> None:
    """The ISR map is rasterised from a floor plan: the localiser, started with the daemon's
    ``map_surface: learn`` (through the cell centres), learns within a few metres that the
    walls lie on the cell faces, from the realistic world's scans, and the figures say so."""
    f = short_tour
    assert f["loc_wall_model"] == "cell_face"
    assert f["loc_wall_model_decided"] is True
    assert f["loc_wall_model_decided_at_m"] < 10.0
    assert f["loc_wall_model_votes"]["cell_face"] > f["loc_wall_model_votes"]["cell_centre"]


def test_short_realistic_tour_covariance_is_honest(short_tour: dict[str, Any]) -> None:
    """The reported covariance covers the error against the truth: NEES per degree of
    freedom near 1 (over 2: too confident), most samples inside the 95 % region."""
    assert 0.1 < short_tour["loc_nees_per_dof"] < 2.0
    assert short_tour["loc_nees_position_per_dof"] < 2.0
    assert short_tour["loc_inside_95"] > 0.8


@pytest.mark.realdata
@pytest.mark.parametrize("name", sorted(REAL_GRAPHS))
def test_real_building_graph_is_drivable(name: str, shared_data: Path) -> None:
    """Every arc of the shipped graph plans on the map's costmap with the robot's footprint
    (0.55 m wide, Nav2 inflation), and the graph finds its map relative to the project root."""
    topo = load_topological_map(REAL_GRAPHS[name])
    assert topo.map_yaml_path is not None
    assert topo.map_yaml_path.resolve() == (shared_data / "maps" / f"{name}.yaml").resolve()
    assert len(topo.tour_nodes()) >= 10
    grid = load_map(topo.map_yaml_path)
    config = PlannerConfig()
    costs = Costmap(grid, config).costs(0.0)
    planner = GlobalPlanner(grid, config)
    for u, v, weight in topo.weighted_arcs():
        a, b = topo.node(u).pose, topo.node(v).pose
        path = planner.plan(costs, (a.x, a.y), (b.x, b.y))
        length = sum(math.dist(p, q) for p, q in itertools.pairwise(path))
        # Straight, clear arcs: the planned path is no detour.
        assert length < 1.5 * weight + 0.5, f"{topo.node(u).name} -> {topo.node(v).name}"


MIN_ARC_WIDTH = 0.8  # [m] narrower than this the robot (0.55 m wide) cannot really pass (issue 12)


@pytest.mark.realdata
@pytest.mark.parametrize("name", sorted(REAL_GRAPHS))
def test_real_building_graph_avoids_gaps_the_robot_cannot_pass(
    name: str, shared_data: Path
) -> None:
    """Every arc joins its nodes through floor at least 0.8 m wide near the straight line (the
    Willow graph once routed its south corridor through a 0.73 m pinch and was blocked there;
    `tools/topo_gaps.py` prints the figures)."""
    topo = load_topological_map(REAL_GRAPHS[name])
    assert topo.map_yaml_path is not None
    grid = load_map(topo.map_yaml_path)
    distance = Costmap(grid).static_distance
    narrow = []
    for u, v, _ in topo.weighted_arcs():
        a, b = topo.node(u).pose, topo.node(v).pose
        margin = 2.0  # [m] around the box of the arc
        rows, cols = grid.world_to_cell(
            [min(a.x, b.x) - margin, max(a.x, b.x) + margin],
            [min(a.y, b.y) - margin, max(a.y, b.y) + margin],
        )
        r0, c0 = max(int(rows[0]), 0), max(int(cols[0]), 0)
        width = free_width(distance[r0 : int(rows[1]) + 1, c0 : int(cols[1]) + 1], grid.resolution)
        (ra, rb), (ca, cb) = grid.world_to_cell([a.x, b.x], [a.y, b.y])
        found = widest_way(width, (int(ra) - r0, int(ca) - c0), (int(rb) - r0, int(cb) - c0))
        if found.width < MIN_ARC_WIDTH:
            x, y = grid.cell_to_world(found.row + r0, found.col + c0)
            narrow.append(
                f"{topo.node(u).name} -> {topo.node(v).name}: {found.width:.2f} m at"
                f" ({float(x):.2f}, {float(y):.2f})"
            )
    assert narrow == []
