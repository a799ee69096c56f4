"""Global search (branch and bound over max-grids): exact against brute force, truth ranked first.

The brute-force reference scores every candidate cell at every heading with the same leaf
function; branch and bound must find the same best score and keep every leaf within
``keep_margin`` of it (no bound may cut a good pose). On real maps (ISR floor, a Willow Garage
crop) the true pose of simulated scans at fixed places must be the first hypothesis.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import OccupancyGrid, load_map
from robot_daemon.localisation.global_search import (
    GlobalSearch,
    GlobalSearchConfig,
    GlobalSearchConfigError,
    SearchRegion,
    select_points,
)
from robot_daemon.sim.simulator import SimConfig, Simulator
from tests.robot_daemon.localisation.synthetic_office import rasterise, square, utm_scan

REPO = Path(__file__).resolve().parents[3]
ISR_MAP = REPO / "maps" / "isr_floor0.yaml"
WILLOW = REPO.parent / "shared" / "data" / "maps" / "willow.yaml"
MOUNT = Pose2D(0.2, 0.0, 0.0)

# A 6 x 5 m room with a desk, a pillar and a cupboard (asymmetric).
ROOM = np.vstack(
    [
        np.array([[0, 0, 6, 0.1], [0, 4.9, 6, 5], [0, 0, 0.1, 5], [5.9, 0, 6, 5]]),
        np.array([[1.0, 3.5, 2.2, 4.0], [4.4, 0.1, 5.9, 0.7]]),
        square(3.8, 2.6, 0.15),
    ]
)


def _close(a: Pose2D, b: Pose2D, xy: float = 0.3, yaw: float = 0.1) -> bool:
    return a.distance_to(b) <= xy and abs(math.remainder(a.yaw - b.yaw, math.tau)) <= yaw


def _brute_force(gs: GlobalSearch, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Leaf score [quantised sum] of every heading x candidate cell, and the cells (row, col)."""
    cfg = gs.config
    pts = select_points(points, cfg.max_range_m, cfg.point_spacing_m, cfg.max_points)
    leaf = gs._level_offsets(pts)[0]  # (headings, n): the leaf windows, as the search uses
    rows, cols = np.nonzero(gs.candidates[: gs.height, : gs.width])
    base = (rows + gs.pad) * gs.stride + cols + gs.pad
    scores = gs._grids.take(leaf[:, None, :] + base[None, :, None]).sum(axis=2)
    return scores, np.column_stack((rows, cols))


def test_branch_and_bound_equals_brute_force_and_keeps_every_good_pose() -> None:
    grid = rasterise(ROOM, size=(6.0, 5.0))
    cfg = GlobalSearchConfig(angular_step_rad=math.radians(5.0), max_hypotheses=1000)
    gs = GlobalSearch(grid, cfg)
    rng = np.random.default_rng(4)
    for laser in (Pose2D(2.0, 1.5, 0.4), Pose2D(4.6, 3.9, -2.5)):
        points = utm_scan(ROOM, laser, 0.0, rng).points()
        result = gs.search(points)
        assert result.complete
        ref, cells = _brute_force(gs, points)
        n = result.points_used
        best_ref = ref.max() / (255 * n)
        assert result.best is not None
        assert result.best.score == pytest.approx(best_ref, abs=1e-9)
        # Every leaf within the margin is represented by a hypothesis near it.
        a_idx, c_idx = np.nonzero(ref >= math.ceil(result.threshold * 255 * n - 1e-6))
        hyps = result.hypotheses
        for a, c in zip(a_idx.tolist(), c_idx.tolist(), strict=True):
            x = grid.origin_x + (cells[c, 1] + 0.5) * gs.resolution
            y = grid.origin_y + (cells[c, 0] + 0.5) * gs.resolution
            pose = Pose2D(x, y, float(gs.angles[a]))
            assert any(
                _close(h.pose, pose, cfg.cluster_xy_m + 1e-9, cfg.cluster_yaw_rad + 1e-9)
                for h in hyps
            ), f"leaf {pose} (score {ref[a, c] / (255 * n):.3f}) lost by the bounds"
        # Ranked best first, and the truth is the best.
        scores = [h.score for h in hyps]
        assert scores == sorted(scores, reverse=True)
        assert _close(hyps[0].pose, laser)


def test_region_limits_the_search_and_bad_input_is_refused() -> None:
    grid = rasterise(ROOM, size=(6.0, 5.0))
    gs = GlobalSearch(grid, GlobalSearchConfig(angular_step_rad=math.radians(5.0)))
    laser = Pose2D(2.0, 1.5, 0.4)
    points = utm_scan(ROOM, laser, 0.0, np.random.default_rng(1)).points()
    inside = gs.search(points, SearchRegion.around(2.0, 1.5, 0.6))
    assert inside.best is not None and _close(inside.best.pose, laser)
    away = gs.search(points, SearchRegion(4.5, 3.0, 5.5, 4.5))
    assert all(4.4 <= h.pose.x <= 5.6 and 2.9 <= h.pose.y <= 4.6 for h in away.hypotheses)
    assert all(not _close(h.pose, laser) for h in away.hypotheses)
    assert gs.search(points[:5]).hypotheses == ()  # too few end points: nothing claimed
    with pytest.raises(GlobalSearchConfigError, match="angle_groups"):
        GlobalSearchConfig(angle_groups=(2, 2, 2, 2, 2, 2, 2))
    with pytest.raises(GlobalSearchConfigError, match="keep_margin"):
        GlobalSearchConfig(keep_margin=-0.1)
    with pytest.raises(ValueError, match="min < max"):
        SearchRegion(1.0, 1.0, 0.0, 2.0)


@pytest.fixture(scope="module")
def isr() -> tuple[OccupancyGrid, GlobalSearch, Simulator]:
    grid = load_map(ISR_MAP)
    return grid, GlobalSearch(grid), Simulator(grid, SimConfig(n_people=0), rng_seed=1)


# Fixed places (topological nodes): the Secretariat door, inside the ISR Shared Experimental
# Area, and the NE corner, which has look-alike runners-up: the truth must still come first.
@pytest.mark.parametrize("node", [2, 7, 15])
def test_isr_truth_ranked_first(
    isr: tuple[OccupancyGrid, GlobalSearch, Simulator], node: int
) -> None:
    from interbot_core.topological_map import load_topological_map

    _, gs, sim = isr
    base = load_topological_map(REPO / "maps" / "isr_floor0_topo.yaml").node(node).pose
    sim.teleport(base)
    sim.step(0.05)
    result = gs.search(sim.scan().points())
    laser = base.compose(MOUNT)
    assert result.best is not None
    assert _close(result.best.pose, laser), (laser, result.hypotheses[:3])
    if node == 15:
        assert len(result.hypotheses) >= 2  # the look-alikes are reported, ranked below


@pytest.mark.skipif(not WILLOW.is_file(), reason="shared data (Willow Garage map) not present")
def test_willow_crop_truth_ranked_first() -> None:
    full = load_map(WILLOW)
    r0, c0, n = 300, 200, 400  # a 20 x 20 m crop of offices and a corridor
    res = full.resolution
    crop = OccupancyGrid(
        full.cells[r0 : r0 + n, c0 : c0 + n].copy(),
        res,
        full.origin_x + c0 * res,
        full.origin_y + r0 * res,
        0.0,
        "willow crop",
    )
    gs = GlobalSearch(crop)
    sim = Simulator(crop, SimConfig(n_people=0), rng_seed=1)
    for base in (Pose2D(17.35, 17.05, 1.81), Pose2D(15.45, 16.95, -1.21)):
        sim.teleport(base)
        sim.step(0.05)
        result = gs.search(sim.scan().points())
        assert result.best is not None
        assert _close(result.best.pose, base.compose(MOUNT)), (base, result.hypotheses[:3])
